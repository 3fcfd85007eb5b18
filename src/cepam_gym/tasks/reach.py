"""What a reference may ask of one plant, compiled: the reachable stiffness interval at a length
and load, the projection of a profile into it, and the pressure rates a profile asks of the valves.

These are the per-step checks of :mod:`cepam_gym.tasks.schedules` and
:mod:`cepam_gym.tasks.references`, written once for a point or a profile of one env on one
parameter row ``p``; the NumPy functions there map them over arrays, and the reset's planner
(:mod:`cepam_gym.tasks.planner`) calls them env by env. ``c`` is the env's constants tuple
(:func:`consts`). The operations are those of the former NumPy code, in its order, so every value
is the same bit for bit (NumPy's ``maximum``, ``minimum`` and ``clip`` propagate NaN: so do
:func:`npmax`, :func:`npmin`, :func:`npclip`). Work is skipped only where its result is already
known: the interval of a step whose length and weight equal the previous step's, the second load
of an interval whose two loads are equal, the rest of a profile once a step exceeds the limit.
"""

from __future__ import annotations

import math

from .._jit import jit, jit_inline
from ..physics import layout as ix
from ..physics.muscle import chamber_volumes, contact_pressures, cpam_tension_at, cpam_tension_terms
from ..physics.statics import solve_static, static_terms
from ..physics.valve import iso6358_flow

P_FLOOR = 2e3  # Pa above the contact pressure: keeps targets off the P_a = 0 kink
_PROBE_K = 1000.0  # the second stiffness of the affine pressure fit [N/m]


@jit_inline
def npmax(a, b):
    """``numpy.maximum`` of two floats (NaN propagates)."""
    return a if (a >= b or a != a) else b


@jit_inline
def npmin(a, b):
    """``numpy.minimum`` of two floats (NaN propagates)."""
    return a if (a <= b or a != a) else b


@jit_inline
def npclip(x, lo, hi):
    """``numpy.clip`` of a float (NaN propagates)."""
    y = x if (x != x or x > lo) else lo
    return y if (y != y or y < hi) else hi


@jit_inline
def consts(p, k_min, k_max, margin):
    """``(k_min, k_max, pressure cap of the targets, has a tension-only CPAM)`` of row ``p``: the
    stiffness range [N/m] and ``margin * min(supply, burst)`` [Pa gauge]."""
    cap = npmin(p[ix.P_SUP] - p[ix.P_ATM], p[ix.P_BURST])
    return k_min, k_max, margin * cap, p[ix.SLACK_W] > 0.0


@jit_inline
def _interval(a, s, lo, hi):
    """The K for which ``lo <= a + K s <= hi``, as ``(K_lo, K_hi)``; empty if ``lo > hi``."""
    e1 = (lo - a) / s
    e2 = (hi - a) / s
    if s > 0.0:
        return e1, e2
    if s < 0.0:
        return e2, e1
    if lo <= a and a <= hi:
        return -math.inf, math.inf
    return math.inf, -math.inf


@jit_inline
def _narrow(k_lo, k_hi, st, tt, prc, pre, w, p_cap, tension):
    """The interval ``(k_lo, k_hi)`` narrowed by one weight ``w`` [N]: both pressures between
    contact (plus the floor) and the cap, and (tension-only CPAM) the braid taut. Pressures are
    affine in K at a fixed length and weight, so each bound is one linear condition."""
    pc0, pe0, _ = solve_static(st, 0.0, w)
    pc1, pe1, _ = solve_static(st, _PROBE_K, w)
    lo, hi = _interval(pc0, (pc1 - pc0) / _PROBE_K, prc + P_FLOOR, p_cap)
    k_lo, k_hi = npmax(k_lo, lo), npmin(k_hi, hi)
    lo, hi = _interval(pe0, (pe1 - pe0) / _PROBE_K, pre + P_FLOOR, p_cap)
    k_lo, k_hi = npmax(k_lo, lo), npmin(k_hi, hi)
    if tension:  # a bidirectional braid's interval is (-inf, inf): nothing to narrow
        c0, c_taut = cpam_tension_at(tt, pc0, pe0)
        c1, _ = cpam_tension_at(tt, pc1, pe1)
        lo, hi = _interval(c0, (c1 - c0) / _PROBE_K, -math.inf, c_taut)
        k_lo, k_hi = npmax(k_lo, lo), npmin(k_hi, hi)
    return k_lo, k_hi


@jit_inline
def interval_at(L, w_lo, w_hi, p, c):
    """Reachable stiffness interval ``(K_lo, K_hi)`` [N/m] at length ``L`` [m] for weights in
    ``[w_lo, w_hi]`` [N] (empty when ``K_lo >= K_hi``): the static model is affine in the weight
    at a fixed length, so the two ends suffice."""
    k_min, k_max, p_cap, tension = c
    prc, _d1, pre, _d2 = contact_pressures(L, p)
    st = static_terms(L, p)
    tt = cpam_tension_terms(L, p)
    k_lo, k_hi = _narrow(k_min, k_max, st, tt, prc, pre, w_lo, p_cap, tension)
    if w_hi != w_lo:  # narrowing twice by the same weight changes nothing
        k_lo, k_hi = _narrow(k_lo, k_hi, st, tt, prc, pre, w_hi, p_cap, tension)
    return k_lo, k_hi


@jit
def project_into(L_in, K_in, load, p, c, len_lo, len_hi, L_out, K_out):
    """Reachable ``(L_out, K_out)`` of a profile under the hanging loads ``load`` [kg]: lengths
    clipped to ``[len_lo, len_hi]``, stiffnesses to the interval reachable at each step's length
    and load, shrunk by 5 % of its width. Returns the first step with no reachable stiffness (the
    load there is more than the plant holds at that length), or -1."""
    L_prev, w_prev, k_lo, k_hi = math.nan, math.nan, 0.0, 0.0
    for i in range(L_in.shape[0]):
        L = npclip(L_in[i], len_lo, len_hi)
        w = (p[ix.M_END] + load[i]) * p[ix.GRAV]
        if not (L == L_prev and w == w_prev):
            k_lo, k_hi = interval_at(L, w, w, p, c)
            L_prev, w_prev = L, w
        if k_hi <= k_lo:
            return i
        pad = 0.05 * (k_hi - k_lo)
        L_out[i] = L
        K_out[i] = npclip(K_in[i], k_lo + pad, k_hi - pad)
    return -1


@jit_inline
def _valve_rate(p_gauge, rising, volume, p):
    """Pressure rate [Pa/s] a fully open proportional valve gives a chamber at gauge pressure
    ``p_gauge`` and volume ``volume``: filling from the supply (``rising``) or venting to the
    atmosphere, adiabatic (``dP/dt = gamma R T mdot / V``)."""
    patm, psup = p[ix.P_ATM], p[ix.P_SUP]
    pa = npclip(p_gauge + patm, patm, psup)
    if rising:
        t = p[ix.T_SUP]
        m = iso6358_flow(psup, pa, p[ix.T_SUP], p[ix.C_PROP], p[ix.B_CRIT], p[ix.R_LAM])
    else:
        t = p[ix.T_AMB]
        m = iso6358_flow(pa, patm, p[ix.T_AMB], p[ix.C_PROP], p[ix.B_CRIT], p[ix.R_LAM])
    return ix.GAMMA * ix.R_AIR * t * m / volume


@jit
def rate_ratios(L, K, load, p, dt, limit, out):
    """Per step, the largest over the two chambers of |dP/dt needed| / (dP/dt a fully open valve
    gives there), into ``out`` (the last step 0); the reference's own demand: the next step's
    targets at this step's load (a load change is a disturbance, not part of what the reference
    asks). Stops after the first step whose ratio is not ``<= limit`` (NaN included) and returns
    whether every step is ``<= limit``."""
    n = L.shape[0]
    for i in range(n):
        out[i] = 0.0
    if n < 2:
        return 0.0 <= limit
    st_next = static_terms(L[0], p)
    for i in range(n - 1):
        st_now = st_next
        if L[i + 1] != L[i]:
            st_next = static_terms(L[i + 1], p)
        w = (p[ix.M_END] + load[i]) * p[ix.GRAV]
        now_c, now_e, _ = solve_static(st_now, K[i], w)
        nxt_c, nxt_e, _ = solve_static(st_next, K[i + 1], w)
        vc, ve, _dvc, _dve = chamber_volumes(L[i], p)
        r = 0.0
        rate = (nxt_c - now_c) / dt
        r = npmax(r, abs(rate) / npmax(_valve_rate(now_c, rate > 0.0, vc, p), 1e-9))
        rate = (nxt_e - now_e) / dt
        r = npmax(r, abs(rate) / npmax(_valve_rate(now_e, rate > 0.0, ve, p), 1e-9))
        out[i] = r
        if not r <= limit:
            return False
    return True
