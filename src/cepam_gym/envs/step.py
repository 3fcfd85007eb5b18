"""The env's step, batched and single: actions -> plant -> reward terms, observation, flags.

This module is also the template of every declared reward's step (:mod:`cepam_gym.envs.step_source`):
its one line importing ``reward_terms`` and ``terminated`` is replaced by the functions generated
from the task's declarations (:class:`~cepam_gym.tasks.reward.Reward`,
:class:`~cepam_gym.tasks.termination.Termination`), so the package's tasks and a user's run the same
step code. Hence the absolute imports.

One compiled function per block of envs (:func:`_env_block`) calls the plant kernel
(:func:`cepam_gym.plant.advance_block`, the only copy of the equations, or its hinge form
:func:`~cepam_gym.plant.advance_block_hinge` for the joint env) and then the task's reward terms
and observation (:mod:`cepam_gym.envs.step_kernel`), through
:func:`~cepam_gym.envs.step_kernel.mechanism_view` (the rig's length or the joint's angle). Every
function takes the env state as one record (:class:`~cepam_gym.envs.state.EnvState`), the
step's settings (:class:`~cepam_gym.envs.state.StepSettings`) and the task's
(:class:`~cepam_gym.envs.task_params.TaskParams`). The vector env calls the serial or parallel
step, the single env :func:`env_step_single`; keeping the per-step task arithmetic compiled is
what makes a single env faster than Gymnasium's Pendulum and a batch of 4096 envs run at millions
of steps per second.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from cepam_gym import plant as pl
from cepam_gym._jit import jit, row_of
from cepam_gym.envs._reward_builtin import NONFINITE, reward_terms, terminated  # declared (envs.step_source)
from cepam_gym.envs.single_slabs import NONFINITE_ACTION, SLAB_READERS
from cepam_gym.envs.step_kernel import mechanism_view, scored, write_obs, write_preview
from cepam_gym.physics.hinge import H_R
from cepam_gym.plant.actions import plant_inputs
from cepam_gym.tasks.rig_info import AUX, INFO_COL, INFO_SRC, LOAD, STATE, TARGET_L

__all__ = ["env_step", "env_step_single", "reward_terms", "terminated"]

_state_of, _settings_of, _task_of, _extras_of = SLAB_READERS


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
        counted = task.uses_allowance == 0 or scored(row_of(tl, i), row_of(tk, i), k, task)
        reward = reward_terms(
            pos, tl[i, k], vel, K, tk[i, k], a[0], a[1], ax[pl.A_AIR], burst, counted, task, terms
        )
        rz = row_of(noise, 0 if noise.shape[0] == 1 else i)
        write_obs(pos, vel, ax, tl[i, k1], tk[i, k1], a, p, task, rz, row_of(obs, i))
        write_preview(row_of(tl, i), row_of(tk, i), t_idx[i] + 1, task, row_of(obs, i))
        if ax[pl.A_FINITE] != 0.0 and math.isfinite(reward):
            reasons[i] = terminated(
                pos, tl[i, k], vel, K, tk[i, k], a[0], a[1], ax[pl.A_AIR], burst, counted, task
            )
            s.rewards[i] = reward
        else:
            reasons[i] = NONFINITE
            s.rewards[i] = 0.0
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
def env_step_single(F, I, obs, a0, a1):
    """One control step of a single env whose records live in the slabs ``F``, ``I``, ``obs``
    (:func:`cepam_gym.envs.single_slabs.single_slabs`), with the action ``(a0, a1)``; returns
    ``(reward, reason)``, or ``(nan, NONFINITE_ACTION)`` without stepping when an action is NaN or
    inf (checked here: one call less on the single env's hot path)."""
    if not (math.isfinite(a0) and math.isfinite(a1)):
        return math.nan, NONFINITE_ACTION
    s = _state_of(F, I, obs)
    ex = _extras_of(F, I, obs)
    s.prev_action[0, 0] = a0
    s.prev_action[0, 1] = a1
    _env_block(0, 1, s, _settings_of(F, I, obs), _task_of(F, I, obs), ex.W)
    # info of the scored step (the targets and load of the step just taken)
    n_steps = s.target_l.shape[1]
    k = min(max(s.t_idx[0] - 1, 0), n_steps - 1)
    info, terms = ex.info, s.terms
    n = INFO_SRC.shape[0]
    for j in range(n):  # the rig's declared info (tasks.rig_info)
        src, col = INFO_SRC[j], INFO_COL[j]
        if src == STATE:
            info[j] = s.state[0, col]
        elif src == AUX:
            info[j] = s.aux[0, col]
        elif src == LOAD:
            info[j] = s.load[0, k]
        elif src == TARGET_L:
            info[j] = s.target_l[0, k]
        else:
            info[j] = s.target_k[0, k]
    for m in range(terms.shape[1]):
        info[n + m] = terms[0, m]
    return s.rewards[0], s.reasons[0]
