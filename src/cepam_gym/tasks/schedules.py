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
"""

from __future__ import annotations

import numpy as np

from ..physics import api
from ..physics import layout as ix
from ..plant.params import pressure_cap_of
from .spec import TaskSpec

_TRIES = 32


def _uniform(rng: np.random.Generator, lo, hi, size=None):
    """``rng.uniform(lo, hi, size)`` bit for bit (numpy computes ``lo + (hi - lo) * next_double``)
    at a quarter of its call cost: a 4096-env reset makes about 100 k of these draws."""
    return lo + (hi - lo) * rng.random(size)


def load_profile(rng: np.random.Generator, spec: TaskSpec, n_steps: int, dt: float) -> np.ndarray:
    """Hanging load [kg] over one episode, one of the task's load kinds picked at random."""
    lo, hi = spec.load_range
    t = np.arange(n_steps) * dt
    kind = spec.load_kinds[rng.integers(len(spec.load_kinds))]
    a, b = _uniform(rng, lo, hi, 2)
    if kind == "constant":
        load = np.full(n_steps, a)
    elif kind == "step":
        t_step = _uniform(rng, 0.2, 0.8) * t[-1] if n_steps > 1 else 0.0
        load = np.where(t < t_step, a, b)
    elif kind == "ramp":
        t0, t1 = np.sort(_uniform(rng, 0.0, max(t[-1], dt), 2))
        load = a + (b - a) * np.clip((t - t0) / max(t1 - t0, dt), 0.0, 1.0)
    elif kind == "sine":
        mid, amp = 0.5 * (lo + hi), 0.5 * (hi - lo) * _uniform(rng, 0.2, 1.0)
        freq = _uniform(rng, 0.05, 0.5)  # Hz: slow enough for the muscle to follow
        load = mid + amp * np.sin(2 * np.pi * freq * t + _uniform(rng, 0.0, 2 * np.pi))
    else:  # random: piecewise constant, a new value every 0.5-3 s
        load = np.empty(n_steps)
        i = 0
        while i < n_steps:
            j = i + max(1, int(_uniform(rng, 0.5, 3.0) / dt))
            load[i:j] = _uniform(rng, lo, hi)
            i = j
    return np.minimum(np.maximum(load, lo), hi)  # np.clip, at a tenth of its call overhead


def segments(rng, spec: TaskSpec, n_steps: int, dt: float) -> list[tuple[int, int]]:
    """``(start, stop)`` step indices of the target segments of one episode, each lasting a
    random ``segment_duration`` (the last one cut at the episode's end)."""
    out, i = [], 0
    while i < n_steps:
        j = min(n_steps, i + max(1, int(_uniform(rng, *spec.segment_duration) / dt)))
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
    p_cap = spec.pressure_margin * pressure_cap_of(p)
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
        # a tension-only CPAM (plant v1) must stay taut: the inverse model assumes its braid pulls,
        # and a slack one adds no force (its load is affine in K too: one more interval)
        c0, c_taut = api.cpam_tension(length, pc0, pe0, p)
        c1, _ = api.cpam_tension(length, pc1, pe1, p)
        if np.any(np.isfinite(c0)):
            lo, hi = _interval(c0, (c1 - c0) / 1000.0, -np.inf, c_taut)
            k_lo, k_hi = np.maximum(k_lo, lo), np.minimum(k_hi, hi)
    return k_lo, k_hi


def sample_target(
    rng, spec: TaskSpec, w_lo: float, w_hi: float, params_row, muscle=None
) -> tuple[float, float]:
    """One reachable ``(length, stiffness)`` target for weights in ``[w_lo, w_hi]`` [N]. With a
    ``muscle`` map (:func:`episode_schedules`), ``w_lo, w_hi`` are the segment's load extremes and
    the position drawn is mapped to the muscle's length and weights."""
    for _ in range(_TRIES):
        L = spec.fixed_length if spec.fixed_length is not None else rng.uniform(*spec.length_range)
        if muscle is None:
            k_lo, k_hi = stiffness_interval(L, w_lo, w_hi, params_row, spec)
        else:
            length, weight_lo = muscle(L, w_lo, params_row)
            k_lo, k_hi = stiffness_interval(
                length, weight_lo, muscle(L, w_hi, params_row)[1], params_row, spec
            )
        k_lo, k_hi = float(k_lo), float(k_hi)
        if k_hi > k_lo:
            # shrink by 5 % of the width on both sides: targets stay strictly inside
            pad = 0.05 * (k_hi - k_lo)
            return L, float(rng.uniform(k_lo + pad, k_hi - pad))
    raise RuntimeError(
        f"task {spec.name!r}: found no reachable target in {_TRIES} tries for loads "
        f"{w_lo / 9.81:.3g}-{w_hi / 9.81:.3g} kg; the plant's pressures cannot hold these loads "
        "(lower load_range, widen length_range, or raise the supply/burst pressure)"
    )


_CANDIDATES = 8  # target candidates drawn per segment before the vectorised feasibility check


def _draw(rng, spec: TaskSpec, n_steps: int, dt: float):
    """All random draws of one episode, in a fixed order that depends only on this env's rng."""
    load = load_profile(rng, spec, n_steps, dt)
    segs = segments(rng, spec, n_steps, dt) + [(0, 1)]  # the last "segment" is the initial state
    n = len(segs)
    if spec.fixed_length is not None:
        cand_l = np.full((n, _CANDIDATES), spec.fixed_length)
    else:
        cand_l = _uniform(rng, *spec.length_range, (n, _CANDIDATES))
    cand_u = _uniform(rng, 0.05, 0.95, (n, _CANDIDATES))  # where in the K interval
    return load, segs, cand_l, cand_u


def episode_schedules(rngs, spec: TaskSpec, params, n_steps: int, dt: float, muscle=None):
    """Schedules of several envs at once: ``(target_length, target_stiffness, load, initial)``
    with arrays of shape (n_envs, n_steps) and ``initial`` (n_envs, 2) = length, stiffness.

    ``muscle``: for another mechanism than the rig's (the joint), a map
    ``muscle(position, load, rows) -> (muscle length [m], weight [N])`` from the mechanism's
    target position (drawn in ``spec.length_range``) and load (in ``spec.load_range``, held over
    a segment at its extremes) to what the muscle sees (``rows``: parameter row(s), one per
    element or one for all). The targets returned are then positions, and stiffnesses the
    muscle's [N/m]. ``None``: the rig (position = length, load = hanging mass).

    Env i uses only ``rngs[i]`` (in the same order whatever the batch), so a batch of envs gets
    exactly the schedules single envs with the same generators would get. Targets come from
    candidates drawn per segment and checked together with :func:`stiffness_interval`; the rare
    segment without a feasible candidate falls back to :func:`sample_target`. Only the random
    draws run per env; everything else runs on all segments of all envs at once (a 4096-env reset
    is dominated by the draws).
    """
    params = np.atleast_2d(np.asarray(params, dtype=float))
    m = len(rngs)
    draws = [_draw(rng, spec, n_steps, dt) for rng in rngs]
    loads = np.stack([d[0] for d in draws]) if m else np.empty((0, n_steps))
    per_env = params if params.shape[0] > 1 else params[[0] * m]
    if muscle is None:
        weights = (per_env[:, ix.M_END, None] + loads) * per_env[:, ix.GRAV, None]  # [N], (m, n_steps)
    else:  # the loads themselves: their extremes per segment go through the map
        weights = loads
    # segments of all envs, the real ones first (they tile each env's row), then one initial
    # pseudo-segment (step 0) per env
    n_seg = np.array([len(d[1]) - 1 for d in draws], dtype=np.int64)
    env_of = np.repeat(np.arange(m), n_seg)
    starts = np.concatenate([[a for a, _ in d[1][:-1]] for d in draws] or [[]]).astype(np.int64)
    flat = weights.ravel()
    first = env_of * n_steps + starts
    w_lo = np.concatenate([np.minimum.reduceat(flat, first) if m else [], weights[:, 0]])
    w_hi = np.concatenate([np.maximum.reduceat(flat, first) if m else [], weights[:, 0]])
    seg_env = np.concatenate([env_of, np.arange(m)])
    seg_idx = np.concatenate([np.arange(len(env_of)) - np.repeat(np.cumsum(n_seg) - n_seg, n_seg), n_seg])
    cand_l = np.concatenate(
        [
            np.concatenate([d[2][:-1] for d in draws] or [np.empty((0, _CANDIDATES))]),
            np.stack([d[2][-1] for d in draws]) if m else np.empty((0, _CANDIDATES)),
        ]
    )
    cand_u = np.concatenate(
        [
            np.concatenate([d[3][:-1] for d in draws] or [np.empty((0, _CANDIDATES))]),
            np.stack([d[3][-1] for d in draws]) if m else np.empty((0, _CANDIDATES)),
        ]
    )
    prow = params[np.repeat(seg_env, _CANDIDATES)] if params.shape[0] > 1 else params[0]
    if muscle is None:
        k_lo, k_hi = stiffness_interval(
            cand_l.ravel(), np.repeat(w_lo, _CANDIDATES), np.repeat(w_hi, _CANDIDATES), prow, spec
        )
    else:
        length, weight_lo = muscle(cand_l.ravel(), np.repeat(w_lo, _CANDIDATES), prow)
        weight_hi = muscle(cand_l.ravel(), np.repeat(w_hi, _CANDIDATES), prow)[1]
        k_lo, k_hi = stiffness_interval(length, weight_lo, weight_hi, prow, spec)
    k_lo, k_hi = k_lo.reshape(-1, _CANDIDATES), k_hi.reshape(-1, _CANDIDATES)
    ok = k_hi > k_lo
    c = ok.argmax(axis=1)  # the first feasible candidate of each segment
    rows = np.arange(len(c))
    lo, hi = k_lo[rows, c], k_hi[rows, c]
    target_l = cand_l[rows, c]
    target_k = lo + cand_u[rows, c] * (hi - lo)
    # the rare segment with no feasible candidate: sample_target, per env in segment order (each
    # env's own generator, after its draws, as a single env would)
    for j in sorted(np.flatnonzero(~ok.any(axis=1)), key=lambda j: (seg_env[j], seg_idx[j])):
        i = seg_env[j]
        target_l[j], target_k[j] = sample_target(rngs[i], spec, w_lo[j], w_hi[j], per_env[i], muscle)
    n_real = len(env_of)
    seg_len = np.concatenate([[b - a for a, b in d[1][:-1]] for d in draws] or [[]]).astype(np.int64)
    tl = np.repeat(target_l[:n_real], seg_len).reshape(m, n_steps)
    tkk = np.repeat(target_k[:n_real], seg_len).reshape(m, n_steps)
    initial = np.stack([target_l[n_real:], target_k[n_real:]], axis=1)
    return tl, tkk, loads, initial
