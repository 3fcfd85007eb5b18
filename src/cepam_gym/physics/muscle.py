"""Geometry, chamber volumes, static force and stiffness of the CE-PAM (paper Eq. 1-45).

All functions are pure scalar kernels compiled by numba; :mod:`cepam_gym.physics.api` maps them
over arrays of any shape (``()`` or ``(N,)``). Lengths in m, pressures in Pa *gauge*, forces in N
with **extension (push) positive**, as the paper's ``F = F_e - F_c`` (Eq. 25).

Kinematic mapping (the project's choice, see docs/physics.md): both braids span the same two end
caps, so the CPAM length and the EPAM length both equal the CE-PAM length ``L``; the braid angles
follow from Eq. 8 and 11, ``cos(theta_c) = L / b_c`` and ``cos(theta_e) = L / b_e``. The paper's
``L_c = 1.3 L_e`` (Eq. 4-5) relates the *rest* lengths (19.5 cm vs 15 cm); it survives only as the
factor ``kappa`` of the paper's force form (Eq. 22), never as a constraint on angles, so nothing
leaves the domain ``|cos| < 1`` over 15-19.5 cm.

Every formula is written in ``u = L / b = cos(theta)`` and ``s = sin(theta) = sqrt(1 - u^2)``, which
avoids trigonometric calls in the hot loop.
"""

from __future__ import annotations

import math

from .._jit import fmax, jit, jit_inline, sqrt
from . import layout as ix
from .bladder import bladder_energy_k
from .stretch import stretched_slopes, stretched_thread


@jit
def braid_from_rest(length, diameter, angle):
    """Thread length ``b`` and turns ``n`` of a braid with the given length, diameter and angle.

    Inverts Eq. 1-2: ``L = b cos(theta)``, ``D = b sin(theta) / (n pi)``.
    """
    b = length / math.cos(angle)
    n = b * math.sin(angle) / (math.pi * diameter)
    return b, n


@jit
def braid_diameter(L, b, n):
    """Outer braid diameter at length ``L`` (Eq. 2 with Eq. 1): ``D = b sin(theta) / (n pi)``."""
    u = L / b
    return b * math.sqrt(1.0 - u * u) / (n * math.pi)


@jit
def braid_terms(L, b, n, ta):
    """Volumes and their length derivatives of one braided muscle at length ``L``.

    Returns ``(V_out, V_air, dV_out/dL, dV_air/dL, d2V_out/dL2, d2V_air/dL2)``:

    * ``V_out = pi D^2 L / 4`` (Eq. 3, 10, 13): the volume the muscle occupies;
    * ``V_air = pi (D - 2 t_a)^2 L / 4`` (Eq. 34-37, 42-43): the air inside a wall of thickness t_a;
    * ``dV_out/dL = -b^2 (3 cos^2 - 1) / (4 pi n^2)`` (Eq. 17-20; Chou's model, Eq. 14);
    * ``dV_air/dL = dV_out/dL + t_a b (2 cos^2 - 1) / (n sin) + pi t_a^2`` (Eq. 40, Eq. 45);
    * the second derivatives are exact (for the stiffness ``K = -dF/dL``).
    """
    return braid_terms_k(
        L,
        b,
        1.0 / b,
        1.0 / (4.0 * math.pi * n * n),
        ta * b / n,
        ta / n,
        b / (math.pi * n),
        math.pi * ta * ta,
        ta,
    )


@jit_inline
def braid_terms_k(L, b, inv_b, q, tbn, tan, dk, pta2, ta):
    """:func:`braid_terms` with the per-muscle constants precomputed: ``inv_b = 1/b``,
    ``q = 1/(4 pi n^2)``, ``tbn = t_a b/n``, ``tan = t_a/n``, ``dk = b/(pi n)``, ``pta2 = pi t_a^2``
    (the plant keeps them in its parameter row, so the sub-step loop has one division)."""
    u = L * inv_b
    s2 = 1.0 - u * u
    s = sqrt(s2)
    inv_s = 1.0 / s
    d_out = dk * s  # Eq. 2
    d_air = d_out - 2.0 * ta  # Eq. 34
    v_out = 0.25 * math.pi * d_out * d_out * L
    v_air = 0.25 * math.pi * d_air * d_air * L
    dv_out = (b * b - 3.0 * L * L) * q
    dv_air = dv_out + tbn * (2.0 * u * u - 1.0) * inv_s + pta2
    d2v_out = -6.0 * L * q
    d2v_air = d2v_out + tan * u * (3.0 - 2.0 * u * u) * (inv_s * inv_s * inv_s)
    return v_out, v_air, dv_out, dv_air, d2v_out, d2v_air


@jit_inline
def cpam_terms(L, p):
    """:func:`braid_terms` of the CPAM of parameter row ``p``."""
    return braid_terms_k(
        L, p[ix.BC], p[ix.INV_BC], p[ix.QC], p[ix.TBN_C], p[ix.TAN_C], p[ix.DK_C], p[ix.PTA2], p[ix.TA]
    )


@jit_inline
def epam_terms(L, p):
    """:func:`braid_terms` of the EPAM of parameter row ``p``."""
    return braid_terms_k(
        L, p[ix.BE], p[ix.INV_BE], p[ix.QE], p[ix.TBN_E], p[ix.TAN_E], p[ix.DK_E], p[ix.PTA2], p[ix.TA]
    )


@jit
def radial_pressure(L, b, n, d_bladder, radial, kr_lo, kr_hi):
    """Pressure spent inflating the bladder to the sleeve, ``P_r``, and ``dP_r/dL``.

    ``P_r = K_r (D_o - D sin(theta))`` (Eq. 27, 28, 32) with ``K_r`` switching from ``kr_hi`` to
    ``kr_lo`` where ``D sin(theta)`` passes ``D_o / 2`` (as the paper states it; the switch is a
    step). ``P_r`` is never negative: once the bladder touches the sleeve no pressure is lost.
    ``radial = 0`` switches it off (the paper's basic model).
    """
    return radial_pressure_k(L, b, 1.0 / (math.pi * n * b), d_bladder, radial, kr_lo, kr_hi)


@jit_inline
def radial_pressure_k(L, b, inv_pnb, d_bladder, radial, kr_lo, kr_hi):
    """:func:`radial_pressure` with ``inv_pnb = 1 / (pi n b)`` precomputed."""
    if radial == 0.0:
        return 0.0, 0.0
    # D sin(theta) = b sin^2(theta) / (pi n) = (b^2 - L^2) / (pi n b)
    x = (b * b - L * L) * inv_pnb
    gap = d_bladder - x
    if gap <= 0.0:
        return 0.0, 0.0
    kr = kr_hi if x < 0.5 * d_bladder else kr_lo
    return kr * gap, kr * 2.0 * L * inv_pnb


@jit_inline
def active_pressure(P, p_r, dpr_dl):
    """Pressure that does work on the braid, ``P_a = P - P_r`` (Eq. 26, 29, 31), and ``dP_a/dL``.

    ``P_a`` is never negative: a bladder below its contact pressure, or under suction, pushes no
    braid.
    """
    pa = P - p_r
    if pa <= 0.0:
        return 0.0, 0.0
    return pa, -dpr_dl


@jit_inline
def contact_pressures(L, p):
    """``(P_rc, dP_rc/dL, P_re, dP_re/dL)`` of the two bladders of parameter row ``p``."""
    prc, dprc = radial_pressure_k(
        L, p[ix.BC], p[ix.INV_PNB_C], p[ix.DOC], p[ix.RADIAL], p[ix.KR_LO], p[ix.KR_HI]
    )
    pre, dpre = radial_pressure_k(
        L, p[ix.BE], p[ix.INV_PNB_E], p[ix.DOE], p[ix.RADIAL], p[ix.KR_LO], p[ix.KR_HI]
    )
    return prc, dprc, pre, dpre


@jit
def cepam_force(L, pc, pe, p):
    """Push force of the CE-PAM and its derivatives, for one plant with parameter row ``p``.

    ``F = P_ae dV_ae/dL - kappa P_ae dV_c/dL + (P_ac - lambda P_ae) dV_ac/dL + F_elastic``

    * paper form (``kappa = 1.3``, ``lambda = 1``): Eq. 41 for ``F_e`` minus Eq. 45 for ``F_c``
      (Eq. 25); with ``t_a = 0`` and ``P_r = 0`` it is Eq. 24 - Eq. 20, with ``P_r`` Eq. 30 - Eq. 33.
    * virtual-work form (``kappa = 1``, ``lambda = 0``): ``F dL = P_e dV_annulus + P_c dV_cpam``
      with ``V_annulus = V_ae - V_c`` and ``V_cpam = V_ac`` (docs/model.md section 3).

    ``V_c`` is the CPAM's *outer* volume (what it displaces in the annulus, Eq. 21 and 38), ``V_ac``
    its air volume, ``V_ae`` the EPAM's air volume. ``pc``, ``pe`` are gauge pressures [Pa].
    Returns ``(F, K, dF/dPc, dF/dPe)`` with ``K = -dF/dL`` at constant chamber pressures.
    """
    _, _, dvc, dvac, d2vc, d2vac = cpam_terms(L, p)
    _, _, _, dvae, _, d2vae = epam_terms(L, p)
    return force_from_slopes(L, pc, pe, p, dvc, dvac, dvae, d2vc, d2vac, d2vae)


@jit_inline
def slack_gate(x):
    """Smooth step ``x^2 (3 - 2 x)`` clipped to [0, 1] and its derivative: 0 for a slack braid
    (``x <= 0``), 1 for a taut one (``x >= 1``), C1 in between."""
    if x <= 0.0:
        return 0.0, 0.0
    if x >= 1.0:
        return 1.0, 0.0
    return x * x * (3.0 - 2.0 * x), 6.0 * x * (1.0 - x)


@jit
def cpam_tension(L, pc, pe, p):
    """The tension-only CPAM's braid load and its full-tension threshold at gauge pressures
    ``pc, pe``: ``(c, c_taut)`` [N] with ``c`` the CPAM's own push (its braid term plus its wall,
    as :func:`force_from_slopes` gates it) and ``c_taut = -w |dV_c/dL|``: the braid is fully taut
    (gate 1, the force model is the paper's) for ``c <= c_taut`` and slack for ``c >= 0``. Both
    are affine in the active pressures ``P - P_r`` (taken unclipped here) at a fixed length, so a
    static target's tautness is a linear condition
    (:func:`cepam_gym.planning.schedules.stiffness_interval`). ``(-inf, 0)`` for a bidirectional
    braid (``p[SLACK_W] = 0``: always "taut")."""
    if p[ix.SLACK_W] <= 0.0:
        return -math.inf, 0.0
    return cpam_tension_at(cpam_tension_terms(L, p), pc, pe)


@jit_inline
def cpam_tension_terms(L, p):
    """What :func:`cpam_tension` needs of the length ``L`` alone, for a tension-only braid
    (``p[SLACK_W] > 0``): computed once per length, the tension is affine in the pressures."""
    _, _, dvc, dvac, _, _ = cpam_terms(L, p)
    prc, _a, pre, _b = contact_pressures(L, p)
    lam = p[ix.LAMBDA]
    gc = lam * dvac + (1.0 - lam) * p[ix.KAPPA] * dvc
    _uc, duc, _d2uc = bladder_energy_k(
        L, p[ix.INV_BC], p[ix.DK_C], p[ix.EL_C], p[ix.INV_LREF_C], p[ix.INV_DREF_C]
    )
    return dvac, gc, duc, prc, pre, -p[ix.SLACK_W] * fmax(-dvc, 1e-12)


@jit_inline
def cpam_tension_at(terms, pc, pe):
    """:func:`cpam_tension` (of a tension-only braid) from the :func:`cpam_tension_terms` of its
    length."""
    dvac, gc, duc, prc, pre, c_taut = terms
    pac, pae = pc - prc, pe - pre  # unclipped, so c stays affine (below contact no target is feasible)
    return pac * dvac - pae * gc - duc, c_taut


@jit
def thread_lengths(L, pc, pe, p):
    """The CPAM's and the EPAM's thread lengths ``(b_c, b_e)`` [m] at length ``L`` and gauge
    pressures ``pc, pe`` (their rest values for inextensible braids)."""
    prc, dprc, pre, dpre = contact_pressures(L, p)
    pac, _ = active_pressure(pc, prc, dprc)
    pae, _ = active_pressure(pe, pre, dpre)
    return (
        stretched_thread(L, fmax(pac - pae, 0.0), p[ix.THR_AC], p[ix.BC])[0],
        stretched_thread(L, pae, p[ix.THR_AE], p[ix.BE])[0],
    )


@jit_inline
def _tension_only_cpam(
    L, pc, pe, p, width, force, dforce_dl, df_dpc, df_dpe, pac, dpac, pae, dpae,
    dvc, dvac, d2vc, d2vac, dvc_p, dvac_p, s_c, duc, d2uc,
):  # fmt: skip
    """The tension-only CPAM's part of :func:`force_from_slopes` (``p[SLACK_W] = width > 0``): the
    CPAM's braid term and wall gated by the smooth step of its pull, and plant v2's seal of a slack
    CPAM; returns ``(force, dforce_dl, df_dpc, df_dpe)`` with those added, in the order of
    operations the force has always had (the trajectories stay bit for bit)."""
    kappa = p[ix.KAPPA]
    lam = p[ix.LAMBDA]
    # the CPAM's own push (braid term plus its bladder wall, see the docstring)
    gc = lam * dvac + (1.0 - lam) * kappa * dvc  # what multiplies -P_ae in the braid term
    c = pac * dvac - pae * gc - duc
    dc = dpac * dvac + pac * d2vac - dpae * gc - pae * (lam * d2vac + (1.0 - lam) * kappa * d2vc) - d2uc
    a = fmax(-dvc, 1e-12)
    da = -d2vc if -dvc > 1e-12 else 0.0
    inv_wa = 1.0 / (width * a)
    x = -c * inv_wa
    dx = -(dc * a - c * da) * inv_wa / a
    g, dg = slack_gate(x)
    dc_dpc = dvac if pac > 0.0 else 0.0
    dc_dpe = -gc if pae > 0.0 else 0.0
    # what moves the gate's x per Pa: c's slope, and the scale a's when the CPAM stretches
    dx_dpc = dc_dpc
    dx_dpe = dc_dpe
    if s_c != 0.0:
        sc_c = pac * dvac_p - pae * (lam * dvac_p + (1.0 - lam) * kappa * dvc_p)  # dc/d(P_ac - P_ae)
        da_p = -dvc_p if -dvc > 1e-12 else 0.0
        dc_dpc += sc_c
        dx_dpc = dc_dpc - c * da_p / a
        if pae > 0.0:
            dc_dpe -= sc_c
            dx_dpe = dc_dpe + c * da_p / a
        else:
            dx_dpe = dc_dpe
    force += (g - 1.0) * c - duc  # the braid term and the wall, now both gated: g c
    dforce_dl += (g - 1.0) * dc + dg * dx * c - d2uc
    df_dpc += (g - 1.0) * dc_dpc - dg * dx_dpc * inv_wa * c
    df_dpe += (g - 1.0) * dc_dpe - dg * dx_dpe * inv_wa * c
    a_col = p[ix.COL_A]
    if a_col > 0.0:
        # plant v2: a slack CPAM (buckled, or collapsed when squeezed by the annulus) carries
        # no axial load through its braid or its bladder, which is longer than L; the cap's
        # face then sees Pc over the CPAM's seal and Pe outside it: (Pc - Pe) A_col, a pull
        # while Pe > Pc, faded in as the braid goes slack (1 - g) so it joins the taut braid
        # term continuously
        fcol = a_col * (pc - pe)
        force += (1.0 - g) * fcol
        dforce_dl -= dg * dx * fcol
        df_dpc += dg * dx_dpc * inv_wa * fcol + (1.0 - g) * a_col
        df_dpe += dg * dx_dpe * inv_wa * fcol - (1.0 - g) * a_col
    return force, dforce_dl, df_dpc, df_dpe


@jit_inline
def force_from_slopes(L, pc, pe, p, dvc, dvac, dvae, d2vc, d2vac, d2vae):
    """:func:`cepam_force` from precomputed volume slopes (the plant computes them once per step).

    Plant v1 terms, both off (exact zeros) in a v0 parameter row:

    * neo-Hookean bladder walls (:func:`bladder_energy_k`): ``F_el = -dU/dL`` per bladder.
    * tension-only CPAM (``p[SLACK_W] > 0``): the CPAM's own push
      ``c = (P_ac - lambda P_ae) dV_ac/dL - (1 - lambda) kappa P_ae dV_c/dL - dU_c/dL`` (its braid
      term, Eq. 45 in the paper form or ``P_c dV_ac - P_e dV_c`` by virtual work, plus its wall)
      is what the CPAM's braid threads carry: a pull (``c < 0``) while they are in tension. It is
      multiplied by a smooth step of ``x = -c / (w |dV_c/dL|)`` (``w`` a pressure width, 1 kPa):
      exactly 0 for a slack CPAM (``c >= 0``: squeezed from outside, or buckled because it is
      shorter than its own free length), exactly 1 from a pull of ``w |dV_c/dL|`` on, C1 between.

    Plant v2 (off, exact zeros, in v0 and v1 rows): the slack CPAM's seal (``COL_A``) and
    extensible braids (``THR_AE``, ``THR_AC``; :func:`stretched_thread`): the slopes are then those
    of the stretched threads, the EPAM's loaded by ``P_ae``, the CPAM's by ``P_ac - P_ae`` while
    positive; the contact pressures ``P_r`` and the walls' energy stay the unstretched braids'.
    """
    kappa = p[ix.KAPPA]
    lam = p[ix.LAMBDA]
    prc, dprc, pre, dpre = contact_pressures(L, p)
    pac, dpac = active_pressure(pc, prc, dprc)
    pae, dpae = active_pressure(pe, pre, dpre)
    # plant v2 stretch: slopes of dV/dL per Pa of each braid's load (zero for inextensible braids)
    dvae_p = 0.0
    dvc_p = 0.0
    dvac_p = 0.0
    if p[ix.THR_AE] > 0.0:
        _o1, dvae, _o2, d2vae, _o3, dvae_p = stretched_slopes(
            L, pae, dpae, p[ix.THR_AE], p[ix.BE], p[ix.QE], p[ix.TAN_E], p[ix.PTA2]
        )
    if p[ix.THR_AC] > 0.0 and pac > pae:
        dvc, dvac, d2vc, d2vac, dvc_p, dvac_p = stretched_slopes(
            L, pac - pae, dpac - dpae, p[ix.THR_AC], p[ix.BC], p[ix.QC], p[ix.TAN_C], p[ix.PTA2]
        )
    ge = dvae - kappa * dvc - lam * dvac  # what multiplies P_ae
    dge = d2vae - kappa * d2vc - lam * d2vac
    k_el = p[ix.K_EL]
    force = pae * ge + pac * dvac - k_el * (L - p[ix.L_EL0])
    dforce_dl = dpae * ge + pae * dge + dpac * dvac + pac * d2vac - k_el
    df_dpc = dvac if pac > 0.0 else 0.0
    df_dpe = ge if pae > 0.0 else 0.0
    if dvae_p != 0.0 and pae > 0.0:
        df_dpe += pae * dvae_p  # the EPAM's thread lengthens with P_ae
    # the CPAM's: its load P_ac - P_ae rises with Pc (P_ac > P_ae > = 0 here) and falls with Pe
    s_c = pac * dvac_p - pae * (kappa * dvc_p + lam * dvac_p)
    if s_c != 0.0:
        df_dpc += s_c
        if pae > 0.0:
            df_dpe -= s_c
    _uc, duc, d2uc = bladder_energy_k(
        L, p[ix.INV_BC], p[ix.DK_C], p[ix.EL_C], p[ix.INV_LREF_C], p[ix.INV_DREF_C]
    )
    _ue, due, d2ue = bladder_energy_k(
        L, p[ix.INV_BE], p[ix.DK_E], p[ix.EL_E], p[ix.INV_LREF_E], p[ix.INV_DREF_E]
    )
    force -= due
    dforce_dl -= d2ue
    width = p[ix.SLACK_W]
    if width > 0.0:
        force, dforce_dl, df_dpc, df_dpe = _tension_only_cpam(
            L, pc, pe, p, width, force, dforce_dl, df_dpc, df_dpe, pac, dpac, pae, dpae,
            dvc, dvac, d2vc, d2vac, dvc_p, dvac_p, s_c, duc, d2uc,
        )  # fmt: skip
    else:
        force -= duc
        dforce_dl -= d2uc
    return force, -dforce_dl, df_dpc, df_dpe


@jit
def chamber_volumes(L, p):
    """Air volumes of the CPAM chamber and of the annulus, dead volumes included, and ``dV/dL``.

    ``V_cpam = V_ac + V_dead,c``; ``V_annulus = V_ae - V_c + V_dead,e`` (Eq. 21: the CPAM occupies
    its outer volume inside the EPAM). Returns ``(V_cpam, V_annulus, dV_cpam/dL, dV_annulus/dL)``.
    """
    vc_out, vc_air, dvc, dvac, _, _ = cpam_terms(L, p)
    _, ve_air, _, dvae, _, _ = epam_terms(L, p)
    return vc_air + p[ix.VD_C], ve_air - vc_out + p[ix.VD_E], dvac, dvae - dvc


@jit
def closed_chamber_stiffness(L, pc, pe, p):
    """Stiffness ``-dF/dL`` with both chambers sealed (valves closed), air polytropic.

    Sealed, ``p_abs V^n = const`` gives ``dp/dL = -n p_abs (dV/dL) / V``; the trapped air adds
    ``-(dF/dPc) dPc/dL - (dF/dPe) dPe/dL`` to the constant-pressure stiffness.
    """
    _, k, df_dpc, df_dpe = cepam_force(L, pc, pe, p)
    vc, ve, dvc, dve = chamber_volumes(L, p)
    npoly = p[ix.N_POLY]
    patm = p[ix.P_ATM]
    dpc_dl = -npoly * (pc + patm) * dvc / vc
    dpe_dl = -npoly * (pe + patm) * dve / ve
    return k - df_dpc * dpc_dl - df_dpe * dpe_dl
