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


def stiffness_interval(length, w_lo, w_hi, params, spec: TaskSpec):
    """Reachable stiffness interval ``(K_lo, K_hi)`` [N/m] at ``length`` for weights in
    ``[w_lo, w_hi]`` [N]; empty when ``K_lo >= K_hi``. ``params`` is one row, or one row per
    element of the (1-D) arguments."""
    p = np.asarray(params, dtype=float)
    cols = p.T if p.ndim == 2 else p
    p_cap = spec.pressure_margin * np.minimum(cols[ix.P_SUP] - cols[ix.P_ATM], cols[ix.P_BURST])
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


_CANDIDATES = 8  # target candidates drawn per segment before the vectorised feasibility check


def _draw(rng, spec: TaskSpec, n_steps: int, dt: float):
    """All random draws of one episode, in a fixed order that depends only on this env's rng."""
    load = load_profile(rng, spec, n_steps, dt)
    segs = _segments(rng, spec, n_steps, dt) + [(0, 1)]  # the last "segment" is the initial state
    n = len(segs)
    if spec.fixed_length is not None:
        cand_l = np.full((n, _CANDIDATES), spec.fixed_length)
    else:
        cand_l = rng.uniform(*spec.length_range, size=(n, _CANDIDATES))
    cand_u = rng.uniform(0.05, 0.95, size=(n, _CANDIDATES))  # where in the K interval
    return load, segs, cand_l, cand_u


def episode_schedules(rngs, spec: TaskSpec, params, n_steps: int, dt: float):
    """Schedules of several envs at once: ``(target_length, target_stiffness, load, initial)``
    with arrays of shape (n_envs, n_steps) and ``initial`` (n_envs, 2) = length, stiffness.

    Env i uses only ``rngs[i]`` (in the same order whatever the batch), so a batch of envs gets
    exactly the schedules single envs with the same generators would get. Targets come from
    candidates drawn per segment and checked together with :func:`stiffness_interval`; the rare
    segment without a feasible candidate falls back to :func:`sample_target`.
    """
    params = np.atleast_2d(np.asarray(params, dtype=float))
    m = len(rngs)
    draws = [_draw(rng, spec, n_steps, dt) for rng in rngs]
    rows, L, wlo, whi = [], [], [], []
    for i, (load, segs, cand_l, _) in enumerate(draws):
        p = params[i if params.shape[0] > 1 else 0]
        w = (p[ix.M_END] + load) * p[ix.GRAV]
        for s_idx, (a, b) in enumerate(segs):
            rows.append(np.full(_CANDIDATES, i))
            L.append(cand_l[s_idx])
            wlo.append(np.full(_CANDIDATES, w[a:b].min()))
            whi.append(np.full(_CANDIDATES, w[a:b].max()))
    rows = np.concatenate(rows)
    L, wlo, whi = np.concatenate(L), np.concatenate(wlo), np.concatenate(whi)
    prow = params[rows] if params.shape[0] > 1 else params[0]
    k_lo, k_hi = stiffness_interval(L, wlo, whi, prow, spec)
    tl = np.empty((m, n_steps))
    tkk = np.empty((m, n_steps))
    loads = np.empty((m, n_steps))
    initial = np.empty((m, 2))
    j = 0
    for i, (load, segs, cand_l, cand_u) in enumerate(draws):
        p = params[i if params.shape[0] > 1 else 0]
        w = (p[ix.M_END] + load) * p[ix.GRAV]
        loads[i] = load
        for s_idx, (a, b) in enumerate(segs):
            lo, hi = k_lo[j:j + _CANDIDATES], k_hi[j:j + _CANDIDATES]
            ok = np.flatnonzero(hi > lo)
            j += _CANDIDATES
            if ok.size:
                c = ok[0]
                target = cand_l[s_idx, c], lo[c] + cand_u[s_idx, c] * (hi[c] - lo[c])
            else:
                target = sample_target(rngs[i], spec, w[a:b].min(), w[a:b].max(), p)
            if s_idx == len(segs) - 1:
                initial[i] = target
            else:
                tl[i, a:b], tkk[i, a:b] = target
    return tl, tkk, loads, initial
