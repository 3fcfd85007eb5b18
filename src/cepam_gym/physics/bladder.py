"""Plant v1's elastic bladder walls: the strain energy of each neo-Hookean bladder and its length
derivatives, the walls' part of the muscle's force and stiffness
(:func:`cepam_gym.physics.muscle.force_from_slopes`)."""

from __future__ import annotations

from .._jit import jit_inline, sqrt
from . import layout as ix


@jit_inline
def bladder_energy_k(L, inv_b, dk, scale, inv_lref, inv_dref):
    """Strain energy of one bladder wall and its first two length derivatives, ``(U, dU/dL, d2U/dL2)``.

    Thin-wall incompressible neo-Hookean cylinder (the elastic energy of Klute and Hannaford 2000,
    there with a Mooney-Rivlin law; neo-Hookean is its one-constant case):
    ``U = mu V_r (lam1^2 + lam2^2 + (lam1 lam2)^-2 - 3) / 2`` with the axial stretch
    ``lam1 = L / L_ref`` (the bladder is glued to both end caps) and the hoop stretch
    ``lam2 = D(L) / D(L_ref)`` (the bladder follows the braid, Eq. 2; stress-free in the muscle's
    unpressurised rest configuration). ``scale = mu V_r`` (rubber volume ``pi (D_o - t_b) t_b L_ref``
    of a tube of outer diameter ``D_o``);
    ``scale = 0`` gives exact zeros. The derivatives are exact (``K = -dF/dL`` needs the second).
    """
    u = L * inv_b
    s2 = 1.0 - u * u
    s = sqrt(s2)
    inv_s = 1.0 / s
    l1 = L * inv_lref
    l1p = inv_lref
    l2 = dk * s * inv_dref
    l2p = -dk * u * inv_b * inv_s * inv_dref  # dD/dL = -dk L / (b^2 s)
    l2pp = -dk * inv_b * inv_b * inv_s * inv_s * inv_s * inv_dref  # d2D/dL2 = -dk / (b^2 s^3)
    j = l1 * l2
    jp = l1p * l2 + l1 * l2p
    jpp = 2.0 * l1p * l2p + l1 * l2pp
    ij = 1.0 / j
    ij2 = ij * ij
    w = 0.5 * (l1 * l1 + l2 * l2 + ij2 - 3.0)
    dw = l1 * l1p + l2 * l2p - jp * ij2 * ij
    d2w = l1p * l1p + l2p * l2p + l2 * l2pp - jpp * ij2 * ij + 3.0 * jp * jp * ij2 * ij2
    return scale * w, scale * dw, scale * d2w


@jit_inline
def bladder_energies(L, p):
    """``(U, dU/dL, d2U/dL2)`` of both bladders of parameter row ``p`` (zeros in a v0 row)."""
    uc, duc, d2uc = bladder_energy_k(
        L, p[ix.INV_BC], p[ix.DK_C], p[ix.EL_C], p[ix.INV_LREF_C], p[ix.INV_DREF_C]
    )
    ue, due, d2ue = bladder_energy_k(
        L, p[ix.INV_BE], p[ix.DK_E], p[ix.EL_E], p[ix.INV_LREF_E], p[ix.INV_DREF_E]
    )
    return uc + ue, duc + due, d2uc + d2ue
