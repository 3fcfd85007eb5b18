"""Batched env state shared by the single env and the vector env (one code path for both).

:class:`CEPAMBatch` owns the arrays of N envs (plant state, parameters, schedules, buffers) and
implements ``reset(indices)`` and ``step(actions)`` on them; the Gymnasium classes in
:mod:`cepam_gym.envs.cepam` only add spaces, seeding and ``info``.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Mapping

import numpy as np

from .. import plant as pl
from ..params import PlantParams, preset
from ..physics import api
from ..physics import layout as ix
from ..tasks import TASKS, RewardWeights, TaskSpec
from ..tasks import kernel as tk
from ..tasks.layout import rig_layout
from ..tasks.references import planned_schedules
from ..tasks.spec import check_kwargs

ACTION_MODES = tuple(pl.MODES)  # "valve", "pwm", "pressure"

_NOISE_KEYS = {"length_mm": 1e-3, "velocity_mm_s": 1e-3, "pressure_kpa": 1e3}


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
    raise TypeError(f"plant must be a PlantParams, preset name, YAML path or dict, got {type(plant).__name__}")


def check_timing(control_dt: float, sub_dt: float, episode_seconds: float) -> tuple[int, int]:
    """``(sub-steps per control step, control steps per episode)``; ``ValueError`` when the
    sub-step does not divide the control period or a duration is not positive."""
    if not (control_dt > 0 and sub_dt > 0):
        raise ValueError(f"control_dt and sub_dt must be > 0, got {control_dt}, {sub_dt}")
    n_sub = round(control_dt / sub_dt)
    if n_sub < 1 or abs(n_sub * sub_dt - control_dt) > 1e-9 * control_dt:
        raise ValueError(f"sub_dt ({sub_dt} s) must divide control_dt ({control_dt} s) evenly")
    if not episode_seconds > 0:
        raise ValueError(f"episode_seconds must be > 0, got {episode_seconds}")
    return int(n_sub), max(1, round(episode_seconds / control_dt))


def check_action_mode(action_mode: str) -> int:
    """The plant's valve mode of an env ``action_mode`` (``ValueError`` naming the valid ones)."""
    if action_mode not in pl.MODES:
        raise ValueError(f"action_mode must be one of {ACTION_MODES}, got {action_mode!r}")
    return pl.MODES[action_mode]


def check_randomize(randomize: Mapping[str, Any] | None) -> dict[str, tuple[float, float]]:
    """``{plant key: (low, high)}`` of the ``randomize`` kwarg, checked (``ValueError`` naming the
    key); keys are unit-named like the YAML files."""
    out = {}
    keys = PlantParams.edge_keys()
    for key, rng in dict(randomize or {}).items():
        if key not in keys:
            raise ValueError(f"randomize: unknown plant parameter {key!r}; valid keys: {sorted(keys)}")
        try:
            lo, hi = (float(v) for v in rng)
        except (TypeError, ValueError):
            raise ValueError(f"randomize: {key!r} needs a [low, high] pair of numbers, got {rng!r}") from None
        if not (np.isfinite(lo) and np.isfinite(hi) and lo <= hi):
            raise ValueError(f"randomize: {key!r} needs finite low <= high, got {rng!r}")
        out[key] = (lo, hi)
    return out


def sample_params(nominal: PlantParams, randomize: Mapping[str, tuple[float, float]],
                  rng: np.random.Generator, nominal_row: np.ndarray | None = None) -> np.ndarray:
    """A parameter row for a new episode: ``nominal`` (its row ``nominal_row`` itself when given
    and nothing is randomised) with each key of ``randomize`` drawn uniformly from its range."""
    if not randomize:
        return nominal.to_array() if nominal_row is None else nominal_row
    draw = {k: rng.uniform(lo, hi) for k, (lo, hi) in randomize.items()}
    return PlantParams.from_dict(draw, base=nominal, where="randomize").to_array()


def as_actions(actions, num_envs: int) -> np.ndarray:
    """``actions`` of ``num_envs`` envs as a float64 (num_envs, 2) array (a single env's may have
    any shape of 2 elements); ``ValueError`` on a wrong shape, NaN or inf. Not clipped."""
    a = np.asarray(actions, dtype=np.float64)
    if a.shape != (num_envs, 2):
        if a.size == 2 and num_envs == 1:
            a = a.reshape(1, 2)
        else:
            raise ValueError(f"action must have shape {(2,) if num_envs == 1 else (num_envs, 2)}, "
                             f"got {np.shape(actions)}")
    if not np.isfinite(a).all():
        raise ValueError(f"action contains NaN or inf: {actions!r}")
    return a


def _check_noise(sensor_noise: Mapping[str, float] | None) -> np.ndarray:
    """Noise standard deviations (SI) for [length, velocity, pressure_c, pressure_e, supply]."""
    sd = dict(sensor_noise or {})
    bad = set(sd) - set(_NOISE_KEYS)
    if bad:
        raise ValueError(f"sensor_noise: unknown keys {sorted(bad)}; valid: {sorted(_NOISE_KEYS)}")
    for k, v in sd.items():
        if not (np.isfinite(v) and v >= 0):
            raise ValueError(f"sensor_noise: {k} must be finite and >= 0, got {v!r}")
    p = sd.get("pressure_kpa", 0.0) * 1e3
    return np.array([sd.get("length_mm", 0.0) * 1e-3, sd.get("velocity_mm_s", 0.0) * 1e-3, p, p, p])


class CEPAMBatch:
    """N CE-PAM envs as arrays. Not a Gymnasium class: see :mod:`cepam_gym.envs.cepam`."""

    def __init__(self, num_envs: int = 1, task: str | TaskSpec = "cepam", plant=None,
                 action_mode: str = "valve", control_dt: float = 0.02, sub_dt: float = 5e-4,
                 episode_seconds: float = 10.0, reward_weights: Mapping[str, float] | None = None,
                 randomize: Mapping[str, Any] | None = None, sensor_noise: Mapping[str, float] | None = None,
                 action_latency_steps: int = 0, supply_drift_kpa: float = 0.0,
                 task_options: Mapping[str, Any] | None = None, preview_steps: int = 0):
        if int(num_envs) != num_envs or num_envs < 1:
            raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")
        self.num_envs = n = int(num_envs)
        if isinstance(task, str):
            if task not in TASKS:
                raise ValueError(f"unknown task {task!r}; available: {sorted(TASKS)}")
            task = TASKS[task]
        if task_options:
            opts = check_kwargs(TaskSpec, task_options, "task_options",
                                exclude=("name", "weights", "scales"))
            opts = {k: tuple(v) if isinstance(v, list) else v for k, v in opts.items()}
            task = dataclasses.replace(task, **opts)
        if reward_weights:
            weights = check_kwargs(RewardWeights, reward_weights, "reward_weights", "terms")
            task = dataclasses.replace(task, weights=dataclasses.replace(task.weights, **weights))
        self.task = task
        self.mode = check_action_mode(action_mode)
        self.action_mode = action_mode
        self.n_sub, self.n_steps = check_timing(control_dt, sub_dt, episode_seconds)
        self.control_dt, self.sub_dt = float(control_dt), float(sub_dt)
        self.nominal = resolve_params(plant)
        self.randomize = check_randomize(randomize)
        self.noise_sd = _check_noise(sensor_noise)
        if int(action_latency_steps) != action_latency_steps or action_latency_steps < 0:
            raise ValueError(f"action_latency_steps must be an integer >= 0, got {action_latency_steps!r}")
        self.latency = int(action_latency_steps)
        if not (np.isfinite(supply_drift_kpa) and supply_drift_kpa >= 0):
            raise ValueError(f"supply_drift_kpa must be finite and >= 0, got {supply_drift_kpa!r}")
        self.supply_drift = float(supply_drift_kpa) * 1e3  # Pa per sqrt(s)
        if isinstance(preview_steps, bool) or int(preview_steps) != preview_steps or not 0 <= preview_steps <= 100:
            raise ValueError(f"preview_steps must be an integer in [0, 100] (control steps announced), "
                             f"got {preview_steps!r}")
        self.preview_steps = int(preview_steps)
        self.obs_layout = rig_layout(task, self.nominal, self.preview_steps)
        self.task_vec = self._task_vector()
        self.obs_dim = self.obs_layout.size
        # --- arrays
        self._nominal_row = nominal_row = self.nominal.to_array()
        self._stable_checked = False
        self.has_noise = bool(self.noise_sd.any())
        # a single env without latency or supply drift steps through one jitted call
        # (tasks.kernel.env_step_single) on two slabs its arrays are views of
        self.fast_single = n == 1 and not self.latency and not self.supply_drift
        if n == 1:
            self._F, self._I, v = tk.single_slabs(self.n_steps, self.mode, self.n_sub, self.sub_dt)
            self.state, self.aux, self.inputs, self.params = v["state"], v["aux"], v["inputs"], v["params"]
            self.target_l, self.target_k, self.load = v["target_l"], v["target_k"], v["load"]
            self.t_idx, self.prev_action, self.rewards = v["t_idx"], v["actions"], v["rewards"]
            self.terms, self.reasons, self.noise, self.info_row = v["terms"], v["reasons"], v["noise"], v["info"]
            self.params[:] = nominal_row
            v["task"][:] = self.task_vec
            self.task_vec = v["task"]
        else:
            self.params = np.repeat(nominal_row[None], n, axis=0)
            self.state = np.zeros((n, pl.N_STATE))
            self.aux = np.zeros((n, pl.N_AUX))
            self.inputs = np.zeros((n, pl.N_INPUT))
            self.target_l = np.zeros((n, self.n_steps))
            self.target_k = np.zeros((n, self.n_steps))
            self.load = np.zeros((n, self.n_steps))
            self.t_idx = np.zeros(n, dtype=np.int64)
            self.prev_action = np.zeros((n, 2))
            self.rewards = np.zeros(n)
            self.terms = np.zeros((n, tk.N_TERMS))
            self.reasons = np.zeros(n, dtype=np.int64)
            self.noise = np.zeros((self.num_envs if self.has_noise else 1, tk.N_NOISE))
        self.queue = np.zeros((self.latency + 1, n, 2))
        self.obs = np.zeros((n, self.obs_dim), dtype=np.float32)
        self.rngs: list[np.random.Generator] = [np.random.default_rng() for _ in range(n)]
        self.noise_rng = np.random.default_rng()
        # prev_action doubles as the buffer of the action being applied (clipped in place by the
        # kernel), so after a step it holds a_{t-1}; the kernel's arguments are bound once
        self._single_action = self.prev_action
        self._kernel_args = (self.state, self.prev_action, self.params, self.mode, self.sub_dt,
                             self.n_sub, self.target_l, self.target_k, self.load, self.t_idx,
                             self.task_vec, self.noise, self.inputs, self.obs, self.rewards,
                             self.terms, self.aux, self.reasons)

    def step_single(self, x0: float, x1: float) -> tuple[float, int]:
        """The single env's step (``fast_single``) with a finite action ``(x0, x1)``: returns
        ``(reward, termination reason)``; ``info_row`` then holds the step's info values."""
        if self.has_noise:
            self._draw_noise()
        return tk.env_step_single(self._F, self._I, self.obs, x0, x1)

    def _task_vector(self) -> np.ndarray:
        t = self.task
        return tk.task_vector(dataclasses.astuple(t.weights), t.scales, self.obs_layout,
                              self.nominal.pressure_cap, t.track_stiffness)

    # ------------------------------------------------------------------ reset
    def seed(self, seed: int | None) -> None:
        """Env i draws from ``default_rng(seed + i)``, as if it were a single env seeded so."""
        ss = [None if seed is None else seed + i for i in range(self.num_envs)]
        self.rngs = [np.random.default_rng(s) for s in ss]
        self.noise_rng = np.random.default_rng(None if seed is None else [seed, 0x5EED])

    def _sample_params(self, rng: np.random.Generator) -> np.ndarray:
        return sample_params(self.nominal, self.randomize, rng, self._nominal_row)

    def pin_targets(self, target_length=None, target_stiffness=None, load_mass=None, indices=None) -> None:
        """Hold the given target length [m], stiffness [N/m] or load [kg] for the whole episode of
        ``indices`` (scalars or per-env arrays); call right after :meth:`reset`. Used by the
        benchmark harness and for evaluation at chosen operating points."""
        idx = np.arange(self.num_envs) if indices is None else np.asarray(indices)
        for arr, val, name in ((self.target_l, target_length, "target_length"),
                               (self.target_k, target_stiffness, "target_stiffness"),
                               (self.load, load_mass, "load_mass")):
            if val is None:
                continue
            v = np.broadcast_to(np.asarray(val, dtype=float), idx.shape)
            if not np.isfinite(v).all():
                raise ValueError(f"{name} must be finite, got {val!r}")
            arr[idx] = v[:, None]
        tk.observe(self.state, self.aux, self.params, self.target_l, self.target_k, self.t_idx,
                   self.prev_action, self.task_vec, self.noise, self.obs)

    def reset(self, indices=None) -> None:
        """Start new episodes for ``indices`` (all envs if None): parameters, schedules, state."""
        idx = np.arange(self.num_envs) if indices is None else np.asarray(indices, dtype=np.int64)
        for i in idx:
            self.params[i] = self._sample_params(self.rngs[i])
        if self.randomize or not self._stable_checked:
            pl.check_stability(self.params[idx], self.sub_dt)
            self._stable_checked = True
        tl, tkk, load, initial = planned_schedules([self.rngs[i] for i in idx], self.task,
                                                   self.params[idx], self.n_steps, self.control_dt)
        self.target_l[idx], self.target_k[idx], self.load[idx] = tl, tkk, load
        p = self.params[idx]
        weight = (p[:, ix.M_END] + load[:, 0]) * p[:, ix.GRAV]
        pc, pe, _ = api.static_pressures(initial[:, 0], initial[:, 1], weight, p)
        self.state[idx] = pl.initial_state(p, initial[:, 0], pc, pe)
        self.aux[idx] = pl.measure(self.state[idx], p)
        self.t_idx[idx] = 0
        self.prev_action[idx] = 0.0
        self.queue[:, idx] = 0.0
        self._draw_noise()
        tk.observe(self.state, self.aux, self.params, self.target_l, self.target_k, self.t_idx,
                   self.prev_action, self.task_vec, self.noise, self.obs)

    # ------------------------------------------------------------------- step
    def _draw_noise(self) -> None:
        """Fresh sensor noise, written in place (the kernel's argument tuple holds this buffer)."""
        if self.has_noise:
            self.noise[:] = self.noise_rng.standard_normal((self.num_envs, tk.N_NOISE)) * self.noise_sd

    def check_actions(self, actions) -> np.ndarray:
        """A float64 (N, 2) copy of ``actions``; ``ValueError`` on a wrong shape, NaN or inf.
        Out-of-range values are clipped by the step kernel."""
        if self.num_envs == 1 and np.shape(actions) == (2,):
            # the single env's hot path: no temporary arrays
            x0, x1 = float(actions[0]), float(actions[1])
            if not (math.isfinite(x0) and math.isfinite(x1)):
                raise ValueError(f"action contains NaN or inf: {actions!r}")
            a = self._single_action
            a[0, 0] = x0
            a[0, 1] = x1
            return a
        self.prev_action[:] = as_actions(actions, self.num_envs)
        return self.prev_action

    def step(self, actions: np.ndarray) -> None:
        """Advance all envs one control period; results in ``obs``, ``rewards``, ``terms``,
        ``reasons``, ``aux``. ``actions`` must be what :meth:`check_actions` returned (the
        ``prev_action`` buffer, clipped in place by the kernel)."""
        if self.latency:
            self.queue[:-1] = self.queue[1:]
            self.queue[-1] = actions
            self.prev_action[:] = self.queue[0]  # what reaches the valves now
        if self.supply_drift:
            nominal = self.nominal.atmospheric_pressure + self.nominal.supply_pressure
            walk = self.noise_rng.standard_normal(self.num_envs) * self.supply_drift * np.sqrt(self.control_dt)
            self.params[:, ix.P_SUP] = np.clip(self.params[:, ix.P_SUP] + walk, 0.8 * nominal, 1.2 * nominal)
        if self.has_noise:
            self._draw_noise()
        tk.env_step(*self._kernel_args)

    def current_targets(self):
        """(target length, target stiffness, load) each env is asked for at its current step."""
        k = np.minimum(self.t_idx, self.n_steps - 1)
        r = np.arange(self.num_envs)
        return self.target_l[r, k], self.target_k[r, k], self.load[r, k]
