"""Valve mass flow (ISO 6358) and valve spool dynamics. Pure scalar kernels.

Pressures here are **absolute** [Pa]; temperatures [K]; sonic conductance C [m^3/(s Pa)].
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import jit, jit_inline, sqrt
from .layout import RHO0, T0


@jit_inline
def laminar_factor(r_lam, b):
    """``sqrt(1 - x^2) / (1 - r_lam)`` with ``x = (r_lam - b) / (1 - b)``: the slope of the
    laminar piece of the ISO 6358 flow per unit of choked flow (continuous with the subsonic curve
    at ``r_lam``). Scalars or arrays (the derived parameter column ``LAM_K``, the stability number):
    the one place it is written."""
    x = (r_lam - b) / (1.0 - b)
    return np.sqrt(1.0 - x * x) / (1.0 - r_lam)


@jit
def iso6358_flow(p_up, p_down, t_up, c, b, r_lam):
    """Mass flow [kg/s] from ``p_up`` to ``p_down`` (requires ``p_up >= p_down``), ISO 6358.

    choked   (r = p_down/p_up <= b): ``mdot = C rho0 p_up sqrt(T0/T_up)``
    subsonic (b < r < r_lam):        ``mdot = C rho0 p_up sqrt(T0/T_up) sqrt(1 - ((r - b)/(1 - b))^2)``
    laminar  (r_lam <= r <= 1):      linear in ``1 - r`` down to zero at ``r = 1``, continuous at
    ``r_lam``. The ISO curve has an infinite slope at ``r = 1``; the linear piece keeps the pressure
    ODE well-conditioned (its slope bounds the stiffest eigenvalue the sub-step must resolve).
    """
    return iso6358_flow_k(
        p_up, p_down, math.sqrt(T0 / t_up), c, b, 1.0 / (1.0 - b), r_lam, laminar_factor(r_lam, b)
    )


@jit_inline
def iso6358_flow_k(p_up, p_down, k_up, c, b, inv_1mb, r_lam, lam_k):
    """:func:`iso6358_flow` with ``k_up = sqrt(T0/T_up)``, ``inv_1mb = 1/(1-b)`` and the laminar
    factor ``lam_k = sqrt(1 - x_lam^2)/(1 - r_lam)`` precomputed.

    Written without branches (every regime is evaluated, then the right one selected) so that the
    plant's loop across plants vectorises; the selected value is the same as with branches. The
    square root of the unused subsonic branch may be NaN; it is discarded."""
    r = p_down / p_up
    choked = c * RHO0 * p_up * k_up
    x = (r - b) * inv_1mb
    subsonic = choked * sqrt(1.0 - x * x)
    laminar = choked * lam_k * (1.0 - r)
    m = choked if r <= b else (subsonic if r < r_lam else laminar)
    return 0.0 if (c <= 0.0 or p_up <= 0.0) else m


@jit
def signed_flow(pa, ta, pb, tb, c, b, r_lam):
    """Mass flow [kg/s] from side a to side b; negative when air flows from b to a.

    The upstream side's temperature is used, whichever it is; the direction is chosen first, so
    the ISO 6358 formula always sees ``p_up >= p_down``.
    """
    return signed_flow_k(
        pa, math.sqrt(T0 / ta), pb, math.sqrt(T0 / tb), c, b, 1.0 / (1.0 - b), r_lam, laminar_factor(r_lam, b)
    )


@jit_inline
def signed_flow_k(pa, ka, pb, kb, c, b, inv_1mb, r_lam, lam_k):
    """:func:`signed_flow` with the temperature factors ``k = sqrt(T0/T)`` precomputed."""
    forward = pa >= pb  # the direction is chosen first (selects, not branches: see iso6358_flow_k)
    m = iso6358_flow_k(
        pa if forward else pb, pb if forward else pa, ka if forward else kb, c, b, inv_1mb, r_lam, lam_k
    )
    return m if forward else -m


@jit_inline
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


def first_order_interval(s0: float, cmd: float, dt: float, tau: float) -> tuple[float, float]:
    """``(mean, end)`` of a first-order spool (:func:`spool_step`'s order 1, ``tau ds/dt = cmd -
    s``) that starts at ``s0`` and follows ``cmd`` for ``dt``: its exact average opening over
    the interval and its opening at the end (end stops not reached). What a detector that sees
    only the command can credit the valve with: the flow is linear in the opening."""
    decay = math.exp(-dt / tau)
    return cmd + (s0 - cmd) * tau / dt * (1.0 - decay), cmd + (s0 - cmd) * decay
