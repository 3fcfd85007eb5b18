"""The two stiffnesses of a CE-PAM, named.

* **tangent stiffness** ``K_t = -dF/dL`` at held chamber pressures
  (:func:`cepam_gym.physics.muscle.cepam_force`, ``aux["stiffness"]``): the local slope a
  controller regulates and the tasks' stiffness targets are stated in.
* **protocol (secant) stiffness** ``K_s``: what a rig reads by the paper's protocol (sections II,
  III, XII) from the current state: each weight ``m`` hung alone, the end moves until the muscle's
  force change, the weight and the dry friction balance, ``K_s = mean(m g / (L_m - L_0))``. Over a
  finite displacement the force is not linear (a slack contractor becomes taut, the braid
  stiffens towards its locking angle) and the friction elements
  (:mod:`cepam_gym.physics.friction`) hold part of each weight, so ``K_s`` differs from ``K_t``.

:func:`secant_stiffness` is the quasi-static version of the protocol: pressures held, the
Maxwell-slip elements relaxed at ``L_0`` (a fresh reading), each loaded length the first root of
``F(L) - F(L_0) + m g - F_f(L - L_0) = 0`` with ``F_f`` the elements' resisting force. The dynamic
protocol (:mod:`cepam_gym.validation.protocols`) runs the same reading on the plant.
"""

from __future__ import annotations

import math

from .._jit import jit
from . import layout as ix
from .friction import DELTA_FRACTIONS, WEIGHTS, breakaway_force
from .muscle import cepam_force

_SCAN = 256  # scan points between L_0 and the upper stop, then bisection


@jit
def _friction_resist(fb, d, x):
    """Force [N] with which relaxed Maxwell-slip elements resist an extension ``x >= 0`` [m]."""
    if fb == 0.0:
        return 0.0
    out = 0.0
    for i in range(3):
        a = DELTA_FRACTIONS[i] * d
        out += WEIGHTS[i] * fb * min(1.0, x / a)
    return out


@jit
def loaded_length(L0, pc, pe, p, weight):
    """Length [m] at which a weight [N] hung at ``L0`` comes to rest (quasi-static, pressures held,
    friction relaxed at ``L0``); ``nan`` if it reaches the upper stop first."""
    f0 = cepam_force(L0, pc, pe, p)[0]
    fb = breakaway_force(p, pc, pe)
    d = p[ix.FR_D]
    hi = p[ix.L_MAX]
    step = (hi - L0) / _SCAN
    a = L0
    for k in range(1, _SCAN + 1):
        b = L0 + k * step
        h = cepam_force(b, pc, pe, p)[0] - f0 + weight - _friction_resist(fb, d, b - L0)
        if h <= 0.0:
            for _ in range(48):
                m = 0.5 * (a + b)
                hm = cepam_force(m, pc, pe, p)[0] - f0 + weight - _friction_resist(fb, d, m - L0)
                if hm > 0.0:
                    a = m
                else:
                    b = m
            return 0.5 * (a + b)
        a = b
    return math.nan


@jit
def secant_stiffness(L0, pc, pe, p, weights):
    """The protocol stiffness [N/m] at length ``L0`` and gauge pressures ``pc, pe`` [Pa]:
    ``mean(W / (L_W - L0))`` over the hanging weights ``weights`` [N] (those that reach the stop
    are left out; ``nan`` if all do)."""
    total = 0.0
    count = 0
    for w in weights:
        Lw = loaded_length(L0, pc, pe, p, w)
        if Lw == Lw and Lw > L0:
            total += w / (Lw - L0)
            count += 1
    return total / count if count > 0 else math.nan
