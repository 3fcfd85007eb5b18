"""Unit conversions at the edges (configs, CLI, plots).

Inside the package everything is SI (Pa, m, kg, s, K, m^3) and pressures used by the force
model are *gauge* (relative to the atmosphere); gas-law and valve-flow code uses *absolute*
pressures and says so. At the edges a quantity carries its unit in its name
(``supply_kpa``, ``cpam_rest_length_cm``); this module is the one place that maps those
suffixes to SI factors.
"""

from __future__ import annotations

import math

from .errors import InputError

#: edge-unit suffix -> factor that converts a value in that unit into SI
EDGE_UNITS: dict[str, float] = {
    "m": 1.0,
    "cm": 1e-2,
    "mm": 1e-3,
    "kpa": 1e3,
    "kpa_abs": 1e3,
    "kpa_per_m": 1e3,
    "deg": math.pi / 180.0,
    "kg": 1.0,
    "g": 1e-3,
    "cm3": 1e-6,
    "ms": 1e-3,
    "s": 1.0,
    "hz": 1.0,
    "k": 1.0,
    "n": 1.0,
    "n_per_m": 1.0,
    "ns_per_m": 1.0,
    "w_per_k": 1.0,
    "w_per_m2_k": 1.0,
    "n_per_kpa": 1e-3,
    "m_per_s2": 1.0,
    # ISO 6358 catalogues give sonic conductance in dm^3/(s bar) = 1e-8 m^3/(s Pa)
    "dm3_per_s_bar": 1e-8,
    "per_kpa": 1e-3,
    "per_kn": 1e-3,  # a compliance: strain per kN of tension
    "": 1.0,
}

P_ATM = 101_325.0  # Pa, standard atmosphere (absolute)


def to_si(value: float, unit: str) -> float:
    """Convert ``value`` given in edge ``unit`` (a key of :data:`EDGE_UNITS`) to SI."""
    try:
        return float(value) * EDGE_UNITS[unit]
    except KeyError:
        raise InputError(f"unknown unit {unit!r}; known: {sorted(EDGE_UNITS)}") from None


def from_si(value, unit: str):
    """Convert an SI ``value`` (scalar or array) to edge ``unit``."""
    try:
        return value / EDGE_UNITS[unit]
    except KeyError:
        raise InputError(f"unknown unit {unit!r}; known: {sorted(EDGE_UNITS)}") from None
