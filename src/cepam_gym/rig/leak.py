"""Leak detection from what a rig measures: an energy balance of each chamber's air on the plant's
own model.

A chamber's internal energy is known from its pressure and volume alone, ``U = p_abs V / (gamma - 1)``
(:func:`cepam_gym.physics.air.pressure_abs` inverted; ``V`` from the measured length by
:func:`cepam_gym.physics.muscle.chamber_volumes`), whatever the air's temperature. Between two
readings the plant's model says how much energy the valves move in and out
(:func:`cepam_gym.physics.air.chamber_rates`, the ISO 6358 flow of the commanded opening at the
measured pressures, the plant's own seal leakage included) and how much work the volume change
takes (``p dV``). The *residual* is the energy the model says should be there and is not. A
leak to the atmosphere shows as a residual that grows with the energy a unit conductance to the
atmosphere would carry out (the *basis*); dividing one by the other estimates the leak's
conductance.

What the model cannot know is allowed for, so a healthy rig that is not exactly the model does not
trip: a fraction ``tolerance`` of the energy the valves and the volume change moved in the window
(a valve, a volume, a spool off by some tens of per cent; the heat the walls exchange), and the
leak must exceed a fraction of the valve's own conductance over a whole window
(:class:`LeakMonitor`). The air is taken at the ambient temperature where the flow law needs a
temperature (an outflow's enthalpy, the flow's density): the energy form keeps that error to a
square root of the temperature ratio.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from .._jit import jit
from ..physics import layout as ix
from ..physics.air import chamber_rates
from ..physics.layout import GAMMA
from ..physics.muscle import chamber_volumes
from ..physics.valve import first_order_interval
from ..plant.actions import check_action_mode
from ..plant.layout import ONOFF, PRESSURE
from ..plant.substep import pwm_open_fraction, valve_command


@jit
def interval_balance(row, chamber, dt, l0, l1, pg0, pg1, spool0, spool1, conductance, p_sup):
    """Energy balance of chamber ``chamber`` (0 CPAM, 1 annulus) of plant row ``row`` over ``dt``
    [s] between two readings: lengths ``l0, l1`` [m], gauge pressures ``pg0, pg1`` [Pa], valve
    openings ``spool0, spool1`` in [-1, 1] at each end (conductance ``conductance`` fully open),
    supply ``p_sup`` [Pa abs]. Returns ``(residual, basis, basis_in, throughput)`` [J, J per
    m^3/(s Pa), the same, J]: the energy the model predicts minus the energy measured, the energy
    a unit conductance to the atmosphere would carry out and one from the supply would carry in,
    and the energy the valves and the volume change moved (trapezoid rule)."""
    vc0, ve0, _a, _b = chamber_volumes(l0, row)
    vc1, ve1, _c, _d = chamber_volumes(l1, row)
    v0 = vc0 if chamber == 0 else ve0
    v1 = vc1 if chamber == 0 else ve1
    patm = row[ix.P_ATM]
    pa0 = pg0 + patm
    pa1 = pg1 + patm
    measured = (pa1 * v1 - pa0 * v0) / (GAMMA - 1.0)
    work = 0.5 * (pa0 + pa1) * (v1 - v0)
    t, k, ts, ks = row[ix.T_AMB], row[ix.K_AMB], row[ix.T_SUP], row[ix.K_SUP]
    vk = (row[ix.B_CRIT], row[ix.INV_1MB], row[ix.R_LAM], row[ix.LAM_K])
    flows = 0.0
    basis = 0.0
    basis_in = 0.0
    moved = 0.0
    for pa, s in ((pa0, spool0), (pa1, spool1)):
        c_in = conductance * max(s, 0.0)
        c_out = conductance * max(-s, 0.0) + row[ix.C_LEAK]
        # the enthalpy in from the supply, out to the atmosphere, and out through a unit conductance
        _m1, du_in, _s1 = chamber_rates(pa, t, k, 0.0, c_in, 0.0, p_sup, ts, ks, patm, t, k, vk, 0.0)
        _m2, du_out, _s2 = chamber_rates(pa, t, k, 0.0, 0.0, c_out, p_sup, ts, ks, patm, t, k, vk, 0.0)
        _m3, du_unit, _s3 = chamber_rates(pa, t, k, 0.0, 0.0, 1.0, p_sup, ts, ks, patm, t, k, vk, 0.0)
        _m4, du_unit_in, _s4 = chamber_rates(pa, t, k, 0.0, 1.0, 0.0, p_sup, ts, ks, patm, t, k, vk, 0.0)
        flows += du_in + du_out
        basis -= du_unit
        basis_in += max(du_unit_in, 0.0)
        moved += abs(du_in) + abs(du_out)
    half = 0.5 * dt
    return half * flows - work - measured, half * basis, half * basis_in, half * moved + abs(work)


class LeakMonitor:
    """The leak check of one run: fed each fresh reading and the command in force since the one
    before (:meth:`update`); :meth:`update` returns ``(reason, sentence)`` when a chamber leaks
    (``"leak"``) or fills from the supply beyond what its valve was told (``"valve_fault"``: a valve
    stuck open to the supply).

    ``plant``: the nominal :class:`~cepam_gym.plant.params.PlantParams`; ``action_mode`` what the
    commands drive; ``setpoint_max`` the gauge pressure of +1 in pressure mode [Pa]; ``dt`` the
    control period [s]. A chamber leaks when, over the last ``window_s`` of readings, the residual
    beyond ``tolerance`` times the energy moved exceeds the basis times ``max_fraction`` of the
    valve's conductance, and the chamber held more than ``min_pressure`` [Pa gauge] (a vented
    chamber cannot leak); its valve is at fault when the same holds of the energy gained beyond
    the model's, against the energy a unit conductance from the supply would bring in."""

    def __init__(
        self,
        plant,
        action_mode: str,
        setpoint_max: float,
        dt: float,
        max_fraction: float,
        window_s: float,
        tolerance: float = 0.3,
        min_pressure: float = 20e3,
    ):
        self.row = np.ascontiguousarray(plant.to_array(), dtype=float)
        self.mode = check_action_mode(action_mode)
        self.setpoint_max = float(setpoint_max)
        self.dt = float(dt)
        self.conductance = float(self.row[ix.C_ONOFF] if self.mode == ONOFF else self.row[ix.C_PROP])
        self.tau = float(self.row[ix.TAU_SWITCH] if self.mode == ONOFF else self.row[ix.TAU_SPOOL])
        self.max_fraction = float(max_fraction)
        self.window_s = float(window_s)
        self.tolerance = float(tolerance)
        self.min_pressure = float(min_pressure)
        self.spool = [0.0, 0.0]  # the valves' estimated opening at the last reading
        self._last = None
        self._window: deque = deque()  # dt, then residual, basis, basis in, throughput, min pressure: c, e
        self.estimate = [0.0, 0.0]  # the latest leak conductance estimates [m^3/(s Pa)]
        self.inflow = [0.0, 0.0]  # the latest estimates of an unexplained opening to the supply

    def reset(self) -> None:
        self._last, self.spool, self.estimate, self.inflow = None, [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]
        self._window.clear()

    def _openings(self, i: int, command: float, dt: float, pg0: float, pg1: float) -> tuple[float, float]:
        """The valve opening at each end of an interval of ``dt`` under ``command``."""
        if self.mode == PRESSURE:  # the in-plant regulator's law at each end's pressure
            half = 0.5 * self.setpoint_max
            u = half * (command + 1.0)
            return (
                valve_command(PRESSURE, u, pg0, 0.0, self.row),
                valve_command(PRESSURE, u, pg1, 0.0, self.row),
            )
        if self.mode == ONOFF:  # a PWM valve's mean opening over its period
            command = math.copysign(pwm_open_fraction(abs(command), self.row), command)
        # a spool (or the mean opening of a PWM valve) following the command with its time constant:
        # both ends carry the interval's mean opening, as the flow is linear in it
        mean, self.spool[i] = first_order_interval(self.spool[i], command, dt, self.tau)
        return mean, mean

    def update(self, reading, command, contiguous: bool) -> str | None:
        """Take a fresh ``reading`` (:class:`~cepam_gym.rig.protocol.Reading`), ``command`` (the
        two commands in force since the previous reading), ``contiguous`` whether that previous
        reading was the last step's (else the interval is skipped: its commands are not known)."""
        last, self._last = self._last, reading
        if last is None or not contiguous or command is None:
            return None
        dt = reading.time - last.time
        if not 0 < dt < 10 * self.dt:
            return None
        p_sup = reading.supply + self.row[ix.P_ATM]
        entry = [dt]
        sums = []
        for i, (p0, p1) in enumerate(
            ((last.pressure_c, reading.pressure_c), (last.pressure_e, reading.pressure_e))
        ):
            s0, s1 = self._openings(i, float(command[i]), dt, p0, p1)
            sums.append(
                interval_balance(
                    self.row, i, dt, last.length, reading.length, p0, p1, s0, s1, self.conductance, p_sup
                )
            )
        for j in range(4):  # residual, basis, basis in, throughput: each chamber's
            entry += [sums[0][j], sums[1][j]]
        entry += [min(last.pressure_c, reading.pressure_c), min(last.pressure_e, reading.pressure_e)]
        self._window.append(entry)
        span = sum(e[0] for e in self._window)
        while self._window and span - self._window[0][0] >= self.window_s:
            span -= self._window.popleft()[0]
        if span < self.window_s - 0.5 * self.dt:
            return None
        w = np.asarray(self._window)
        limit = self.max_fraction * self.conductance
        for i, name in enumerate(("CPAM", "EPAM")):
            residual, basis, basis_in, moved = (w[:, 1 + 2 * j + i].sum() for j in range(4))
            held = w[:, 9 + i].min() >= self.min_pressure
            self.estimate[i] = max(0.0, (residual - self.tolerance * moved) / basis) if held else 0.0
            self.inflow[i] = (
                max(0.0, (-residual - self.tolerance * moved) / basis_in) if basis_in > 0 else 0.0
            )
            if self.estimate[i] > limit:
                return "leak", (
                    f"{name} chamber loses {residual / span:.2f} W of air energy the valves do not explain "
                    f"over {span * 1e3:.0f} ms: a leak of about {self.estimate[i] / self.conductance:.2f} "
                    f"of the valve's conductance (limit {self.max_fraction:g})"
                )
            if self.inflow[i] > limit:
                return "valve_fault", (
                    f"{name} chamber gains {-residual / span:.2f} W of air energy its valve was not told to "
                    f"let in over {span * 1e3:.0f} ms: a valve open to the supply by about "
                    f"{self.inflow[i] / self.conductance:.2f} of its conductance beyond its command"
                )
        return None
