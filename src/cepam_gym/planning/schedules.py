"""Per-episode schedules of targets and hanging loads, sampled so every episode is solvable.

A schedule is three arrays of shape (n_steps,) per env: target length [m], target stiffness
[N/m] and hanging load [kg]. Targets hold for random segments; the load follows one of the
profiles of :data:`~cepam_gym.tasks.spec.LOAD_KINDS`. Each (length, stiffness) target is checked
with the inverse static model (:func:`cepam_gym.physics.api.static_pressures`) against the
smallest and the largest load of its segment: both chamber pressures must be positive and below
``pressure_margin * min(supply, burst)``, and on plant v1 the contractor's braid must stay taut
(a slack braid adds no force, so the inverse model's pressures would not give the target). Because
the static model is affine in stiffness and load at a fixed length, feasibility at the two load
extremes implies feasibility in between.

The sampling is compiled (:func:`schedule_env`, one env from its own generator's state,
:mod:`cepam_gym.planning.rng`) and run env by env by the reset's planner
(:mod:`cepam_gym.planning.episodes`, whose :func:`~cepam_gym.planning.episodes.episode_schedules` gives
the schedules of several envs); the functions taking a NumPy generator here are its Python faces.
The draws of an episode, in order: the load profile, the segments, 8 candidate lengths per segment
and for the initial state, 8 positions in their stiffness intervals, then (only for a segment
whose 8 candidates are all infeasible) the fallback's draws.
"""

from __future__ import annotations

import numpy as np

from .._jit import jit
from ..physics import layout as ix
from ..tasks.spec import TaskSpec
from . import plan_vectors as pv
from . import rng as R
from .reach import consts, interval_at, npmax, npmin

_TRIES = 32
_CANDIDATES = 8  # target candidates drawn per segment


@jit
def load_profile_k(s, sv, n_steps, dt, out):
    """Hanging load [kg] (the joint's: external torque [N m]) over one episode into ``out``, one
    of the spec vector's load kinds picked at random; ``s`` a generator state row."""
    lo, hi = sv[pv.SV_LOAD_LO], sv[pv.SV_LOAD_HI]
    t_last = (n_steps - 1) * dt
    kind = int(sv[pv.SV_LOADS + R.integers(s, int(sv[pv.SV_N_LOADS]))])
    a = R.uniform(s, lo, hi)
    b = R.uniform(s, lo, hi)
    if kind == pv.LOAD_CONSTANT:
        for i in range(n_steps):
            out[i] = a
    elif kind == pv.LOAD_STEP:
        t_step = R.uniform(s, 0.2, 0.8) * t_last if n_steps > 1 else 0.0
        for i in range(n_steps):
            out[i] = a if i * dt < t_step else b
    elif kind == pv.LOAD_RAMP:
        top = max(t_last, dt)
        t0, t1 = R.uniform(s, 0.0, top), R.uniform(s, 0.0, top)
        if t1 < t0:
            t0, t1 = t1, t0
        span = max(t1 - t0, dt)
        for i in range(n_steps):
            out[i] = a + (b - a) * min(max((i * dt - t0) / span, 0.0), 1.0)
    elif kind == pv.LOAD_SINE:
        mid, amp = 0.5 * (lo + hi), 0.5 * (hi - lo) * R.uniform(s, 0.2, 1.0)
        omega = 2 * np.pi * R.uniform(s, 0.05, 0.5)  # Hz: slow enough for the muscle to follow
        phase = R.uniform(s, 0.0, 2 * np.pi)
        for i in range(n_steps):
            out[i] = mid + amp * np.sin(omega * (i * dt) + phase)
    else:  # random: piecewise constant, a new value every 0.5-3 s
        i = 0
        while i < n_steps:
            j = i + max(1, int(R.uniform(s, 0.5, 3.0) / dt))
            v = R.uniform(s, lo, hi)
            for k in range(i, min(j, n_steps)):
                out[k] = v
            i = j
    for i in range(n_steps):
        out[i] = npmin(npmax(out[i], lo), hi)


@jit
def segments_k(s, seg_lo, seg_hi, n_steps, dt, starts):
    """Target segments of one episode, each lasting a random duration in ``[seg_lo, seg_hi]`` s
    (the last one cut at the episode's end): their start steps into ``starts`` followed by
    ``n_steps``; returns their number."""
    n, i = 0, 0
    while i < n_steps:
        starts[n] = i
        n += 1
        i = min(n_steps, i + max(1, int(R.uniform(s, seg_lo, seg_hi) / dt)))
    starts[n] = n_steps
    return n


@jit
def _muscle_interval(pos, w_lo, w_hi, p, c, mv):
    """:func:`~cepam_gym.planning.reach.interval_at` of a target position under loads in
    ``[w_lo, w_hi]`` (the rig: lengths and weights; the joint: through its mechanism)."""
    if mv[pv.MV_JOINT] == 0.0:
        return interval_at(pos, w_lo, w_hi, p, c)
    length, weight_lo = pv.muscle_of(pos, w_lo, p, mv)
    return interval_at(length, weight_lo, pv.muscle_of(pos, w_hi, p, mv)[1], p, c)


@jit
def sample_target_k(s, sv, mv, p, c, w_lo, w_hi):
    """One reachable ``(ok, position, stiffness)`` target for loads in ``[w_lo, w_hi]`` (weights
    [N] on the rig, torques [N m] on the joint), at most ``_TRIES`` positions drawn."""
    fixed = sv[pv.SV_FIXED]
    for _ in range(_TRIES):
        pos = fixed if fixed == fixed else R.uniform(s, sv[pv.SV_LEN_LO], sv[pv.SV_LEN_HI])
        k_lo, k_hi = _muscle_interval(pos, w_lo, w_hi, p, c, mv)
        if k_hi > k_lo:
            # shrink by 5 % of the width on both sides: targets stay strictly inside
            pad = 0.05 * (k_hi - k_lo)
            return True, pos, R.uniform(s, k_lo + pad, k_hi - pad)
    return False, np.nan, np.nan


@jit
def schedule_env(s, sv, mv, p, n_steps, dt, tl, tk, load, initial, fail):
    """One env's schedule from generator state ``s`` on parameter row ``p``: targets into ``tl``,
    ``tk`` (positions and the muscle's stiffness [N/m]), loads into ``load``, the initial target
    into ``initial``. Each segment's target is its first feasible candidate, else
    :func:`sample_target_k`. Returns False (the segment's load extremes in ``fail``) when no
    reachable target exists for some segment."""
    load_profile_k(s, sv, n_steps, dt, load)
    starts = np.empty(n_steps + 1, dtype=np.int64)
    n_seg = segments_k(s, sv[pv.SV_SEG_LO], sv[pv.SV_SEG_HI], n_steps, dt, starts)
    n_cand = (n_seg + 1) * _CANDIDATES  # the last row: the initial state
    cand_l = np.empty(n_cand)
    fixed = sv[pv.SV_FIXED]
    for j in range(n_cand):
        cand_l[j] = fixed if fixed == fixed else R.uniform(s, sv[pv.SV_LEN_LO], sv[pv.SV_LEN_HI])
    cand_u = np.empty(n_cand)
    for j in range(n_cand):
        cand_u[j] = R.uniform(s, 0.05, 0.95)  # where in the K interval
    c = consts(p, sv[pv.SV_K_MIN], sv[pv.SV_K_MAX], sv[pv.SV_MARGIN])
    rig = mv[pv.MV_JOINT] == 0.0
    for g in range(n_seg + 1):
        a, b = (starts[g], starts[g + 1]) if g < n_seg else (0, 1)
        w0 = (p[ix.M_END] + load[a]) * p[ix.GRAV] if rig else load[a]
        w_lo, w_hi = w0, w0
        for i in range(a + 1, b):
            w = (p[ix.M_END] + load[i]) * p[ix.GRAV] if rig else load[i]
            w_lo, w_hi = npmin(w_lo, w), npmax(w_hi, w)
        ok = False
        pos, k = 0.0, 0.0
        for j in range(g * _CANDIDATES, (g + 1) * _CANDIDATES):
            k_lo, k_hi = _muscle_interval(cand_l[j], w_lo, w_hi, p, c, mv)
            if k_hi > k_lo:
                ok, pos, k = True, cand_l[j], k_lo + cand_u[j] * (k_hi - k_lo)
                break
        if not ok:
            ok, pos, k = sample_target_k(s, sv, mv, p, c, w_lo, w_hi)
            if not ok:
                fail[0], fail[1] = w_lo, w_hi
                return False
        if g < n_seg:
            for i in range(a, b):
                tl[i] = pos
                tk[i] = k
        else:
            initial[0], initial[1] = pos, k
    return True


# ------------------------------------------------------------------ the NumPy faces
def load_profile(rng: np.random.Generator, spec: TaskSpec, n_steps: int, dt: float) -> np.ndarray:
    """Hanging load [kg] over one episode, one of the task's load kinds picked at random."""
    s = R.pack([rng])
    out = np.empty(n_steps)
    load_profile_k(s[0], pv.spec_vector(spec), n_steps, dt, out)
    R.unpack([rng], s)
    return out


def segments(rng, spec: TaskSpec, n_steps: int, dt: float) -> list[tuple[int, int]]:
    """``(start, stop)`` step indices of the target segments of one episode, each lasting a
    random ``segment_duration`` (the last one cut at the episode's end)."""
    s = R.pack([rng])
    starts = np.empty(n_steps + 1, dtype=np.int64)
    n = segments_k(s[0], *spec.segment_duration, n_steps, dt, starts)
    R.unpack([rng], s)
    return list(zip(starts[:n].tolist(), starts[1 : n + 1].tolist()))


@jit
def _intervals(L, w_lo, w_hi, P, k_min, k_max, margin, out_lo, out_hi):
    shared = P.shape[0] == 1
    for i in range(L.shape[0]):
        p = P[0] if shared else P[i]
        out_lo[i], out_hi[i] = interval_at(L[i], w_lo[i], w_hi[i], p, consts(p, k_min, k_max, margin))


def stiffness_interval(length, w_lo, w_hi, params, spec: TaskSpec):
    """Reachable stiffness interval ``(K_lo, K_hi)`` [N/m] at ``length`` for weights in
    ``[w_lo, w_hi]`` [N] (arrays of their broadcast shape); empty when ``K_lo >= K_hi``. ``params``
    is one row, or one row per element of the (1-D) arguments."""
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (length, w_lo, w_hi)))
    shape = arrays[0].shape
    flat = [np.ascontiguousarray(a).reshape(-1) for a in arrays]
    P = np.ascontiguousarray(np.atleast_2d(np.asarray(params, dtype=float)))
    out_lo, out_hi = np.empty(flat[0].shape[0]), np.empty(flat[0].shape[0])
    _intervals(
        *flat, P, *(float(v) for v in spec.stiffness_range), float(spec.pressure_margin), out_lo, out_hi
    )
    return out_lo.reshape(shape), out_hi.reshape(shape)


def _no_target(spec: TaskSpec, w_lo: float, w_hi: float) -> RuntimeError:
    return RuntimeError(
        f"task {spec.name!r}: found no reachable target in {_TRIES} tries for loads "
        f"{w_lo / 9.81:.3g}-{w_hi / 9.81:.3g} kg; the plant's pressures cannot hold these loads "
        "(lower load_range, widen length_range, or raise the supply/burst pressure)"
    )


def sample_target(rng, spec: TaskSpec, w_lo: float, w_hi: float, params_row) -> tuple[float, float]:
    """One reachable ``(length, stiffness)`` target for weights in ``[w_lo, w_hi]`` [N] (at most
    32 lengths drawn; ``RuntimeError`` when none is reachable)."""
    p = np.asarray(params_row, dtype=float)
    sv = pv.spec_vector(spec)
    s = R.pack([rng])
    c = (sv[pv.SV_K_MIN], sv[pv.SV_K_MAX], sv[pv.SV_MARGIN])
    ok, length, k = _sample_target(s[0], sv, pv.rig_mechanism(), p, *c, float(w_lo), float(w_hi))
    R.unpack([rng], s)
    if not ok:
        raise _no_target(spec, w_lo, w_hi)
    return length, k


@jit
def _sample_target(s, sv, mv, p, k_min, k_max, margin, w_lo, w_hi):
    return sample_target_k(s, sv, mv, p, consts(p, k_min, k_max, margin), w_lo, w_hi)
