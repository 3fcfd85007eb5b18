"""What a reference may ask of one plant, compiled: the reachable stiffness interval at a length
and load, the projection of a profile into it, and the pressure rates a profile asks of the valves.

These are the per-step checks of :mod:`cepam_gym.planning.schedules` and
:mod:`cepam_gym.planning.references`, written once for a point or a profile of one env on one
parameter row ``p``; the NumPy functions there map them over arrays, and the reset's planner
(:mod:`cepam_gym.planning.episodes`) calls them env by env. ``c`` is the env's constants tuple
(:func:`consts`). The operations are those of the former NumPy code, in its order, so every value
is the same bit for bit (NumPy's ``maximum``, ``minimum`` and ``clip`` propagate NaN: so do
:func:`npmax`, :func:`npmin`, :func:`npclip`). Work is skipped only where its result is already
known: the terms of a length held over several steps (computed once), the second load of an
interval whose two loads are equal (narrowing twice by one weight changes nothing). LLVM
vectorises the loops over a profile's steps; a vectorised IEEE operation rounds as the scalar one,
and the only transcendental function (``sin``, of the periodic references and the joint) stays a
scalar libm call, NumPy's own.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import jit, jit_inline, strided_tuple
from ..physics import layout as ix
from ..physics.layout import T0
from ..physics.muscle import contact_pressures, cpam_tension_at, cpam_tension_terms
from ..physics.statics import solve_static, static_terms
from ..physics.valve import iso6358_flow_k, laminar_factor
from ..plant.substep import volumes_at

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


# ------------------------------------------------------------------ profiles
# A profile's per-step checks need the same terms of each step's length: those of the inverse
# static model, the CPAM's tension and the chamber volumes. They are computed once per step, in a
# loop LLVM vectorises across steps (no branch survives that it cannot turn into a select), and
# kept as rows of ``T`` (structure of arrays); the interval and rate loops then read them.
(
    _T_GE,
    _T_DGE,
    _T_DVAC,
    _T_D2VAC,
    _T_FEL,
    _T_DU,
    _T_D2U,
    _T_PRC,
    _T_DPRC,
    _T_PRE,
    _T_DPRE,
    _T_DET,
    _T_GC,
    _T_DUC,
    _T_CTAUT,
    _T_VC,
    _T_VE,
) = range(17)
N_T = 17
_NP = ix.N_PARAMS  # literal for strided_tuple


_B = 16  # steps per block of profile_terms


@jit
def profile_terms(L, p, T):
    """The terms of every step's length ``L[i]`` into the rows of ``T`` (N_T, n). A length held
    over several steps (the holds between moves, a fixed length) is computed once."""
    n = L.shape[0]
    starts = np.empty(n + 1, dtype=np.int64)
    m = 0
    for i in range(n):
        if i == 0 or L[i] != L[i - 1]:
            starts[m] = i
            m += 1
    starts[m] = n
    if 4 * m > 3 * n:  # few repeats: every step
        _terms(L, p, T)
        return
    held = np.empty(m)
    for r in range(m):
        held[r] = L[starts[r]]
    T_held = np.empty((N_T, m))
    _terms(held, p, T_held)
    for k in range(N_T):
        for r in range(m):
            v = T_held[k, r]
            for i in range(starts[r], starts[r + 1]):
                T[k, i] = v


@jit
def _terms(L, p, T):
    q = strided_tuple(p, 0, _NP, 1)  # the row as a tuple: no loads the loop must keep re-reading
    n = L.shape[0]
    W = np.empty(N_T * _B)
    for lo in range(0, n, _B):
        m = min(_B, n - lo)
        _terms_block(L, lo, m, q, W)
        for k in range(N_T):
            for j in range(m):
                T[k, lo + j] = W[k * _B + j]


@jit_inline
def _terms_block(L, lo, m, q, W):
    """The terms of steps ``lo .. lo + m - 1`` into the scratch rows of ``W`` (one base, constant
    row offsets: LLVM sees the rows cannot overlap and vectorises the loop across steps)."""
    for j in range(m):
        x = L[lo + j]
        ge, dge, dvac, d2vac, _k, f_el, du, d2u, prc, dprc, pre, dpre, det = static_terms(x, q)
        _dvac, gc, duc, _prc, _pre, c_taut = cpam_tension_terms(x, q)
        vc, ve, _a, _b, _c = volumes_at(x, q)
        W[_T_GE * _B + j], W[_T_DGE * _B + j], W[_T_DVAC * _B + j], W[_T_D2VAC * _B + j] = (
            ge,
            dge,
            dvac,
            d2vac,
        )
        W[_T_FEL * _B + j], W[_T_DU * _B + j], W[_T_D2U * _B + j] = f_el, du, d2u
        W[_T_PRC * _B + j], W[_T_DPRC * _B + j], W[_T_PRE * _B + j], W[_T_DPRE * _B + j] = (
            prc,
            dprc,
            pre,
            dpre,
        )
        W[_T_DET * _B + j], W[_T_GC * _B + j], W[_T_DUC * _B + j], W[_T_CTAUT * _B + j] = det, gc, duc, c_taut
        W[_T_VC * _B + j], W[_T_VE * _B + j] = vc, ve


@jit_inline
def _static_of(T, i, k_el):
    """The :func:`~cepam_gym.physics.statics.static_terms` of step ``i`` of ``T``."""
    return (
        T[_T_GE, i],
        T[_T_DGE, i],
        T[_T_DVAC, i],
        T[_T_D2VAC, i],
        k_el,
        T[_T_FEL, i],
        T[_T_DU, i],
        T[_T_D2U, i],
        T[_T_PRC, i],
        T[_T_DPRC, i],
        T[_T_PRE, i],
        T[_T_DPRE, i],
        T[_T_DET, i],
    )


@jit
def profile_intervals(T, w, p, c, k_lo, k_hi):
    """:func:`interval_at` of every step of a profile (terms ``T``) under the weight ``w[i]`` [N]
    into ``k_lo``, ``k_hi``."""
    k_min, k_max, p_cap, tension = c
    k_el = p[ix.K_EL]
    for i in range(w.shape[0]):
        st = _static_of(T, i, k_el)
        tt = (T[_T_DVAC, i], T[_T_GC, i], T[_T_DUC, i], T[_T_PRC, i], T[_T_PRE, i], T[_T_CTAUT, i])
        k_lo[i], k_hi[i] = _narrow(k_min, k_max, st, tt, T[_T_PRC, i], T[_T_PRE, i], w[i], p_cap, tension)


@jit
def project_into(L_in, K_in, load, p, c, len_lo, len_hi, L_out, K_out, T):
    """Reachable ``(L_out, K_out)`` of a profile under the hanging loads ``load`` [kg]: lengths
    clipped to ``[len_lo, len_hi]``, stiffnesses to the interval reachable at each step's length
    and load, shrunk by 5 % of its width. Returns the first step with no reachable stiffness (the
    load there is more than the plant holds at that length), or -1. ``T`` (N_T, n) then holds
    the terms of ``L_out`` (for :func:`rate_ratios`)."""
    n = L_in.shape[0]
    w, k_lo, k_hi = np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):
        L_out[i] = npclip(L_in[i], len_lo, len_hi)
        w[i] = (p[ix.M_END] + load[i]) * p[ix.GRAV]
    profile_terms(L_out, p, T)
    profile_intervals(T, w, p, c, k_lo, k_hi)
    for i in range(n):
        if k_hi[i] <= k_lo[i]:
            return i
    for i in range(n):
        pad = 0.05 * (k_hi[i] - k_lo[i])
        K_out[i] = npclip(K_in[i], k_lo[i] + pad, k_hi[i] - pad)
    return -1


@jit
def rate_ratios(L, K, load, p, dt, limit, out, T):
    """Per step, the largest over the two chambers of |dP/dt needed| / (dP/dt a fully open valve
    gives there), into ``out`` (the last step 0); the reference's own demand: the next step's
    targets at this step's load (a load change is a disturbance, not part of what the reference
    asks). ``T``: the :func:`profile_terms` of ``L``. Returns whether every step is ``<= limit``
    (NaN is not)."""
    n = L.shape[0]
    k_el = p[ix.K_EL]
    m_end, grav, patm, psup = p[ix.M_END], p[ix.GRAV], p[ix.P_ATM], p[ix.P_SUP]
    t_sup, t_amb, cond, b, r_lam = p[ix.T_SUP], p[ix.T_AMB], p[ix.C_PROP], p[ix.B_CRIT], p[ix.R_LAM]
    # what iso6358_flow derives from its arguments, once
    k_sup, k_amb, inv_1mb, lam_k = (
        math.sqrt(T0 / t_sup),
        math.sqrt(T0 / t_amb),
        1.0 / (1.0 - b),
        laminar_factor(r_lam, b),
    )
    gas = ix.GAMMA * ix.R_AIR
    for i in range(n - 1):
        w = (m_end + load[i]) * grav
        now_c, now_e, _ = solve_static(_static_of(T, i, k_el), K[i], w)
        nxt_c, nxt_e, _ = solve_static(_static_of(T, i + 1, k_el), K[i + 1], w)
        r = 0.0
        for now, nxt, vol in ((now_c, nxt_c, T[_T_VC, i]), (now_e, nxt_e, T[_T_VE, i])):
            rate = (nxt - now) / dt
            pa = npclip(now + patm, patm, psup)
            # a fully open proportional valve: filling from the supply or venting, adiabatic
            # (dP/dt = gamma R T mdot / V)
            m_in = iso6358_flow_k(psup, pa, k_sup, cond, b, inv_1mb, r_lam, lam_k)
            m_out = iso6358_flow_k(pa, patm, k_amb, cond, b, inv_1mb, r_lam, lam_k)
            rising = rate > 0.0
            cap = gas * (t_sup if rising else t_amb) * (m_in if rising else m_out) / vol
            r = npmax(r, abs(rate) / npmax(cap, 1e-9))
        out[i] = r
    ok = True
    if n > 0:
        out[n - 1] = 0.0
        for i in range(n):
            ok = ok and out[i] <= limit
    return ok
