"""Braid-bladder friction as Maxwell-slip elements (plant v1). Pure scalar kernels.

Dry friction between the braids, the bladders and the CPAM inside the EPAM bladder grows with
the pressure that presses them together and with the contact area (Tondu and Lopez 2000). A
Maxwell-slip model (Vo-Minh, Tjahjowidodo, Ramon and Van Brussel 2011) represents it, and the
hysteresis it causes, by ``N_ELEMENTS`` elasto-slide elements in parallel: element ``i`` sticks
as a spring while its force is below its break-away force ``f_i`` and slides at ``f_i`` beyond.
Here ``f_i = w_i F_b`` with ``F_b = c (Pc+ + Pe+)`` (gauge pressures, positive parts) and fixed
weights ``w_i``; its presliding displacement ``delta_i = r_i delta`` is fixed, so the element
state is its spring deflection ``z_i`` with ``|z_i| <= delta_i`` and its force
``-f_i z_i / delta_i`` (it opposes the deflection). Dissipation: a sliding element turns
``f_i |dL|`` into heat (not added to the air); a sticking one stores and returns energy.
"""

from __future__ import annotations

from .._jit import fmax, fmin, jit_inline
from . import layout as ix

N_ELEMENTS = 3
WEIGHTS = (0.5, 0.3, 0.2)  # share of the break-away force per element (sum 1)
DELTA_FRACTIONS = (0.1, 0.4, 1.0)  # presliding displacement per element, times FR_D


@jit_inline
def breakaway_force(p, pc, pe):
    """Total break-away force [N] at gauge pressures ``pc, pe`` [Pa]: ``F_b = c (Pc+ + Pe+)``
    (plant v1), or with the contact-area law of plant v2 (``p[FR_MU] > 0``)
    ``F_b = mu (Pc+ S_c + Pe+ S_e)``: each bladder is pressed onto its braid by its own chamber's
    pressure over the braid's inner surface ``S = pi D L`` (Tondu and Lopez 2000), taken at
    mid-stroke (``FR_CC = mu S_c``, ``FR_C = mu S_e``, filled by ``fill_derived``)."""
    if p[ix.FR_MU] > 0.0:
        return p[ix.FR_CC] * fmax(pc, 0.0) + p[ix.FR_C] * fmax(pe, 0.0)
    return p[ix.FR_C] * (fmax(pc, 0.0) + fmax(pe, 0.0))


@jit_inline
def friction_force(p, pc, pe, z1, z2, z3):
    """Push force [N] of the elements with deflections ``z1..z3`` [m] (exact zero without friction)."""
    fb = breakaway_force(p, pc, pe)
    if fb == 0.0:
        return 0.0
    d = p[ix.FR_D]
    return -fb * (
        WEIGHTS[0] * z1 / (DELTA_FRACTIONS[0] * d)
        + WEIGHTS[1] * z2 / (DELTA_FRACTIONS[1] * d)
        + WEIGHTS[2] * z3 / (DELTA_FRACTIONS[2] * d)
    )


@jit_inline
def friction_slip(p, dl, z1, z2, z3):
    """The deflections after the free end moved by ``dl`` [m]: each grows with the motion and
    is held at its presliding displacement while the element slides."""
    d = p[ix.FR_D]
    a1, a2, a3 = DELTA_FRACTIONS[0] * d, DELTA_FRACTIONS[1] * d, DELTA_FRACTIONS[2] * d
    return (fmax(-a1, fmin(a1, z1 + dl)), fmax(-a2, fmin(a2, z2 + dl)), fmax(-a3, fmin(a3, z3 + dl)))
