"""The dynamic parameters ``identify`` fits, their physical bounds, and the sensor parameters.

Each entry is a :class:`~cepam_gym.validation.fitcore.FitParam` of one PlantParams field in its
edge unit. Quantities that span decades between their bounds (conductances, volumes, time
constants, heat transfer) are scaled logarithmically so that a fit moves them by ratios. The
statics (:data:`cepam_gym.validation.static_params.FIT_PARAMS`) stay frozen unless ``--free``
names them.

The sensors: a rig's transducers report each channel late, scaled and offset,
``gain * y(t - delay) + bias`` (:func:`.simulate.sensed`); those nine numbers are fitted with the
physics (the PlantParams do not carry them: they describe the rig's instruments, not the muscle).
"""

from __future__ import annotations

from ..plant import MODES
from ..validation.fitcore import FitParam, field_param
from ..validation.static_params import FIT_PARAMS as STATIC_PARAMS

DYNAMIC_PARAMS: dict[str, FitParam] = {
    fp.name: fp
    for fp in (
        field_param(
            "valve_conductance",
            0.005,
            1.0,
            "ISO 6358 sonic conductance of the proportional valves, fully open: the slope of a "
            "pressure ramp under a full command (miniature valves 0.01-0.5 dm3/(s bar))",
            log=True,
        ),
        field_param(
            "spool_time_constant",
            0.3,
            100.0,
            "spool lag: how late and how rounded a pressure ramp starts after a command step",
            log=True,
        ),
        field_param(
            "valve_critical_ratio",
            0.05,
            0.6,
            "ISO 6358 b: how the flow falls as a chamber nears the supply or the atmosphere",
        ),
        field_param("spool_damping", 0.1, 2.0, "damping ratio of a second-order spool (spool_order 2)"),
        field_param(
            "onoff_conductance", 0.005, 1.0, "sonic conductance of the on/off solenoid valves", log=True
        ),
        field_param("onoff_switch_time", 0.3, 30.0, "on/off valve switching lag", log=True),
        # dead times of solenoid valves are a few ms; beyond half the 20 ms PWM period a shift of
        # both edges aliases with the period (the fit finds such false minima)
        field_param("onoff_open_delay", 0.0, 10.0, "dead time from a PWM rising edge to the valve opening"),
        field_param("onoff_close_delay", 0.0, 10.0, "dead time from a PWM falling edge to the valve closing"),
        field_param(
            "regulator_gain",
            0.001,
            1.0,
            "set-point mode: spool opening per kPa of error, how stiffly a set-point is held",
            log=True,
        ),
        field_param(
            "dead_volume_cpam",
            0.1,
            50.0,
            "port and tubing volume of the CPAM chamber: slows its pressure and softens its air spring",
            log=True,
        ),
        field_param(
            "dead_volume_epam",
            0.1,
            50.0,
            "port and tubing volume of the annulus: the same for the EPAM side",
            log=True,
        ),
        field_param(
            "heat_transfer_coefficient",
            0.5,
            500.0,
            "wall heat transfer: how fast a pressure overshoot after filling relaxes as the air cools",
            log=True,
        ),
        field_param(
            "friction_coefficient",
            0.0,
            0.05,
            "braid-bladder dry friction per kPa: the hysteresis and the stick of the length",
        ),
        field_param(
            "friction_presliding",
            0.02,
            5.0,
            "presliding displacement: how far the length creeps before the friction breaks away",
            log=True,
        ),
        field_param("damping", 0.0, 200.0, "viscous damping of the free end: the ringing of the length"),
        field_param("coulomb_friction", 0.0, 2.0, "pressure-independent friction of the end in its guide"),
        field_param("leak_conductance", 0.0, 0.01, "leak of each chamber: pressure decay with valves shut"),
        field_param("supply_pressure", 50.0, 800.0, "supply (gauge): the pressure a full fill reaches"),
    )
}

_SHARED = (
    "dead_volume_cpam",
    "dead_volume_epam",
    "heat_transfer_coefficient",
    "friction_coefficient",
    "friction_presliding",
    "damping",
    "coulomb_friction",
    "leak_conductance",
)
# a real valve's critical ratio is as unknown as its conductance; left frozen, a wrong one leaves
# the fit at 10-14 % NRMSE with nothing identifiable (docs/identify.md, "Measured")
DEFAULT_FREE: dict[str, tuple[str, ...]] = {
    "valve": ("valve_conductance", "valve_critical_ratio", "spool_time_constant", *_SHARED),
    "pwm": ("onoff_conductance", "onoff_switch_time", "onoff_open_delay", "onoff_close_delay", *_SHARED),
    "pressure": (
        "regulator_gain",
        "valve_conductance",
        "valve_critical_ratio",
        "spool_time_constant",
        *_SHARED,
    ),
}
assert set(DEFAULT_FREE) == set(MODES)

# every name --free accepts: the dynamic table, then the statics calibrate fits (end_mass among them)
ALL_PARAMS: dict[str, FitParam] = {**STATIC_PARAMS, **DYNAMIC_PARAMS}

# the sensors, per channel: name stem, unit of the bias, bias bound
SENSOR_CHANNELS = (("pressure_c", "kpa", 20.0), ("pressure_e", "kpa", 20.0), ("length", "cm", 2.0))


def _sensor(name: str, unit: str, lo: float, hi: float, why: str) -> FitParam:
    # not a PlantParams field: no getter or setter, writes nothing
    return FitParam(name, unit, lo, hi, why, lambda p: 0.0, lambda p, v: {}, ())


SENSOR_PARAMS: dict[str, FitParam] = {
    fp.name: fp
    for ch, unit, b in SENSOR_CHANNELS
    for fp in (
        _sensor(f"{ch}_delay", "ms", 0.0, 50.0, f"how late the {ch} sensor (and its filter) reports"),
        _sensor(f"{ch}_gain", "", 0.8, 1.25, f"scale error of the {ch} sensor"),
        _sensor(f"{ch}_bias", unit, -b, b, f"offset of the {ch} sensor"),
    )
}
SENSOR_NEUTRAL = {
    f"{ch}_{k}": (1.0 if k == "gain" else 0.0)
    for ch, _, _ in SENSOR_CHANNELS
    for k in ("delay", "gain", "bias")
}
