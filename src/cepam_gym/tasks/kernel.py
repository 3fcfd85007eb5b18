"""The fused control step of every CE-PAM env: actions -> plant -> observation, reward, flags.

One compiled function per env row (:func:`_env_row`) calls the plant kernel
(:func:`cepam_gym.plant._advance`, the only copy of the equations) and then the task's
observation and reward terms. The single env and the vector env both call :func:`env_step`;
keeping the per-step task arithmetic compiled is what makes a single env faster than
Gymnasium's Pendulum and a batch of 4096 envs run at millions of steps per second.
"""

from __future__ import annotations

import math

from numba import njit, prange

from .._jit import jit
from ..physics import layout as ix
from .. import plant as pl

# columns of the task vector (TaskSpec + env kwargs flattened for the kernel)
(T_W_LEN, T_W_STIFF, T_W_EFFORT, T_W_AIR, T_W_BURST, T_TRACK_K, T_L_CENTER, T_L_HALF,
 T_V_SCALE, T_P_SCALE, T_K_SCALE, T_SETPOINT_MAX, T_LEN_CLIP, T_STIFF_CLIP, T_OBS_K) = range(15)
N_TASK = 15

REWARD_TERMS = ("length", "stiffness", "effort", "air", "burst")
N_TERMS = 5
# observation features (the stiffness target only when the task tracks stiffness)
OBS_FIELDS = ("length", "velocity", "pressure_c", "pressure_e", "supply_pressure",
              "target_length", "target_stiffness", "previous_action_c", "previous_action_e")
# noise columns: length [m], velocity [m/s], pressure_c, pressure_e, supply [Pa]
N_NOISE = 5

TERMINATION_NONE, TERMINATION_BURST, TERMINATION_NONFINITE = 0, 1, 2
TERMINATION_REASONS = ("", "burst", "non_finite_state")

_OBS_CLIP = 10.0


@jit
def write_obs(x, aux, target_l, target_k, prev_a, p, task, noise, obs):
    """Scaled float observation of one env (what a real rig measures, plus targets and a_{t-1})."""
    lc = task[T_L_CENTER]
    lh = task[T_L_HALF]
    ps = task[T_P_SCALE]
    vals = (
        (x[pl.S_L] + noise[0] - lc) / lh,
        (x[pl.S_V] + noise[1]) / task[T_V_SCALE],
        (aux[pl.A_PC] + noise[2]) / ps,
        (aux[pl.A_PE] + noise[3]) / ps,
        (p[ix.P_SUP] - p[ix.P_ATM] + noise[4]) / ps,
        (target_l - lc) / lh,
        target_k / task[T_K_SCALE],
        prev_a[0],
        prev_a[1],
    )
    j = 0
    for k in range(9):
        if k == 6 and task[T_OBS_K] == 0.0:
            continue
        v = vals[k]
        obs[j] = max(-_OBS_CLIP, min(_OBS_CLIP, v))
        j += 1


@jit
def reward_terms(L, K, air, burst, a, target_l, target_k, task, terms):
    """Signed reward terms of one env (all <= 0); returns their sum."""
    e_len = min(abs(L - target_l) / 0.01, task[T_LEN_CLIP])  # cm
    terms[0] = -task[T_W_LEN] * e_len
    if task[T_TRACK_K] != 0.0:
        terms[1] = -task[T_W_STIFF] * min(abs(K - target_k) / target_k, task[T_STIFF_CLIP])
    else:
        terms[1] = 0.0
    terms[2] = -task[T_W_EFFORT] * 0.5 * (a[0] * a[0] + a[1] * a[1])
    terms[3] = -task[T_W_AIR] * air / 1e-5  # per 10 mg
    terms[4] = -task[T_W_BURST] if burst else 0.0
    return terms[0] + terms[1] + terms[2] + terms[3] + terms[4]


@jit
def _env_row(x, a, p, mode, dt, n_sub, target_l, target_k, next_l, next_k, load, task, noise,
             inp, obs, terms, aux):
    """One control step of one env. ``a`` is the action the plant receives now; it is clipped to
    [-1, 1] here, in place, so the caller's buffer then holds what was applied."""
    a[0] = max(-1.0, min(1.0, a[0]))
    a[1] = max(-1.0, min(1.0, a[1]))
    if mode == pl.PRESSURE:
        half = 0.5 * task[T_SETPOINT_MAX]
        inp[pl.I_CMD_C] = half * (a[0] + 1.0)
        inp[pl.I_CMD_E] = half * (a[1] + 1.0)
    else:
        inp[pl.I_CMD_C] = a[0]
        inp[pl.I_CMD_E] = a[1]
    inp[pl.I_LOAD] = load
    inp[pl.I_FEXT] = 0.0
    pl._advance(x, inp, p, mode, dt, n_sub, x, aux)
    burst = aux[pl.A_BURST] != 0.0
    reward = reward_terms(x[pl.S_L], aux[pl.A_STIFF], aux[pl.A_AIR], burst, a, target_l, target_k,
                          task, terms)
    write_obs(x, aux, next_l, next_k, a, p, task, noise, obs)
    if aux[pl.A_FINITE] == 0.0 or not math.isfinite(reward):
        return 0.0, TERMINATION_NONFINITE
    if burst:
        return reward, TERMINATION_BURST
    return reward, TERMINATION_NONE


@jit
def _row(i, state, actions, params, mode, dt, n_sub, tl, tk, loads, t_idx, task, noise, inputs,
         obs, rewards, terms, aux, reasons):
    n_t = tl.shape[1]
    k = min(t_idx[i], n_t - 1)
    k1 = min(t_idx[i] + 1, n_t - 1)
    p = params[0] if params.shape[0] == 1 else params[i]
    rz = noise[0] if noise.shape[0] == 1 else noise[i]
    r, why = _env_row(state[i], actions[i], p, mode, dt, n_sub, tl[i, k], tk[i, k], tl[i, k1],
                      tk[i, k1], loads[i, k], task, rz, inputs[i], obs[i], terms[i], aux[i])
    rewards[i] = r
    reasons[i] = why
    t_idx[i] += 1


@jit
def _env_step_serial(state, actions, params, mode, dt, n_sub, tl, tk, loads, t_idx, task, noise,
                     inputs, obs, rewards, terms, aux, reasons):
    for i in range(state.shape[0]):
        _row(i, state, actions, params, mode, dt, n_sub, tl, tk, loads, t_idx, task, noise, inputs,
             obs, rewards, terms, aux, reasons)


@njit(parallel=True, cache=True, error_model="numpy")
def _env_step_parallel(state, actions, params, mode, dt, n_sub, tl, tk, loads, t_idx, task, noise,
                       inputs, obs, rewards, terms, aux, reasons):
    for i in prange(state.shape[0]):
        _row(i, state, actions, params, mode, dt, n_sub, tl, tk, loads, t_idx, task, noise, inputs,
             obs, rewards, terms, aux, reasons)


def env_step(*args):
    """Step every env of a batch in place (argument order as :func:`_env_step_serial`)."""
    n = args[0].shape[0]
    (_env_step_parallel if n >= pl._PARALLEL_MIN_BATCH else _env_step_serial)(*args)


@jit
def observe(state, aux, params, tl, tk, t_idx, prev_actions, task, noise, obs):
    """Observations of a batch without stepping (after reset)."""
    n_t = tl.shape[1]
    for i in range(state.shape[0]):
        k = min(t_idx[i], n_t - 1)
        p = params[0] if params.shape[0] == 1 else params[i]
        rz = noise[0] if noise.shape[0] == 1 else noise[i]
        write_obs(state[i], aux[i], tl[i, k], tk[i, k], prev_actions[i], p, task, rz, obs[i])
