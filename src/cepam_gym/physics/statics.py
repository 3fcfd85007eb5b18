"""Inverse static model: the chamber pressures that hold a length with a stiffness under a load.

With the active pressures ``P_a = P - P_r(L)`` as unknowns, both the force balance and the
stiffness of :func:`cepam_gym.physics.muscle.cepam_force` are affine, so the inverse is a 2x2
solve (paper Eq. 25 with Eq. 26-45; Eq. 20/24 at the basic level).
"""

from __future__ import annotations

from .._jit import jit, jit_inline
from . import layout as ix
from .bladder import bladder_energies
from .muscle import active_pressure, contact_pressures, cpam_terms, epam_terms
from .stretch import stretched_slopes


@jit
def static_pressures(L, K, weight, p):
    """Gauge pressures ``(Pc, Pe)`` [Pa] giving stiffness ``K`` [N/m] in equilibrium at ``L`` [m]
    with the downward force ``weight`` [N] (load times g plus any external force).

    Solves ``F(L, Pc, Pe) + weight = 0`` and ``-dF/dL = K``. Returns ``(Pc, Pe, ok)`` with
    ``ok = 1.0`` when both active pressures are positive (the solution is physical; whether it
    lies under the supply pressure is the caller's check), else ``0.0``.

    Plant v1: the bladder walls' force ``-dU/dL`` and stiffness ``d2U/dL2`` do not depend on the
    pressures and join the constant terms. A tension-only CPAM is assumed taut (the solution has
    the CPAM pulling whenever it has ``P_ac`` well above ``P_ae``; a solution that needs a slack CPAM
    is not found by this 2x2 solve).

    Plant v2's extensible braids are taken at their rest threads here: the force is then no longer
    affine in the pressures, and the tasks' planning (:mod:`cepam_gym.planning.reach`) relies on this
    affine solve; :func:`static_pressures_exact` is the exact inverse of a stretching plant.
    """
    return solve_static(static_terms(L, p), K, weight)


@jit
def static_pressures_exact(L, K, weight, p):
    """:func:`static_pressures` of a plant with extensible braids (plant v2): the 2x2 solve
    repeated with the slopes of the threads stretched at the previous solution (a fixed point; the
    stretch changes the slopes by a few per cent per 100 kPa, so each pass gains about a decimal).
    The same as :func:`static_pressures` for inextensible braids."""
    pc, pe, ok = solve_static(static_terms(L, p), K, weight)
    if p[ix.THR_AE] > 0.0 or p[ix.THR_AC] > 0.0:
        for _ in range(STRETCH_PASSES):
            pc, pe, ok = solve_static(static_terms_at(L, p, pc, pe), K, weight)
    return pc, pe, ok


STRETCH_PASSES = 12  # fixed-point passes of a plant with extensible braids (none for v0 and v1)


@jit_inline
def _assembled(L, p, dvc, dvac, d2vc, d2vac, dvae, d2vae, prc, dprc, pre, dpre):
    """The terms of :func:`solve_static` from the braids' volume slopes and the contact pressures."""
    ge = dvae - p[ix.KAPPA] * dvc - p[ix.LAMBDA] * dvac
    dge = d2vae - p[ix.KAPPA] * d2vc - p[ix.LAMBDA] * d2vac
    k_el = p[ix.K_EL]
    _u, du, d2u = bladder_energies(L, p)
    f_el = k_el * (L - p[ix.L_EL0])
    det = -ge * d2vac + dvac * dge
    return ge, dge, dvac, d2vac, k_el, f_el, du, d2u, prc, dprc, pre, dpre, det


@jit_inline
def static_terms(L, p):
    """What :func:`static_pressures` needs of the length ``L`` alone (geometry, contact pressures,
    walls): computed once per length, the solve is then cheap for any ``K`` and ``weight`` (the
    reset's reference planning solves each length for several)."""
    _, _, dvc, dvac, d2vc, d2vac = cpam_terms(L, p)
    _, _, _, dvae, _, d2vae = epam_terms(L, p)
    prc, dprc, pre, dpre = contact_pressures(L, p)
    return _assembled(L, p, dvc, dvac, d2vc, d2vac, dvae, d2vae, prc, dprc, pre, dpre)


@jit_inline
def static_terms_at(L, p, pc, pe):
    """:func:`static_terms` with the slopes of braids stretched by the gauge pressures ``pc, pe``
    (plant v2; the same terms as :func:`static_terms` for inextensible braids)."""
    _, _, dvc, dvac, d2vc, d2vac = cpam_terms(L, p)
    _, _, _, dvae, _, d2vae = epam_terms(L, p)
    prc, dprc, pre, dpre = contact_pressures(L, p)
    pac, dpac = active_pressure(pc, prc, dprc)
    pae, dpae = active_pressure(pe, pre, dpre)
    if p[ix.THR_AE] > 0.0:
        _o1, dvae, _o2, d2vae, _o3, _o4 = stretched_slopes(
            L, pae, dpae, p[ix.THR_AE], p[ix.BE], p[ix.QE], p[ix.TAN_E], p[ix.PTA2]
        )
    if p[ix.THR_AC] > 0.0 and pac > pae:
        dvc, dvac, d2vc, d2vac, _o5, _o6 = stretched_slopes(
            L, pac - pae, dpac - dpae, p[ix.THR_AC], p[ix.BC], p[ix.QC], p[ix.TAN_C], p[ix.PTA2]
        )
    return _assembled(L, p, dvc, dvac, d2vc, d2vac, dvae, d2vae, prc, dprc, pre, dpre)


@jit_inline
def solve_static(terms, K, weight):
    """:func:`static_pressures` from the :func:`static_terms` of its length."""
    ge, dge, dvac, d2vac, k_el, f_el, du, d2u, prc, dprc, pre, dpre, det = terms
    # unknowns x = P_ae, y = P_ac (active pressures, dP_a/dL = -dP_r/dL while active)
    # force:     ge x + dvac y = -weight + k_el (L - L_el0) + dU/dL
    # stiffness: -dge x - d2vac y = K - k_el - d2U/dL2 - dpre ge - dprc dvac
    r1 = -weight + f_el + du
    r2 = K - k_el - d2u - dpre * ge - dprc * dvac
    x = (r1 * (-d2vac) - dvac * r2) / det
    y = (ge * r2 + dge * r1) / det
    ok = 1.0 if (x > 0.0 and y > 0.0) else 0.0
    return y + prc, x + pre, ok
