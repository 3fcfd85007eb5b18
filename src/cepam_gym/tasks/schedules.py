"""Per-episode schedules of targets and hanging loads, sampled so every episode is solvable.

A schedule is three arrays of shape (n_steps,) per env: target length [m], target stiffness
[N/m] and hanging load [kg]. Targets hold for random segments; the load follows one of the
profiles of :data:`~cepam_gym.tasks.spec.LOAD_KINDS`. Each (length, stiffness) target is checked
with the inverse static model (:func:`cepam_gym.physics.api.static_pressures`) against the
smallest and the largest load of its segment: both chamber pressures must be positive and below
``pressure_margin * min(supply, burst)``. Because the static model is affine in stiffness and
load at a fixed length, feasibility at the two load extremes implies feasibility in between.
"""

from __future__ import annotations

import numpy as np

from ..physics import api
from ..physics import layout as ix
from .spec import TaskSpec

_TRIES = 32


def load_profile(rng: np.random.Generator, spec: TaskSpec, n_steps: int, dt: float) -> np.ndarray:
    """Hanging load [kg] over one episode, one of the task's load kinds picked at random."""
    lo, hi = spec.load_range
    t = np.arange(n_steps) * dt
    kind = spec.load_kinds[rng.integers(len(spec.load_kinds))]
    a, b = rng.uniform(lo, hi, size=2)
    if kind == "constant":
        load = np.full(n_steps, a)
    elif kind == "step":
        t_step = rng.uniform(0.2, 0.8) * t[-1] if n_steps > 1 else 0.0
        load = np.where(t < t_step, a, b)
    elif kind == "ramp":
        t0, t1 = np.sort(rng.uniform(0.0, max(t[-1], dt), size=2))
        load = a + (b - a) * np.clip((t - t0) / max(t1 - t0, dt), 0.0, 1.0)
    elif kind == "sine":
        mid, amp = 0.5 * (lo + hi), 0.5 * (hi - lo) * rng.uniform(0.2, 1.0)
        freq = rng.uniform(0.05, 0.5)  # Hz: slow enough for the muscle to follow
        load = mid + amp * np.sin(2 * np.pi * freq * t + rng.uniform(0, 2 * np.pi))
    else:  # random: piecewise constant, a new value every 0.5-3 s
        load = np.empty(n_steps)
        i = 0
        while i < n_steps:
            j = i + max(1, int(rng.uniform(0.5, 3.0) / dt))
            load[i:j] = rng.uniform(lo, hi)
            i = j
    return np.clip(load, lo, hi)


def _segments(rng, spec: TaskSpec, n_steps: int, dt: float) -> list[tuple[int, int]]:
    out, i = [], 0
    while i < n_steps:
        j = min(n_steps, i + max(1, int(rng.uniform(*spec.segment_duration) / dt)))
        out.append((i, j))
        i = j
    return out


def _interval(a, s, lo, hi):
    """The K for which ``lo <= a + K s <= hi`` (arrays), as ``(K_lo, K_hi)``; empty if lo > hi."""
    with np.errstate(divide="ignore", invalid="ignore"):
        e1, e2 = (lo - a) / s, (hi - a) / s
    inside = (lo <= a) & (a <= hi)
    k_lo = np.where(s > 0, e1, np.where(s < 0, e2, np.where(inside, -np.inf, np.inf)))
    k_hi = np.where(s > 0, e2, np.where(s < 0, e1, np.where(inside, np.inf, -np.inf)))
    return k_lo, k_hi


def stiffness_interval(length, w_lo, w_hi, params_row, spec: TaskSpec):
    """Reachable stiffness interval ``(K_lo, K_hi)`` [N/m] at ``length`` for weights in
    ``[w_lo, w_hi]`` [N]; empty when ``K_lo >= K_hi``. Arrays broadcast."""
    p = np.asarray(params_row)
    p_cap = spec.pressure_margin * min(p[ix.P_SUP] - p[ix.P_ATM], p[ix.P_BURST])
    p_floor = 2e3  # Pa above the contact pressure: keeps targets off the P_a = 0 kink
    prc, pre = api.contact_pressures(length, p)
    k_lo = np.full(np.broadcast(length, w_lo, w_hi).shape, spec.stiffness_range[0], dtype=float)
    k_hi = np.full_like(k_lo, spec.stiffness_range[1])
    for w in (w_lo, w_hi):
        # pressures are affine in K at fixed (L, W): P(K) = P(0) + K dP/dK
        pc0, pe0, _ = api.static_pressures(length, 0.0, w, p)
        pc1, pe1, _ = api.static_pressures(length, 1000.0, w, p)
        for p0, p1, pr in ((pc0, pc1, prc), (pe0, pe1, pre)):
            lo, hi = _interval(p0, (p1 - p0) / 1000.0, pr + p_floor, p_cap)
            k_lo, k_hi = np.maximum(k_lo, lo), np.minimum(k_hi, hi)
    return k_lo, k_hi


def sample_target(rng, spec: TaskSpec, w_lo: float, w_hi: float, params_row) -> tuple[float, float]:
    """One reachable ``(length, stiffness)`` target for weights in ``[w_lo, w_hi]`` [N]."""
    for _ in range(_TRIES):
        L = spec.fixed_length if spec.fixed_length is not None else rng.uniform(*spec.length_range)
        k_lo, k_hi = stiffness_interval(L, w_lo, w_hi, params_row, spec)
        k_lo, k_hi = float(k_lo), float(k_hi)
        if k_hi > k_lo:
            # shrink by 5 % of the width on both sides: targets stay strictly inside
            pad = 0.05 * (k_hi - k_lo)
            return L, float(rng.uniform(k_lo + pad, k_hi - pad))
    raise RuntimeError(
        f"task {spec.name!r}: found no reachable target in {_TRIES} tries for loads "
        f"{w_lo / 9.81:.3g}-{w_hi / 9.81:.3g} kg; the plant's pressures cannot hold these loads "
        "(lower load_range, widen length_range, or raise the supply/burst pressure)")


def episode_schedule(rng, spec: TaskSpec, params_row, n_steps: int, dt: float):
    """``(target_length, target_stiffness, load, initial)`` arrays of one episode.

    ``initial`` is a separate reachable ``(length, stiffness)`` pair at the first load, where the
    episode starts at rest (so the agent first has to move to the first target).
    """
    p = np.asarray(params_row)
    g = p[ix.GRAV]
    m_end = p[ix.M_END]
    load = load_profile(rng, spec, n_steps, dt)
    tl = np.empty(n_steps)
    tk = np.empty(n_steps)
    for i, j in _segments(rng, spec, n_steps, dt):
        w = (m_end + load[i:j]) * g
        L, K = sample_target(rng, spec, w.min(), w.max(), p)
        tl[i:j] = L
        tk[i:j] = K
    w0 = (m_end + load[0]) * g
    initial = sample_target(rng, spec, w0, w0, p)
    return tl, tk, load, initial
