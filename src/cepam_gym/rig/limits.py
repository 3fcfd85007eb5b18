"""The safety supervisor's limits: from the plant preset (:meth:`SafetyLimits.from_plant`), and a
YAML file may only tighten them (:meth:`SafetyLimits.tightened`; unknown keys are refused), edge
units with the unit in the key::

    pressure_max_c_kpa: 200      # <= the preset's limit
    pressure_max_e_kpa: 200
    pressure_min_c_kpa: -10      # >= the floor (-20 kPa): below it a sensor fails low
    pressure_min_e_kpa: -10
    length_min_cm: 15.2          # >= the preset's
    length_max_cm: 18.5          # <=
    supply_min_kpa: 150          # >=
    supply_max_kpa: 280          # <=
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

BURST_MARGIN = 0.9  # default pressure limit: this fraction of the burst pressure
LENGTH_MARGIN = 0.002  # m beyond each end stop before the length trips
SUPPLY_MIN_FRACTION = 0.5  # of the nominal supply
# of the nominal supply: a regulator set above its range (a supply above it would let a valve stuck
# open push a chamber past its limit before any other check could see it)
SUPPLY_MAX_FRACTION = 1.2
# Pa gauge: a chamber that vents to the atmosphere cannot read much below it (the annulus, closed
# while the muscle extends, dips a few kPa); lower is a sensor failing low
PRESSURE_FLOOR = -20e3


@dataclass(frozen=True)
class SafetyLimits:
    """The supervisor's limits, SI (gauge pressures [Pa], lengths [m], times [s])."""

    pressure_max_c: float
    pressure_max_e: float
    length_min: float
    length_max: float
    supply_min: float
    supply_max: float = math.inf
    pressure_min_c: float = PRESSURE_FLOOR
    pressure_min_e: float = PRESSURE_FLOOR
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
        stops, supply within :data:`SUPPLY_MIN_FRACTION` and :data:`SUPPLY_MAX_FRACTION` of its nominal
        supply, chambers above :data:`PRESSURE_FLOOR`."""
        burst = BURST_MARGIN * plant.burst_pressure
        return cls(
            pressure_max_c=burst,
            pressure_max_e=burst,
            length_min=plant.min_length - LENGTH_MARGIN,
            length_max=plant.max_length + LENGTH_MARGIN,
            supply_min=SUPPLY_MIN_FRACTION * plant.supply_pressure,
            supply_max=SUPPLY_MAX_FRACTION * plant.supply_pressure,
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
        for low, high in (("length_min", "length_max"), ("supply_min", "supply_max")):
            if getattr(out, low) >= getattr(out, high):
                raise InputError(f"{where}: {low} must be below {high}")
        for side in ("c", "e"):
            if getattr(out, f"pressure_min_{side}") >= getattr(out, f"pressure_max_{side}"):
                raise InputError(f"{where}: pressure_min_{side}_kpa must be below pressure_max_{side}_kpa")
        return out

    def describe(self) -> str:
        return ", ".join(f"{k} {getattr(self, n) / s:g}" for k, (n, s, _u) in _KEYS.items())


# file key -> (field, factor to SI, whether the field is an upper bound)
_KEYS = {
    "pressure_max_c_kpa": ("pressure_max_c", 1e3, True),
    "pressure_max_e_kpa": ("pressure_max_e", 1e3, True),
    "length_min_cm": ("length_min", 1e-2, False),
    "length_max_cm": ("length_max", 1e-2, True),
    "pressure_min_c_kpa": ("pressure_min_c", 1e3, False),
    "pressure_min_e_kpa": ("pressure_min_e", 1e3, False),
    "supply_min_kpa": ("supply_min", 1e3, False),
    "supply_max_kpa": ("supply_max", 1e3, True),
    "stale_after_s": ("stale_after_s", 1.0, True),
    "frozen_after_s": ("frozen_after_s", 1.0, True),
    "valve_check_s": ("valve_check_s", 1.0, True),
    "command_rate_per_s": ("command_rate_per_s", 1.0, True),
    "leak_max_fraction": ("leak_max_fraction", 1.0, True),
    "leak_window_s": ("leak_window_s", 1.0, True),
}
assert set(n for n, _s, _u in _KEYS.values()) == {f.name for f in fields(SafetyLimits)}
