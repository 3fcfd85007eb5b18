"""The task's settings as the compiled step reads them: one record (:class:`TaskParams`), built by
each task from its spec, scales and observation layout (:func:`task_params`)."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..tasks.layout import OBS_FIELDS, ObsLayout
from ..tasks.reward import MAX_TERMS, Reward, reward_index
from .records import Field, build, record

MAX_OBS = len(OBS_FIELDS)  # measured columns of a layout (one per measured quantity at most)

TaskParams = record(
    "TaskParams",
    (
        Field("w", "f8", (MAX_TERMS,), "the reward terms' weights, in the reward's order"),
        Field("reward_index", "i8", (), "the reward's branch in the compiled step (envs.step_source)"),
        Field("track_k", "i8", (), "1 if the task sets a stiffness target"),
        Field("track_unit", "f8", (), "the position error that scores 1 [m or rad]"),
        Field("track_clip", "f8", (), "largest position term (in units)"),
        Field("stiff_clip", "f8", (), "largest stiffness term (in units)"),
        Field("stiff_unit", "f8", (), "the relative stiffness error of one unit"),
        Field("uses_allowance", "i8", (), "1: the reward reads `counted` (the score's settling allowance)"),
        Field("allow_steps", "i8", (), "control steps left out after a jump of a target"),
        Field("jump_pos", "f8", (), "a position change larger than this in one step is a jump [SI]"),
        Field("jump_k", "f8", (), "a relative stiffness change larger than this is a jump"),
        Field("air_unit", "f8", (), "the supply air that scores 1 [kg]"),
        Field("setpoint_max", "f8", (), "gauge set-point of the action +1 in pressure mode [Pa]"),
        Field("obs_clip", "f8", (), "every observation column is clipped to +- this"),
        Field("obs_n", "i8", (), "measured columns"),
        Field("obs_src", "i8", (MAX_OBS,), "each measured column's source (OBS_FIELDS index)"),
        Field("obs_off", "f8", (MAX_OBS,), "each measured column's offset"),
        Field("obs_scale", "f8", (MAX_OBS,), "each measured column's scale"),
        Field("preview", "i8", (), "control steps of targets announced (preview columns)"),
        Field("prev_off", "f8", (), "offset of the position preview columns"),
        Field("prev_scale", "f8", (), "scale of the position preview columns"),
        Field("prev_k_scale", "f8", (), "scale of the stiffness preview columns"),
    ),
    "The task's settings of the compiled step: reward weights (in the reward's order), units and "
    "clips of the terms, the pressure set-point range, the observation layout.",
    __name__,
)


def task_params(
    reward: Reward,
    weights,
    scales,
    layout: ObsLayout,
    setpoint_max: float,
    track_stiffness: bool = True,
    position: str = "length",
    allowance=(0, 0.0, 0.0),
    terminations=(),
) -> TaskParams:
    """The :class:`TaskParams` of a task: ``reward`` its declaration
    (:class:`~cepam_gym.tasks.reward.Reward`), ``weights`` an object with one weight per term
    (:meth:`Reward.weight_values`), ``scales`` a :class:`~cepam_gym.tasks.spec.TaskScales`,
    ``layout`` the observation layout
    (at most :data:`MAX_OBS` measured columns), ``setpoint_max`` [Pa] the gauge pressure of the
    action +1 in pressure mode, ``position`` the name of the tracked position in the preview
    columns (``"length"`` on the rig, ``"angle"`` on the joint), ``allowance`` the score's
    ``(steps, jump_position, jump_stiffness)``: the control steps left out after a jump of a target
    (:func:`allowance_of`; read when the reward declares ``allowance``), ``terminations`` the task's
    (:class:`~cepam_gym.tasks.termination.Termination`: the parameters their conditions read are
    checked too)."""
    n = layout.n_measured
    if n > MAX_OBS:
        raise ValueError(f"an observation layout has at most {MAX_OBS} measured columns; got {layout.names}")
    src, off, scale = np.zeros(MAX_OBS), np.zeros(MAX_OBS), np.zeros(MAX_OBS)
    src[:n], off[:n], scale[:n] = layout.sources()[:n], layout.offsets()[:n], layout.scales()[:n]
    steps = layout.preview_steps
    prev = (0.0, 0.0, 0.0)
    if steps:
        if layout.preview_of != position or layout.has("target_stiffness") != bool(track_stiffness):
            raise ValueError(
                f"the layout previews {layout.preview_of} (stiffness: {layout.has('target_stiffness')}), "
                f"the task tracks {position} (stiffness: {bool(track_stiffness)})"
            )
        col = layout.columns[n]
        prev = (col.offset, col.scale, layout.columns[n + steps].scale if track_stiffness else 1.0)
    unknown = sorted(reward.task_attributes() - set(TaskParams._fields))
    if unknown:
        raise InputError(
            f"reward {reward.name!r} reads task.{', task.'.join(unknown)}; the task's parameters are "
            f"{list(TaskParams._fields)}"
        )
    for t in terminations:
        unknown = sorted(t.task_attributes() - set(TaskParams._fields))
        if unknown:
            raise InputError(
                f"termination {t.name!r} reads task.{', task.'.join(unknown)}; the task's parameters "
                f"are {list(TaskParams._fields)}"
            )
    w = np.zeros(MAX_TERMS)
    w[: len(reward.terms)] = reward.weight_values(weights)
    return build(
        TaskParams,
        w=w,
        reward_index=reward_index(reward),
        track_k=int(bool(track_stiffness)),
        track_unit=scales.tracking_unit,
        track_clip=scales.tracking_clip,
        stiff_clip=scales.stiffness_clip,
        stiff_unit=scales.stiffness_unit,
        uses_allowance=int(reward.allowance),
        allow_steps=int(allowance[0]),
        jump_pos=float(allowance[1]),
        jump_k=float(allowance[2]),
        air_unit=scales.air_unit,
        setpoint_max=setpoint_max,
        obs_clip=layout.clip,
        obs_n=n,
        obs_src=src,
        obs_off=off,
        obs_scale=scale,
        preview=steps,
        prev_off=prev[0],
        prev_scale=prev[1],
        prev_k_scale=prev[2],
    )


def allowance_of(trade, control_dt: float) -> tuple[int, float, float]:
    """``(steps, jump_position, jump_stiffness)`` of a contract's score trade
    (:class:`~cepam_gym.tasks.contract.ScoreTrade`) at ``control_dt`` [s], rounded as the score's
    mask rounds it (:func:`cepam_gym.control.objective.scored_steps`)."""
    return int(round(trade.allowance_s / control_dt)), trade.jump_position, trade.jump_stiffness
