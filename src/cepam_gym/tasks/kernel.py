"""The fused control step of every CE-PAM env: actions -> plant -> observation, reward, flags.

One compiled function per block of envs (:func:`_env_block`) calls the plant kernel
(:func:`cepam_gym.plant.advance_block`, the only copy of the equations, or its hinge form
:func:`~cepam_gym.plant.advance_block_hinge` for the joint env) and then the task's observation
and reward terms, through :func:`mechanism_view` (the rig's length or the joint's angle). The
single env and the vector env both call :func:`env_step`; keeping the per-step task arithmetic
compiled is what makes a single env faster than Gymnasium's Pendulum and a batch of 4096 envs
run at millions of steps per second.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .. import plant as pl
from .._jit import jit, row_of, row_view, vec_view
from ..physics import layout as ix
from ..physics.hinge import H_R, N_HINGE
from ..plant.actions import valve_commands
from .contract import RIG
from .layout import OBS_FIELDS, ObsLayout
from .spec import TERMINATION_BURST, TERMINATION_NONE, TERMINATION_NONFINITE, TERMINATION_REASONS

__all__ = [
    "OBS_FIELDS",
    "TERMINATION_REASONS",
    "task_vector",
    "encode",
    "write_obs",
    "write_preview",
    "reward_terms",
    "termination",
    "valve_commands",
    "env_step",
    "observe",
    "mechanism_view",
    "no_hinge",
]

# The task vector: everything the kernel needs to know of the task, flattened (built by
# :func:`task_vector` from the task spec, its scales and its observation layout): reward weights
# (in REWARD_TERMS order), units and clips of the terms, the pressure set-point range, then the
# observation layout, one (source field, offset, scale) triple per column.
(
    T_W_TRACK,
    T_W_STIFF,
    T_W_EFFORT,
    T_W_AIR,
    T_W_BURST,
    T_TRACK_K,
    T_TRACK_UNIT,
    T_TRACK_CLIP,
    T_STIFF_CLIP,
    T_AIR_UNIT,
    T_SETPOINT_MAX,
    T_OBS_CLIP,
    T_OBS_N,
) = range(13)
T_OBS = 13
MAX_OBS = len(OBS_FIELDS)
# then the preview: steps announced, and the offset and scale of the length and stiffness columns
T_PREVIEW = T_OBS + 3 * MAX_OBS
T_PREV_L_OFF, T_PREV_L_SCALE, T_PREV_K_SCALE = T_PREVIEW + 1, T_PREVIEW + 2, T_PREVIEW + 3
N_TASK = T_PREVIEW + 4

# the names of the term slots, the rig's (tasks.contract; the joint names the first "angle")
REWARD_TERMS = RIG.reward_terms
N_TERMS = len(REWARD_TERMS)
# noise columns: length [m], velocity [m/s], pressure_c, pressure_e, supply [Pa]
N_NOISE = 5


def task_vector(
    weights,
    scales,
    layout: ObsLayout,
    setpoint_max: float,
    track_stiffness: bool = True,
    position: str = "length",
) -> np.ndarray:
    """The task vector of a task: ``weights`` the five reward weights in REWARD_TERMS order,
    ``scales`` a :class:`~cepam_gym.tasks.spec.TaskScales`, ``layout`` the observation layout (at
    most :data:`MAX_OBS` columns), ``setpoint_max`` [Pa] the gauge pressure of the action +1 in
    pressure mode, ``position`` the name of the tracked position in the preview columns
    (``"length"`` on the rig, ``"angle"`` on the joint)."""
    v = np.zeros(N_TASK)
    v[T_W_TRACK : T_W_BURST + 1] = [float(w) for w in weights]
    v[T_TRACK_K] = float(track_stiffness)
    v[T_TRACK_UNIT], v[T_TRACK_CLIP] = scales.tracking_unit, scales.tracking_clip
    v[T_STIFF_CLIP], v[T_AIR_UNIT] = scales.stiffness_clip, scales.air_unit
    v[T_SETPOINT_MAX] = setpoint_max
    # the measured columns (at most one per measured quantity), then the preview columns
    n = layout.n_measured
    if n > MAX_OBS:
        raise ValueError(f"an observation layout has at most {MAX_OBS} measured columns; got {layout.names}")
    v[T_OBS_CLIP], v[T_OBS_N] = layout.clip, n
    v[T_OBS : T_OBS + 3 * n : 3] = layout.sources()[:n]
    v[T_OBS + 1 : T_OBS + 3 * n : 3] = layout.offsets()[:n]
    v[T_OBS + 2 : T_OBS + 3 * n : 3] = layout.scales()[:n]
    steps = layout.preview_steps
    if steps:
        if layout.preview_of != position or layout.has("target_stiffness") != bool(track_stiffness):
            raise ValueError(
                f"the layout previews {layout.preview_of} (stiffness: {layout.has('target_stiffness')}), "
                f"the task tracks {position} (stiffness: {bool(track_stiffness)})"
            )
        v[T_PREVIEW] = steps
        v[T_PREV_L_OFF] = layout.columns[n].offset
        v[T_PREV_L_SCALE] = layout.columns[n].scale
        v[T_PREV_K_SCALE] = layout.columns[n + steps].scale if track_stiffness else 1.0
    return v


@jit
def encode(vals, task, obs):
    """Observation of the measured ``vals`` (a tuple in the layout's ``fields`` order, SI) by the
    layout in ``task``: ``clip((value - offset) / scale)`` per column
    (:class:`~cepam_gym.tasks.layout.ObsLayout`)."""
    clip = task[T_OBS_CLIP]
    for j in range(int(task[T_OBS_N])):
        c = T_OBS + 3 * j
        v = (vals[int(task[c])] - task[c + 1]) / task[c + 2]
        obs[j] = max(-clip, min(clip, v))


@jit
def write_preview(tl_row, tk_row, k_next, task, obs):
    """The preview columns: the targets of the ``T_PREVIEW`` control steps after step ``k_next``
    (the one the ``target_*`` columns show), the last target held past the episode's end."""
    steps = int(task[T_PREVIEW])
    if steps == 0:
        return
    n_t = tl_row.shape[0]
    base = int(task[T_OBS_N])
    clip = task[T_OBS_CLIP]
    track_k = task[T_TRACK_K] != 0.0
    for j in range(steps):
        kk = min(k_next + 1 + j, n_t - 1)
        v = (tl_row[kk] - task[T_PREV_L_OFF]) / task[T_PREV_L_SCALE]
        obs[base + j] = max(-clip, min(clip, v))
        if track_k:
            v = tk_row[kk] / task[T_PREV_K_SCALE]
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
def reward_terms(x, x_target, K, K_target, a0, a1, air, burst, task, terms):
    """Signed reward terms of one env (all <= 0), written to ``terms``; returns their sum.

    ``x`` is the tracked position (muscle length [m] on the rig, joint angle [rad] on the joint),
    ``K`` the stiffness the task sets (N/m, or N m/rad), ``a0, a1`` the applied action, ``air`` the
    supply air of the step [kg], ``burst`` whether a chamber burst. The same function scores every
    env (rig and joint)."""
    terms[0] = -task[T_W_TRACK] * min(abs(x - x_target) / task[T_TRACK_UNIT], task[T_TRACK_CLIP])
    if task[T_TRACK_K] != 0.0:
        terms[1] = -task[T_W_STIFF] * min(abs(K - K_target) / K_target, task[T_STIFF_CLIP])
    else:
        terms[1] = 0.0
    terms[2] = -task[T_W_EFFORT] * 0.5 * (a0 * a0 + a1 * a1)
    terms[3] = -task[T_W_AIR] * air / task[T_AIR_UNIT]
    terms[4] = -task[T_W_BURST] if burst else 0.0
    return terms[0] + terms[1] + terms[2] + terms[3] + terms[4]


@jit
def termination(finite, burst):
    """Termination reason code (:data:`TERMINATION_REASONS`) of a step: a non-finite state or
    reward first, then a burst."""
    if not finite:
        return TERMINATION_NONFINITE
    return TERMINATION_BURST if burst else TERMINATION_NONE


@jit
def _env_block(
    lo,
    n,
    state,
    actions,
    params,
    hinge,
    mech,
    mode,
    dt,
    n_sub,
    tl,
    tk,
    loads,
    t_idx,
    task,
    noise,
    inputs,
    obs,
    rewards,
    terms,
    aux,
    reasons,
    W,
):
    """One control step of envs ``lo .. lo + n - 1`` (one plant block, ``n <= plant.BLOCK``).

    ``mech``: :data:`cepam_gym.plant.RIG` (``loads`` are hanging masses [kg]) or
    :data:`cepam_gym.plant.HINGE` (``hinge`` rows, ``loads`` external torques [N m], targets in
    rad and N m/rad).

    Each env's action (the plant receives it now) is clipped to [-1, 1] in place, so the caller's
    buffer then holds what was applied; the plant block advances; then each env's reward terms,
    observation and termination reason are written."""
    n_t = tl.shape[1]
    for i in range(lo, lo + n):
        a = row_of(actions, i)
        a[0] = max(-1.0, min(1.0, a[0]))
        a[1] = max(-1.0, min(1.0, a[1]))
        inp = row_of(inputs, i)
        inp[pl.I_CMD_C], inp[pl.I_CMD_E] = valve_commands(mode, a[0], a[1], task[T_SETPOINT_MAX])
        if mech == pl.HINGE:  # the external torque acts on the muscle as tau / r
            inp[pl.I_LOAD] = 0.0
            inp[pl.I_FEXT] = loads[i, min(t_idx[i], n_t - 1)] / hinge[0 if hinge.shape[0] == 1 else i, H_R]
        else:
            inp[pl.I_LOAD] = loads[i, min(t_idx[i], n_t - 1)]
            inp[pl.I_FEXT] = 0.0
    if mech == pl.HINGE:
        pl.advance_block_hinge(state, inputs, params, hinge, lo, n, mode, dt, n_sub, state, aux, W)
    else:
        pl.advance_block(state, inputs, params, lo, n, mode, dt, n_sub, state, aux, W)
    for i in range(lo, lo + n):
        k = min(t_idx[i], n_t - 1)
        k1 = min(t_idx[i] + 1, n_t - 1)
        x = row_of(state, i)
        ax = row_of(aux, i)
        burst = ax[pl.A_BURST] != 0.0
        a = row_of(actions, i)
        p = row_of(params, 0 if params.shape[0] == 1 else i)
        pos, vel, K = mechanism_view(
            x, ax[pl.A_STIFF], p, row_of(hinge, 0 if hinge.shape[0] == 1 else i), mech
        )
        reward = reward_terms(
            pos, tl[i, k], K, tk[i, k], a[0], a[1], ax[pl.A_AIR], burst, task, row_of(terms, i)
        )
        write_obs(
            pos,
            vel,
            ax,
            tl[i, k1],
            tk[i, k1],
            a,
            p,
            task,
            row_of(noise, 0 if noise.shape[0] == 1 else i),
            row_of(obs, i),
        )
        write_preview(row_of(tl, i), row_of(tk, i), t_idx[i] + 1, task, row_of(obs, i))
        reasons[i] = termination(ax[pl.A_FINITE] != 0.0 and math.isfinite(reward), burst)
        rewards[i] = 0.0 if reasons[i] == TERMINATION_NONFINITE else reward
        t_idx[i] += 1


@jit
def _env_step_serial(
    state,
    actions,
    params,
    hinge,
    mech,
    mode,
    dt,
    n_sub,
    tl,
    tk,
    loads,
    t_idx,
    task,
    noise,
    inputs,
    obs,
    rewards,
    terms,
    aux,
    reasons,
):
    n = state.shape[0]
    W = np.empty(pl.W_SIZE)
    for lo in range(0, n, pl.BLOCK):
        _env_block(
            lo,
            min(pl.BLOCK, n - lo),
            state,
            actions,
            params,
            hinge,
            mech,
            mode,
            dt,
            n_sub,
            tl,
            tk,
            loads,
            t_idx,
            task,
            noise,
            inputs,
            obs,
            rewards,
            terms,
            aux,
            reasons,
            W,
        )


@njit(parallel=True, cache=True, error_model="numpy")
def _env_step_parallel(
    state,
    actions,
    params,
    hinge,
    mech,
    mode,
    dt,
    n_sub,
    tl,
    tk,
    loads,
    t_idx,
    task,
    noise,
    inputs,
    obs,
    rewards,
    terms,
    aux,
    reasons,
):
    n = state.shape[0]
    for b in prange((n + pl.BLOCK - 1) // pl.BLOCK):
        lo = b * pl.BLOCK
        _env_block(
            lo,
            min(pl.BLOCK, n - lo),
            state,
            actions,
            params,
            hinge,
            mech,
            mode,
            dt,
            n_sub,
            tl,
            tk,
            loads,
            t_idx,
            task,
            noise,
            inputs,
            obs,
            rewards,
            terms,
            aux,
            reasons,
            np.empty(pl.W_SIZE),
        )


def env_step(*args):
    """Step every env of a batch in place (argument order as :func:`_env_step_serial`)."""
    n = args[0].shape[0]
    (_env_step_parallel if n >= pl.PARALLEL_MIN_BATCH else _env_step_serial)(*args)


@jit
def observe(state, aux, params, hinge, mech, tl, tk, t_idx, prev_actions, task, noise, obs):
    """Observations of a batch without stepping (after reset)."""
    n_t = tl.shape[1]
    for i in range(state.shape[0]):
        k = min(t_idx[i], n_t - 1)
        p = params[0] if params.shape[0] == 1 else params[i]
        rz = noise[0] if noise.shape[0] == 1 else noise[i]
        h = hinge[0 if hinge.shape[0] == 1 else i]
        pos, vel, _k = mechanism_view(state[i], aux[i, pl.A_STIFF], p, h, mech)
        write_obs(pos, vel, aux[i], tl[i, k], tk[i, k], prev_actions[i], p, task, rz, obs[i])
        write_preview(tl[i], tk[i], t_idx[i], task, obs[i])


# ------------------------------------------------------------------ single env
# A single env's step is dominated by Python overhead, a good part of it the dispatch of a jitted
# call (about 55 ns per array argument). Its arrays are therefore views into two slabs, one float64
# and one int64, and its step is one jitted call with three arrays and two floats; the call also
# writes the values of the step's ``info`` in order (length, velocity, the AUX_INFO columns,
# load, targets, reward terms). Inside, the views are borrowed (``_jit.row_view``): a reshaped
# slice calls a helper and is reference counted across every call it is passed to, which cost
# 0.3 us of the single step's 0.7 us of fixed compiled work.
AUX_INFO = (pl.A_STIFF, pl.A_STIFF_CLOSED, pl.A_FORCE, pl.A_PC, pl.A_PE, pl.A_TC, pl.A_TE, pl.A_AIR)
N_INFO = 2 + len(AUX_INFO) + 3 + N_TERMS
_SINGLE_FIELDS = (
    ("state", pl.N_STATE),
    ("actions", 2),
    ("params", ix.N_PARAMS),
    ("hinge", N_HINGE),
    ("inputs", pl.N_INPUT),
    ("aux", pl.N_AUX),
    ("terms", N_TERMS),
    ("rewards", 1),
    ("noise", N_NOISE),
    ("task", N_TASK),
    ("dt", 1),
    ("info", N_INFO),
    ("W", pl.W_SIZE),
)
_OFF = {}
_o = 0
for _name, _size in _SINGLE_FIELDS:
    _OFF[_name] = _o
    _o += _size
_F_STATE, _F_ACT, _F_PARAMS, _F_HINGE, _F_INPUTS, _F_AUX = (
    _OFF[k] for k in ("state", "actions", "params", "hinge", "inputs", "aux")
)
_F_TERMS, _F_REW, _F_NOISE, _F_TASK, _F_DT, _F_INFO, _F_W = (
    _OFF[k] for k in ("terms", "rewards", "noise", "task", "dt", "info", "W")
)
_F_SCHED = _o  # then target length, target stiffness and load, n_steps each
_I_T, _I_REASON, _I_MODE, _I_NSUB, _I_MECH = range(5)
NONFINITE_ACTION = -1  # env_step_single's reason for an action it refused


def single_slabs(n_steps: int, mode: int, n_sub: int, dt: float, mech: int = pl.RIG):
    """``(F, I, views)`` of a single env: the two slabs and named (1, k) views into them (state,
    actions, params, hinge, inputs, aux, terms, rewards (1,), noise, task (N_TASK,), target_l,
    target_k, load, t_idx (1,), reasons (1,), info (N_INFO,))."""
    F = np.zeros(_F_SCHED + 3 * n_steps)
    I = np.zeros(5, dtype=np.int64)
    I[_I_MODE], I[_I_NSUB], I[_I_MECH] = mode, n_sub, mech
    F[_F_DT] = dt
    v = {name: F[_OFF[name] : _OFF[name] + size].reshape(1, size) for name, size in _SINGLE_FIELDS}
    v["rewards"] = v["rewards"].reshape(1)
    v["task"] = v["task"].reshape(N_TASK)
    v["info"] = v["info"].reshape(N_INFO)
    for j, name in enumerate(("target_l", "target_k", "load")):
        v[name] = F[_F_SCHED + j * n_steps : _F_SCHED + (j + 1) * n_steps].reshape(1, n_steps)
    v["t_idx"] = I[_I_T : _I_T + 1]
    v["reasons"] = I[_I_REASON : _I_REASON + 1]
    return F, I, v


@jit
def env_step_single(F, I, obs, a0, a1):
    """One control step of a single env whose arrays live in the slabs ``F``, ``I`` (see
    :func:`single_slabs`), with the action ``(a0, a1)``; returns ``(reward, reason)``, or
    ``(nan, NONFINITE_ACTION)`` without stepping when an action is NaN or inf (checked here: one
    call less on the single env's hot path)."""
    if not (math.isfinite(a0) and math.isfinite(a1)):
        return math.nan, NONFINITE_ACTION
    n_steps = (F.shape[0] - _F_SCHED) // 3
    state = row_view(F, _F_STATE, pl.N_STATE)
    actions = row_view(F, _F_ACT, 2)
    actions[0, 0] = a0
    actions[0, 1] = a1
    tl = row_view(F, _F_SCHED, n_steps)
    tk = row_view(F, _F_SCHED + n_steps, n_steps)
    loads = row_view(F, _F_SCHED + 2 * n_steps, n_steps)
    t_idx = vec_view(I, _I_T, 1)
    aux = row_view(F, _F_AUX, pl.N_AUX)
    terms = row_view(F, _F_TERMS, N_TERMS)
    _env_block(
        0,
        1,
        state,
        actions,
        row_view(F, _F_PARAMS, ix.N_PARAMS),
        row_view(F, _F_HINGE, N_HINGE),
        I[_I_MECH],
        I[_I_MODE],
        F[_F_DT],
        I[_I_NSUB],
        tl,
        tk,
        loads,
        t_idx,
        vec_view(F, _F_TASK, N_TASK),
        row_view(F, _F_NOISE, N_NOISE),
        row_view(F, _F_INPUTS, pl.N_INPUT),
        obs,
        vec_view(F, _F_REW, 1),
        terms,
        aux,
        vec_view(I, _I_REASON, 1),
        vec_view(F, _F_W, pl.W_SIZE),
    )
    # info of the scored step (the targets and load of the step just taken)
    k = min(max(t_idx[0] - 1, 0), n_steps - 1)
    info = vec_view(F, _F_INFO, N_INFO)
    info[0] = state[0, pl.S_L]
    info[1] = state[0, pl.S_V]
    for j in range(len(AUX_INFO)):
        info[2 + j] = aux[0, AUX_INFO[j]]
    j = 2 + len(AUX_INFO)
    info[j] = loads[0, k]
    info[j + 1] = tl[0, k]
    info[j + 2] = tk[0, k]
    for m in range(N_TERMS):
        info[j + 3 + m] = terms[0, m]
    return F[_F_REW], I[_I_REASON]
