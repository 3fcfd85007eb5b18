"""Valve mass flow (ISO 6358) and valve spool dynamics. Pure scalar kernels.

Pressures here are **absolute** [Pa]; temperatures [K]; sonic conductance C [m^3/(s Pa)].
"""

from __future__ import annotations

import math

from .._jit import jit
from .layout import RHO0, T0


@jit
def iso6358_flow(p_up, p_down, t_up, c, b, r_lam):
    """Mass flow [kg/s] from ``p_up`` to ``p_down`` (requires ``p_up >= p_down``), ISO 6358.

    choked   (r = p_down/p_up <= b): ``mdot = C rho0 p_up sqrt(T0/T_up)``
    subsonic (b < r < r_lam):        ``mdot = C rho0 p_up sqrt(T0/T_up) sqrt(1 - ((r - b)/(1 - b))^2)``
    laminar  (r_lam <= r <= 1):      linear in ``1 - r`` down to zero at ``r = 1``, continuous at
    ``r_lam``. The ISO curve has an infinite slope at ``r = 1``; the linear piece keeps the pressure
    ODE well-conditioned (its slope bounds the stiffest eigenvalue the sub-step must resolve).
    """
    if c <= 0.0 or p_up <= 0.0:
        return 0.0
    r = p_down / p_up
    choked = c * RHO0 * p_up * math.sqrt(T0 / t_up)
    if r <= b:
        return choked
    if r < r_lam:
        x = (r - b) / (1.0 - b)
        return choked * math.sqrt(1.0 - x * x)
    x = (r_lam - b) / (1.0 - b)
    return choked * math.sqrt(1.0 - x * x) * (1.0 - r) / (1.0 - r_lam)


@jit
def signed_flow(pa, ta, pb, tb, c, b, r_lam):
    """Mass flow [kg/s] from side a to side b; negative when air flows from b to a.

    The upstream side's temperature is used, whichever it is; no square root of a negative number
    is ever taken because the direction is chosen first.
    """
    if pa >= pb:
        return iso6358_flow(pa, pb, ta, c, b, r_lam)
    return -iso6358_flow(pb, pa, tb, c, b, r_lam)


@jit
def spool_step(s, s_rate, cmd, dt, tau, order, zeta, decay):
    """Advance a valve spool (opening in [-1, 1]) by ``dt`` towards command ``cmd``.

    Order 1: ``tau ds/dt = cmd - s`` integrated exactly over ``dt``, with ``decay = exp(-dt/tau)``
    passed in (computed once per control step, not per sub-step). Order 2: ``s'' = w^2 (cmd - s)
    - 2 zeta w s'`` with ``w = 1/tau`` (semi-implicit Euler). The opening saturates at +-1 (the
    spool's end stops), where its rate is reset.
    """
    if order == 1:
        s = cmd + (s - cmd) * decay
        s_rate = 0.0
    else:
        w = 1.0 / tau
        s_rate += dt * (w * w * (cmd - s) - 2.0 * zeta * w * s_rate)
        s += dt * s_rate
    if s > 1.0:
        s = 1.0
        s_rate = 0.0
    elif s < -1.0:
        s = -1.0
        s_rate = 0.0
    return s, s_rate
