"""The reset's planning in Python: per-env NumPy code, kept verbatim as the judge of the compiled
planner (``tests/planning/test_reset_kernels.py``). Not used by the library. Its physics goes through
:mod:`cepam_gym.physics.api` (NumPy arrays over the scalar kernels)."""

from __future__ import annotations

import numpy as np

from cepam_gym.errors import InputError
from cepam_gym.physics import api
from cepam_gym.physics import layout as ix
from cepam_gym.plant.params import pressure_cap_of
from cepam_gym.tasks.spec import TaskSpec

# ---------------------------------------------------------------- planning/schedules.py
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


# ---------------------------------------------------------------- planning/references.py
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
    """:func:`~cepam_gym.planning.schedules.episode_schedules` with each episode's targets shaped by
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


# ---------------------------------------------------------------- tasks/joint.py
def _equivalent_load(geom, angle, torque, p):
    return geom.equivalent_weight(angle, torque, p) / p[ix.GRAV] - p[ix.M_END]


def joint_muscle_map(geom, nominal_row):
    l_max = float(nominal_row[ix.L_MAX])

    def muscle(position, torque, rows):
        q = np.asarray(rows).T  # q[col]: a column of rows, or the value of one row
        theta = (l_max - np.asarray(position, dtype=float)) / geom.lever_arm
        return geom.length(theta, q), geom.equivalent_weight(theta, torque, q)

    return muscle


def joint_planned_schedules(rngs, task, geom, params, nominal_row, n_steps: int, dt: float):
    """Schedules of several joint envs at once, ``(target_angle, target_stiffness,
    external_torque, initial)`` (arrays (n_envs, n_steps), ``initial`` (n_envs, 2) = angle, joint
    stiffness): the rig's batched sampler (:func:`~cepam_gym.planning.schedules.episode_schedules`
    through :func:`joint_muscle_map`; env i draws only from ``rngs[i]``), then each episode's
    targets shaped by a reference kind drawn from ``task.references`` (the rig's
    :func:`~cepam_gym.planning.references.shape_reference` in muscle coordinates, the joint's loads
    as an equivalent hanging load; the link's weight depends on the angle, so a shaped reference
    is projected once more at its own angles; one that cannot be made reachable falls back to
    ``min_jerk`` moves, then to the set-points). With references other than ``step`` an episode
    starts at rest on its reference's first point. ``RuntimeError`` when a plant row leaves the
    task's angles outside the joint's range or has no reachable target (the env redraws it)."""
    params = np.atleast_2d(np.asarray(params, dtype=float))
    for row in params:
        try:
            task.check_range(geom, row)
        except ValueError as e:
            raise RuntimeError(str(e)) from None
    spec = task.muscle_spec(geom, nominal_row)
    r, l_max = geom.lever_arm, float(nominal_row[ix.L_MAX])
    pos, k_muscle, torque, initial = episode_schedules(
        rngs, spec, params, n_steps, dt, muscle=joint_muscle_map(geom, nominal_row)
    )
    ta, tk = (l_max - pos) / r, k_muscle * r**2
    initial = np.stack([(l_max - initial[:, 0]) / r, initial[:, 1] * r**2], axis=1)
    if tuple(task.references) == ("step",):
        return ta, tk, torque, initial
    for i, rng in enumerate(rngs):
        p = params[i if params.shape[0] > 1 else 0]
        spec_i = task.muscle_spec(geom, p)
        kind = task.references[int(rng.integers(len(task.references)))]
        L, K = geom.length(ta[i], p), tk[i] / r**2
        for k in (kind, "min_jerk"):
            shaped = shape_reference(
                k, rng, spec_i, p, L, K, _equivalent_load(geom, ta[i], torque[i], p), n_steps, dt
            )
            if shaped is None:
                continue
            try:
                Ls, Ks = project(
                    *shaped, _equivalent_load(geom, geom.angle(shaped[0], p), torque[i], p), p, spec_i
                )
            except ValueError:
                continue
            ta[i], tk[i] = geom.angle(Ls, p), Ks * r**2
            initial[i] = ta[i, 0], tk[i, 0]
            break
    return ta, tk, torque, initial
