"""The joint's Task object: a hinge (elbow or wrist) driven by the CE-PAM through a rack and
pinion. Its spec is a :class:`~cepam_gym.tasks.joint.JointTask` on a
:class:`~cepam_gym.tasks.joint.JointGeometry`; targets are a joint angle [rad] and a joint
stiffness [N m/rad], the load an external torque [N m]. The plant kernel integrates the hinge as
the rig's load step in muscle coordinates (``mech = HINGE``, :mod:`cepam_gym.physics.hinge`)."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from .. import plant as pl
from ..physics import layout as ix
from ..planning.episodes import start_at_rest
from ..planning.joint import apply_reset_options, joint_planned_schedules, unreachable_torque
from ..planning.plan_vectors import mechanism_vector
from ..planning.randomization import Randomizer, unstable
from ..tasks.contract import JOINT
from ..tasks.hinge_info import hinge_info
from ..tasks.joint import JointGeometry, JointRewardWeights, JointTask, joint_layout
from ..tasks.mechanism import HingeMechanism
from ..tasks.reward import JOINT_SCORE_REWARD
from ..tasks.spec import check_kwargs
from . import step_kernel as tk
from .task import Task
from .task_params import allowance_of

# v1: planned references (smooth moves, the paper's two profiles), as the rig's v1 tasks
V1_REFERENCES = ("min_jerk", "sine", "chirp", "stiffness_ramp")
# v3: the v1 joint paying the score's per-step form (tasks.contract, "Reward and score"): 10 deg and
# 20 % one unit each, squared; a burst charged as 500 steps that each score the failure weight 2
JOINT_SCORE_SCALES = dataclasses.replace(
    JointTask.scales, tracking_clip=30.0, stiffness_unit=0.2, stiffness_clip=25.0
)
JOINT_SCORE_WEIGHTS = JointRewardWeights(**{t.name: t.weight for t in JOINT_SCORE_REWARD.terms})
JOINT_TASKS = {
    "joint": JointTask(),
    "joint_v1": JointTask(references=V1_REFERENCES),
    "joint_v3": JointTask(
        references=V1_REFERENCES,
        scales=JOINT_SCORE_SCALES,
        weights=JOINT_SCORE_WEIGHTS,
        reward=JOINT_SCORE_REWARD,
    ),
}
REWARD_TERMS = JOINT.reward_terms  # the package's joint rewards' terms, in order
INFO_KEYS = JOINT.info_keys


class HingeTask(Task):
    """A joint task: ``spec`` (targets, torques, references), ``geometry`` (the mechanism),
    ``weights`` (reward weights), the preview count."""

    contract = JOINT
    pin_keys = JOINT.pin_keys
    renderers = ("mujoco",)
    track_stiffness = True

    def __init__(
        self, spec: JointTask, geometry: JointGeometry, weights: JointRewardWeights, preview_steps=0
    ):
        self.spec, self.geometry, self.weights = spec, geometry, weights
        self.mechanism = HingeMechanism(geometry=geometry)
        self.name = "joint"
        self.preview_steps = int(preview_steps)

    @classmethod
    def from_kwargs(cls, task, task_options=None, reward_weights=None, preview_steps=0, joint=None):
        if isinstance(task, str):
            task = JOINT_TASKS[task]
        elif not isinstance(task, JointTask):
            raise TypeError(f"task must be a joint task name or a JointTask, got {type(task).__name__}")
        opts = check_kwargs(JointTask, task_options, "task_options", exclude=("scales", "weights", "reward"))
        if opts:
            task = dataclasses.replace(
                task, **{k: tuple(v) if isinstance(v, list) else v for k, v in opts.items()}
            )
        weights = dataclasses.replace(
            task.weights, **check_kwargs(type(task.weights), reward_weights, "reward_weights", "terms")
        )
        return cls(task, JointGeometry.from_kwargs(joint), weights, preview_steps)

    # ------------------------------------------------------------------ build
    def bind(self, nominal, sub_dt: float, control_dt: float = 0.02) -> None:
        self.nominal, self.sub_dt = nominal, sub_dt
        self.nominal_row = nominal_row = nominal.to_array()
        self.mechanism_vector = mechanism_vector(self.mechanism, nominal_row, self.spec.angle_range)
        self.spec.check_range(self.geometry, nominal_row)
        self.angle_max = self.geometry.max_angle(nominal_row)
        self.layout = joint_layout(self.spec, self.angle_max, nominal.supply_pressure, self.preview_steps)
        self.params = tk.task_params(
            self.spec.reward,
            self.weights,
            self.spec.scales,
            self.layout,
            nominal.pressure_cap,
            True,
            "angle",
            allowance=allowance_of(JOINT.trade, control_dt),
            terminations=self.spec.terminations,
        )

    def hinge_row(self) -> np.ndarray:
        return self.mechanism.hinge_row()

    def check_plant(self, row: np.ndarray) -> str | None:
        """Why parameter row ``row`` cannot run the joint task (``None`` if it can): an unstable
        sub-step, target angles outside the joint's range, a torque with no reachable target."""
        why = unstable(row, self.sub_dt)
        if why:
            return why
        try:
            self.spec.check_range(self.geometry, row)
        except ValueError as e:
            return str(e)
        tau = unreachable_torque(self.spec, self.geometry, row)
        if tau is not None:
            return f"the joint task has no reachable target under an external torque of {tau:.3g} N m"
        return None

    def randomizer(self, randomize, sub_dt: float) -> Randomizer:
        return Randomizer(randomize, self.nominal, None, sub_dt, check=self.check_plant)

    # ------------------------------------------------------------------ reset
    def plan(self, rngs: list, rows: np.ndarray, n_steps: int, control_dt: float) -> tuple:
        """:func:`~cepam_gym.planning.joint.joint_planned_schedules` (the rig's sampler through the
        joint's mechanism map, then the references)."""
        return joint_planned_schedules(
            rngs, self.spec, self.geometry, rows, self.nominal_row, n_steps, control_dt
        )

    def start(self, s, idx: np.ndarray, initial: np.ndarray) -> None:
        """At rest at the (angle, joint stiffness) rows with the chamber pressures of the inverse
        static model under the first external torque, clipped to ``[0, min(supply, burst)]`` (as
        :meth:`~cepam_gym.mujoco.joint_sim.JointSimulator.reset`;
        :func:`~cepam_gym.planning.episodes.start_at_rest`)."""
        s.initial[idx] = initial
        start_at_rest(s, idx, s.initial[idx], self.mechanism_vector)

    def apply_options(self, s, options: dict) -> None:
        """``target_angle`` [rad], ``target_stiffness`` [N m/rad], ``external_torque`` [N m] pinned
        for the episode; ``initial_angle`` [rad], ``initial_stiffness`` [N m/rad] the starting
        point (scalars, every env; :func:`~cepam_gym.planning.joint.apply_reset_options`)."""
        n = s.state.shape[0]
        for i in range(n):
            sched = (s.target_l[i], s.target_k[i], s.load[i])
            start = tuple(s.initial[i])
            s.initial[i] = apply_reset_options(options, sched, start, self.geometry, s.params[i])
        self.start(s, np.arange(n), s.initial.copy())

    def pin(self, s, values: dict, idx: np.ndarray) -> None:
        raise NotImplementedError("the joint env pins targets through reset(options=...)")

    # ------------------------------------------------------------------ info
    def info_single(self, s, scored: bool) -> dict[str, Any]:
        """:meth:`info_arrays` of env 0 as Python floats, built without temporary arrays: the same
        declared expressions (:mod:`cepam_gym.tasks.hinge_info`) on floats."""
        g = self.geometry
        x, a = s.state[0].tolist(), s.aux[0].tolist()
        p = s.params[0]
        k = min(max(int(s.t_idx[0]) - (1 if scored else 0), 0), s.target_l.shape[1] - 1)
        info = hinge_info(
            x[pl.S_L], x[pl.S_V], float(g.angle(x[pl.S_L], p)), a[pl.A_FORCE], a[pl.A_STIFF],
            a[pl.A_PC], a[pl.A_PE], a[pl.A_AIR] if scored else 0.0, float(s.load[0, k]),
            float(s.target_l[0, k]), float(s.target_k[0, k]), float(p[ix.GRAV]),
            g.lever_arm, g.link_mass, g.link_com,
        )  # fmt: skip
        if scored:
            info.update(zip(self.term_keys, s.terms[0].tolist()))
        info["redraws"] = int(s.redraws[0])
        return info

    def info_arrays(self, s, scored: bool) -> dict[str, np.ndarray]:
        """Per-env info arrays (SI): the joint's quantities (as
        :meth:`~cepam_gym.mujoco.joint_sim.JointSimulator.measure`), loads, targets, reward terms."""
        g = self.geometry
        n = s.state.shape[0]
        k = np.minimum(np.maximum(s.t_idx - (1 if scored else 0), 0), s.target_l.shape[1] - 1)
        rows = np.arange(n)
        q = np.broadcast_to(s.params, (n, ix.N_PARAMS)).T
        L = s.state[:, pl.S_L].copy()
        out = hinge_info(
            L, s.state[:, pl.S_V], g.angle(L, q), s.aux[:, pl.A_FORCE].copy(), s.aux[:, pl.A_STIFF].copy(),
            s.aux[:, pl.A_PC].copy(), s.aux[:, pl.A_PE].copy(),
            s.aux[:, pl.A_AIR].copy() if scored else np.zeros(n), s.load[rows, k],
            s.target_l[rows, k], s.target_k[rows, k], q[ix.GRAV], g.lever_arm, g.link_mass, g.link_com,
        )  # fmt: skip
        if scored:
            out.update(zip(self.term_keys, np.ascontiguousarray(s.terms.T)))
        out["redraws"] = s.redraws.copy()
        return out
