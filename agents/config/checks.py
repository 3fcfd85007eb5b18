"""The checks that turn a YAML value into a typed config value: :class:`ConfigError`, the numbers
YAML 1.1 leaves as strings, typed readers (integer, number, boolean, mapping) and the unknown-key
check. Every failure names the key's path (``env.num_envs``) and what was expected."""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Mapping
from typing import Any

from cepam_gym.errors import InputError

_NUMBER = re.compile(r"^[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?$")


class ConfigError(InputError):
    """A training config is invalid; the message names the offending key."""


def parse_number(value: Any) -> Any:
    """``'1e-3'`` -> 0.001 (YAML 1.1 leaves such scalars as strings); other values unchanged."""
    if isinstance(value, str) and _NUMBER.match(value.strip()):
        v = float(value)
        return int(v) if re.fullmatch(r"[+-]?\d+", value.strip()) else v
    return value


def numbers_deep(value: Any) -> Any:
    """:func:`parse_number` applied through nested mappings and lists."""
    if isinstance(value, Mapping):
        return {k: numbers_deep(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [numbers_deep(v) for v in value]
    return parse_number(value)


def as_int(value: Any, where: str, minimum: int | None = None) -> int:
    v = parse_number(value)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or v != v or int(v) != v:
        raise ConfigError(f"{where} must be an integer, got {value!r}")
    v = int(v)
    if minimum is not None and v < minimum:
        raise ConfigError(f"{where} must be >= {minimum}, got {v}")
    return v


def as_float(value: Any, where: str, minimum: float | None = None) -> float:
    v = parse_number(value)
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ConfigError(f"{where} must be a number, got {value!r}")
    v = float(v)
    if not v == v or v in (float("inf"), float("-inf")):
        raise ConfigError(f"{where} must be finite, got {value!r}")
    if minimum is not None and v < minimum:
        raise ConfigError(f"{where} must be >= {minimum}, got {v}")
    return v


def as_bool(value: Any, where: str) -> bool:
    if not isinstance(value, bool):
        raise ConfigError(f"{where} must be true or false, got {value!r}")
    return value


def as_widths(value: Any, where: str) -> list[int]:
    """A network's hidden layer widths: a non-empty list of integers >= 1."""
    if not isinstance(value, (list, tuple)) or not value:
        raise ConfigError(f"{where} must be a list of layer widths, got {value!r}")
    return [as_int(w, f"{where}[{i}]", 1) for i, w in enumerate(value)]


def as_mapping(value: Any, where: str) -> dict:
    """A mapping with string keys (``None``: an empty one, as an empty YAML section reads)."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise ConfigError(f"{where} must be a mapping, got {type(value).__name__} {value!r}")
    bad = [k for k in value if not isinstance(k, str)]
    if bad:
        raise ConfigError(f"{where}: keys must be strings, got {bad!r}")
    return dict(value)


def check_keys(data: Mapping, cls, where: str) -> None:
    """Every key of ``data`` is a field of the dataclass ``cls``; else the first unknown one is named
    with the valid keys."""
    valid = [f.name for f in dataclasses.fields(cls)]
    bad = [k for k in data if k not in valid]
    if bad:
        label = f"in {where}" if where else "at the top level"
        raise ConfigError(
            f"unknown config key {bad[0]!r} {label}"
            f"{' (also: ' + ', '.join(map(repr, bad[1:])) + ')' if bad[1:] else ''}; "
            f"valid keys: {valid}"
        )
