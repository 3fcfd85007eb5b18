"""The fused control step of every CE-PAM env: actions -> plant -> observation, reward, flags.

One compiled function per block of envs (:func:`_env_block`) calls the plant kernel
(:func:`cepam_gym.plant.advance_block`, the only copy of the equations, or its hinge form
:func:`~cepam_gym.plant.advance_block_hinge` for the joint env) and then the task's observation
and reward terms, through :func:`mechanism_view` (the rig's length or the joint's angle). Every
function takes the env state as one record (:class:`~cepam_gym.tasks.state.EnvState`), the step's
settings (:class:`~cepam_gym.tasks.state.StepSettings`) and the task's
(:class:`~cepam_gym.tasks.task_params.TaskParams`). The vector env calls :func:`env_step`, the
single env :func:`cepam_gym.tasks.single.env_step_single`; keeping the per-step task arithmetic
compiled is what makes a single env faster than Gymnasium's Pendulum and a batch of 4096 envs
run at millions of steps per second.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .. import plant as pl
from .._jit import jit, row_of
from ..physics import layout as ix
from ..physics.hinge import H_R, N_HINGE
from ..plant.actions import plant_inputs, valve_commands
from .layout import OBS_FIELDS
from .spec import TERMINATION_BURST, TERMINATION_NONE, TERMINATION_NONFINITE, TERMINATION_REASONS
from .state import N_NOISE, N_TERMS, REWARD_TERMS, EnvState, StepSettings
from .task_params import MAX_OBS, TaskParams, task_params

__all__ = [
    "MAX_OBS",
    "N_NOISE",
    "N_TERMS",
    "OBS_FIELDS",
    "REWARD_TERMS",
    "TERMINATION_REASONS",
    "EnvState",
    "StepSettings",
    "TaskParams",
    "task_params",
    "encode",
    "write_obs",
    "write_preview",
    "reward_terms",
    "scored",
    "termination",
    "plant_inputs",
    "valve_commands",
    "env_step",
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
def reward_terms(x, x_target, K, K_target, a0, a1, air, burst, task, terms, counted=True):
    """Signed reward terms of one env (all <= 0), written to ``terms``; returns their sum.

    ``x`` is the tracked position (muscle length [m] on the rig, joint angle [rad] on the joint),
    ``K`` the stiffness the task sets (N/m, or N m/rad), ``a0, a1`` the applied action, ``air`` the
    supply air of the step [kg], ``burst`` whether a chamber burst, ``task`` the
    :class:`TaskParams`, ``counted`` whether the score counts the step (:func:`scored`; read by the
    score form only). The same function scores every env (rig and joint).

    The absolute form (v0-v2) prices ``min(|e| / unit, clip)``; the score form (v3) squares it and
    pays nothing on a step the score leaves out (tasks.contract, "Reward and score")."""
    e_x = min(abs(x - x_target) / task.track_unit, task.track_clip)
    e_k = 0.0
    if task.track_k != 0:
        e_k = min(abs(K - K_target) / K_target / task.stiff_unit, task.stiff_clip)
    if task.score_form != 0:
        terms[0] = -task.w_track * e_x * e_x if counted else 0.0
        terms[1] = -task.w_stiff * e_k * e_k if counted and task.track_k != 0 else 0.0
    else:
        terms[0] = -task.w_track * e_x
        terms[1] = -task.w_stiff * e_k if task.track_k != 0 else 0.0
    terms[2] = -task.w_effort * 0.5 * (a0 * a0 + a1 * a1)
    terms[3] = -task.w_air * air / task.air_unit
    terms[4] = -task.w_burst if burst else 0.0
    return terms[0] + terms[1] + terms[2] + terms[3] + terms[4]


@jit
def termination(finite, burst):
    """Termination reason code (:data:`TERMINATION_REASONS`) of a step: a non-finite state or
    reward first, then a burst."""
    if not finite:
        return TERMINATION_NONFINITE
    return TERMINATION_BURST if burst else TERMINATION_NONE


@jit
def _env_block(lo, n, s, c, task, W):
    """One control step of envs ``lo .. lo + n - 1`` of state ``s`` (one plant block,
    ``n <= plant.BLOCK``), settings ``c``, task ``task``, plant scratch ``W``.

    ``c.mech``: :data:`cepam_gym.plant.RIG` (``s.load`` are hanging masses [kg]) or
    :data:`cepam_gym.plant.HINGE` (``s.hinge`` rows, ``s.load`` external torques [N m], targets in
    rad and N m/rad).

    Each env's action (the plant receives it now) is clipped to [-1, 1] in place, so the caller's
    buffer then holds what was applied; the plant block advances; then each env's reward terms,
    observation and termination reason are written."""
    state, actions, params, hinge, aux = s.state, s.prev_action, s.params, s.hinge, s.aux
    tl, tk, loads, t_idx = s.target_l, s.target_k, s.load, s.t_idx
    mech = c.mech
    n_t = tl.shape[1]
    for i in range(lo, lo + n):
        a = row_of(actions, i)
        load = loads[i, min(t_idx[i], n_t - 1)]
        if mech == pl.HINGE:  # the external torque acts on the muscle as tau / r
            load = load / hinge[0 if hinge.shape[0] == 1 else i, H_R]
        a[0], a[1] = plant_inputs(row_of(s.inputs, i), c.mode, mech, a[0], a[1], task.setpoint_max, load)
    if mech == pl.HINGE:
        pl.advance_block_hinge(state, s.inputs, params, hinge, lo, n, c.mode, c.dt, c.n_sub, state, aux, W)
    else:
        pl.advance_block(state, s.inputs, params, lo, n, c.mode, c.dt, c.n_sub, state, aux, W)
    noise, obs, reasons = s.noise, s.obs, s.reasons
    for i in range(lo, lo + n):
        k = min(t_idx[i], n_t - 1)
        k1 = min(t_idx[i] + 1, n_t - 1)
        x = row_of(state, i)
        ax = row_of(aux, i)
        burst = ax[pl.A_BURST] != 0.0
        a = row_of(actions, i)
        p = row_of(params, 0 if params.shape[0] == 1 else i)
        h = row_of(hinge, 0 if hinge.shape[0] == 1 else i)
        pos, vel, K = mechanism_view(x, ax[pl.A_STIFF], p, h, mech)
        terms = row_of(s.terms, i)
        counted = task.score_form == 0 or scored(row_of(tl, i), row_of(tk, i), k, task)
        reward = reward_terms(
            pos, tl[i, k], K, tk[i, k], a[0], a[1], ax[pl.A_AIR], burst, task, terms, counted
        )
        rz = row_of(noise, 0 if noise.shape[0] == 1 else i)
        write_obs(pos, vel, ax, tl[i, k1], tk[i, k1], a, p, task, rz, row_of(obs, i))
        write_preview(row_of(tl, i), row_of(tk, i), t_idx[i] + 1, task, row_of(obs, i))
        reasons[i] = termination(ax[pl.A_FINITE] != 0.0 and math.isfinite(reward), burst)
        s.rewards[i] = 0.0 if reasons[i] == TERMINATION_NONFINITE else reward
        t_idx[i] += 1


@jit
def _env_step_serial(s, c, task):
    n = s.state.shape[0]
    W = np.empty(pl.W_SIZE)
    for lo in range(0, n, pl.BLOCK):
        _env_block(lo, min(pl.BLOCK, n - lo), s, c, task, W)


@njit(parallel=True, cache=True, error_model="numpy")
def _env_step_parallel(s, c, task):
    n = s.state.shape[0]
    for b in prange((n + pl.BLOCK - 1) // pl.BLOCK):
        lo = b * pl.BLOCK
        _env_block(lo, min(pl.BLOCK, n - lo), s, c, task, np.empty(pl.W_SIZE))


def env_step(s, c, task) -> None:
    """Step every env of state ``s`` (an :class:`EnvState`) in place, with settings ``c`` and task
    ``task``."""
    (_env_step_parallel if s.state.shape[0] >= pl.PARALLEL_MIN_BATCH else _env_step_serial)(s, c, task)


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
