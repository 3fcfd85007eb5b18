"""Plants at rest, what a state measures, and the stability limit of the explicit air update."""

from __future__ import annotations

import numpy as np

from .._jit import jit
from ..errors import InputError
from ..physics import layout as ix
from ..physics.air import state_from_pressure
from ..physics.muscle import chamber_volumes
from ..physics.valve import laminar_factor
from .layout import N_AUX, N_STATE, S_L, S_MC, S_ME, S_UC, S_UE
from .substep import measure_row


@jit
def rest_rows(rows, L, pc, pe, params, state, aux):
    """Plants ``rows`` of a batch at rest at ``L[j]`` [m] with gauge pressures ``pc[j]``, ``pe[j]``
    [Pa], air at the ambient temperature (as :func:`initial_state`), into ``state`` and their
    :func:`measure` into ``aux``, in one compiled call (the reset's). Returns the first ``j``
    :func:`initial_state` would refuse (outside the end stops, below vacuum), else -1, having
    written nothing."""
    shared = params.shape[0] == 1
    for j in range(rows.shape[0]):
        p = params[0] if shared else params[rows[j]]
        patm = p[ix.P_ATM]
        if not (p[ix.L_MIN] <= L[j] <= p[ix.L_MAX]) or pc[j] + patm <= 0.0 or pe[j] + patm <= 0.0:
            return j
    for j in range(rows.shape[0]):
        i = rows[j]
        p = params[0] if shared else params[i]
        _initial_row(L[j], pc[j], pe[j], p[ix.T_AMB], p, state[i])
        aux[i, :] = 0.0  # as measure's fresh rows: nothing of the last step's bookkeeping stays
        measure_row(state[i], p, aux[i])
    return -1


@jit
def _initial_row(L, pc, pe, temp, p, x):
    vol_c, vol_e, _a, _b = chamber_volumes(L, p)
    patm = p[ix.P_ATM]
    x[:] = 0.0
    x[S_L] = L
    x[S_MC], x[S_UC] = state_from_pressure(pc + patm, temp, vol_c)
    x[S_ME], x[S_UE] = state_from_pressure(pe + patm, temp, vol_e)


def initial_state(params, length, pressure_c=0.0, pressure_e=0.0, temperature=None):
    """Plants at rest at ``length`` [m] with gauge chamber pressures [Pa], air at ``temperature``.

    Arguments broadcast over the batch given by ``params`` (N or 1 rows) and the arguments.
    """
    params = np.atleast_2d(np.asarray(params, dtype=float))
    L, pc, pe = np.broadcast_arrays(
        np.atleast_1d(length).astype(float),
        np.atleast_1d(pressure_c).astype(float),
        np.atleast_1d(pressure_e).astype(float),
    )
    n = max(L.shape[0], params.shape[0])
    # copies, not broadcast views: numba warns that it will stop treating those as writable
    L, pc, pe = (np.array(np.broadcast_to(a, (n,))) for a in (L, pc, pe))
    t_amb = params[:, ix.T_AMB] if temperature is None else np.atleast_1d(temperature)
    temp = np.array(np.broadcast_to(t_amb, (n,)))
    prow = np.array(np.broadcast_to(params, (n, params.shape[1])))
    lo, hi = prow[:, ix.L_MIN], prow[:, ix.L_MAX]
    if np.any((L < lo) | (L > hi)) or not np.all(np.isfinite(L)):
        raise InputError(f"initial length must lie within the end stops [{lo.min()}, {hi.max()}] m, got {L}")
    if np.any(pc + prow[:, ix.P_ATM] <= 0) or np.any(pe + prow[:, ix.P_ATM] <= 0):
        raise InputError("initial gauge pressures must be above vacuum (> -atmospheric)")
    x = np.zeros((n, N_STATE))
    _initial_rows(L, pc, pe, temp, prow, x)
    return x


@jit
def _initial_rows(L, pc, pe, temp, prow, x):
    for i in range(x.shape[0]):
        _initial_row(L[i], pc[i], pe[i], temp[i], prow[i], x[i])


def stability_number(params, dt: float) -> np.ndarray:
    """``dt * lambda_max`` of the explicit chamber-air integration, per parameter row.

    Two stiff modes act on a chamber's air, both largest at its smallest volume ``V``:

    * the valve flow: a chamber fed through a fully open valve in the linearised (laminar)
      region near equal pressures, ``lambda_v = gamma R T / V * dmdot/dp`` with
      ``dmdot/dp = C rho0 sqrt(T0/T) sqrt(1 - x^2) / (1 - r_lam)``, ``x = (r_lam - b) / (1 - b)``;
    * the wall heat transfer: ``dU/dt = hA (T_amb - T)`` with ``U = m cv T`` relaxes the air
      temperature at ``lambda_h = hA / (m cv)``. The least air a chamber holds is at atmospheric
      pressure (it exhausts to the atmosphere): ``m = p_atm V / (R T)``, so with
      ``cv = R / (gamma - 1)``: ``lambda_h = hA (gamma - 1) T / (p_atm V)``.

    Both modes damp the same state (mass and energy of one chamber), so their sum bounds the
    largest eigenvalue (Gershgorin). Explicit Euler is stable below 2 and free of overshoot
    below 1. ``T`` is the hotter of supply and ambient air (least mass, fastest flow).
    """
    p = np.atleast_2d(params)
    c = np.maximum(p[:, ix.C_PROP], p[:, ix.C_ONOFF]) + p[:, ix.C_LEAK]
    t = np.maximum(p[:, ix.T_SUP], p[:, ix.T_AMB])
    slope = c * ix.RHO0 * np.sqrt(ix.T0 / t) * laminar_factor(p[:, ix.R_LAM], p[:, ix.B_CRIT])
    v_min = np.full(p.shape[0], np.inf)
    from ..physics import api

    for L in np.linspace(p[:, ix.L_MIN], p[:, ix.L_MAX], 16):
        vc, ve, _, _ = api.chamber_volumes(L, p)
        v_min = np.minimum(v_min, np.minimum(vc, ve))
    lam_valve = ix.GAMMA * ix.R_AIR * t / v_min * slope
    lam_heat = p[:, ix.HA] * (ix.GAMMA - 1.0) * t / (p[:, ix.P_ATM] * v_min)
    return dt * (lam_valve + lam_heat)


def check_stability(params, dt: float, limit: float = 1.2) -> None:
    """Raise ``ValueError`` when the sub-step ``dt`` is too long for these valves, heat transfer
    and volumes (:func:`stability_number` above ``limit``)."""
    s = stability_number(params, dt)
    if np.any(s > limit):
        worst = float(s.max())
        raise InputError(
            f"sub-step {dt * 1e3:.3g} ms is too long for the valve conductance, heat transfer and "
            f"chamber volume (stability number {worst:.2f} > {limit}): use sub_dt <= "
            f"{dt * limit / worst * 1e3:.3g} ms, a smaller valve_conductance or heat_transfer, "
            "or a larger dead volume"
        )


def measure(state, params):
    """``aux`` of states without stepping them (force, stiffness, pressures, volumes...)."""
    state = np.atleast_2d(state)
    params = np.atleast_2d(params)
    aux = np.zeros((state.shape[0], N_AUX))
    _measure_rows(state, params, aux)
    return aux


@jit
def _measure_rows(state, params, aux):
    for i in range(state.shape[0]):
        measure_row(state[i], params[0] if params.shape[0] == 1 else params[i], aux[i])
