"""Plant parameters: a frozen dataclass in SI units, presets, YAML loading with unit-named keys.

Every field is SI (m, Pa, kg, s, K). In YAML each key carries the unit it is written in
(``supply_kpa: 300``), converted by :mod:`cepam_gym.units`; unknown keys and wrong units are
rejected with the key's name. Pressures called ``*_kpa`` are gauge; ``*_kpa_abs`` absolute.

The defaults are plant v1 (docs/physics.md, "Plant v1"): tension-only braids and a neo-Hookean
wall per bladder. Values marked ``calibrate=True`` are not reported by the paper; their defaults
are one bounded least-squares fit of every computable reported number (CE-PAM, single CPAM and
EPAM, the tube-thickness rows; ``cepam-gym calibrate --v1``, docs/calibration.md, "Plant v1"). The
v0 plant (braids that also push, one linear spring, fitted to the 13 CE-PAM numbers) is the preset
``balloon_v0``; the pre-calibration guesses on it are ``balloon_uncalibrated``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from .. import units
from ..errors import InputError
from ..physics.muscle import braid_from_rest
from .param_checks import (  # noqa: F401  (the model choices' public names)
    BLADDER_MODELS,
    BRAID_TENSIONS,
    FORCE_FORMS,
    FORCE_MODELS,
    FRICTION_LAWS,
    PWM_TIMINGS,
    validate,
)
from .param_row import fill_derived, param_row, pressure_cap_of  # noqa: F401  (the row's public names)
from .params_yaml import changes_of


def _f(default, unit: str, doc: str, calibrate: bool = False):
    return field(default=default, metadata={"unit": unit, "doc": doc, "calibrate": calibrate})


@dataclass(frozen=True)
class PlantParams:
    """Physical parameters of one CE-PAM rig (SI units). Defaults: the paper's balloon CE-PAM,
    its unreported values calibrated to the paper's CE-PAM numbers (docs/calibration.md)."""

    # --- muscle geometry (paper sections II, III, V; docs/model.md section 1) ---
    cpam_rest_length: float = _f(0.195, "cm", "CPAM length unpressurised (section II)")
    cpam_rest_diameter: float = _f(0.005, "mm", "CPAM braid diameter at rest (section II)")
    cpam_rest_angle: float = _f(
        math.radians(20.3),
        "deg",
        "CPAM braid angle at rest (only '< 54.7 deg' reported); fitted to every reported number "
        "(plant v1, docs/calibration.md); on its lower bound, which keeps the CPAM within twice its "
        "5 mm over the stroke",
        calibrate=True,
    )
    epam_sleeve_free_length: float = _f(0.30, "cm", "EPAM sleeve length before compression (section III)")
    epam_sleeve_free_diameter: float = _f(0.010, "mm", "EPAM sleeve diameter before compression")
    epam_sleeve_free_angle: float = _f(
        math.radians(33.18),
        "deg",
        "EPAM free-sleeve braid angle (not reported); fitted like the CPAM's (+/- 3.2 deg; >= 26.6 deg "
        "keeps the sleeve within twice its 10 mm). Unequal angles: the paper's relations Eq. 6-7 "
        "then hold only approximately",
        calibrate=True,
    )
    cpam_bladder_diameter: float = _f(0.005, "mm", "D_oc of Eq. 32")
    epam_bladder_diameter: float = _f(0.010, "mm", "D_oe of Eq. 28")
    bladder_thickness: float = _f(
        0.0001043,
        "mm",
        "t_b of Eq. 35 (balloon: < 1 mm) and the wall of the strain energy; fitted (+/- 0.03 mm)",
        calibrate=True,
    )
    sleeve_thickness: float = _f(
        0.00005, "mm", "t_s of Eq. 35 (not reported); fitted, on its 0.05 mm lower bound", calibrate=True
    )
    kr_high: float = _f(2.0e6, "kpa_per_m", "K_r for D sin(theta) < D_o/2 (Eq. 27)")
    kr_low: float = _f(5.0e5, "kpa_per_m", "K_r for D sin(theta) > D_o/2 (Eq. 27)")
    paper_length_ratio: float = _f(1.3, "", "the 1.3 of Eq. 5 that the paper form carries into Eq. 22")
    force_model: str = _f("enhanced", "", "basic (Eq. 25) | radial (Eq. 30-33) | enhanced (Eq. 41, 45)")
    force_form: str = _f("virtual_work", "", "virtual_work (energy-consistent) | paper (Eq. 22, 15)")
    min_length: float = _f(0.15, "cm", "lower end stop: the CE-PAM's nominal length (section VIII)")
    max_length: float = _f(0.195, "cm", "upper end stop: the CPAM's rest length (section V)")
    elastic_stiffness: float = _f(
        0.0,
        "n_per_m",
        "v0 bladder spring (not in the paper; bladder_model = "
        "spring only; v0 fitted 166 N/m, preset balloon_v0)",
        calibrate=True,
    )
    elastic_rest_length: float = _f(0.15, "cm", "rest length of that elasticity")
    # --- plant v1 statics (docs/physics.md, "Plant v1"); preset balloon_v0 sets them to v0 ---
    braid_tension: str = _f(
        "tension_only",
        "",
        "bidirectional (v0: the CPAM braid also pushes) | tension_only (v1: a slack braid adds no force)",
    )
    slack_width: float = _f(
        1e3, "kpa", "tension_only: pressure width of the CPAM braid's smooth slack switch"
    )
    bladder_model: str = _f(
        "neo_hookean",
        "",
        "spring (v0: elastic_stiffness) | neo_hookean (v1: strain "
        "energy of each bladder wall, Klute and Hannaford 2000)",
    )
    bladder_shear_modulus: float = _f(
        1000e3,
        "kpa",
        "neo_hookean: shear modulus mu of the bladder rubber (wall thickness: bladder_thickness)",
        calibrate=True,
    )
    epam_bladder_length: float = _f(0.15, "cm", "EPAM bladder length, its stress-free length (section III)")
    tube_shear_modulus: float = _f(
        426.9e3,
        "kpa",
        "neo_hookean: shear modulus of the rubber-tube bladders of "
        "sections II, III, X (the reproduction's tube rows; preset rubber_tube)",
        calibrate=True,
    )
    # --- air supply, valves, chambers (docs/model.md section 4) ---
    supply_pressure: float = _f(
        250e3, "kpa", "supply pressure (gauge): the highest the paper used on the balloon"
    )
    atmospheric_pressure: float = _f(units.P_ATM, "kpa_abs", "atmosphere (absolute)")
    supply_temperature: float = _f(293.15, "k", "supply air temperature")
    ambient_temperature: float = _f(293.15, "k", "ambient and wall temperature")
    valve_conductance: float = _f(1e-9, "dm3_per_s_bar", "proportional valve sonic conductance C, fully open")
    valve_critical_ratio: float = _f(0.3, "", "ISO 6358 critical pressure ratio b")
    laminar_ratio: float = _f(0.995, "", "pressure ratio above which the valve flow is linearised")
    leak_conductance: float = _f(1e-12, "dm3_per_s_bar", "leakage of each chamber to atmosphere")
    spool_time_constant: float = _f(0.005, "ms", "proportional spool time constant (about 30 Hz)")
    spool_order: int = _f(1, "", "spool dynamics: 1 (first order) or 2 (second order)")
    spool_damping: float = _f(0.7, "", "spool damping ratio when spool_order = 2")
    onoff_conductance: float = _f(1e-9, "dm3_per_s_bar", "on/off solenoid valve sonic conductance")
    onoff_switch_time: float = _f(0.003, "ms", "on/off valve switching lag")
    friction_coefficient: float = _f(
        2e-6,
        "n_per_kpa",
        "v1: braid-bladder dry friction, break-away force per kPa of Pc+ + Pe+ "
        "(Maxwell-slip, Tondu and Lopez 2000; assumed, not identified); 0 = v0",
    )
    friction_presliding: float = _f(
        0.0005,
        "mm",
        "v1: presliding displacement of the slowest Maxwell-slip element (the others: 0.1 and 0.4 of it)",
    )
    friction_law: str = _f(
        "pressure_sum",
        "",
        "pressure_sum (v1: friction_coefficient times Pc+ + Pe+) | contact_area (v2: friction_mu times "
        "each chamber's pressure times its braid's inner surface pi D L at mid-stroke, Tondu and Lopez 2000)",
    )
    friction_mu: float = _f(
        0.0,
        "",
        "v2 (friction_law contact_area): effective braid-bladder friction coefficient, identified by "
        "the hanging-weight protocols (docs/calibration.md, 'Plant v2')",
        calibrate=True,
    )
    collapse_seal_diameter: float = _f(
        0.0,
        "mm",
        "v2: diameter of the CPAM's seal on the end cap: while the CPAM is slack (buckled, or collapsed "
        "when Pe > Pc) it carries no axial load and (Pc - Pe) acts on this area; at most the CPAM "
        "bladder's 5 mm. 0 = v1",
        calibrate=True,
    )
    epam_thread_compliance: float = _f(
        0.0,
        "per_kn",
        "v2: extensible EPAM braid (Chambers and Wereley 2022): strain of its threads per kN of their total "
        "tension, the tension being the ideal braid's P_ae b L / (2 pi n^2) (Eq. 14's braid); "
        "0 = inextensible",
        calibrate=True,
    )
    cpam_thread_compliance: float = _f(
        0.0,
        "per_kn",
        "v2: extensible CPAM braid, as epam_thread_compliance, loaded by its net active pressure "
        "P_ac - P_ae while that is positive (a squeezed braid is slack); 0 = inextensible",
        calibrate=True,
    )
    onoff_open_delay: float = _f(
        0.004,
        "ms",
        "v1: on/off valve dead time from the command's rising edge to opening (solenoid pull-in); 0 = v0",
    )
    onoff_close_delay: float = _f(
        0.002,
        "ms",
        "v1: dead time from the falling edge to closing; a pulse "
        "shorter than open - close delay passes no air. 0 = v0",
    )
    pwm_frequency: float = _f(50.0, "hz", "PWM frequency of the on/off valves")
    pwm_timing: str = _f(
        "substep",
        "",
        "substep (every released preset: the PWM phase and the dead times are read once per sub-step, "
        "so a pulse lasts whole sub-steps) | exact (each sub-step integrates the spool through the "
        "edges that fall inside it: duty and dead times act continuously; docs/physics.md, 'PWM timing')",
    )
    dead_volume_cpam: float = _f(2e-6, "cm3", "port and tubing volume of the CPAM chamber")
    dead_volume_epam: float = _f(2e-6, "cm3", "port and tubing volume of the annulus")
    heat_transfer: float = _f(
        0.02, "w_per_k", "v0: wall heat transfer hA of each chamber (used when heat_transfer_coefficient = 0)"
    )
    heat_transfer_coefficient: float = _f(
        10.0,
        "w_per_m2_k",
        "v1: wall heat transfer coefficient h; each chamber's hA is h times its wall "
        "area at mid-stroke (CPAM: its bladder; annulus: the EPAM bladder and the CPAM's outside). 0 = v0",
    )
    burst_pressure: float = _f(300e3, "kpa", "balloon burst pressure (gauge), about 250-300 kPa")
    polytropic_exponent: float = _f(1.4, "", "exponent of the closed-chamber stiffness (1.4 adiabatic)")
    regulator_gain: float = _f(
        1.0 / 20e3, "per_kpa", "set-point mode: spool opening per kPa of pressure error"
    )
    # --- load mechanics ---
    end_mass: float = _f(0.02, "g", "moving mass of the free end cap")
    damping: float = _f(5.0, "ns_per_m", "viscous damping of the free end")
    coulomb_friction: float = _f(0.0, "n", "Coulomb friction of the free end in its guide tube")
    gravity: float = _f(9.81, "m_per_s2", "gravitational acceleration (down extends the muscle)")

    def __post_init__(self):
        self.validate()

    # ------------------------------------------------------------------ checks
    def validate(self) -> None:
        """Raise ``ValueError`` naming the parameter if the set is impossible
        (:func:`~cepam_gym.plant.param_checks.validate`)."""
        validate(self)

    # --------------------------------------------------------------- derived
    # the braid inversion is physics.muscle.braid_from_rest, run as Python here (``py_func``: the
    # parameters are built once per plant, not in a compiled loop)
    def cpam_braid(self) -> tuple[float, float]:
        """Thread length b_c [m] and turns n_c of the CPAM (Eq. 8-9 at rest)."""
        return braid_from_rest.py_func(self.cpam_rest_length, self.cpam_rest_diameter, self.cpam_rest_angle)

    def epam_braid(self) -> tuple[float, float]:
        """Thread length b_e [m] and turns n_e of the EPAM sleeve (Eq. 11-12, free sleeve)."""
        return braid_from_rest.py_func(
            self.epam_sleeve_free_length, self.epam_sleeve_free_diameter, self.epam_sleeve_free_angle
        )

    @property
    def pressure_cap(self) -> float:
        """The highest gauge pressure [Pa] a chamber may be asked for: ``min(supply, burst)``."""
        return min(self.supply_pressure, self.burst_pressure)

    def wall_thickness(self) -> float:
        """t_a = t_s + t_b (Eq. 35) when the enhanced model is selected, else 0."""
        return self.sleeve_thickness + self.bladder_thickness if self.force_model == "enhanced" else 0.0

    def to_array(self) -> np.ndarray:
        """The flat float64 parameter row the compiled kernels read (layout in physics.layout;
        :func:`~cepam_gym.plant.param_row.param_row`)."""
        return param_row(self)

    def replace(self, **changes: Any) -> PlantParams:
        """A copy with SI-valued fields changed (validated)."""
        return dataclasses.replace(self, **changes)

    # ------------------------------------------------------------------ YAML
    @classmethod
    def edge_keys(cls) -> dict[str, str]:
        """YAML key (with unit suffix) -> field name."""
        out = {}
        for f in fields(cls):
            unit = f.metadata["unit"]
            out[f"{f.name}_{unit}" if unit else f.name] = f.name
        return out

    @classmethod
    def from_dict(
        cls, data: dict[str, Any], base: PlantParams | None = None, where: str = "plant parameters"
    ) -> PlantParams:
        """Build from unit-named keys (``supply_kpa: 300``); ``preset: NAME`` picks the base."""
        data = dict(data or {})
        if "preset" in data:
            base = preset(data.pop("preset"))
        return dataclasses.replace(base or cls(), **changes_of(cls, data, base or cls(), where))

    def to_dict(self) -> dict[str, Any]:
        """Unit-named keys with edge values (the inverse of :meth:`from_dict`)."""
        out = {}
        for key, name in self.edge_keys().items():
            v = getattr(self, name)
            unit = self.__dataclass_fields__[name].metadata["unit"]
            out[key] = (
                v
                if isinstance(v, (str, int)) and not isinstance(v, float)
                else float(v / units.EDGE_UNITS[unit])
            )
        return out

    @classmethod
    def from_yaml(cls, path: str | Path) -> PlantParams:
        import yaml

        path = Path(path)
        with path.open() as fh:
            data = yaml.safe_load(fh) or {}
        if not isinstance(data, dict):
            raise InputError(f"{path}: expected a mapping of parameter keys, got {type(data).__name__}")
        return cls.from_dict(data, where=str(path))


_PRESET_DIR = Path(__file__).parents[1] / "presets"


def preset_names() -> list[str]:
    return sorted(p.stem for p in _PRESET_DIR.glob("*.yaml"))


def preset(name: str) -> PlantParams:
    """Named parameter set shipped with the package (``balloon`` is the default plant)."""
    path = _PRESET_DIR / f"{name}.yaml"
    if not path.exists():
        raise InputError(f"unknown preset {name!r}; available: {preset_names()}")
    return PlantParams.from_yaml(path)
