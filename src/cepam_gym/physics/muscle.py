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

from .._jit import jit
from . import layout as ix


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
    u = L / b
    s2 = 1.0 - u * u
    s = math.sqrt(s2)
    d_out = b * s / (n * math.pi)
    d_air = d_out - 2.0 * ta
    v_out = 0.25 * math.pi * d_out * d_out * L
    v_air = 0.25 * math.pi * d_air * d_air * L
    four_pi_n2 = 4.0 * math.pi * n * n
    dv_out = (b * b - 3.0 * L * L) / four_pi_n2
    dv_air = dv_out + ta * b * (2.0 * u * u - 1.0) / (n * s) + math.pi * ta * ta
    d2v_out = -6.0 * L / four_pi_n2
    d2v_air = d2v_out + ta * u * (3.0 - 2.0 * u * u) / (n * s2 * s)
    return v_out, v_air, dv_out, dv_air, d2v_out, d2v_air


@jit
def radial_pressure(L, b, n, d_bladder, radial, kr_lo, kr_hi):
    """Pressure spent inflating the bladder to the sleeve, ``P_r``, and ``dP_r/dL``.

    ``P_r = K_r (D_o - D sin(theta))`` (Eq. 27, 28, 32) with ``K_r`` switching from ``kr_hi`` to
    ``kr_lo`` where ``D sin(theta)`` passes ``D_o / 2`` (as the paper states it; the switch is a
    step). ``P_r`` is never negative: once the bladder touches the sleeve no pressure is lost.
    ``radial = 0`` switches it off (the paper's basic model).
    """
    if radial == 0.0:
        return 0.0, 0.0
    # D sin(theta) = b sin^2(theta) / (pi n) = (b^2 - L^2) / (pi n b)
    x = (b * b - L * L) / (math.pi * n * b)
    gap = d_bladder - x
    if gap <= 0.0:
        return 0.0, 0.0
    kr = kr_hi if x < 0.5 * d_bladder else kr_lo
    return kr * gap, kr * 2.0 * L / (math.pi * n * b)


@jit
def active_pressure(P, L, b, n, d_bladder, radial, kr_lo, kr_hi):
    """Pressure that does work on the braid, ``P_a = P - P_r`` (Eq. 26, 29, 31), and ``dP_a/dL``.

    ``P_a`` is never negative: a bladder below its contact pressure, or under suction, pushes no
    braid.
    """
    p_r, dpr_dl = radial_pressure(L, b, n, d_bladder, radial, kr_lo, kr_hi)
    pa = P - p_r
    if pa <= 0.0:
        return 0.0, 0.0
    return pa, -dpr_dl


@jit
def cepam_force(L, pc, pe, p):
    """Push force of the CE-PAM and its derivatives, for one plant with parameter row ``p``.

    ``F = P_ae dV_ae/dL - kappa P_ae dV_c/dL + (P_ac - lambda P_ae) dV_ac/dL + F_elastic``

    * paper form (``kappa = 1.3``, ``lambda = 1``): Eq. 41 for ``F_e`` minus Eq. 45 for ``F_c``
      (Eq. 25); with ``t_a = 0`` and ``P_r = 0`` it is Eq. 24 - Eq. 20, with ``P_r`` Eq. 30 - Eq. 33.
    * virtual-work form (``kappa = 1``, ``lambda = 0``): ``F dL = P_e dV_annulus + P_c dV_cpam``
      with ``V_annulus = V_ae - V_c`` and ``V_cpam = V_ac`` (model-notes section 2).

    ``V_c`` is the CPAM's *outer* volume (what it displaces in the annulus, Eq. 21 and 38), ``V_ac``
    its air volume, ``V_ae`` the EPAM's air volume. ``pc``, ``pe`` are gauge pressures [Pa].
    Returns ``(F, K, dF/dPc, dF/dPe)`` with ``K = -dF/dL`` at constant chamber pressures.
    """
    _, _, dvc, dvac, d2vc, d2vac = braid_terms(L, p[ix.BC], p[ix.NC], p[ix.TA])
    _, _, _, dvae, _, d2vae = braid_terms(L, p[ix.BE], p[ix.NE], p[ix.TA])
    return force_from_slopes(L, pc, pe, p, dvc, dvac, dvae, d2vc, d2vac, d2vae)


@jit
def force_from_slopes(L, pc, pe, p, dvc, dvac, dvae, d2vc, d2vac, d2vae):
    """:func:`cepam_force` from precomputed volume slopes (the plant computes them once per step)."""
    kappa = p[ix.KAPPA]
    lam = p[ix.LAMBDA]
    pac, dpac = active_pressure(pc, L, p[ix.BC], p[ix.NC], p[ix.DOC], p[ix.RADIAL], p[ix.KR_LO], p[ix.KR_HI])
    pae, dpae = active_pressure(pe, L, p[ix.BE], p[ix.NE], p[ix.DOE], p[ix.RADIAL], p[ix.KR_LO], p[ix.KR_HI])
    ge = dvae - kappa * dvc - lam * dvac  # what multiplies P_ae
    dge = d2vae - kappa * d2vc - lam * d2vac
    k_el = p[ix.K_EL]
    force = pae * ge + pac * dvac - k_el * (L - p[ix.L_EL0])
    dforce_dl = dpae * ge + pae * dge + dpac * dvac + pac * d2vac - k_el
    df_dpc = dvac if pac > 0.0 else 0.0
    df_dpe = ge if pae > 0.0 else 0.0
    return force, -dforce_dl, df_dpc, df_dpe


@jit
def chamber_volumes(L, p):
    """Air volumes of the CPAM chamber and of the annulus, dead volumes included, and ``dV/dL``.

    ``V_cpam = V_ac + V_dead,c``; ``V_annulus = V_ae - V_c + V_dead,e`` (Eq. 21: the CPAM occupies
    its outer volume inside the EPAM). Returns ``(V_cpam, V_annulus, dV_cpam/dL, dV_annulus/dL)``.
    """
    vc_out, vc_air, dvc, dvac, _, _ = braid_terms(L, p[ix.BC], p[ix.NC], p[ix.TA])
    _, ve_air, _, dvae, _, _ = braid_terms(L, p[ix.BE], p[ix.NE], p[ix.TA])
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
