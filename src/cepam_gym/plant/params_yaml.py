"""Plant parameters from unit-named keys (``supply_kpa: 300``): the field changes a mapping asks
for (:func:`changes_of`, behind :meth:`cepam_gym.plant.params.PlantParams.from_dict`), each key's
unit converted by :mod:`cepam_gym.units`, unknown keys and values of the wrong kind refused by
name."""

from __future__ import annotations

import math
from typing import Any

from .. import units
from ..errors import InputError


def changes_of(cls, data: dict[str, Any], base, where: str) -> dict[str, Any]:
    """The SI field values of ``data`` (unit-named keys, ``preset`` already taken out) for the
    parameters dataclass ``cls``, the kinds of values read off ``base``; ``where`` names the source
    in errors."""
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
    return changes


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
