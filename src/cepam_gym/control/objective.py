"""The benchmark's objective, defined once: what the score counts and how it trades errors.

The combined score of a suite (lower is better, :func:`cepam_gym.bench.metrics.score_traces`) is
``RMSE(position) / position_norm + RMSE(stiffness / target - 1) / STIFFNESS_NORM
+ FAILURE_WEIGHT * failure rate``, the stiffness term only where the task tracks stiffness, the
RMSEs over the steps :func:`tracking_mask` keeps (alive, and, on the v1 suites, not within the
settling allowance after a jump of the target). The planner of the model-based controllers
(:mod:`cepam_gym.control.planner`) minimises the squared form of the same trade on the same steps
(:func:`step_error_sq`, called by the compiled rollouts), from this module, so the two cannot drift
apart. The trade itself (the errors that score 1, the failure weight) and the info keys each trace
column reads are each task's contract (:mod:`cepam_gym.tasks.contract`), which also states how the
env's reward relates to it.

This module sits in ``control`` (below ``bench`` in the import layers) because both use it;
:mod:`cepam_gym.bench.metrics` re-exports its names.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from .._jit import jit_inline
from ..tasks.contract import JOINT as _JOINT
from ..tasks.contract import RIG as _RIG

STIFFNESS_NORM = _RIG.trade.stiffness_norm  # a relative stiffness error of 20 % scores 1 ...
FAILURE_WEIGHT = _RIG.trade.failure_weight  # ... and a failed (burst) episode scores 2
assert (_JOINT.trade.stiffness_norm, _JOINT.trade.failure_weight) == (STIFFNESS_NORM, FAILURE_WEIGHT)
LENGTH_BAND = 1e-3  # m: "settled" means within 1 mm ...
STIFFNESS_BAND = 0.05  # ... and within 5 % of the stiffness target
MIN_STEP = 2e-3  # m: overshoot is measured on target changes of at least 2 mm


@dataclass(frozen=True)
class TraceSpec:
    """What a suite's trace columns hold and how the tracked quantity is scored and plotted.

    ``info_keys`` maps each trace column to the env's ``info`` key; ``scale`` converts the SI
    ``length`` column to ``unit``, and the metric is named ``f"{quantity}_rmse_{unit}"``;
    ``band`` and ``min_step`` are SI; ``score_norm`` (in ``unit``) is the error that scores 1."""

    quantity: str = _RIG.position
    unit: str = _RIG.trade.unit
    scale: float = _RIG.trade.scale
    band: float = LENGTH_BAND
    min_step: float = MIN_STEP
    score_norm: float = _RIG.trade.score_norm
    info_keys: dict[str, str] = field(default_factory=lambda: dict(_RIG.score_keys))
    # plots: (label, unit, scale from SI) of the tracked quantity, the stiffness and the load
    plot_quantity: tuple[str, str, float] = ("length", "cm", 100.0)
    plot_stiffness: tuple[str, str, float] = ("stiffness", "N/m", 1.0)
    plot_load: tuple[str, str, float] = ("load", "g", 1000.0)
    # tracking with preview (v1): seconds left out after each jump of the target, and what a jump is
    allowance_s: float = 0.0
    jump_length: float = _RIG.trade.jump_position  # SI (m, or rad): more than this in one control step
    jump_stiffness: float = _RIG.trade.jump_stiffness  # relative: more than this in one control step

    @property
    def rmse_key(self) -> str:
        return f"{self.quantity}_rmse_{self.unit}"

    @property
    def position_norm(self) -> float:
        """The position error [SI: m or rad] that scores 1 (``score_norm`` in SI)."""
        return self.score_norm / self.scale


RIG = TraceSpec()
# the v1 suites: tracking with preview, 0.5 s of settling allowed after a jump of the target
RIG_V1 = TraceSpec(allowance_s=_RIG.trade.allowance_s)
JOINT = TraceSpec(
    quantity=_JOINT.position,
    unit=_JOINT.trade.unit,
    scale=_JOINT.trade.scale,
    band=np.deg2rad(2.0),
    min_step=np.deg2rad(5.0),
    score_norm=_JOINT.trade.score_norm,
    info_keys=dict(_JOINT.score_keys),
    plot_quantity=("angle", "deg", 180.0 / np.pi),
    plot_stiffness=("joint stiffness", "N m/rad", 1.0),
    plot_load=("external torque", "mN m", 1000.0),
)
# the v1 joint: tracking with preview, the same allowance as the rig's v1 suites
JOINT_V1 = dataclasses.replace(JOINT, allowance_s=_JOINT.trade.allowance_s)
assert (JOINT.jump_length, JOINT.jump_stiffness) == (_JOINT.trade.jump_position, _JOINT.trade.jump_stiffness)


def _model_of(core):
    """The :class:`~cepam_gym.envs.model.EnvModel` given, or that of a ``CEPAMBatch``."""
    from ..envs.model import EnvModel

    return core if isinstance(core, EnvModel) else EnvModel.of(core)


def version_of_core(core):
    """The row of the version table (:mod:`cepam_gym.versions`) whose env ``core`` (the envs'
    :class:`~cepam_gym.envs.model.EnvModel`, or their ``CEPAMBatch``) runs
    (:attr:`EnvModel.version <cepam_gym.envs.model.EnvModel>`); None for a task or plant of
    one's own."""
    return _model_of(core).version


def spec_of_core(core) -> TraceSpec:
    """How the benchmark scores the envs of ``core`` (their ``EnvModel``, or their
    ``CEPAMBatch``), as the suites of :mod:`cepam_gym.bench.suites` do: the joint's spec on a
    hinge, the rig's otherwise; with the settling allowance on the planned-reference tasks (task
    version 1 in the version table, :mod:`cepam_gym.versions`: every v1 and v2 id). A task of
    one's own (a Task object) is scored on every step, as the v0 tasks."""
    from .. import plant as pl

    model = _model_of(core)
    joint = model.mech == pl.HINGE
    if (model.task_version or 0) >= 1:
        return JOINT_V1 if joint else RIG_V1
    return JOINT if joint else RIG


def combined_score(position_rmse_si, stiffness_rmse_rel, failure_rate, spec: TraceSpec):
    """The combined score from the position RMSE [SI], the relative stiffness RMSE (None where
    the task does not track stiffness) and the failure rate (floats or arrays alike)."""
    score = np.asarray(position_rmse_si) / spec.position_norm + FAILURE_WEIGHT * np.asarray(failure_rate)
    if stiffness_rmse_rel is not None:
        score = score + np.asarray(stiffness_rmse_rel) / STIFFNESS_NORM
    return float(score) if np.ndim(score) == 0 else score


@jit_inline
def step_error_sq(x, x_target, K, K_target, w, track_stiffness, position_norm, stiffness_norm):
    """The squared form of the score's error at one step, weighted ``w`` (0 on the steps the score
    leaves out): ``w ((x - x*) / x_norm)^2 + w ((K - K*) / (stiffness_norm K*))^2``, the stiffness
    part only where the task tracks stiffness. What the planners' rollouts
    (:func:`cepam_gym.control.rollout.rollout_cost`) accumulate."""
    e = (x - x_target) / position_norm
    c = w * e * e
    if track_stiffness:
        ek = (K - K_target) / (stiffness_norm * K_target)
        c += w * ek * ek
    return c


def jumps(target_l: np.ndarray, target_k: np.ndarray, track_stiffness: bool, spec: TraceSpec) -> np.ndarray:
    """(T, ...) bool: the target jumps at this step (a change larger than the spec's jump sizes);
    time runs along axis 0."""
    out = np.zeros(target_l.shape, dtype=bool)
    out[1:] = np.abs(np.diff(target_l, axis=0)) > spec.jump_length
    if track_stiffness:
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.abs(np.diff(target_k, axis=0)) / np.abs(target_k[:-1])
        out[1:] |= rel > spec.jump_stiffness
    return out


def scored_steps(target_l, target_k, track_stiffness: bool, spec: TraceSpec, dt: float) -> np.ndarray:
    """(T, ...) bool: the steps whose errors the score counts (before failures): all of them,
    except the ``spec.allowance_s`` seconds after each jump of the target. A function of the
    target schedule only, so a planner that knows the schedule weighs its errors as the score will."""
    n_allow = int(round(spec.allowance_s / dt))
    if n_allow <= 0:
        return np.ones(np.shape(target_l), dtype=bool)
    j = jumps(target_l, target_k, track_stiffness, spec)
    T = j.shape[0]
    steps = np.arange(T).reshape((T,) + (1,) * (j.ndim - 1))
    # steps since the last jump (a large number before the first one)
    last = np.maximum.accumulate(np.where(j, steps, -10 * (n_allow + T)), axis=0)
    return steps - last >= n_allow
