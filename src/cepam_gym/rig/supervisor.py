"""The safety supervisor: below the policy, every command goes through it and it cannot be bypassed.

Each control step the deploy loop hands it the newest reading (or None) and the command the policy
wants; it returns the command to send. Checks, in this order:

* **stale sensor**: no new reading for ``stale_after_s`` (packets lost, a cable, a dead rig);
* **frozen sensor**: readings keep coming but pressures and length are bit-identical for
  ``frozen_after_s`` (a hung ADC; a real sensor's noise always moves its last bit);
* **supply loss**: the supply's gauge pressure below ``supply_min``;
* **pressure limit**: a chamber's gauge pressure above its limit (the balloon's burst pressure
  with a margin);
* **length limit**: the length outside ``[length_min, length_max]`` (the end stops with a margin:
  beyond them the sensor or the mechanism has failed);
* **stopped**: the rig says it is in its safe state (its own emergency stop);
* **leak**: a chamber loses air the valves do not explain, judged by an energy balance of its air
  on the plant's model over ``leak_window_s`` (:mod:`cepam_gym.rig.leak`): a leak larger than
  ``leak_max_fraction`` of the valve's conductance trips, also one a controller compensates by
  holding its supply valve open (needs the env's model: ``Supervisor(..., model=...)``); the same
  balance calls a valve faulty when a chamber gains air its valve was not told to let in (a valve
  stuck open to the supply);
* **valve fault**: a chamber commanded to exhaust (command <= -0.9) for ``valve_check_s`` still
  holds more than half its pressure and more than :data:`VENTED` (a valve stuck open to the
  supply, a blocked exhaust);
* **bad command**: the policy's command is not finite;
* **command rate**: each command moves at most ``command_rate_per_s`` per second (a clamp, not a
  trip; unlimited by default, as the envs train).

A trip is latched: from the step it happens on, the command is :data:`SAFE_COMMANDS` (both
chambers vented) and the loop stops the rig (:meth:`~cepam_gym.rig.protocol.Rig.stop`, which
also shuts off the supply). So the safe state is reached on the step the fault is seen, within one
control period. Why vented, not closed: a closed valve keeps a chamber's air, and with it the
pressure that may be the fault (over-pressure, a stuck supply valve); venting takes both chambers
to the atmosphere, where the balloon cannot burst and the muscle rests at its passive length
under the load. Each trip is recorded (:class:`Trip`) with its reason.

Limits (:class:`SafetyLimits`) come from the plant preset (:meth:`SafetyLimits.from_plant`) and a
YAML file may only tighten them (:meth:`SafetyLimits.tightened`; unknown keys are refused), edge
units with the unit in the key::

    pressure_max_c_kpa: 200      # <= the preset's limit
    pressure_max_e_kpa: 200
    length_min_cm: 15.2          # >= the preset's
    length_max_cm: 18.5          # <=
    supply_min_kpa: 150          # >=
    stale_after_s: 0.05          # <=
    frozen_after_s: 0.05         # <=
    valve_check_s: 0.1           # <=
    command_rate_per_s: 20       # <=
    leak_max_fraction: 0.05      # <=
    leak_window_s: 0.1           # <=
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from pathlib import Path

import yaml

from ..errors import InputError
from .leak import LeakMonitor
from .protocol import SAFE_COMMANDS, Reading

BURST_MARGIN = 0.9  # default pressure limit: this fraction of the burst pressure
LENGTH_MARGIN = 0.002  # m beyond each end stop before the length trips
SUPPLY_MIN_FRACTION = 0.5  # of the nominal supply
EXHAUST = -0.9  # a command at or below this asks a chamber to empty
VENTED = 20e3  # Pa: a chamber below this gauge pressure counts as emptied


@dataclass(frozen=True)
class SafetyLimits:
    """The supervisor's limits, SI (gauge pressures [Pa], lengths [m], times [s])."""

    pressure_max_c: float
    pressure_max_e: float
    length_min: float
    length_max: float
    supply_min: float
    stale_after_s: float = 0.1
    frozen_after_s: float = 0.1
    valve_check_s: float = 0.2
    command_rate_per_s: float = math.inf
    leak_max_fraction: float = 0.1
    leak_window_s: float = 0.2

    @classmethod
    def from_plant(cls, plant) -> SafetyLimits:
        """The limits of a plant (:class:`~cepam_gym.plant.params.PlantParams`): pressures at
        :data:`BURST_MARGIN` of its burst pressure, lengths :data:`LENGTH_MARGIN` beyond its end
        stops, supply at :data:`SUPPLY_MIN_FRACTION` of its nominal supply."""
        burst = BURST_MARGIN * plant.burst_pressure
        return cls(
            pressure_max_c=burst,
            pressure_max_e=burst,
            length_min=plant.min_length - LENGTH_MARGIN,
            length_max=plant.max_length + LENGTH_MARGIN,
            supply_min=SUPPLY_MIN_FRACTION * plant.supply_pressure,
        )

    def tightened(self, path: str | Path) -> SafetyLimits:
        """These limits tightened by the YAML file ``path`` (see the module docstring)."""
        path = Path(path)
        if not path.is_file():
            raise InputError(f"limits file {path} does not exist")
        try:
            data = yaml.safe_load(path.read_text()) or {}
        except yaml.YAMLError as e:
            raise InputError(f"{path}: not valid YAML: {e}") from None
        if not isinstance(data, dict):
            raise InputError(f"{path}: expected a mapping of limits, got {type(data).__name__}")
        return self.tighten(data, str(path))

    def tighten(self, values: dict, where: str = "limits") -> SafetyLimits:
        changes = {}
        for key, value in values.items():
            if key not in _KEYS:
                raise InputError(f"{where}: unknown key {key!r}; the keys are {', '.join(_KEYS)}")
            name, scale, upper = _KEYS[key]
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
                raise InputError(f"{where}: {key} must be a finite number, got {value!r}")
            v = float(value) * scale
            old = getattr(self, name)
            if (v > old) if upper else (v < old):
                raise InputError(
                    f"{where}: {key} = {value:g} loosens the preset's limit ({old / scale:g}); "
                    "a limits file may only tighten"
                )
            changes[name] = v
        out = replace(self, **changes)
        if out.length_min >= out.length_max:
            raise InputError(f"{where}: length_min_cm must be below length_max_cm")
        return out

    def describe(self) -> str:
        return ", ".join(f"{k} {getattr(self, n) / s:g}" for k, (n, s, _u) in _KEYS.items())


# file key -> (field, factor to SI, whether the field is an upper bound)
_KEYS = {
    "pressure_max_c_kpa": ("pressure_max_c", 1e3, True),
    "pressure_max_e_kpa": ("pressure_max_e", 1e3, True),
    "length_min_cm": ("length_min", 1e-2, False),
    "length_max_cm": ("length_max", 1e-2, True),
    "supply_min_kpa": ("supply_min", 1e3, False),
    "stale_after_s": ("stale_after_s", 1.0, True),
    "frozen_after_s": ("frozen_after_s", 1.0, True),
    "valve_check_s": ("valve_check_s", 1.0, True),
    "command_rate_per_s": ("command_rate_per_s", 1.0, True),
    "leak_max_fraction": ("leak_max_fraction", 1.0, True),
    "leak_window_s": ("leak_window_s", 1.0, True),
}
assert set(n for n, _s, _u in _KEYS.values()) == {f.name for f in fields(SafetyLimits)}


@dataclass(frozen=True)
class Trip:
    """Why the supervisor stopped the rig: ``reason`` (one of :data:`REASONS`), a sentence with
    the values, the host time [s] and the rig time [s] of the reading it acted on (NaN if none)."""

    reason: str
    detail: str
    host_time: float
    rig_time: float


REASONS = (
    "stale_sensor",
    "frozen_sensor",
    "supply_loss",
    "pressure_limit",
    "length_limit",
    "valve_fault",
    "leak",
    "stopped",
    "bad_command",
)


class Supervisor:
    """The checks of the module docstring over the readings of one run, at control period ``dt``;
    ``model`` (the env's :class:`~cepam_gym.envs.model.EnvModel`: its nominal plant, action mode
    and pressure set-point scale) enables the leak check."""

    def __init__(self, limits: SafetyLimits, dt: float, model=None):
        self.limits = limits
        self.dt = float(dt)
        self.leak = None
        if model is not None:
            self.leak = LeakMonitor(
                model.nominal,
                model.action_mode,
                model.setpoint_max,
                self.dt,
                limits.leak_max_fraction,
                limits.leak_window_s,
            )
        self._fresh_before = False  # whether the last step had a new reading
        self.trip: Trip | None = None
        self._last_fresh: float | None = None  # host time of the last new reading
        self._last_values: tuple | None = None
        self._same_since: float | None = None
        self._last_command = None
        self._exhaust_since: list[float | None] = [None, None]  # host time each chamber began to exhaust
        self._exhaust_from = [0.0, 0.0]  # its pressure then [Pa]
        self.clamped = 0  # steps whose command the rate limit changed

    @property
    def tripped(self) -> bool:
        return self.trip is not None

    def _check(self, reading: Reading | None, now: float) -> tuple[str, str] | None:
        lim = self.limits
        if reading is not None:
            self._last_fresh = now
            values = (reading.pressure_c, reading.pressure_e, reading.length)
            if values != self._last_values:
                self._last_values, self._same_since = values, now
        elif self._last_fresh is None:
            self._last_fresh = now  # the watchdog starts with the loop
        age = now - self._last_fresh
        if age > lim.stale_after_s:
            return (
                "stale_sensor",
                f"no reading for {age * 1e3:.0f} ms (limit {lim.stale_after_s * 1e3:.0f} ms)",
            )
        if self._same_since is not None and now - self._same_since > lim.frozen_after_s:
            return "frozen_sensor", (
                f"pressures and length unchanged for {(now - self._same_since) * 1e3:.0f} ms "
                f"(limit {lim.frozen_after_s * 1e3:.0f} ms)"
            )
        if reading is None:
            return None
        if reading.stopped:
            return "stopped", "the rig reports it is stopped"
        if reading.supply < lim.supply_min:
            return "supply_loss", f"supply {reading.supply / 1e3:.1f} kPa < {lim.supply_min / 1e3:.1f} kPa"
        for name, p, pmax in (
            ("CPAM", reading.pressure_c, lim.pressure_max_c),
            ("EPAM", reading.pressure_e, lim.pressure_max_e),
        ):
            if not p <= pmax:
                return "pressure_limit", f"{name} chamber at {p / 1e3:.1f} kPa > {pmax / 1e3:.1f} kPa"
        if not lim.length_min <= reading.length <= lim.length_max:
            return "length_limit", (
                f"length {reading.length * 100:.2f} cm outside "
                f"[{lim.length_min * 100:.2f}, {lim.length_max * 100:.2f}] cm"
            )
        if self.leak is not None:
            # the command sent last step was in force since the last reading if that was fresh too
            found = self.leak.update(reading, self._last_command, self._fresh_before)
            if found is not None:
                return found
        return self._check_exhaust(reading, now)

    def _check_exhaust(self, reading: Reading, now: float) -> tuple[str, str] | None:
        if self._last_command is None:
            return None
        for i, (name, p) in enumerate((("CPAM", reading.pressure_c), ("EPAM", reading.pressure_e))):
            if self._last_command[i] > EXHAUST:
                self._exhaust_since[i] = None
            elif self._exhaust_since[i] is None:
                self._exhaust_since[i], self._exhaust_from[i] = now, p
            elif now - self._exhaust_since[i] >= self.limits.valve_check_s:
                p0 = self._exhaust_from[i]
                if p > max(0.5 * p0, VENTED):
                    held = now - self._exhaust_since[i]
                    return "valve_fault", (
                        f"{name} chamber at {p / 1e3:.1f} kPa after {held * 1e3:.0f} ms "
                        f"of exhaust (from {p0 / 1e3:.1f} kPa): its valve does not vent"
                    )
        return None

    def filter(self, reading: Reading | None, command, now: float) -> tuple[tuple[float, float], Trip | None]:
        """The command to send this step for the policy's ``command`` (two floats), and the trip
        of this step (None if none happened now). ``now``: host time [s]."""
        if self.trip is None:
            found = self._check(reading, now)
            self._fresh_before = reading is not None
            if found is None and not all(math.isfinite(x) for x in command):
                found = "bad_command", f"the policy sent a non-finite command {tuple(command)}"
            if found is not None:
                rig_time = reading.time if reading is not None else math.nan
                self.trip = Trip(found[0], found[1], now, rig_time)
                self._last_command = SAFE_COMMANDS
                return SAFE_COMMANDS, self.trip
        if self.trip is not None:
            return SAFE_COMMANDS, None
        c = [float(min(1.0, max(-1.0, x))) for x in command]
        if math.isfinite(self.limits.command_rate_per_s) and self._last_command is not None:
            step = self.limits.command_rate_per_s * self.dt
            limited = [min(p + step, max(p - step, x)) for x, p in zip(c, self._last_command)]
            self.clamped += limited != c
            c = limited
        self._last_command = (c[0], c[1])
        return self._last_command, None
