"""The reset's planner: every env's episode (load profile, target schedule, shaped reference) in
one compiled call, env by env from each env's own generator.

A reset used to shape each env's reference in Python (about 1 ms per env: a 1024-env batch spent
as long resetting as stepping through its episode). Here the generators' states are copied into
compiled code (:mod:`cepam_gym.planning.rng`), every draw and every check runs there in the order the
NumPy code ran them, and the states are copied back: the episodes are the former ones bit for bit
(``tests/planning/test_reset_kernels.py`` compares them with the former code, kept in the tests, on many
seeds and tasks; the golden tests compare whole trajectories). Env i draws only from ``rngs[i]``,
so a batch equals single envs.

Per env: :func:`~cepam_gym.planning.schedules.schedule_env` (the step schedule, the loads and the
initial target), then, for tasks with references other than ``step``, a reference kind drawn from
the task's and :func:`~cepam_gym.planning.references.shape_k`; a reference that cannot be made
reachable at some step (a load too large for the length the move passes) falls back to ``min_jerk``
moves between the schedule's set-points, and those to the set-points themselves. With a shaped
reference the episode starts at rest on its first point (no jump at t = 0). The loads stay the
schedule's: a load change is a disturbance the controller is not told about.

The joint (mechanism vector :func:`~cepam_gym.planning.plan_vectors.joint_mechanism`): targets are
drawn as muscle lengths of the nominal plant and returned as joint angles [rad] and joint
stiffnesses [N m/rad], loads are external torques [N m]; its references are shaped in muscle
coordinates under the equivalent hanging load and projected once more at their own angles (the
link's weight depends on the angle).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .._jit import jit
from ..physics import layout as ix
from ..physics.statics import static_pressures
from ..plant.state import initial_state, rest_rows
from ..tasks.spec import TaskSpec
from . import plan_vectors as pv
from . import rng as R
from .reach import N_T, consts, npclip, npmin, project_into
from .references import shape_k
from .schedules import _no_target, schedule_env

# batches at least this large are planned on every core (each env is independent)
PARALLEL_MIN_ENVS = 64


@jit
def _reference_rig(s, sv, p, dt, tl, tk, load, initial):
    """The rig's shaped reference of one env, in place of its step schedule ``(tl, tk)``."""
    n = tl.shape[0]
    c = consts(p, sv[pv.SV_K_MIN], sv[pv.SV_K_MAX], sv[pv.SV_MARGIN])
    kind = int(sv[pv.SV_REFS + R.integers(s, int(sv[pv.SV_N_REFS]))])
    L, K = np.empty(n), np.empty(n)
    lo, hi = sv[pv.SV_LEN_LO], sv[pv.SV_LEN_HI]
    ok = shape_k(kind, s, sv, p, c, lo, hi, tl, tk, load, dt, L, K)
    if not ok and kind != pv.REF_STEP:
        ok = shape_k(pv.REF_MIN_JERK, s, sv, p, c, lo, hi, tl, tk, load, dt, L, K)
    if ok:
        tl[:] = L
        tk[:] = K
        initial[0], initial[1] = L[0], K[0]


@jit
def _equivalent_load(angle, torque, p, mv, out):
    """The hanging load [kg] on the rig that the joint's loads at ``angle`` amount to."""
    for i in range(angle.shape[0]):
        out[i] = pv.equivalent_weight(angle[i], torque[i], p, mv) / p[ix.GRAV] - p[ix.M_END]


@jit
def _reference_joint(s, sv, mv, p, dt, ta, tk, torque, initial):
    """The joint's shaped reference of one env, in place of its step schedule ``(ta, tk)``
    (angles [rad], joint stiffnesses [N m/rad])."""
    n = ta.shape[0]
    r, r2 = mv[pv.MV_R], mv[pv.MV_R2]
    c = consts(p, sv[pv.SV_K_MIN], sv[pv.SV_K_MAX], sv[pv.SV_MARGIN])
    # the task as this plant's muscle sees it (its end stop sets the lengths of the angle range)
    len_lo, len_hi = p[ix.L_MAX] - r * mv[pv.MV_A_HI], p[ix.L_MAX] - r * mv[pv.MV_A_LO]
    kind = int(sv[pv.SV_REFS + R.integers(s, int(sv[pv.SV_N_REFS]))])
    L, K, load = np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):
        L[i] = p[ix.L_MAX] - r * ta[i]
        K[i] = tk[i] / r2
    _equivalent_load(ta, torque, p, mv, load)
    work = np.empty((6, n))
    Ls, Ks, angle, load2, L2, K2 = work[0], work[1], work[2], work[3], work[4], work[5]
    T = np.empty((N_T, n))
    for attempt in range(2):
        k = kind if attempt == 0 else pv.REF_MIN_JERK
        if attempt == 1 and kind == pv.REF_MIN_JERK:
            return  # min_jerk draws nothing: a second try would fail alike
        if not shape_k(k, s, sv, p, c, len_lo, len_hi, L, K, load, dt, Ls, Ks):
            continue
        for i in range(n):
            angle[i] = (p[ix.L_MAX] - Ls[i]) / r
        _equivalent_load(angle, torque, p, mv, load2)
        if project_into(Ls, Ks, load2, p, c, len_lo, len_hi, L2, K2, T) >= 0:
            continue
        for i in range(n):
            ta[i] = (p[ix.L_MAX] - L2[i]) / r
            tk[i] = K2[i] * r2
        initial[0], initial[1] = ta[0], tk[0]
        return


@jit
def _plan_env(s, sv, mv, p, n_steps, dt, shape, tl, tk, load, initial, fail):
    """One env's episode (see the module doc); False when no reachable target exists."""
    if not schedule_env(s, sv, mv, p, n_steps, dt, tl, tk, load, initial, fail):
        return False
    if mv[pv.MV_JOINT] != 0.0:  # positions (muscle lengths of the nominal plant) to angles
        for i in range(n_steps):
            tl[i] = (mv[pv.MV_L_MAX] - tl[i]) / mv[pv.MV_R]
            tk[i] = tk[i] * mv[pv.MV_R2]
        initial[0] = (mv[pv.MV_L_MAX] - initial[0]) / mv[pv.MV_R]
        initial[1] = initial[1] * mv[pv.MV_R2]
        if shape:
            _reference_joint(s, sv, mv, p, dt, tl, tk, load, initial)
    elif shape:
        _reference_rig(s, sv, p, dt, tl, tk, load, initial)
    return True


@jit
def _plan_serial(states, params, sv, mv, n_steps, dt, shape, tl, tk, load, initial, ok, fail):
    shared = params.shape[0] == 1
    for i in range(states.shape[0]):
        p = params[0] if shared else params[i]
        ok[i] = _plan_env(
            states[i], sv, mv, p, n_steps, dt, shape, tl[i], tk[i], load[i], initial[i], fail[i]
        )


@njit(parallel=True, cache=True, error_model="numpy")
def _plan_parallel(states, params, sv, mv, n_steps, dt, shape, tl, tk, load, initial, ok, fail):
    shared = params.shape[0] == 1
    for i in prange(states.shape[0]):
        p = params[0] if shared else params[i]
        ok[i] = _plan_env(
            states[i], sv, mv, p, n_steps, dt, shape, tl[i], tk[i], load[i], initial[i], fail[i]
        )


def plan(rngs, spec: TaskSpec, params, n_steps: int, dt: float, mechanism=None, shape=True):
    """``(target_l, target_k, load, initial)`` (arrays (n_envs, n_steps), ``initial`` (n_envs, 2))
    of the envs drawing from ``rngs`` on parameter ``params`` (one row, or one per env).
    ``mechanism``: None (the rig) or the joint's vector (``spec`` then the task as the nominal
    plant's muscle sees it); ``shape``: shape the references of ``spec.references``.
    ``RuntimeError`` when no reachable target exists for some env (the generators have then
    advanced as far as that env's failed draws)."""
    m = len(rngs)
    P = np.ascontiguousarray(np.atleast_2d(np.asarray(params, dtype=float)))
    mv = pv.rig_mechanism() if mechanism is None else np.asarray(mechanism, dtype=float)
    sv = pv.spec_vector(spec)
    shape = bool(shape) and tuple(spec.references) != ("step",)
    tl, tk, load = (np.empty((m, n_steps)) for _ in range(3))
    initial, fail = np.empty((m, 2)), np.zeros((m, 2))
    ok = np.zeros(m, dtype=np.bool_)
    states = R.pack(rngs)
    kernel = _plan_parallel if m >= PARALLEL_MIN_ENVS else _plan_serial
    kernel(states, P, sv, mv, int(n_steps), float(dt), shape, tl, tk, load, initial, ok, fail)
    R.unpack(rngs, states)
    if not ok.all():
        i = int(np.argmin(ok))
        raise _no_target(spec, *fail[i])
    return tl, tk, load, initial


def planned_schedules(rngs, spec: TaskSpec, params, n_steps: int, dt: float):
    """The rig's episodes: :func:`plan` with the references of ``spec.references``."""
    return plan(rngs, spec, params, n_steps, dt)


def episode_schedules(rngs, spec: TaskSpec, params, n_steps: int, dt: float, mechanism=None):
    """The step schedules of several envs (no reference shaping): ``(target_length,
    target_stiffness, load, initial)`` with arrays of shape (n_envs, n_steps) and ``initial``
    (n_envs, 2) = length, stiffness; :func:`plan` with ``shape=False``."""
    return plan(rngs, spec, params, n_steps, dt, mechanism, shape=False)


@jit
def _start_pressures(idx, initial, load0, params, mv, L, pc, pe):
    """The muscle length [m] and chamber pressures [Pa] of the inverse static model at each env's
    initial target under its first load (the joint's clipped to ``[0, min(supply, burst)]``, as
    :meth:`~cepam_gym.mujoco.joint_sim.JointSimulator.reset` starts)."""
    shared = params.shape[0] == 1
    joint = mv[pv.MV_JOINT] != 0.0
    for j in range(idx.shape[0]):
        p = params[0] if shared else params[idx[j]]
        if joint:
            a0 = initial[j, 0]
            L[j] = p[ix.L_MAX] - mv[pv.MV_R] * a0
            w = pv.equivalent_weight(a0, load0[j], p, mv)
            c, e, _ = static_pressures(L[j], initial[j, 1] / mv[pv.MV_R2], w, p)
            cap = npmin(p[ix.P_SUP] - p[ix.P_ATM], p[ix.P_BURST])
            pc[j], pe[j] = npclip(c, 0.0, cap), npclip(e, 0.0, cap)
        else:
            L[j] = initial[j, 0]
            w = (p[ix.M_END] + load0[j]) * p[ix.GRAV]
            pc[j], pe[j], _ = static_pressures(L[j], initial[j, 1], w, p)


def start_at_rest(s, idx, initial, mechanism=None) -> None:
    """Envs ``idx`` of env state ``s`` (:class:`~cepam_gym.envs.state.EnvState`) at rest at their
    ``initial`` (position, stiffness) rows under their first load, step 0 (one compiled call for
    the pressures, one for the plants)."""
    idx = np.ascontiguousarray(idx, dtype=np.int64)
    mv = pv.rig_mechanism() if mechanism is None else mechanism
    m = idx.shape[0]
    L, pc, pe = np.empty(m), np.empty(m), np.empty(m)
    load0 = np.ascontiguousarray(s.load[idx, 0])
    _start_pressures(idx, np.ascontiguousarray(initial, dtype=float), load0, s.params, mv, L, pc, pe)
    if rest_rows(idx, L, pc, pe, s.params, s.state, s.aux) >= 0:
        initial_state(s.params[idx], L, pc, pe)  # raises, naming what is wrong
    s.t_idx[idx] = 0
