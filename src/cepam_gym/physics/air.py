"""Air in one chamber: open-system first law with variable volume. Pure scalar kernels.

State per chamber: air mass ``m`` [kg] and internal energy ``U = m cv T`` [J]. Then
``T = U / (m cv)`` and ``p_abs = m R T / V = (gamma - 1) U / V``. With ``h = cp T``::

    dm/dt = mdot_in - mdot_out
    dU/dt = mdot_in cp T_in - mdot_out cp T - p_abs dV/dt + hA (T_wall - T)

(docs/model.md section 4). Mass is exactly conserved with closed valves because only the flows
change ``m``; the ``p dV`` term makes compression heat the air, so the closed-chamber stiffness
of the plant is the adiabatic one on short time scales and the isothermal one on long ones.
"""

from __future__ import annotations

from .._jit import jit, jit_inline
from .layout import CP, CV, GAMMA, R_AIR
from .valve import signed_flow_k


@jit
def pressure_abs(m, u, volume):
    """Absolute pressure [Pa] of air with mass ``m``, internal energy ``u`` in ``volume``."""
    return (GAMMA - 1.0) * u / volume


@jit
def temperature(m, u):
    """Temperature [K] of air with mass ``m`` and internal energy ``u``."""
    return u / (m * CV)


@jit
def state_from_pressure(p_abs, t, volume):
    """Mass and internal energy of air at absolute pressure ``p_abs``, temperature ``t``."""
    m = p_abs * volume / (R_AIR * t)
    return m, m * CV * t


@jit_inline
def chamber_rates(p, t, kt, dvol_dt, c_in, c_out, p_sup, t_sup, k_sup, p_atm, t_amb, k_amb, vk, ha):
    """Rates ``(dm/dt, dU/dt)`` of one chamber and the mass flow drawn from the supply.

    ``p`` absolute pressure, ``t`` temperature and ``kt = sqrt(T0/t)`` of the chamber air;
    ``c_in`` connects the chamber to the supply, ``c_out`` to the atmosphere (exhaust plus
    leakage); ``vk = (b, 1/(1-b), r_lam, lam_k)`` the valve constants. Reverse flows (chamber above
    supply, or below atmosphere) are allowed and carry the upstream temperature.
    """
    b, inv_1mb, r_lam, lam_k = vk
    m_sup = signed_flow_k(p_sup, k_sup, p, kt, c_in, b, inv_1mb, r_lam, lam_k)  # > 0: supply -> chamber
    m_exh = signed_flow_k(p, kt, p_atm, k_amb, c_out, b, inv_1mb, r_lam, lam_k)  # > 0: chamber -> atm
    h_sup = CP * (t_sup if m_sup > 0.0 else t) * m_sup
    h_exh = CP * (t if m_exh > 0.0 else t_amb) * m_exh
    dm = m_sup - m_exh
    du = h_sup - h_exh - p * dvol_dt + ha * (t_amb - t)
    return dm, du, m_sup
