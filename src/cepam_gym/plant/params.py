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
from ..physics import layout as ix
from ..physics.muscle import braid_from_rest
from ..physics.valve import laminar_factor

FORCE_MODELS = ("basic", "radial", "enhanced")  # paper sections VII, IX, XI
FORCE_FORMS = ("paper", "virtual_work")
BRAID_TENSIONS = ("bidirectional", "tension_only")  # v0 | v1 (docs/physics.md, plant v1)
BLADDER_MODELS = ("spring", "neo_hookean")  # v0 | v1
FRICTION_LAWS = ("pressure_sum", "contact_area")  # v1 | v2
PWM_TIMINGS = ("substep", "exact")  # on/off valve edges read once per sub-step (released) | at their times


def _f(default, unit: str, doc: str, calibrate: bool = False):
    return field(default=default, metadata={"unit": unit, "doc": doc, "calibrate": calibrate})


# parameters that must be > 0 and >= 0 (validate)
_POSITIVE = (
    "cpam_rest_length",
    "cpam_rest_diameter",
    "epam_sleeve_free_length",
    "epam_sleeve_free_diameter",
    "min_length",
    "atmospheric_pressure",
    "supply_temperature",
    "ambient_temperature",
    "spool_time_constant",
    "onoff_switch_time",
    "pwm_frequency",
    "end_mass",
    "burst_pressure",
    "polytropic_exponent",
    "slack_width",
    "epam_bladder_length",
    "friction_presliding",
)
_NONNEG = (
    "bladder_thickness",
    "sleeve_thickness",
    "kr_high",
    "kr_low",
    "elastic_stiffness",
    "supply_pressure",
    "valve_conductance",
    "leak_conductance",
    "onoff_conductance",
    "dead_volume_cpam",
    "dead_volume_epam",
    "heat_transfer",
    "damping",
    "coulomb_friction",
    "regulator_gain",
    "spool_damping",
    "bladder_shear_modulus",
    "tube_shear_modulus",
    "heat_transfer_coefficient",
    "onoff_open_delay",
    "onoff_close_delay",
    "friction_coefficient",
    "friction_mu",
    "epam_thread_compliance",
    "cpam_thread_compliance",
)
# the settings that name a model or option, and the names each may take
_CHOICES = (
    ("force_model", FORCE_MODELS),
    ("force_form", FORCE_FORMS),
    ("braid_tension", BRAID_TENSIONS),
    ("bladder_model", BLADDER_MODELS),
    ("friction_law", FRICTION_LAWS),
    ("pwm_timing", PWM_TIMINGS),
)


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
        """Raise ``ValueError`` naming the parameter if the set is impossible."""
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, float) and not math.isfinite(v):
                raise InputError(f"parameter {f.name} is not finite: {v}")
        for name, allowed in _CHOICES:
            if getattr(self, name) not in allowed:
                raise InputError(f"{name} must be one of {allowed}, got {getattr(self, name)!r}")
        if not 0.0 <= self.collapse_seal_diameter <= self.cpam_bladder_diameter:
            raise InputError(
                "collapse_seal_diameter must lie between 0 and the CPAM bladder's diameter "
                f"({self.cpam_bladder_diameter * 1e3:.3g} mm), got {self.collapse_seal_diameter * 1e3:.3g} mm"
            )
        if self.spool_order not in (1, 2):
            raise InputError(f"spool_order must be 1 or 2, got {self.spool_order!r}")
        for name in _POSITIVE:
            if not getattr(self, name) > 0.0:
                raise InputError(f"parameter {name} must be > 0, got {getattr(self, name)}")
        for name in _NONNEG:
            if not getattr(self, name) >= 0.0:
                raise InputError(f"parameter {name} must be >= 0, got {getattr(self, name)}")
        for name in ("cpam_rest_angle", "epam_sleeve_free_angle"):
            a = getattr(self, name)
            if not 0.0 < a < math.pi / 2:
                raise InputError(
                    f"parameter {name} must be between 0 and 90 deg, got {math.degrees(a):.3g} deg"
                )
        if not self.cpam_rest_angle < math.acos(1 / math.sqrt(3)):
            raise InputError(
                "cpam_rest_angle must be below 54.7 deg (a contractor's braid), got "
                f"{math.degrees(self.cpam_rest_angle):.3g} deg"
            )
        if not 0.0 <= self.valve_critical_ratio < self.laminar_ratio < 1.0:
            raise InputError(
                "need 0 <= valve_critical_ratio < laminar_ratio < 1, got "
                f"{self.valve_critical_ratio} and {self.laminar_ratio}"
            )
        if not self.min_length < self.max_length:
            raise InputError(
                f"min_length ({self.min_length} m) must be below max_length ({self.max_length} m)"
            )
        if self.end_mass <= 0:
            raise InputError("end_mass must be > 0")
        self._check_geometry()

    def _check_geometry(self) -> None:
        bc, nc = self.cpam_braid()
        be, ne = self.epam_braid()
        ta = self.wall_thickness()
        for name, b in (("CPAM", bc), ("EPAM", be)):
            if self.max_length >= b:
                raise InputError(
                    f"{name} braid thread ({b * 100:.3g} cm) is not longer than max_length "
                    f"({self.max_length * 100:.3g} cm): the braid cannot reach that length; "
                    "change the braid angle or the end stops"
                )
        lengths = np.linspace(self.min_length, self.max_length, 64)
        dc = bc * np.sqrt(1 - (lengths / bc) ** 2) / (np.pi * nc)
        de = be * np.sqrt(1 - (lengths / be) ** 2) / (np.pi * ne)
        if np.any(dc - 2 * ta <= 0):
            raise InputError("wall thickness (bladder_thickness + sleeve_thickness) leaves the CPAM no air")
        if np.any(de - 2 * ta <= dc):
            i = int(np.argmax(de - 2 * ta <= dc))
            raise InputError(
                f"the CPAM (outer diameter {dc[i] * 1e3:.3g} mm) does not fit inside the EPAM "
                f"(air diameter {(de[i] - 2 * ta) * 1e3:.3g} mm) at L = {lengths[i] * 100:.3g} cm"
            )

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
        """The flat float64 parameter row the compiled kernels read (layout in physics.layout)."""
        p = np.zeros(ix.N_PARAMS)
        p[ix.BC], p[ix.NC] = self.cpam_braid()
        p[ix.BE], p[ix.NE] = self.epam_braid()
        p[ix.TA] = self.wall_thickness()
        p[ix.RADIAL] = 0.0 if self.force_model == "basic" else 1.0
        p[ix.DOC] = self.cpam_bladder_diameter
        p[ix.DOE] = self.epam_bladder_diameter
        p[ix.KR_LO] = self.kr_low
        p[ix.KR_HI] = self.kr_high
        paper = self.force_form == "paper"
        p[ix.KAPPA] = self.paper_length_ratio if paper else 1.0
        p[ix.LAMBDA] = 1.0 if paper else 0.0
        p[ix.K_EL] = (
            self.elastic_stiffness if self.bladder_model == "spring" else 0.0
        )  # v1: the walls' energy replaces it
        p[ix.L_EL0] = self.elastic_rest_length
        p[ix.L_MIN] = self.min_length
        p[ix.L_MAX] = self.max_length
        p[ix.P_ATM] = self.atmospheric_pressure
        p[ix.P_SUP] = self.atmospheric_pressure + self.supply_pressure
        p[ix.T_SUP] = self.supply_temperature
        p[ix.T_AMB] = self.ambient_temperature
        p[ix.C_PROP] = self.valve_conductance
        p[ix.B_CRIT] = self.valve_critical_ratio
        p[ix.R_LAM] = self.laminar_ratio
        p[ix.C_LEAK] = self.leak_conductance
        p[ix.TAU_SPOOL] = self.spool_time_constant
        p[ix.SPOOL_ORDER] = self.spool_order
        p[ix.ZETA] = self.spool_damping
        p[ix.C_ONOFF] = self.onoff_conductance
        p[ix.TAU_SWITCH] = self.onoff_switch_time
        p[ix.PWM_PERIOD] = 1.0 / self.pwm_frequency
        p[ix.VD_C] = self.dead_volume_cpam
        p[ix.VD_E] = self.dead_volume_epam
        p[ix.HA] = self.heat_transfer
        p[ix.P_BURST] = self.burst_pressure
        p[ix.N_POLY] = self.polytropic_exponent
        p[ix.M_END] = self.end_mass
        p[ix.DAMP] = self.damping
        p[ix.F_COUL] = self.coulomb_friction
        p[ix.GRAV] = self.gravity
        p[ix.REG_GAIN] = self.regulator_gain
        p[ix.SLACK_W] = self.slack_width if self.braid_tension == "tension_only" else 0.0
        p[ix.MU_B] = self.bladder_shear_modulus if self.bladder_model == "neo_hookean" else 0.0
        p[ix.TB_EL] = self.bladder_thickness
        p[ix.LREF_C] = self.cpam_rest_length
        p[ix.LREF_E] = self.epam_bladder_length
        p[ix.H_WALL] = self.heat_transfer_coefficient
        p[ix.D_ON] = self.onoff_open_delay
        p[ix.D_OFF] = self.onoff_close_delay
        # the contact-area law (v2) replaces the v1 coefficient: fill_derived sets FR_C = mu S_e
        p[ix.FR_C] = self.friction_coefficient if self.friction_law == "pressure_sum" else 0.0
        p[ix.FR_D] = self.friction_presliding
        p[ix.COL_A] = 0.25 * math.pi * self.collapse_seal_diameter**2
        p[ix.FR_MU] = self.friction_mu if self.friction_law == "contact_area" else 0.0
        p[ix.THR_E] = self.epam_thread_compliance
        p[ix.THR_C] = self.cpam_thread_compliance
        p[ix.PWM_EXACT] = 1.0 if self.pwm_timing == "exact" else 0.0
        fill_derived(p)
        return p

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
        base = base or cls()
        keys = cls.edge_keys()
        changes = {}
        for key, value in data.items():
            if key not in keys:
                hint = [k for k in keys if k.split("_")[0] == key.split("_")[0]][:6]
                raise InputError(
                    f"unknown key {key!r} in {where}"
                    + (f"; did you mean one of {hint}?" if hint else f"; valid keys: {sorted(keys)}")
                )
            name = keys[key]
            f = cls.__dataclass_fields__[name]
            unit = f.metadata["unit"]
            default = getattr(base, name)
            if isinstance(default, str):
                if not isinstance(value, str):
                    raise InputError(f"key {key!r} in {where} must be a string, got {value!r}")
                changes[name] = value
            elif isinstance(default, int) and not isinstance(default, bool) and name == "spool_order":
                if not isinstance(value, int) or isinstance(value, bool):
                    raise InputError(f"key {key!r} in {where} must be an integer, got {value!r}")
                changes[name] = value
            else:
                changes[name] = _number(value, key, where) * units.EDGE_UNITS[unit]
        return dataclasses.replace(base, **changes)

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


def pressure_cap_of(p) -> np.ndarray:
    """:attr:`PlantParams.pressure_cap` of parameter row(s) ``p`` (randomised plants):
    ``min(supply, burst)`` gauge [Pa]."""
    p = np.asarray(p, dtype=float)
    return np.minimum(p[..., ix.P_SUP] - p[..., ix.P_ATM], p[..., ix.P_BURST])


def fill_derived(p: np.ndarray) -> np.ndarray:
    """Fill the derived columns of parameter row(s) ``p`` (layout.INV_BC ... K_AMB) in place."""
    from ..physics.layout import T0

    q = p.T
    ta = q[ix.TA]
    for b_i, n_i, inv_b, qq, tbn, tan, dk, inv_pnb in (
        (ix.BC, ix.NC, ix.INV_BC, ix.QC, ix.TBN_C, ix.TAN_C, ix.DK_C, ix.INV_PNB_C),
        (ix.BE, ix.NE, ix.INV_BE, ix.QE, ix.TBN_E, ix.TAN_E, ix.DK_E, ix.INV_PNB_E),
    ):
        b, n = q[b_i], q[n_i]
        q[inv_b] = 1.0 / b
        q[qq] = 1.0 / (4.0 * math.pi * n * n)
        q[tbn] = ta * b / n
        q[tan] = ta / n
        q[dk] = b / (math.pi * n)
        q[inv_pnb] = 1.0 / (math.pi * n * b)
    q[ix.PTA2] = math.pi * ta * ta
    for lref, inv_l, inv_d, el, b_i, dk, d_o in (
        (ix.LREF_C, ix.INV_LREF_C, ix.INV_DREF_C, ix.EL_C, ix.BC, ix.DK_C, ix.DOC),
        (ix.LREF_E, ix.INV_LREF_E, ix.INV_DREF_E, ix.EL_E, ix.BE, ix.DK_E, ix.DOE),
    ):
        u = q[lref] / q[b_i]
        q[inv_l] = 1.0 / q[lref]
        q[inv_d] = 1.0 / (q[dk] * np.sqrt(1.0 - u * u))  # braid diameter at the bladder's rest length
        # mu times the rubber volume of a tube of outer diameter D_o and wall t_b, pi (D_o - t_b) t_b L
        q[el] = q[ix.MU_B] * math.pi * (q[d_o] - q[ix.TB_EL]) * q[ix.TB_EL] * q[lref]
    # chamber wall areas at mid-stroke: CPAM bladder inside; annulus = EPAM bladder inside + CPAM outside
    lm = 0.5 * (q[ix.L_MIN] + q[ix.L_MAX])
    d_c = q[ix.DK_C] * np.sqrt(1.0 - (lm / q[ix.BC]) ** 2)
    d_e = q[ix.DK_E] * np.sqrt(1.0 - (lm / q[ix.BE]) ** 2)
    # plant v2 contact-area friction: mu times each braid's inner surface pi D L at mid-stroke
    mu = q[ix.FR_MU]
    v2 = mu > 0.0
    q[ix.FR_CC] = np.where(v2, mu * math.pi * d_c * lm, 0.0)
    q[ix.FR_C] = np.where(v2, mu * math.pi * d_e * lm, q[ix.FR_C])
    # plant v2 extensible braids: a stretched thread is b / (1 - THR_A P L), P its net active pressure
    q[ix.THR_AE] = q[ix.THR_E] * q[ix.BE] / (2.0 * math.pi * q[ix.NE] ** 2)
    q[ix.THR_AC] = q[ix.THR_C] * q[ix.BC] / (2.0 * math.pi * q[ix.NC] ** 2)
    h = q[ix.H_WALL]
    q[ix.HA_C] = np.where(h > 0.0, h * math.pi * (d_c - 2.0 * ta) * lm, q[ix.HA])
    q[ix.HA_E] = np.where(h > 0.0, h * math.pi * (d_e - 2.0 * ta + d_c) * lm, q[ix.HA])
    bc = q[ix.B_CRIT]
    q[ix.INV_1MB] = 1.0 / (1.0 - bc)
    q[ix.LAM_K] = laminar_factor(q[ix.R_LAM], bc)
    q[ix.K_SUP] = np.sqrt(T0 / q[ix.T_SUP])
    q[ix.K_AMB] = np.sqrt(T0 / q[ix.T_AMB])
    return p


def _number(value: Any, key: str, where: str) -> float:
    # YAML 1.1 reads "1e-3" as a string; accept numeric strings, reject everything else by name.
    if isinstance(value, bool):
        raise InputError(f"key {key!r} in {where} must be a number, got {value!r}")
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise InputError(f"key {key!r} in {where} must be a number, got {value!r}") from None
    if not math.isfinite(out):
        raise InputError(f"key {key!r} in {where} must be finite, got {value!r}")
    return out


_PRESET_DIR = Path(__file__).parents[1] / "presets"


def preset_names() -> list[str]:
    return sorted(p.stem for p in _PRESET_DIR.glob("*.yaml"))


def preset(name: str) -> PlantParams:
    """Named parameter set shipped with the package (``balloon`` is the default plant)."""
    path = _PRESET_DIR / f"{name}.yaml"
    if not path.exists():
        raise InputError(f"unknown preset {name!r}; available: {preset_names()}")
    return PlantParams.from_yaml(path)
