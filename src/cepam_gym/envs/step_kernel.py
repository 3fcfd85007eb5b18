"""The compiled parts of the env's step that no reward declares: the observation (its encoding,
the preview columns), the mechanism's view (the rig's length or the joint's angle), the score's
settling allowance; and :func:`observe` after a reset. The termination reason is declared by the
task (:mod:`cepam_gym.tasks.termination`) and generated with its reward.

The step itself (:mod:`cepam_gym.envs.step`) calls them around the plant kernel and the
declared reward (:mod:`cepam_gym.tasks.reward`).
"""

from __future__ import annotations

import numpy as np

from .. import plant as pl
from .._jit import jit
from ..physics import layout as ix
from ..physics.hinge import H_R, N_HINGE
from ..plant.actions import plant_inputs, valve_commands
from ..tasks.layout import OBS_FIELDS
from ..tasks.spec import TERMINATION_NONE, TERMINATION_REASONS
from .state import N_NOISE, EnvState, StepSettings
from .task_params import MAX_OBS, TaskParams, task_params

__all__ = [
    "MAX_OBS",
    "N_NOISE",
    "OBS_FIELDS",
    "TERMINATION_NONE",
    "TERMINATION_REASONS",
    "EnvState",
    "StepSettings",
    "TaskParams",
    "task_params",
    "encode",
    "write_obs",
    "write_preview",
    "scored",
    "plant_inputs",
    "valve_commands",
    "observe",
    "mechanism_view",
    "no_hinge",
]


@jit
def encode(vals, task, obs):
    """Observation of the measured ``vals`` (a tuple in the layout's ``fields`` order, SI) by the
    layout in ``task`` (:class:`TaskParams`): ``clip((value - offset) / scale)`` per column
    (:class:`~cepam_gym.tasks.layout.ObsLayout`)."""
    clip = task.obs_clip
    src, off, scale = task.obs_src, task.obs_off, task.obs_scale
    for j in range(task.obs_n):
        v = (vals[src[j]] - off[j]) / scale[j]
        obs[j] = max(-clip, min(clip, v))


@jit
def write_preview(tl_row, tk_row, k_next, task, obs):
    """The preview columns: the targets of the ``task.preview`` control steps after step
    ``k_next`` (the one the ``target_*`` columns show), the last target held past the episode's
    end."""
    steps = task.preview
    if steps == 0:
        return
    n_t = tl_row.shape[0]
    base = task.obs_n
    clip = task.obs_clip
    track_k = task.track_k != 0
    for j in range(steps):
        kk = min(k_next + 1 + j, n_t - 1)
        v = (tl_row[kk] - task.prev_off) / task.prev_scale
        obs[base + j] = max(-clip, min(clip, v))
        if track_k:
            v = tk_row[kk] / task.prev_k_scale
            obs[base + steps + j] = max(-clip, min(clip, v))


@jit
def mechanism_view(x, stiffness, p, h, mech):
    """``(position, velocity, stiffness)`` the task sees of plant state row ``x`` with muscle
    stiffness ``stiffness`` [N/m]: on the rig the muscle's length [m], rate [m/s] and stiffness;
    on a hinge (``mech == plant.HINGE``, hinge row ``h``, :mod:`cepam_gym.physics.hinge`) the
    joint angle ``(L_max - L) / r`` [rad], its rate [rad/s] and the joint stiffness ``K r^2``
    [N m/rad]."""
    if mech == pl.HINGE:
        r = h[H_R]
        return (p[ix.L_MAX] - x[pl.S_L]) / r, -x[pl.S_V] / r, stiffness * r * r
    return x[pl.S_L], x[pl.S_V], stiffness


def no_hinge() -> np.ndarray:
    """The hinge argument of a rig's kernel call (read only by hinge blocks)."""
    return np.zeros((1, N_HINGE))


@jit
def write_obs(pos, vel, aux, target_l, target_k, prev_a, p, task, noise, obs):
    """Scaled float observation of one env (what a real rig or joint measures, plus targets and
    a_{t-1}): the quantities of :data:`OBS_FIELDS` (the joint's: angle and angular velocity for
    ``pos``, ``vel``), encoded by the task's layout."""
    vals = (
        pos + noise[0],
        vel + noise[1],
        aux[pl.A_PC] + noise[2],
        aux[pl.A_PE] + noise[3],
        p[ix.P_SUP] - p[ix.P_ATM] + noise[4],
        target_l,
        target_k,
        prev_a[0],
        prev_a[1],
    )
    encode(vals, task, obs)


@jit
def scored(tl_row, tk_row, k, task):
    """Whether step ``k`` of an episode with targets ``tl_row``, ``tk_row`` is one the score counts:
    no jump of a target (:attr:`TaskParams.jump_pos`, ``jump_k``) within the ``task.allow_steps``
    steps up to it. The compiled twin of :func:`cepam_gym.control.objective.scored_steps` (a test
    holds them equal)."""
    for j in range(max(1, k - task.allow_steps + 1), k + 1):
        if abs(tl_row[j] - tl_row[j - 1]) > task.jump_pos:
            return False
        if task.track_k != 0 and abs(tk_row[j] - tk_row[j - 1]) / abs(tk_row[j - 1]) > task.jump_k:
            return False
    return True


@jit
def observe(s, mech, task):
    """Observations of a batch without stepping (after reset)."""
    tl, tk, t_idx, obs = s.target_l, s.target_k, s.t_idx, s.obs
    n_t = tl.shape[1]
    for i in range(s.state.shape[0]):
        k = min(t_idx[i], n_t - 1)
        p = s.params[0] if s.params.shape[0] == 1 else s.params[i]
        rz = s.noise[0] if s.noise.shape[0] == 1 else s.noise[i]
        h = s.hinge[0 if s.hinge.shape[0] == 1 else i]
        pos, vel, _k = mechanism_view(s.state[i], s.aux[i, pl.A_STIFF], p, h, mech)
        write_obs(pos, vel, s.aux[i], tl[i, k], tk[i, k], s.prev_action[i], p, task, rz, obs[i])
        write_preview(tl[i], tk[i], t_idx[i], task, obs[i])
