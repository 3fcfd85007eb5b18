"""``identify``'s self-check: a rig whose dynamics lie outside every preset, simulated with sensor
errors and noise, identified, and compared with the truth.

The truth moves every default-free dynamic parameter of the mode away from the preset by 20-80 %
(and gives the end a Coulomb friction and the chambers a leak 10 times the presets'), and its
sensors are late, scaled and offset. A fitting log and a different held-out log (another seed of
:func:`.excite.schedule`) are simulated on it; :func:`run` returns the identification and the truth.
"""

from __future__ import annotations

from pathlib import Path

from ..plant.params import PlantParams, preset
from .dynamic_params import ALL_PARAMS, DEFAULT_FREE
from .excite import schedule, simulate_log
from .logs import write_log
from .run import Identification, identify, model_plant

# factor on the preset's value (edge units); a value the presets leave at 0 gets an absolute one
TRUTH_FACTORS = {
    "valve_conductance": 0.8,
    "valve_critical_ratio": 1.3,
    "onoff_conductance": 0.8,
    "spool_time_constant": 1.4,
    "onoff_switch_time": 1.5,
    "onoff_open_delay": 1.3,
    "onoff_close_delay": 1.5,
    "regulator_gain": 0.7,
    "dead_volume_cpam": 1.35,
    "dead_volume_epam": 0.75,
    "heat_transfer_coefficient": 1.8,
    "friction_coefficient": 1.4,
    "friction_presliding": 1.4,
    "damping": 1.5,
}
TRUTH_ABSOLUTE = {"coulomb_friction": 0.05, "leak_conductance": 0.001}
# sensors: delay [s], gain, bias [Pa, Pa, m]
TRUTH_SENSORS = {
    "delay_s": (0.002, 0.002, 0.006),
    "gain": (1.02, 0.97, 1.003),
    "bias": (1500.0, -1000.0, 3e-4),
}


def truth_plant(base: PlantParams, mode: str) -> tuple[PlantParams, dict[str, float]]:
    """The truth plant and its free parameters' values (edge units)."""
    p = base
    values = {}
    for n in DEFAULT_FREE[mode]:
        fp = ALL_PARAMS[n]
        v = TRUTH_ABSOLUTE.get(n, fp.get(base) * TRUTH_FACTORS.get(n, 1.0))
        p = p.replace(**fp.set(p, v))
        values[n] = v
    return p, values


def simulate_pair(
    out_dir: str | Path,
    base: str = "balloon",
    mode: str = "valve",
    fit_s: float = 60.0,
    holdout_s: float = 20.0,
    rate_hz: float = 500.0,
    seed: int = 0,
) -> tuple[Path, Path, dict[str, float]]:
    """Write a fitting log and a held-out log of the truth plant; their paths and the truth."""
    truth, values = truth_plant(model_plant(preset(base), mode), mode)
    out = Path(out_dir)
    paths = []
    for name, seconds, s in (("fit", fit_s, seed), ("holdout", holdout_s, seed + 1)):
        log = simulate_log(schedule(seconds, rate_hz, mode, seed=s), truth, mode, seed=s, **TRUTH_SENSORS)
        paths.append(write_log(out / f"selfcheck_{name}.csv", log))
    return paths[0], paths[1], values


def run(out_dir: str | Path, base: str = "balloon", mode: str = "valve", **kw) -> tuple[Identification, dict]:
    fit_s, holdout_s = kw.pop("fit_s", 60.0), kw.pop("holdout_s", 20.0)
    fit_log, held_log, values = simulate_pair(out_dir, base, mode, fit_s, holdout_s, kw.pop("rate_hz", 500.0))
    return identify([fit_log], base, mode, holdout=[held_log], **kw), values
