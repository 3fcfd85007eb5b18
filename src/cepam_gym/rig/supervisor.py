"""The safety supervisor: below the policy, every command goes through it and it cannot be bypassed.

Each control step the deploy loop hands it the newest reading (or None) and the command the policy
wants; it returns the command to send. Every reading is judged; a reading that cannot be judged is
a trip. Checks, in this order (the trip's reason in brackets):

* **stale sensor** [``stale_sensor``]: no new reading for ``stale_after_s`` (packets lost, a
  cable, a dead rig);
* **restart** [``rig_restarted``]: the rig's packet numbers began again or its clock ran backwards
  (a reboot: whatever it was doing, it is no longer the run the controller started);
* **stopped** [``stopped``]: the rig says it is in its safe state (its own emergency stop, or its
  watchdog: its flag says which);
* **non-finite** [``nonfinite_reading``]: any channel or the rig's time NaN or infinite;
* **supply** [``supply_loss``, ``supply_high``]: the supply's gauge pressure below ``supply_min``,
  or above ``supply_max`` (above its regulator's range);
* **pressure** [``pressure_limit``, ``pressure_floor``]: a chamber's gauge pressure above its
  limit (the balloon's burst pressure with a margin) or below its floor (a chamber vented to the
  atmosphere cannot read much below it: a sensor failing low);
* **length** [``length_limit``]: the length outside ``[length_min, length_max]`` (the end stops
  with a margin: beyond them the sensor or the mechanism has failed);
* **frozen sensor** [``frozen_sensor``]: readings keep coming but one channel (either pressure,
  the length or the supply) is bit-identical for ``frozen_after_s`` (a hung ADC, a dead channel;
  a real sensor's noise always moves its last bit);
* **leak** [``leak``, ``valve_fault``]: a chamber loses air the valves do not explain, judged by an
  energy balance of its air on the plant's model over ``leak_window_s``
  (:mod:`cepam_gym.rig.leak`): a leak larger than ``leak_max_fraction`` of the valve's
  conductance trips, also one a controller compensates by holding its supply valve open (needs
  the env's model: ``Supervisor(..., model=...)``); the same balance calls a valve faulty when a
  chamber gains air its valve was not told to let in (a valve stuck open to the supply);
* **valve fault** [``valve_fault``]: a chamber commanded to exhaust (command <= -0.9) for
  ``valve_check_s`` still holds more than half its pressure and more than :data:`VENTED` (a valve
  stuck open to the supply, a blocked exhaust);
* **fill fault** [``fill_fault``]: a chamber commanded to fill (command >= :data:`FILL`) for
  ``valve_check_s`` from a supply above ``supply_min`` still reads below :data:`VENTED` (its
  sensor failing low while the chamber fills, or a valve that does not open);
* **bad command** [``bad_command``]: the policy's command is not finite;
* **command rate**: each command moves at most ``command_rate_per_s`` per second (a clamp, not a
  trip; unlimited by default, as the envs train).

The leak balance is the only check built on the plant's model; the others need only the limits
(model-free: what ``excite --rig`` runs on a rig whose model is not known yet).

A trip is latched: from the step it happens on, the command is :data:`SAFE_COMMANDS` (both
chambers vented) and the loop stops the rig (:meth:`~cepam_gym.rig.protocol.Rig.stop`, which
also shuts off the supply). So the safe state is asked for on the step the fault is seen. Why
vented, not closed: a closed valve keeps a chamber's air, and with it the pressure that may be the
fault (over-pressure, a stuck supply valve); venting takes both chambers to the atmosphere, where
the balloon cannot burst and the muscle rests at its passive length under the load. Each trip is
recorded (:class:`Trip`) with its reason.

The limits are :class:`~cepam_gym.rig.limits.SafetyLimits` (from the plant preset; a YAML file may
only tighten them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .leak import LeakMonitor
from .limits import SafetyLimits
from .protocol import SAFE_COMMANDS, Reading, seq_newer

__all__ = ["REASONS", "SafetyLimits", "Supervisor", "Trip"]

EXHAUST = -0.9  # a command at or below this asks a chamber to empty
FILL = 0.5  # a command at or above this asks a chamber to fill
VENTED = 20e3  # Pa: a chamber below this gauge pressure counts as emptied
CHANNEL_NAMES = ("CPAM pressure", "EPAM pressure", "length", "supply")


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
    "rig_restarted",
    "stopped",
    "nonfinite_reading",
    "supply_loss",
    "supply_high",
    "pressure_limit",
    "pressure_floor",
    "length_limit",
    "frozen_sensor",
    "leak",
    "valve_fault",
    "fill_fault",
    "bad_command",
)


class Supervisor:
    """The checks of the module docstring over the readings of one run, at control period ``dt``;
    ``model`` (the env's :class:`~cepam_gym.envs.model.EnvModel`: its nominal plant, action mode
    and pressure set-point scale) enables the leak check (the only one built on the model)."""

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
        self._last_reading: Reading | None = None
        self._same_since: list[float | None] = [None] * len(CHANNEL_NAMES)  # each channel's last change
        self._last_command = None
        # host time each chamber began to exhaust (index 0, 1) or to fill (2, 3), and its pressure then
        self._since: list[float | None] = [None] * 4
        self._from = [0.0] * 4
        self.clamped = 0  # steps whose command the rate limit changed

    @property
    def tripped(self) -> bool:
        return self.trip is not None

    def _check(self, reading: Reading | None, now: float) -> tuple[str, str] | None:
        lim = self.limits
        if reading is not None:
            self._last_fresh = now
        elif self._last_fresh is None:
            self._last_fresh = now  # the watchdog starts with the loop
        age = now - self._last_fresh
        if age > lim.stale_after_s:
            return (
                "stale_sensor",
                f"no reading for {age * 1e3:.0f} ms (limit {lim.stale_after_s * 1e3:.0f} ms)",
            )
        if reading is None:
            return None
        last, self._last_reading = self._last_reading, reading
        found = self._check_link(reading, last) or self._check_ranges(reading)
        found = found or self._check_frozen(reading, last, now)
        if found is None and self.leak is not None:
            # the command sent last step was in force since the last reading if that was fresh too
            found = self.leak.update(reading, self._last_command, self._fresh_before)
        return found or self._check_valves(reading, now)

    def _check_link(self, reading: Reading, last: Reading | None) -> tuple[str, str] | None:
        went_back = reading.seq != last.seq and not seq_newer(reading.seq, last.seq) if last else False
        if last is not None and (went_back or reading.time < last.time):
            return "rig_restarted", (
                f"the rig's packet numbers began again ({last.seq} then {reading.seq}) or its clock "
                f"ran back ({last.time:.3f} s then {reading.time:.3f} s): it restarted"
            )
        if reading.stopped:
            if reading.by_watchdog:
                return "stopped", "the rig's watchdog stopped it: no command reached it in time"
            return "stopped", "the rig reports it is stopped"
        bad = [
            n
            for n, v in zip(("time", *CHANNEL_NAMES), (reading.time, *reading.channels()))
            if not math.isfinite(v)
        ]
        if bad:
            values = dict(zip(("time", *CHANNEL_NAMES), (reading.time, *reading.channels())))
            return "nonfinite_reading", "the rig sent " + ", ".join(f"{n} = {values[n]}" for n in bad)
        return None

    def _check_ranges(self, reading: Reading) -> tuple[str, str] | None:
        lim = self.limits
        if reading.supply < lim.supply_min:
            return "supply_loss", f"supply {reading.supply / 1e3:.1f} kPa < {lim.supply_min / 1e3:.1f} kPa"
        if reading.supply > lim.supply_max:
            return "supply_high", (
                f"supply {reading.supply / 1e3:.1f} kPa > {lim.supply_max / 1e3:.1f} kPa, above its "
                "regulator's range"
            )
        for name, p, pmin, pmax in (
            ("CPAM", reading.pressure_c, lim.pressure_min_c, lim.pressure_max_c),
            ("EPAM", reading.pressure_e, lim.pressure_min_e, lim.pressure_max_e),
        ):
            if p > pmax:
                return "pressure_limit", f"{name} chamber at {p / 1e3:.1f} kPa > {pmax / 1e3:.1f} kPa"
            if p < pmin:
                return "pressure_floor", (
                    f"{name} chamber reads {p / 1e3:.1f} kPa < {pmin / 1e3:.1f} kPa, below what a vented "
                    "chamber can read: its sensor fails low"
                )
        if not lim.length_min <= reading.length <= lim.length_max:
            return "length_limit", (
                f"length {reading.length * 100:.2f} cm outside "
                f"[{lim.length_min * 100:.2f}, {lim.length_max * 100:.2f}] cm"
            )
        return None

    def _check_frozen(self, reading: Reading, last: Reading | None, now: float) -> tuple[str, str] | None:
        frozen = []
        for i, v in enumerate(reading.channels()):
            if last is None or v != last.channels()[i] or self._same_since[i] is None:
                self._same_since[i] = now
            elif now - self._same_since[i] > self.limits.frozen_after_s:
                frozen.append(
                    f"{CHANNEL_NAMES[i]} at {v:g} unchanged for {(now - self._same_since[i]) * 1e3:.0f} ms"
                )
        if frozen:
            return "frozen_sensor", "; ".join(frozen) + f" (limit {self.limits.frozen_after_s * 1e3:.0f} ms)"
        return None

    def _check_valves(self, reading: Reading, now: float) -> tuple[str, str] | None:
        """A chamber told to exhaust that does not empty, or told to fill that reads empty."""
        if self._last_command is None:
            return None
        check_s = self.limits.valve_check_s
        for i, (name, p) in enumerate((("CPAM", reading.pressure_c), ("EPAM", reading.pressure_e))):
            for j, asked in ((i, self._last_command[i] <= EXHAUST), (i + 2, self._last_command[i] >= FILL)):
                if not asked:
                    self._since[j] = None
                elif self._since[j] is None:
                    self._since[j], self._from[j] = now, p
            held = [None if s is None else now - s for s in (self._since[i], self._since[i + 2])]
            p0 = self._from[i]
            if held[0] is not None and held[0] >= check_s and p > max(0.5 * p0, VENTED):
                return "valve_fault", (
                    f"{name} chamber at {p / 1e3:.1f} kPa after {held[0] * 1e3:.0f} ms "
                    f"of exhaust (from {p0 / 1e3:.1f} kPa): its valve does not vent"
                )
            if (
                held[1] is not None
                and held[1] >= check_s
                and p < VENTED
                and reading.supply >= self.limits.supply_min
            ):
                return "fill_fault", (
                    f"{name} chamber reads {p / 1e3:.1f} kPa after {held[1] * 1e3:.0f} ms of its valve told "
                    f"to fill it (command >= {FILL:g}) from a {reading.supply / 1e3:.0f} kPa supply: its "
                    "sensor reads low or its valve does not open"
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
