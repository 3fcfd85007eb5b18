"""The checks of a plant's parameters (:meth:`cepam_gym.plant.params.PlantParams.validate`): every
field finite, the model choices among their names, signs, angles, the valve's ratios, the end
stops and the braids' geometry; each failure an ``InputError`` naming the parameter."""

from __future__ import annotations

import math
from dataclasses import fields

import numpy as np

from ..errors import InputError

FORCE_MODELS = ("basic", "radial", "enhanced")  # paper sections VII, IX, XI
FORCE_FORMS = ("paper", "virtual_work")
BRAID_TENSIONS = ("bidirectional", "tension_only")  # v0 | v1 (docs/physics.md, plant v1)
BLADDER_MODELS = ("spring", "neo_hookean")  # v0 | v1
FRICTION_LAWS = ("pressure_sum", "contact_area")  # v1 | v2
PWM_TIMINGS = ("substep", "exact")  # on/off valve edges read once per sub-step (released) | at their times


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


def validate(self) -> None:
    """Raise ``InputError`` (a ``ValueError``) naming the parameter if the plant ``self`` (a
    :class:`~cepam_gym.plant.params.PlantParams`) is impossible."""
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
            raise InputError(f"parameter {name} must be between 0 and 90 deg, got {math.degrees(a):.3g} deg")
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
        raise InputError(f"min_length ({self.min_length} m) must be below max_length ({self.max_length} m)")
    if self.end_mass <= 0:
        raise InputError("end_mass must be > 0")
    _check_geometry(self)


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
