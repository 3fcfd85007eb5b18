"""Plant v2's extensible braids (Chambers and Wereley 2022): the thread length a braid stretches to
under its net active pressure, and the volume slopes of the stretched braid, for the force
(:func:`cepam_gym.physics.muscle.force_from_slopes`) and the statics
(:mod:`cepam_gym.physics.statics`)."""

from __future__ import annotations

from .._jit import fmax, jit_inline, sqrt


@jit_inline
def stretched_thread(L, P, a, b0):
    """Plant v2's extensible braid (Chambers and Wereley 2022: braid threads stretch under the
    tension of the pressure): ``(b, db/dP, db/dL at fixed P)`` of a braid of rest thread ``b0``
    loaded by the net active pressure ``P`` (>= 0).

    The threads' total tension is the ideal braid's, ``T = P dV/db = P b L / (2 pi n^2)``
    (``V = (b^2 - L^2) L / (4 pi n^2)``, Eq. 1-3 with Eq. 14: the tension whose axial part is the
    pressure on the end cap less the push), and they stretch linearly, ``b = b0 (1 + C T)`` (``C``
    the thread compliance, strain per N of total tension). Both are linear in ``b``, so
    ``b = b0 / (1 - a P L)`` with ``a = C b0 / (2 pi n^2)`` (columns ``THR_AE``, ``THR_AC``); the
    turns ``n`` stay (the braid's topology). The denominator is floored at 0.2 (a fivefold thread)
    so a runaway stretch stays finite; the fitted plants stay far from it.
    """
    den = fmax(1.0 - a * P * L, 0.2)
    b = b0 / den
    k = a * b / den
    return b, k * L, k * P


@jit_inline
def stretched_slopes(L, P, dP, a, b0, q, tan, pta2):
    """Volume slopes of a braid with stretched threads (:func:`stretched_thread`; ``dP = dP/dL``):
    ``(dV_out/dL, dV_air/dL, d2V_out/dL2, d2V_air/dL2, d(dV_out/dL)/dP, d(dV_air/dL)/dP)``, the
    second length derivatives total (through ``b(L, P(L))``). With ``r = sqrt(b^2 - L^2)``,
    :func:`braid_terms_k` in ``L, b`` reads ``dV_out/dL = (b^2 - 3 L^2) q`` and ``dV_air/dL =
    dV_out/dL + (t_a/n) (2 L^2 - b^2) / r + pi t_a^2``, whose ``b``-slopes are ``2 b q`` and
    ``2 b q - (t_a/n) b^3 / r^3``."""
    b, db_dp, db_dl = stretched_thread(L, P, a, b0)
    db_dl += db_dp * dP
    inv_r = 1.0 / sqrt(b * b - L * L)
    inv_r3 = inv_r * inv_r * inv_r
    dv_out = (b * b - 3.0 * L * L) * q
    dv_air = dv_out + tan * (2.0 * L * L - b * b) * inv_r + pta2
    out_l = -6.0 * L * q
    out_b = 2.0 * b * q
    air_l = out_l + tan * L * (3.0 * b * b - 2.0 * L * L) * inv_r3
    air_b = out_b - tan * b * b * b * inv_r3
    return dv_out, dv_air, out_l + out_b * db_dl, air_l + air_b * db_dl, out_b * db_dp, air_b * db_dp
