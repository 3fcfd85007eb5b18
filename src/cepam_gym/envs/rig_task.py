"""The rig's Task object: the paper's vertical rig, a load hanging from the muscle's free end
(paper Fig. 5, 16, 17). Targets are a length [m] and a stiffness [N/m], the load a mass [kg]."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from ..errors import InputError
from ..planning.episodes import planned_schedules, start_at_rest
from ..planning.randomization import Randomizer
from ..tasks.contract import RIG
from ..tasks.layout import rig_layout
from ..tasks.mechanism import RIG_MECHANISM
from ..tasks.rig_info import AUX, INFO_KEYS, LOAD, RIG_INFO, STATE, TARGET_K, TARGET_L, columns
from ..tasks.schedule import check_schedules
from ..tasks.spec import TASKS, TaskSpec, check_kwargs
from . import step_kernel as tk
from .id_window import INFO_KEY
from .task import Task
from .task_params import allowance_of

_MAX_LOAD_KG = 20.0  # far above what the muscle holds: larger values are grams passed as kg
# the state's and aux's columns of the declared info (tasks.rig_info), gathered in one copy each
_STATE_KEYS, _STATE_COLS = columns(STATE)
_AUX_KEYS, _AUX_COLS = columns(AUX)


class RigTask(Task):
    """A rig task: a :class:`~cepam_gym.tasks.spec.TaskSpec` (references, loads, reward weights
    and scales) with its preview count."""

    mechanism = RIG_MECHANISM
    contract = RIG
    pin_keys = RIG.pin_keys
    renderers = ("numpy", "mujoco")

    def __init__(self, spec: TaskSpec, preview_steps: int = 0):
        self.spec = spec
        self.name = spec.name
        self.preview_steps = int(preview_steps)
        self.track_stiffness = bool(spec.track_stiffness)
        self.step_keys = (*INFO_KEYS, *spec.reward.term_keys)
        reserved = (*RIG.info_keys, *spec.reward.term_keys, "termination_reason", INFO_KEY)
        check_schedules(spec.schedules, reserved)

    @classmethod
    def from_kwargs(cls, task, task_options=None, reward_weights=None, preview_steps: int = 0) -> RigTask:
        """``task`` (a name of :data:`~cepam_gym.tasks.spec.TASKS` or a spec) with the kwargs'
        overrides, checked."""
        if isinstance(task, str):
            task = TASKS[task]
        elif not isinstance(task, TaskSpec):
            raise TypeError(f"task must be a task name or a TaskSpec, got {type(task).__name__}")
        if task_options:
            opts = check_kwargs(
                TaskSpec,
                task_options,
                "task_options",
                exclude=("name", "weights", "scales", "reward", "schedules"),
            )
            opts = {k: tuple(v) if isinstance(v, list) else v for k, v in opts.items()}
            task = dataclasses.replace(task, **opts)
        if reward_weights:
            weights = check_kwargs(type(task.weights), reward_weights, "reward_weights", "terms")
            task = dataclasses.replace(task, weights=dataclasses.replace(task.weights, **weights))
        return cls(task, preview_steps)

    # ------------------------------------------------------------------ build
    def bind(self, nominal, sub_dt: float, control_dt: float = 0.02) -> None:
        """Task ranges in SI against the plant (lengths [m] within the end stops), then the
        observation layout and the task's parameters (the score form's settling allowance in
        steps of ``control_dt``)."""
        lo, hi = nominal.min_length, nominal.max_length
        t = self.spec
        for name, vals in (
            ("length_range", t.length_range),
            ("fixed_length", () if t.fixed_length is None else (t.fixed_length,)),
        ):
            if any(not lo <= v <= hi for v in vals):
                raise InputError(
                    f"task {name} is in metres and must lie within the end stops "
                    f"[{lo:g}, {hi:g}] m, got {vals}"
                )
        self.nominal, self.sub_dt = nominal, sub_dt
        self.layout = rig_layout(t, nominal, self.preview_steps)
        self.params = tk.task_params(
            t.reward,
            t.weights,
            t.scales,
            self.layout,
            nominal.pressure_cap,
            t.track_stiffness,
            allowance=allowance_of(RIG.trade, control_dt),
            terminations=t.terminations,
        )

    def hinge_row(self) -> np.ndarray:
        return self.mechanism.hinge_row()

    def randomizer(self, randomize, sub_dt: float) -> Randomizer:
        return Randomizer(randomize, self.nominal, self.spec, sub_dt)

    # ------------------------------------------------------------------ reset
    def plan(self, rngs: list, rows: np.ndarray, n_steps: int, control_dt: float) -> tuple:
        """:func:`~cepam_gym.planning.episodes.planned_schedules`."""
        return planned_schedules(rngs, self.spec, rows, n_steps, control_dt)

    def start(self, s, idx: np.ndarray, initial: np.ndarray) -> None:
        """At rest at the (length, stiffness) rows under the first load: chamber pressures of the
        inverse static model, step 0 (:func:`~cepam_gym.planning.episodes.start_at_rest`)."""
        s.initial[idx] = initial
        start_at_rest(s, idx, initial)

    def apply_options(self, s, options: dict) -> None:
        """Pin any of target_length [m], target_stiffness [N/m], load_mass [kg] for the episode
        (the env observes once afterwards)."""
        self.pin(s, options, np.arange(s.state.shape[0]))

    def pin(self, s, values: dict, idx: np.ndarray) -> None:
        """Hold ``values`` (pin key -> scalars or per-env arrays) for the episode of ``idx``."""
        for name, arr in (
            ("target_length", s.target_l),
            ("target_stiffness", s.target_k),
            ("load_mass", s.load),
        ):
            val = values.get(name)
            if val is None:
                continue
            try:
                v = np.broadcast_to(np.asarray(val, dtype=float), idx.shape)
            except (TypeError, ValueError):
                raise InputError(
                    f"{name} must be a number or one per env ({len(idx)}), got {val!r}"
                ) from None
            self._check_pin(name, v)
            arr[idx] = v[:, None]

    def _check_pin(self, name: str, v: np.ndarray) -> None:
        """Units and ranges of a pinned target (SI: m, N/m, kg), ``ValueError`` naming it."""
        if not np.isfinite(v).all():
            raise InputError(f"{name} must be finite, got {v.tolist()}")
        if name == "target_length":
            lo, hi = self.nominal.min_length, self.nominal.max_length
            if ((v < lo) | (v > hi)).any():
                raise InputError(
                    f"target_length is in metres and must lie within the end stops "
                    f"[{lo:g}, {hi:g}] m, got {v.tolist()} (17.5 cm is 0.175)"
                )
        elif name == "target_stiffness":
            if (v <= 0).any():
                raise InputError(f"target_stiffness must be > 0 N/m, got {v.tolist()}")
        elif name == "load_mass":
            if (v < 0).any():
                raise InputError(f"load_mass must be >= 0 kg, got {v.tolist()}")
            if (v > _MAX_LOAD_KG).any():
                raise InputError(
                    f"load_mass is in kg and at most {_MAX_LOAD_KG:g} kg, got {v.tolist()} (200 g is 0.2)"
                )

    # ------------------------------------------------------------------ info
    def info_single(self, s, scored: bool) -> dict[str, Any]:
        """:meth:`info_arrays` of env 0 as Python floats, built without temporary arrays (the
        single env's step is dominated by Python overhead, so this path is kept lean)."""
        k = min(max(int(s.t_idx[0]) - (1 if scored else 0), 0), s.target_l.shape[1] - 1)
        rows = {STATE: s.state[0].tolist(), AUX: s.aux[0].tolist()}
        at_k = {
            LOAD: float(s.load[0, k]),
            TARGET_L: float(s.target_l[0, k]),
            TARGET_K: float(s.target_k[0, k]),
        }
        info = {key: rows[src][col] if src in rows else at_k[src] for key, src, col in RIG_INFO}
        if scored:
            info.update(zip(self.term_keys, s.terms[0].tolist()))
        info["redraws"] = int(s.redraws[0])
        return info

    def info_arrays(self, s, scored: bool) -> dict[str, np.ndarray]:
        """Per-env info arrays: true plant quantities (SI), the targets scored, reward terms. Each
        group is gathered in one copy and handed out as its rows (fresh arrays every step)."""
        k = np.minimum(np.maximum(s.t_idx - (1 if scored else 0), 0), s.target_l.shape[1] - 1)
        r = np.arange(s.state.shape[0])
        got = dict(zip(_STATE_KEYS, np.ascontiguousarray(s.state[:, _STATE_COLS].T)))
        got.update(zip(_AUX_KEYS, np.ascontiguousarray(s.aux[:, _AUX_COLS].T)))
        at_k = {LOAD: s.load[r, k], TARGET_L: s.target_l[r, k], TARGET_K: s.target_k[r, k]}
        out = {key: got[key] if src in (STATE, AUX) else at_k[src] for key, src, _ in RIG_INFO}
        if scored:
            out.update(zip(self.term_keys, np.ascontiguousarray(s.terms.T)))
        out["redraws"] = s.redraws.copy()
        return out
