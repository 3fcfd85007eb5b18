"""The checks of an env's kwargs and actions, each failing with one line that names the input
(:class:`~cepam_gym.errors.InputError`). Shared by the batched core and the MuJoCo joint env."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import InputError
from ..plant.params import PlantParams, preset

_MAX_CONTROL_DT = 1.0  # s: larger values are milliseconds passed as seconds
# sensor_noise keys -> (noise column, SI per unit); a hinge's position is its angle, so its noise can
# be given in mrad (the same column as the rig's length)
_NOISE_KEYS = {
    "length_mm": (0, 1e-3),
    "velocity_mm_s": (1, 1e-3),
    "angle_mrad": (0, 1e-3),
    "angular_velocity_mrad_s": (1, 1e-3),
    "pressure_kpa": (2, 1e3),
}


def resolve_params(plant: PlantParams | str | Mapping[str, Any] | None) -> PlantParams:
    """A PlantParams from an instance, a preset name, a YAML path or a dict of edge-unit keys."""
    if plant is None:
        return PlantParams()
    if isinstance(plant, PlantParams):
        return plant
    if isinstance(plant, str):
        if plant.endswith((".yaml", ".yml")):
            return PlantParams.from_yaml(plant)
        return preset(plant)
    if isinstance(plant, Mapping):
        return PlantParams.from_dict(dict(plant), where="env kwarg 'plant'")
    raise TypeError(
        f"plant must be a PlantParams, preset name, YAML path or dict, got {type(plant).__name__}"
    )


def check_timing(control_dt: float, sub_dt: float, episode_seconds: float) -> tuple[int, int]:
    """``(sub-steps per control step, control steps per episode)``; ``ValueError`` when the
    sub-step does not divide the control period or a duration is not positive."""
    if not (control_dt > 0 and sub_dt > 0):
        raise InputError(f"control_dt and sub_dt must be > 0, got {control_dt}, {sub_dt}")
    if control_dt > _MAX_CONTROL_DT:
        raise InputError(
            f"control_dt is in seconds and at most {_MAX_CONTROL_DT:g} s, got {control_dt} (20 ms is 0.02)"
        )
    n_sub = round(control_dt / sub_dt)
    if n_sub < 1 or abs(n_sub * sub_dt - control_dt) > 1e-9 * control_dt:
        raise InputError(f"sub_dt ({sub_dt} s) must divide control_dt ({control_dt} s) evenly")
    if not episode_seconds > 0:
        raise InputError(f"episode_seconds must be > 0, got {episode_seconds}")
    return int(n_sub), max(1, round(episode_seconds / control_dt))


def check_randomize(randomize: Mapping[str, Any] | None) -> dict[str, tuple[float, float]]:
    """``{plant key: (low, high)}`` of the ``randomize`` kwarg, checked (``ValueError`` naming the
    key); keys are unit-named like the YAML files."""
    out = {}
    keys = PlantParams.edge_keys()
    for key, rng in dict(randomize or {}).items():
        if key not in keys:
            raise InputError(f"randomize: unknown plant parameter {key!r}; valid keys: {sorted(keys)}")
        try:
            lo, hi = (float(v) for v in rng)
        except (TypeError, ValueError):
            raise InputError(f"randomize: {key!r} needs a [low, high] pair of numbers, got {rng!r}") from None
        if not (np.isfinite(lo) and np.isfinite(hi) and lo <= hi):
            raise InputError(f"randomize: {key!r} needs finite low <= high, got {rng!r}")
        out[key] = (lo, hi)
    return out


def check_threads(num_threads) -> int | None:
    """``num_threads`` of the batched kernel: ``None`` (the count that steps fastest, found while
    the env runs: :mod:`cepam_gym.envs.threads`), or 1 .. ``NUMBA_NUM_THREADS`` (fixed). On a
    machine where another process keeps a core busy (training: the learner), fewer threads than
    cores avoid waiting on a descheduled thread (benchmarks/throughput.py ``--busy-core`` measures
    each setting)."""
    if num_threads is None:
        return None
    import numba

    top = numba.config.NUMBA_NUM_THREADS
    if isinstance(num_threads, bool) or int(num_threads) != num_threads or not 1 <= num_threads <= top:
        raise InputError(
            f"num_threads must be an integer in [1, {top}] (NUMBA_NUM_THREADS) or None, got {num_threads!r}"
        )
    return int(num_threads)


def as_actions(actions, num_envs: int, single: bool | None = None) -> np.ndarray:
    """``actions`` of ``num_envs`` envs as a float64 (num_envs, 2) array; ``InputError`` on
    anything but real numbers of the expected shape, NaN or inf (naming the envs, not printing the
    batch). The shape is exact, never broadcast: a single env's action is ``(2,)`` (``single``;
    by default when ``num_envs`` is 1), a batch's ``(num_envs, 2)``; ``(1, 2)``, ``(2, 1)`` or
    ``(1, 1, 2)`` on a single env is refused, naming the expected shape. Not clipped."""
    single = num_envs == 1 if single is None else single
    shape = (2,) if single else (num_envs, 2)
    raw = np.asarray(actions) if not isinstance(actions, (str, bytes, Mapping)) else None
    if raw is None or raw.dtype.kind not in "biuf":
        kind = type(actions).__name__ if raw is None else f"{type(actions).__name__} of {raw.dtype}"
        raise InputError(f"action must be real numbers of shape {shape} in [-1, 1], got a {kind}")
    if raw.shape != shape:
        what = "a single env's action" if single else f"the actions of {num_envs} envs"
        raise InputError(f"{what} must have shape {shape} (one command per chamber), got {raw.shape}")
    a = raw.astype(np.float64, copy=False).reshape(num_envs, 2)
    bad = ~np.isfinite(a).all(axis=1)
    if bad.any():
        envs = np.flatnonzero(bad)
        where = "" if single else f" in env(s) {envs[:8].tolist()}{' ...' if envs.size > 8 else ''}"
        raise InputError(f"action contains NaN or inf{where} (of {num_envs}); actions must be finite")
    return a


def check_noise(sensor_noise: Mapping[str, float] | None) -> np.ndarray:
    """Noise standard deviations (SI) for [position, velocity, pressure_c, pressure_e, supply]
    (the position is the rig's length or the hinge's angle)."""
    sd = dict(sensor_noise or {})
    bad = set(sd) - set(_NOISE_KEYS)
    if bad:
        raise InputError(f"sensor_noise: unknown keys {sorted(bad)}; valid: {sorted(_NOISE_KEYS)}")
    for k, v in sd.items():
        if not (np.isfinite(v) and v >= 0):
            raise InputError(f"sensor_noise: {k} must be finite and >= 0, got {v!r}")
    out = np.zeros(5)
    for k, v in sd.items():
        col, si = _NOISE_KEYS[k]
        if out[col]:
            raise InputError(f"sensor_noise: {k} and another key set the same sensor's noise; give one")
        out[col] = float(v) * si
    out[3:] = out[2]  # one pressure noise for both chambers and the supply
    return out
