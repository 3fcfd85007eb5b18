"""The plant of the emulated rig, one tick at a time, with the sensors' imperfections and the faults
of the plant and of one sensor channel (the sockets and the link's faults: :mod:`.emulator`).

Faults (:data:`~cepam_gym.rig.protocol.FAULTS`), each with a size:

* ``frozen_sensor``: the pressures and the length stop changing (packets keep coming);
* ``supply_drop``: the supply falls to ``size`` times its nominal gauge pressure (default 0.2);
* ``leak``: each chamber leaks to the atmosphere through ``size`` times the valve's conductance
  (default 0.3);
* ``stuck_valve``: the CPAM's valve stays at command ``size`` (default +1: open to the supply);
* ``channel_value``: one sensor channel (:data:`~cepam_gym.rig.protocol.CHANNELS`) reads ``size``
  [SI] plus its noise, whatever the plant does: a sensor failing low (0, -50 kPa) or high, or a
  non-finite value (NaN, -inf);
* ``frozen_channel``: one channel repeats its last value; the others keep moving.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import plant as pl
from ..errors import InputError
from ..physics import layout as ix
from ..plant.actions import check_action_mode, plant_inputs
from .protocol import CHANNELS, FAULTS, SAFE_COMMANDS

DEFAULT_FAULT_SIZE = {"frozen_sensor": 0.0, "supply_drop": 0.2, "leak": 0.3, "stuck_valve": 1.0}
CHANNEL_FAULTS = ("channel_value", "frozen_channel")
PLANT_FAULTS = (*DEFAULT_FAULT_SIZE, *CHANNEL_FAULTS)


@dataclass(frozen=True)
class RigImperfections:
    """What stands between the plant and the host: one-way ``latency_s`` plus a uniform
    ``jitter_s`` per packet (each direction), Gaussian sensor noise (sd: ``noise_pressure`` [Pa],
    ``noise_length`` [m]), quantisation steps (``quant_pressure`` [Pa], ``quant_length`` [m]) and
    the fraction ``drop`` of packets lost (each direction)."""

    latency_s: float = 0.001
    jitter_s: float = 0.0005
    noise_pressure: float = 200.0
    noise_length: float = 3e-5
    quant_pressure: float = 50.0
    quant_length: float = 1e-5
    drop: float = 0.0

    def __post_init__(self):
        for f, v in self.__dict__.items():
            if not (math.isfinite(v) and v >= 0):
                raise InputError(f"{f} must be finite and >= 0, got {v!r}")
        if self.drop >= 1:
            raise InputError(f"drop must be below 1, got {self.drop!r}")


def _quantised(v: float, step: float) -> float:
    return round(v / step) * step if step > 0 and math.isfinite(v) else v


@dataclass
class EmulatedPlant:
    """The plant of the emulated rig, one tick at a time (no sockets: :func:`.emulator.serve` adds
    them)."""

    params: pl.PlantParams
    mode: str = "valve"
    load: float = 0.1  # the hanging mass [kg]
    rate_hz: float = 500.0
    sub_dt: float = 5e-4
    # pressure mode: the gauge set-point of +1 [Pa]: the env's (``EnvModel.setpoint_max``; the
    # command line's --env), as the controller expects; None: this plant's own pressure cap
    setpoint_max: float | None = None
    faults: dict = field(default_factory=dict)

    def __post_init__(self):
        self._mode = check_action_mode(self.mode)
        if not (math.isfinite(self.load) and self.load >= 0):
            raise InputError(f"the load must be a mass >= 0 kg, got {self.load!r}")
        self.n_sub = max(1, int(round(1.0 / (self.rate_hz * self.sub_dt))))
        self.tick_dt = self.n_sub * self.sub_dt
        self.nominal_row = self.params.to_array()
        pl.check_stability(self.nominal_row, self.sub_dt)
        if self.setpoint_max is None:
            self.setpoint_max = self.params.pressure_cap
        self.W = np.empty(pl.W_SIZE)
        self.restart()

    def restart(self) -> None:
        """At rest at the lower end stop, vented, supply on, no faults, not stopped."""
        self.prow = self.nominal_row.copy()[None]
        self.x = pl.initial_state(self.prow, self.params.min_length)
        self.aux = pl.measure(self.x, self.prow)
        self.inputs = np.zeros((1, pl.N_INPUT))
        self.time = 0.0
        self.command = SAFE_COMMANDS
        self.stopped = False
        self.faults = {}
        self._frozen: tuple | None = None
        self._channel_faults: dict[int, tuple[str, float]] = {}  # channel -> (fault, value)
        self._last_sensed: tuple | None = None

    def stop(self) -> None:
        self.stopped = True
        self.command = SAFE_COMMANDS
        self.prow[0, ix.P_SUP] = self.prow[0, ix.P_ATM]  # the dump valve: supply line at the atmosphere

    def inject(self, name: str, size: float | None = None, channel: int = 0) -> None:
        """Fault ``name`` of ``size`` (None: its default; ``channel_value``: the value it reads)
        on sensor channel ``channel`` (the faults of one channel)."""
        if name not in PLANT_FAULTS:
            known = ", ".join(f for f in FAULTS if f in PLANT_FAULTS)
            raise InputError(f"unknown fault {name!r}; the faults of the plant are {known}")
        if name in CHANNEL_FAULTS:
            if not 0 <= int(channel) < len(CHANNELS):
                raise InputError(f"{name}: channel must lie in [0, {len(CHANNELS)}), got {channel}")
            if name == "channel_value" and size is None:
                raise InputError("channel_value needs the value the channel reads (its size)")
            if name == "frozen_channel" and self._last_sensed is not None:
                size = self._last_sensed[int(channel)]
            self._channel_faults[int(channel)] = (name, size)
            self.faults[name] = size
            return
        size = DEFAULT_FAULT_SIZE[name] if size is None else float(size)
        self.faults[name] = size
        if name == "supply_drop" and not self.stopped:
            atm = self.prow[0, ix.P_ATM]
            self.prow[0, ix.P_SUP] = atm + size * (self.nominal_row[ix.P_SUP] - atm)
        elif name == "leak":
            self.prow[0, ix.C_LEAK] = size * self.nominal_row[ix.C_PROP]
        elif name == "frozen_sensor":
            self._frozen = self.true_values()

    def true_values(self) -> tuple[float, float, float]:
        return float(self.aux[0, pl.A_PC]), float(self.aux[0, pl.A_PE]), float(self.x[0, pl.S_L])

    def tick(self) -> None:
        a0, a1 = self.command
        if "stuck_valve" in self.faults:
            a0 = self.faults["stuck_valve"]
        plant_inputs(self.inputs[0], self._mode, pl.RIG, a0, a1, self.setpoint_max, self.load)
        pl.advance_block(
            self.x,
            self.inputs,
            self.prow,
            0,
            1,
            self._mode,
            self.sub_dt,
            self.n_sub,
            self.x,
            self.aux,
            self.W,
        )
        self.time += self.tick_dt

    def sensed(self, imp: RigImperfections, rng) -> tuple[float, float, float, float]:
        """``(pressure_c, pressure_e, length, supply)`` as the sensors report them now."""
        noise = (imp.noise_pressure, imp.noise_pressure, imp.noise_length, imp.noise_pressure)
        quant = (imp.quant_pressure, imp.quant_pressure, imp.quant_length, imp.quant_pressure)
        draws = rng.standard_normal(4) * noise
        if self._frozen is not None:
            values = [*self._frozen, 0.0]
            draws[:3] = 0.0
        else:
            values = [*self.true_values(), 0.0]
        values[3] = self.prow[0, ix.P_SUP] - self.prow[0, ix.P_ATM]
        for ch, (name, value) in self._channel_faults.items():
            if name == "channel_value":
                values[ch] = value
            elif value is not None:  # frozen: the value it read when the fault came, noise and all
                values[ch], draws[ch] = value, 0.0
        out = tuple(_quantised(v + d, q) for v, d, q in zip(values, draws, quant))
        for ch, (name, value) in self._channel_faults.items():
            if name == "frozen_channel" and value is None:  # injected before any reading: frozen now
                self._channel_faults[ch] = (name, out[ch])
        self._last_sensed = out
        return out
