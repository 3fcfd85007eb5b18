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
(:func:`~cepam_gym.tasks.schedules.stiffness_interval`, pressures within the task's margin). And
**followable**: :func:`pressure_rate_ratio` compares the chamber pressure rates the reference asks
for (the inverse static model along it) with what a fully open valve gives each chamber at that
pressure and volume (ISO 6358 flow, adiabatic filling ``dP/dt = gamma R T mdot / V``); the
generators lower the frequency or lengthen the moves until the ratio is below ``rate_fraction``.
Pure numpy on one parameter row; no RNG but the generator passed in.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..physics import api
from ..physics import layout as ix
from .schedules import episode_schedules, stiffness_interval
from .spec import REFERENCE_KINDS, TaskSpec

__all__ = [
    "REFERENCE_KINDS",
    "min_jerk",
    "smooth_steps",
    "project",
    "pressure_rate_ratio",
    "periodic_length",
    "smooth_reference",
    "stiffness_ramp",
    "planned_schedules",
    "shape_reference",
]
_SLOWDOWN = 0.7  # factor on the frequency (or 1/factor on a move) per followability retry
_RETRIES = 8


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
    out = v.copy()
    n = v.shape[0]
    m = max(1, int(round(move_s / dt)))
    rows = v.reshape(n, -1)
    change = np.flatnonzero(np.any(rows[1:] != rows[:-1], axis=1)) + 1
    bounds = list(change) + [n]
    for a, b in zip(bounds[:-1], bounds[1:]):
        start = out[a - 1]
        end = v[a]
        k = np.arange(b - a)
        s = min_jerk((k + 1) / m)
        out[a:b] = start + (end - start) * (s[:, None] if v.ndim > 1 else s)
    return out


def project(target_l, target_k, load, params_row, spec: TaskSpec):
    """Reachable ``(target_l, target_k)``: lengths clipped to ``spec.length_range``, stiffnesses to
    the interval reachable at each step's length and load (shrunk by 5 % of its width, as the
    step schedules' targets are). A step with no reachable stiffness raises ``ValueError``: the
    load there is more than the plant can hold at that length."""
    p = np.asarray(params_row, dtype=float)
    L = np.clip(np.asarray(target_l, dtype=float), *spec.length_range)
    w = (p[ix.M_END] + np.asarray(load, dtype=float)) * p[ix.GRAV]
    k_lo, k_hi = stiffness_interval(L, w, w, p, spec)
    if np.any(k_hi <= k_lo):
        i = int(np.argmax(k_hi <= k_lo))
        raise InputError(
            f"task {spec.name!r}: no reachable stiffness at L = {L[i] * 100:.3g} cm with "
            f"load {load[i]:.3g} kg (step {i}); lower the load range or widen the length range"
        )
    pad = 0.05 * (k_hi - k_lo)
    return L, np.clip(np.asarray(target_k, dtype=float), k_lo + pad, k_hi - pad)


def _valve_rate(p_gauge, rising, volume, p):
    """Pressure rate [Pa/s] a fully open proportional valve gives a chamber at gauge pressure
    ``p_gauge`` and volume ``volume``: filling from the supply (``rising``) or venting to the
    atmosphere, adiabatic (``dP/dt = gamma R T mdot / V``)."""
    patm, psup = p[ix.P_ATM], p[ix.P_SUP]
    pa = np.clip(p_gauge + patm, patm, psup)
    m_in = api.iso6358_flow(np.full_like(pa, psup), pa, p[ix.T_SUP], p[ix.C_PROP], p[ix.B_CRIT], p[ix.R_LAM])
    m_out = api.iso6358_flow(pa, np.full_like(pa, patm), p[ix.T_AMB], p[ix.C_PROP], p[ix.B_CRIT], p[ix.R_LAM])
    t = np.where(rising, p[ix.T_SUP], p[ix.T_AMB])
    return ix.GAMMA * ix.R_AIR * t * np.where(rising, m_in, m_out) / volume


def pressure_rate_ratio(target_l, target_k, load, params_row, dt: float) -> np.ndarray:
    """Per step, the largest over the two chambers of |dP/dt needed| / (dP/dt a fully open valve
    gives there): above 1 no valve can follow the reference; below about 0.5 it leaves room for
    feedback."""
    p = np.asarray(params_row, dtype=float)
    L = np.asarray(target_l, dtype=float)
    K = np.asarray(target_k, dtype=float)
    w = (p[ix.M_END] + np.asarray(load, dtype=float)) * p[ix.GRAV]
    ratio = np.zeros(L.shape[0])
    if L.shape[0] < 2:
        return ratio
    # the reference's own demand: the next step's targets at this step's load (a load change is
    # a disturbance, not part of what the reference asks)
    now = api.static_pressures(L[:-1], K[:-1], w[:-1], p)
    nxt = api.static_pressures(L[1:], K[1:], w[:-1], p)
    vc, ve, _, _ = api.chamber_volumes(L[:-1], p)
    for j, vol in ((0, vc), (1, ve)):
        rate = (nxt[j] - now[j]) / dt
        cap = _valve_rate(now[j], rate > 0, vol, p)
        ratio[:-1] = np.maximum(ratio[:-1], np.abs(rate) / np.maximum(cap, 1e-9))
    return ratio


def _constant_k(rng, spec, L, load, p):
    """One stiffness reachable over the whole length profile ``L`` under ``load`` (the middle of
    the intersection of the per-step intervals), or None."""
    w = (p[ix.M_END] + load) * p[ix.GRAV]
    k_lo, k_hi = stiffness_interval(L, w, w, p, spec)
    lo, hi = float(np.max(k_lo)), float(np.min(k_hi))
    if hi <= lo:
        return None
    return lo + rng.uniform(0.2, 0.8) * (hi - lo)


def periodic_length(
    rng,
    spec: TaskSpec,
    load,
    params_row,
    n_steps: int,
    dt: float,
    kind: str = "sine",
    freq_hz=(0.1, 0.5),
    rate_fraction: float = 0.5,
):
    """``sine`` or ``chirp`` length at a constant reachable stiffness; the amplitude shrinks until
    one constant stiffness is reachable throughout, the frequency until the valves can follow."""
    p = np.asarray(params_row, dtype=float)
    lo, hi = spec.length_range
    t = np.arange(n_steps) * dt
    centre = rng.uniform(lo + 0.25 * (hi - lo), hi - 0.25 * (hi - lo))
    amp = rng.uniform(0.3, 1.0) * min(centre - lo, hi - centre)
    f0, f1 = sorted(rng.uniform(*freq_hz, 2))
    phase = rng.uniform(0.0, 2 * np.pi)
    for _ in range(_RETRIES * 2):
        if kind == "chirp":
            arg = 2 * np.pi * (f0 * t + 0.5 * (f1 - f0) / max(t[-1], dt) * t * t) + phase
        else:
            arg = 2 * np.pi * f1 * t + phase
        L = centre + amp * np.sin(arg)
        K = _constant_k(rng, spec, L, load, p)
        if K is None:
            amp *= _SLOWDOWN
            continue
        tk = np.full(n_steps, K)
        if pressure_rate_ratio(L, tk, load, p, dt).max() <= rate_fraction:
            return L, tk
        f0, f1 = f0 * _SLOWDOWN, f1 * _SLOWDOWN
    raise InputError(
        f"task {spec.name!r}: no followable {kind} reference after {_RETRIES * 2} tries "
        "(loads too large for a constant stiffness, or valves too small)"
    )


def smooth_reference(
    target_l,
    target_k,
    load,
    params_row,
    spec: TaskSpec,
    dt: float,
    move_s: float = 0.6,
    rate_fraction: float = 0.5,
):
    """``min_jerk`` moves between the set-points of a step schedule (both channels), lengthened
    until the valves can follow (ratio below ``rate_fraction``; after the last retry the slowest
    moves are kept: near the pressure cap a fully open valve's fill rate vanishes, so a move ending
    there can stay above it), then projected into the reachable region."""
    p = np.asarray(params_row, dtype=float)
    both = np.stack([target_l, target_k], axis=1)
    for _ in range(_RETRIES):
        smooth = smooth_steps(both, dt, move_s)
        L, K = project(smooth[:, 0], smooth[:, 1], load, p, spec)
        if pressure_rate_ratio(L, K, load, p, dt).max() <= rate_fraction:
            return L, K
        move_s /= _SLOWDOWN
    return L, K  # the slowest moves tried; the ratio says how far from followable they remain


def stiffness_ramp(target_k, load, params_row, spec: TaskSpec, dt: float, length: float):
    """The paper's varying stiffness at a fixed length: linear ramps between the stiffness
    set-points of a step schedule, each over its segment's first half, at ``length``."""
    k = np.asarray(target_k, dtype=float)
    n = k.shape[0]
    out = k.copy()
    change = np.flatnonzero(k[1:] != k[:-1]) + 1
    bounds = list(change) + [n]
    for a, b in zip(bounds[:-1], bounds[1:]):
        m = max(1, (b - a) // 2)
        s = np.minimum((np.arange(b - a) + 1) / m, 1.0)
        out[a:b] = out[a - 1] + (k[a] - out[a - 1]) * s
    return project(np.full(n, length), out, load, params_row, spec)


def planned_schedules(rngs, spec: TaskSpec, params, n_steps: int, dt: float):
    """:func:`~cepam_gym.tasks.schedules.episode_schedules` with each episode's targets shaped by
    a reference kind drawn from ``spec.references`` (each env's own generator, after its schedule
    draws, so a batch equals single envs). Returns ``(target_length, target_stiffness, load,
    initial)`` like it; with references other than ``step`` the episode starts at rest on its
    reference's first point (no jump at t = 0). The loads stay the schedule's: a load change is a
    disturbance the controller is not told about. A reference that cannot be made reachable at
    some step (a load too large for the length the move passes) falls back to ``min_jerk`` moves
    between the schedule's set-points, and those to the set-points themselves."""
    tl, tk, load, initial = episode_schedules(rngs, spec, params, n_steps, dt)
    if spec.references == ("step",):
        return tl, tk, load, initial
    params = np.atleast_2d(np.asarray(params, dtype=float))
    for i, rng in enumerate(rngs):
        p = params[i if params.shape[0] > 1 else 0]
        kind = spec.references[int(rng.integers(len(spec.references)))]
        shaped = shape_reference(kind, rng, spec, p, tl[i], tk[i], load[i], n_steps, dt)
        if shaped is None and kind != "step":
            shaped = shape_reference("min_jerk", rng, spec, p, tl[i], tk[i], load[i], n_steps, dt)
        if shaped is not None:
            tl[i], tk[i] = shaped
            initial[i] = tl[i, 0], tk[i, 0]
    return tl, tk, load, initial


def shape_reference(kind, rng, spec, p, tl, tk, load, n_steps, dt):
    """One episode's reference of ``kind`` from its step schedule, or None when not reachable."""
    try:
        if kind == "min_jerk":
            return smooth_reference(tl, tk, load, p, spec, dt, spec.move_s)
        if kind in ("sine", "chirp"):
            return periodic_length(rng, spec, load, p, n_steps, dt, kind=kind)
        if kind == "stiffness_ramp":
            length = spec.fixed_length if spec.fixed_length is not None else float(tl[0])
            return stiffness_ramp(tk, load, p, spec, dt, length)
        return tl, tk
    except ValueError:
        return None
