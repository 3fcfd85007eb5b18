"""Reference trajectories for tracking tasks: what a CE-PAM user plans, so a controller can be told
the next fraction of a second in advance.

Kinds (:data:`REFERENCE_KINDS`), each a pair of arrays (target length [m], target stiffness
[N/m]) over an episode's control steps:

* ``step``: set-points held for a segment, changing at once (the v0 schedule);
* ``min_jerk``: the same set-points joined by minimum-jerk moves (Flash and Hogan 1985) in length
  and stiffness together, each lasting ``move_s`` seconds (shorter if the next set-point comes
  first);
* ``sine``: length ``c + a sin(2 pi f t + phi)`` at a constant stiffness: the paper's profile of a
  constant stiffness at varying length (section XII);
* ``chirp``: the same with the frequency rising linearly from ``f0`` to ``f1`` over the episode;
* ``stiffness_ramp``: a fixed length with the stiffness moving linearly between set-points: the
  paper's profile of varying stiffness at a fixed length (section XII).

Every reference is **reachable**: :func:`project` clips, step by step, the length to the task's
range and the stiffness to the interval the inverse static model reaches at that length and load
(:func:`~cepam_gym.planning.schedules.stiffness_interval`, pressures within the task's margin). And
**followable**: :func:`pressure_rate_ratio` compares the chamber pressure rates the reference asks
for (the inverse static model along it) with what a fully open valve gives each chamber at that
pressure and volume (ISO 6358 flow, adiabatic filling ``dP/dt = gamma R T mdot / V``); the
generators lower the frequency or lengthen the moves until the ratio is below ``rate_fraction``.

The shaping is compiled (:func:`shape_k`, one env on one parameter row, from its generator's state,
:mod:`cepam_gym.planning.rng`), so the reset's planner (:mod:`cepam_gym.planning.episodes`) runs it env
by env without Python; the functions taking arrays and NumPy generators here are its Python faces.
A reference that cannot be made reachable is "None" (the planner then falls back).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .._jit import jit, jit_inline
from ..errors import InputError
from ..physics import layout as ix
from ..tasks.spec import REFERENCE_KINDS, TaskSpec
from . import plan_vectors as pv
from . import rng as R
from .reach import (
    N_T,
    consts,
    npclip,
    npmax,
    npmin,
    profile_intervals,
    profile_terms,
    project_into,
    rate_ratios,
)

__all__ = [
    "REFERENCE_KINDS",
    "min_jerk",
    "smooth_steps",
    "project",
    "pressure_rate_ratio",
    "periodic_length",
    "smooth_reference",
    "stiffness_ramp",
    "shape_reference",
]
_SLOWDOWN = 0.7  # factor on the frequency (or 1/factor on a move) per followability retry
_RETRIES = 8
_RATE_FRACTION = 0.5  # the generators' target for pressure_rate_ratio
_FREQ_HZ = (0.1, 0.5)  # the periodic references' frequency range before any slow-down


@jit_inline
def _min_jerk(s):
    s = npclip(s, 0.0, 1.0)
    return s * s * s * (10.0 + s * (-15.0 + 6.0 * s))


@jit
def smooth_steps_k(v, dt, move_s, out):
    """:func:`smooth_steps` of the channels ``v`` (k, n) into ``out`` (k, n)."""
    k, n = v.shape
    m = max(1, int(np.rint(move_s / dt)))  # Python's round: half to even
    out[:] = v
    a = 0
    while a < n:
        b = a + 1  # the next change after a
        while b < n:
            changed = False
            for ch in range(k):
                if v[ch, b] != v[ch, b - 1]:
                    changed = True
            if changed:
                break
            b += 1
        if a > 0:
            for ch in range(k):
                start, end = out[ch, a - 1], v[ch, a]
                for j in range(b - a):
                    out[ch, a + j] = start + (end - start) * _min_jerk((j + 1) / m)
        a = b


@jit
def smooth_reference_k(tl, tk, load, p, c, len_lo, len_hi, dt, move_s, L_out, K_out):
    """:func:`smooth_reference` into ``(L_out, K_out)``; False when not reachable."""
    n = tl.shape[0]
    both, smooth, ratio, T = np.empty((2, n)), np.empty((2, n)), np.empty(n), np.empty((N_T, n))
    both[0], both[1] = tl, tk
    for _ in range(_RETRIES):
        smooth_steps_k(both, dt, move_s, smooth)
        if project_into(smooth[0], smooth[1], load, p, c, len_lo, len_hi, L_out, K_out, T) >= 0:
            return False
        if rate_ratios(L_out, K_out, load, p, dt, _RATE_FRACTION, ratio, T):
            return True
        move_s /= _SLOWDOWN
    return True  # the slowest moves tried; the ratio says how far from followable they remain


@jit
def _constant_k(s, L, load, p, c, T):
    """One stiffness reachable over the whole length profile ``L`` under ``load`` (the middle of
    the intersection of the per-step intervals, drawn), or NaN without a draw when there is none.
    ``T`` then holds the terms of ``L``."""
    n = L.shape[0]
    w, k_lo, k_hi = np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):
        w[i] = (p[ix.M_END] + load[i]) * p[ix.GRAV]
    profile_terms(L, p, T)
    profile_intervals(T, w, p, c, k_lo, k_hi)
    lo, hi = k_lo[0], k_hi[0]
    for i in range(1, n):
        lo, hi = npmax(lo, k_lo[i]), npmin(hi, k_hi[i])
    if hi <= lo:
        return np.nan
    return lo + R.uniform(s, 0.2, 0.8) * (hi - lo)


@jit
def periodic_length_k(s, load, p, c, len_lo, len_hi, dt, chirp, f_lo, f_hi, L_out, K_out):
    """:func:`periodic_length` into ``(L_out, K_out)``; False when not followable."""
    n = L_out.shape[0]
    t_last = (n - 1) * dt
    centre = R.uniform(s, len_lo + 0.25 * (len_hi - len_lo), len_hi - 0.25 * (len_hi - len_lo))
    amp = R.uniform(s, 0.3, 1.0) * min(centre - len_lo, len_hi - centre)
    f0, f1 = R.uniform(s, f_lo, f_hi), R.uniform(s, f_lo, f_hi)
    if f1 < f0:
        f0, f1 = f1, f0
    phase = R.uniform(s, 0.0, 2 * np.pi)
    ratio, T = np.empty(n), np.empty((N_T, n))
    for _ in range(_RETRIES * 2):
        if chirp:
            sweep = 0.5 * (f1 - f0) / max(t_last, dt)
            for i in range(n):
                t = i * dt
                L_out[i] = centre + amp * np.sin(2 * np.pi * (f0 * t + sweep * t * t) + phase)
        else:
            omega = 2 * np.pi * f1
            for i in range(n):
                L_out[i] = centre + amp * np.sin(omega * (i * dt) + phase)
        K = _constant_k(s, L_out, load, p, c, T)
        if K != K:
            amp *= _SLOWDOWN
            continue
        K_out[:] = K
        if rate_ratios(L_out, K_out, load, p, dt, _RATE_FRACTION, ratio, T):
            return True
        f0, f1 = f0 * _SLOWDOWN, f1 * _SLOWDOWN
    return False


@jit
def stiffness_ramp_k(tk, load, p, c, len_lo, len_hi, length, L_out, K_out):
    """:func:`stiffness_ramp` into ``(L_out, K_out)``; False when not reachable."""
    n = tk.shape[0]
    ramp = tk.copy()
    a = 1
    while a < n:
        if tk[a] == tk[a - 1]:
            a += 1
            continue
        b = a + 1
        while b < n and tk[b] == tk[b - 1]:
            b += 1
        m = max(1, (b - a) // 2)
        start = ramp[a - 1]
        for j in range(b - a):
            ramp[a + j] = start + (tk[a] - start) * npmin((j + 1) / m, 1.0)
        a = b
    L_out[:] = length
    return project_into(L_out, ramp, load, p, c, len_lo, len_hi, L_out, K_out, np.empty((N_T, n))) < 0


@jit
def shape_k(kind, s, sv, p, c, len_lo, len_hi, tl, tk, load, dt, L_out, K_out):
    """One episode's reference of kind ``kind`` (a ``REFERENCE_KINDS`` index) from its step
    schedule ``(tl, tk)`` under the hanging loads ``load`` [kg], into ``(L_out, K_out)``; False
    when not reachable. ``sv`` the task's spec vector; lengths in ``[len_lo, len_hi]``."""
    if kind == pv.REF_MIN_JERK:
        return smooth_reference_k(tl, tk, load, p, c, len_lo, len_hi, dt, sv[pv.SV_MOVE_S], L_out, K_out)
    if kind == pv.REF_SINE or kind == pv.REF_CHIRP:
        chirp = kind == pv.REF_CHIRP
        return periodic_length_k(
            s, load, p, c, len_lo, len_hi, dt, chirp, _FREQ_HZ[0], _FREQ_HZ[1], L_out, K_out
        )
    if kind == pv.REF_STIFFNESS_RAMP:
        fixed = sv[pv.SV_FIXED]
        return stiffness_ramp_k(
            tk, load, p, c, len_lo, len_hi, fixed if fixed == fixed else tl[0], L_out, K_out
        )
    L_out[:] = tl
    K_out[:] = tk
    return True


# ------------------------------------------------------------------ the NumPy faces
def min_jerk(s):
    """Minimum-jerk position profile on ``s`` in [0, 1]: ``10 s^3 - 15 s^4 + 6 s^5`` (zero
    velocity and acceleration at both ends; Flash and Hogan 1985)."""
    s = np.clip(s, 0.0, 1.0)
    return s * s * s * (10.0 + s * (-15.0 + 6.0 * s))


def smooth_steps(values: np.ndarray, dt: float, move_s: float) -> np.ndarray:
    """A piecewise-constant schedule whose changes become minimum-jerk moves of ``move_s``
    seconds starting at each change (cut short by the next change, which then starts from where
    the move had got to). ``values`` (n_steps,) or (n_steps, k) for several channels at once."""
    v = np.asarray(values, dtype=float)
    rows = np.ascontiguousarray(v.reshape(v.shape[0], -1).T)
    out = np.empty_like(rows)
    smooth_steps_k(rows, float(dt), float(move_s), out)
    return out.T.reshape(v.shape).copy()


def _row_consts(params_row, spec: TaskSpec):
    p = np.ascontiguousarray(params_row, dtype=float)
    return p, (float(spec.stiffness_range[0]), float(spec.stiffness_range[1]), float(spec.pressure_margin))


@jit
def _project(L, K, load, p, k_min, k_max, margin, len_lo, len_hi, L_out, K_out):
    c = consts(p, k_min, k_max, margin)
    return project_into(L, K, load, p, c, len_lo, len_hi, L_out, K_out, np.empty((N_T, L.shape[0])))


def project(target_l, target_k, load, params_row, spec: TaskSpec):
    """Reachable ``(target_l, target_k)``: lengths clipped to ``spec.length_range``, stiffnesses to
    the interval reachable at each step's length and load (shrunk by 5 % of its width, as the
    step schedules' targets are). A step with no reachable stiffness raises ``InputError``: the
    load there is more than the plant can hold at that length."""
    p, c = _row_consts(params_row, spec)
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (target_l, target_k, load)))
    L, K, w = (np.ascontiguousarray(a).reshape(-1) for a in arrays)
    L_out, K_out = np.empty_like(L), np.empty_like(K)
    i = _project(L, K, w, p, *c, *map(float, spec.length_range), L_out, K_out)
    if i >= 0:
        raise InputError(
            f"task {spec.name!r}: no reachable stiffness at L = {L_out[i] * 100:.3g} cm with "
            f"load {w[i]:.3g} kg (step {i}); lower the load range or widen the length range"
        )
    return L_out.reshape(arrays[0].shape), K_out.reshape(arrays[0].shape)


def pressure_rate_ratio(target_l, target_k, load, params_row, dt: float) -> np.ndarray:
    """Per step, the largest over the two chambers of |dP/dt needed| / (dP/dt a fully open valve
    gives there): above 1 no valve can follow the reference; below about 0.5 it leaves room for
    feedback."""
    L, K, w = (np.ascontiguousarray(a, dtype=float) for a in (target_l, target_k, load))
    p = np.ascontiguousarray(params_row, dtype=float)
    out, T = np.empty(L.shape[0]), np.empty((N_T, L.shape[0]))
    profile_terms(L, p, T)
    rate_ratios(L, K, w, p, float(dt), np.inf, out, T)
    return out


@jit
def _shape(kind, s, sv, p, k_min, k_max, margin, tl, tk, load, dt, L_out, K_out):
    c = consts(p, k_min, k_max, margin)
    return shape_k(kind, s, sv, p, c, sv[pv.SV_LEN_LO], sv[pv.SV_LEN_HI], tl, tk, load, dt, L_out, K_out)


def shape_reference(kind, rng, spec, p, tl, tk, load, n_steps, dt):
    """One episode's reference of ``kind`` from its step schedule, or None when not reachable."""
    p, c = _row_consts(p, spec)
    arrays = [np.ascontiguousarray(a, dtype=float) for a in (tl, tk, load)]
    L_out, K_out = np.empty(n_steps), np.empty(n_steps)
    s = R.pack([rng]) if rng is not None else np.zeros((1, R.N_RNG), dtype=np.uint64)  # kinds without draws
    ok = _shape(
        REFERENCE_KINDS.index(kind), s[0], pv.spec_vector(spec), p, *c, *arrays, float(dt), L_out, K_out
    )
    if rng is not None:
        R.unpack([rng], s)
    return (L_out, K_out) if ok else None


def periodic_length(rng, spec: TaskSpec, load, params_row, n_steps: int, dt: float, kind: str = "sine"):
    """``sine`` or ``chirp`` length at a constant reachable stiffness; the amplitude shrinks until
    one constant stiffness is reachable throughout, the frequency until the valves can follow
    (``InputError`` after 16 tries)."""
    tl = np.zeros(n_steps)
    out = shape_reference(kind, rng, spec, params_row, tl, tl, load, n_steps, dt)
    if out is None:
        raise InputError(
            f"task {spec.name!r}: no followable {kind} reference after {_RETRIES * 2} tries "
            "(loads too large for a constant stiffness, or valves too small)"
        )
    return out


def smooth_reference(target_l, target_k, load, params_row, spec: TaskSpec, dt: float, move_s=None):
    """``min_jerk`` moves of ``move_s`` seconds (default: the spec's) between the set-points of a
    step schedule (both channels), lengthened until the valves can follow (ratio below 0.5; after
    the last retry the slowest moves are kept: near the pressure cap a fully open valve's fill
    rate vanishes, so a move ending there can stay above it), then projected into the reachable
    region (``InputError`` if not reachable)."""
    if move_s is not None:
        spec = dataclasses.replace(spec, move_s=move_s)
    out = shape_reference("min_jerk", None, spec, params_row, target_l, target_k, load, len(target_l), dt)
    if out is None:
        project(target_l, target_k, load, params_row, spec)  # raises, naming the step
    return out


def stiffness_ramp(target_k, load, params_row, spec: TaskSpec, dt: float, length: float):
    """The paper's varying stiffness at a fixed length: linear ramps between the stiffness
    set-points of a step schedule, each over its segment's first half, at ``length``."""
    p, c = _row_consts(params_row, spec)
    tk, w = (np.ascontiguousarray(a, dtype=float) for a in (target_k, load))
    L_out, K_out = np.empty_like(tk), np.empty_like(tk)
    sv = pv.spec_vector(spec)
    if not _ramp(tk, w, p, *c, sv[pv.SV_LEN_LO], sv[pv.SV_LEN_HI], float(length), L_out, K_out):
        project(np.full_like(tk, length), tk, w, p, spec)  # raises, naming the step
    return L_out, K_out


@jit
def _ramp(tk, load, p, k_min, k_max, margin, len_lo, len_hi, length, L_out, K_out):
    return stiffness_ramp_k(
        tk, load, p, consts(p, k_min, k_max, margin), len_lo, len_hi, length, L_out, K_out
    )
