"""Batched env state shared by the single env and the vector env (one code path for both).

:class:`CEPAMBatch` owns the arrays of N envs (plant state, parameters, schedules, buffers) and
implements ``reset(indices)`` and ``step(actions)`` on them; the Gymnasium classes in
:mod:`cepam_gym.envs.cepam` only add spaces, seeding and ``info``.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np

from .. import plant as pl
from .._jit import bound
from ..errors import InputError
from ..physics import layout as ix
from ..planning.episodes import PARALLEL_MIN_ENVS
from ..planning.randomization import MAX_REDRAWS
from ..plant.actions import check_action_mode
from ..tasks import schedule as sched
from . import id_window as win
from . import step_kernel as tk
from .checks import as_actions, check_noise, check_randomize, check_threads, check_timing, resolve_params
from .records import allocate, build
from .single_slabs import single_slabs
from .state import EnvState, StepSettings, dims
from .step_source import step_module
from .streams import RandomStreams
from .task import Task
from .task_registry import make_task
from .threads import KernelThreads, numba_threads


class CEPAMBatch(RandomStreams):
    """N CE-PAM envs as arrays. Not a Gymnasium class: see :mod:`cepam_gym.envs.cepam`.

    What the envs are asked to do is the :class:`~cepam_gym.envs.task.Task` object ``task`` (a
    task name, rig or joint, or a Task): its mechanism (the rig's free end or a hinge), layout,
    task vector, plant checks, references, starting point, reset options and info. The core holds
    the plant and the arrays, and steps them with the one compiled kernel whatever the task."""

    def __init__(
        self,
        num_envs: int = 1,
        task: str | Task = "cepam",
        plant=None,
        action_mode: str = "valve",
        control_dt: float = 0.02,
        sub_dt: float = 5e-4,
        episode_seconds: float = 10.0,
        reward_weights: Mapping[str, float] | None = None,
        randomize: Mapping[str, Any] | None = None,
        sensor_noise: Mapping[str, float] | None = None,
        action_latency_steps: int = 0,
        supply_drift_kpa: float = 0.0,
        task_options: Mapping[str, Any] | None = None,
        stream: int = 0,
        num_threads: int | None = None,
        preview_steps: int = 0,
        joint: Mapping[str, float] | None = None,
    ):
        self._init_args = {k: v for k, v in locals().items() if k not in ("self", "__class__")}
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise InputError(f"num_envs must be a positive integer, got {num_envs!r}")
        self.num_envs = n = int(num_envs)
        self.task = make_task(task, task_options, reward_weights, preview_steps, joint)
        self.preview_steps = self.task.preview_steps
        self.mech = self.task.mech
        self.mode = check_action_mode(action_mode)
        self.action_mode = action_mode
        self.n_sub, n_tracked = check_timing(control_dt, sub_dt, episode_seconds)
        self.control_dt, self.sub_dt = float(control_dt), float(sub_dt)
        # the identification window's steps come first (envs.id_window); n_steps counts both
        self.n_window = win.window_steps(self.task.spec, self.control_dt)
        self.n_tracked, self.n_steps = n_tracked, self.n_window + n_tracked
        self.nominal = resolve_params(plant)
        self.task.bind(self.nominal, self.sub_dt, self.control_dt)
        if self.nominal.supply_pressure > self.nominal.burst_pressure:
            warnings.warn(
                f"supply_pressure ({self.nominal.supply_pressure / 1e3:g} kPa) is above "
                f"burst_pressure ({self.nominal.burst_pressure / 1e3:g} kPa): a fully open supply "
                "valve bursts the bladder (the episode then terminates, reason 'burst')",
                stacklevel=3,
            )
        self.randomize = check_randomize(randomize)
        self.randomizer = self.task.randomizer(self.randomize, self.sub_dt)
        self.noise_sd = check_noise(sensor_noise)
        if int(action_latency_steps) != action_latency_steps or action_latency_steps < 0:
            raise InputError(f"action_latency_steps must be an integer >= 0, got {action_latency_steps!r}")
        self.latency = int(action_latency_steps)
        if isinstance(stream, bool) or int(stream) != stream or stream < 0:
            raise InputError(f"stream must be an integer >= 0, got {stream!r}")
        self.stream = int(stream)
        self.num_threads = check_threads(num_threads)
        self.threads = KernelThreads(self.num_threads, n, pl.PARALLEL_MIN_BATCH)
        if not (np.isfinite(supply_drift_kpa) and supply_drift_kpa >= 0):
            raise InputError(f"supply_drift_kpa must be finite and >= 0, got {supply_drift_kpa!r}")
        self.supply_drift = float(supply_drift_kpa) * 1e3  # Pa per sqrt(s)
        self.planned = self._declared_schedules(n)
        self.obs_layout = self.task.layout
        self.task_params = self.task.params
        # the step compiled with the task's reward and terminations
        self.step_module = step_module(self.task.reward, self.task.terminations)
        self.obs_dim = self.obs_layout.size
        self.settings = build(StepSettings, mech=self.mech, mode=self.mode, dt=self.sub_dt, n_sub=self.n_sub)
        self._allocate(n)

    def _declared_schedules(self, n: int) -> sched.PlannedSchedules | None:
        """The task's declared schedules of plant parameters (:mod:`cepam_gym.tasks.schedule`), or
        None without any."""
        declared = self.task.schedules
        if not declared:
            return None
        if self.supply_drift and any(s.column == "P_SUP" for s in declared):
            raise InputError(
                "supply_drift_kpa drifts the supply pressure, which a schedule of the task drives: "
                "drop one of them"
            )
        return sched.PlannedSchedules(declared, n, self.n_steps, self.n_window)

    def _allocate(self, n: int) -> None:
        """The env state's arrays for ``n`` envs at the nominal plant, the latency queue, the
        random streams and the bound kernels (the end of construction)."""
        self._nominal_row = nominal_row = self.nominal.to_array()
        self.has_noise = bool(self.noise_sd.any())
        # a single env without latency, supply drift, window or declared schedules steps through
        # one jitted call (envs.step.env_step_single) on slabs its state's arrays are views of
        self.fast_single = (
            n == 1 and not self.latency and not self.supply_drift and not self.n_window and not self.planned
        )
        if n == 1:
            self.slabs, self.s, extras = single_slabs(
                self.n_steps, self.obs_dim, self.settings, self.task_params
            )
            self.info_row = extras.info
        else:
            self.s = allocate(EnvState, dims(n, self.n_steps, self.obs_dim, self.has_noise))
        self.s.params[:] = nominal_row
        self.s.hinge[:] = self.task.hinge_row()
        self.needs_reset = True  # no episode yet: the envs refuse to step (Gymnasium's ResetNeeded)
        self.queue = np.zeros((self.latency + 1, n, 2))
        self.seed(None)
        # prev_action doubles as the buffer of the action being applied (clipped in place by the
        # kernel), so after a step it holds a_{t-1}
        self._single_action = self.s.prev_action
        self._step_args = (self.s, self.settings, self.task_params)
        self._kernels = None  # the step's compiled entry points, bound at the first step
        self._observe_kernel = bound(tk.observe, (self.s, self.mech, self.task_params))

    # -------------------------------------------------- copies, pickles
    # besides the env state, what a running episode is: the latency queue and the noise buffers
    _CORE_ARRAYS = ("queue", "_normals", "_normal_pos")

    def episode_state(self) -> dict[str, Any]:
        """Everything a running episode is (arrays, random streams), as copies."""
        out = {k: v.copy() for k, v in self.s._asdict().items()}
        out.update((k, getattr(self, k).copy()) for k in self._CORE_ARRAYS)
        out["rngs"] = [r.bit_generator.state for r in self.streams.generators()]
        out["noise_rngs"] = [r.bit_generator.state for r in self.noise_rngs]
        if self.planned:
            out["schedules"] = self.planned.values.copy()
            out["schedule_rngs"] = [r.bit_generator.state for r in self.schedule_rngs]
        out["needs_reset"] = self.needs_reset
        return out

    def restore(self, episode: dict[str, Any]) -> None:
        """Continue the episode of :meth:`episode_state` (on a core built with the same args)."""
        for k, v in self.s._asdict().items():
            v[...] = episode[k]
        for k in self._CORE_ARRAYS:
            getattr(self, k)[...] = episode[k]
        for r, st in zip(self.streams.generators(), episode["rngs"]):
            r.bit_generator.state = st
        for r, st in zip(self.noise_rngs, episode["noise_rngs"]):
            r.bit_generator.state = st
        if self.planned:
            self.planned.values[...] = episode["schedules"]
            for r, st in zip(self.schedule_rngs, episode["schedule_rngs"]):
                r.bit_generator.state = st
        self.needs_reset = episode["needs_reset"]

    def __getstate__(self) -> dict[str, Any]:
        # rebuilt from the constructor's arguments, then the episode restored in place: the
        # single env's arrays are views of its slabs and the bound kernels hold the records,
        # which a plain copy of __dict__ would tear apart
        return {"init": self._init_args, "episode": self.episode_state()}

    def __setstate__(self, st: dict[str, Any]) -> None:
        self.__init__(**st["init"])
        self.restore(st["episode"])

    # ------------------------------------------------------------------ reset
    def apply_options(self, options: dict | None) -> None:
        """``reset(options=...)``: the task's pin keys (``task.pin_keys``; the rig's:
        target_length [m], target_stiffness [N/m], load_mass [kg] held for the episode, scalars
        or per-env arrays)."""
        if not options:
            return
        if not isinstance(options, Mapping):
            raise InputError(
                f"reset options must be a dict with keys among {list(self.task.pin_keys)}, "
                f"got {type(options).__name__}"
            )
        bad = set(options) - set(self.task.pin_keys)
        if bad:
            raise InputError(f"reset options: unknown keys {sorted(bad)}; valid: {list(self.task.pin_keys)}")
        self.task.apply_options(self.s, dict(options))
        self._observe()

    def pin_targets(self, target_length=None, target_stiffness=None, load_mass=None, indices=None) -> None:
        """Hold the given target length [m], stiffness [N/m] or load [kg] for the whole episode of
        ``indices`` (scalars or per-env arrays); call right after :meth:`reset`. Used by the
        benchmark harness and for evaluation at chosen operating points (rig tasks)."""
        idx = np.arange(self.num_envs) if indices is None else np.asarray(indices)
        values = {
            "target_length": target_length,
            "target_stiffness": target_stiffness,
            "load_mass": load_mass,
        }
        self.task.pin(self.s, values, idx)
        self._observe()

    def _observe(self) -> None:
        """The observations of every env from its current state (after a reset or a pin)."""
        self._observe_kernel(self.s, self.mech, self.task_params)

    def reset(self, indices=None) -> None:
        """Start new episodes for ``indices`` (all envs if None): parameters, schedules, state."""
        idx = np.arange(self.num_envs) if indices is None else np.asarray(indices, dtype=np.int64)
        if self.randomizer.ranges:
            self.s.params[idx], self.s.redraws[idx] = self.randomizer.draw(self.streams.generators(idx))
        else:
            self.s.params[idx], self.s.redraws[idx] = self._nominal_row, 0
        tl, tkk, load, initial = self._schedules(idx)
        self.s.target_l[idx], self.s.target_k[idx], self.s.load[idx] = tl, tkk, load
        if self.planned:  # the declared schedules' first values are in the rows the start reads
            rngs = [self.schedule_rngs[i] for i in idx]
            self.planned.plan(idx, rngs, self.s.params, self.control_dt)
        self.task.start(self.s, idx, initial)
        self.s.prev_action[idx] = 0.0
        self.queue[:, idx] = 0.0
        self._draw_noise(idx)
        self._observe()
        if indices is None:
            self.needs_reset = False

    def _plan(self, rngs, rows: np.ndarray) -> tuple:
        """``(target_l, target_k, load, initial)`` of the task (:meth:`Task.plan`), the
        identification window's steps in front (:func:`~cepam_gym.envs.id_window.prepend`)."""
        return win.prepend(self.task.plan(rngs, rows, self.n_tracked, self.control_dt), self.n_window)

    def _schedules(self, idx: np.ndarray) -> tuple:
        """:meth:`_plan` of the envs ``idx``. A plant for which the task finds no
        reachable target (``RuntimeError``) is redrawn with its schedule, env by env from its own
        stream (the streams are rewound first, so every env draws as it would alone)."""
        view = self.streams.view(idx)
        saved = view.pack()
        try:
            if len(idx) < PARALLEL_MIN_ENVS:  # planned serially
                return self._plan(view, self.s.params[idx])
            with numba_threads(self.threads.now()):  # the planner runs env by env on these
                return self._plan(view, self.s.params[idx])
        except RuntimeError:
            pass
        view.unpack(saved)
        out = [np.empty((len(idx), self.n_steps)) for _ in range(3)] + [np.empty((len(idx), 2))]
        for j, (i, rng) in enumerate(zip(idx, self.streams.generators(idx))):
            for attempt in range(MAX_REDRAWS + 2):
                try:
                    one = self._plan([rng], self.s.params[i : i + 1])
                    break
                except RuntimeError:
                    if attempt == MAX_REDRAWS + 1:
                        raise
                    self.s.redraws[i] += 1
                    if attempt >= MAX_REDRAWS:  # the nominal plant (checked at build), a new schedule
                        self.s.params[i] = self.randomizer.fallback()
                    else:
                        rows, extra = self.randomizer.draw([rng])
                        self.s.params[i], self.s.redraws[i] = rows[0], self.s.redraws[i] + extra[0]
            for a, b in zip(out, one):
                a[j] = b[0]
        return tuple(out)

    # ------------------------------------------------------------------- step
    def check_actions(self, actions, single: bool = False) -> np.ndarray:
        """A float64 (N, 2) copy of ``actions``; ``InputError`` on a wrong shape (exactly (2,) for
        a ``single`` env, (N, 2) for a batch: :func:`~.checks.as_actions`), NaN or inf.
        Out-of-range values are clipped by the step kernel."""
        if single and isinstance(actions, np.ndarray) and actions.shape == (2,):
            # the single env's hot path: no temporary arrays
            if actions.dtype.kind not in "biuf":
                as_actions(actions, 1, single=True)  # raises, naming the dtype
            x0, x1 = float(actions[0]), float(actions[1])
            if not (math.isfinite(x0) and math.isfinite(x1)):
                raise InputError(f"action contains NaN or inf: {actions.tolist()}; actions must be finite")
            a = self._single_action
            a[0, 0] = x0
            a[0, 1] = x1
            return a
        self.s.prev_action[:] = as_actions(actions, self.num_envs, single=single)
        return self.s.prev_action

    def step(self, actions: np.ndarray, active: np.ndarray | None = None) -> None:
        """Advance all envs one control period; results in ``obs``, ``rewards``, ``terms``,
        ``reasons``, ``aux``. ``actions`` must be what :meth:`check_actions` returned (the
        ``prev_action`` buffer, clipped in place by the kernel). ``active``: indices of the envs
        whose step counts (the others are reset right after, by a next-step autoreset): only
        they draw sensor noise and supply drift from their streams, as a single env would."""
        if self.latency:
            self.queue[:-1] = self.queue[1:]
            self.queue[-1] = actions
            self.s.prev_action[:] = self.queue[0]  # what reaches the valves now
        z = self._draw_noise(active)
        if self.supply_drift:
            nominal = self.nominal.atmospheric_pressure + self.nominal.supply_pressure
            rows = slice(None) if active is None else active
            walk = z * self.supply_drift * np.sqrt(self.control_dt)
            self.s.params[rows, ix.P_SUP] = np.clip(
                self.s.params[rows, ix.P_SUP] + walk, 0.8 * nominal, 1.2 * nominal
            )
        if self.planned:
            self.planned.apply(self.s.params, self.s.t_idx)
        if self._kernels is None:
            parallel = self.num_envs >= pl.PARALLEL_MIN_BATCH  # else never called
            serial, par = self.step_module._env_step_serial, self.step_module._env_step_parallel
            self._kernels = (bound(serial, self._step_args), bound(par, self._step_args) if parallel else par)
        windowed = self.s.t_idx < self.n_window if self.n_window else None
        self.threads.run(*self._kernels, self._step_args)
        if windowed is not None:
            self._window_step(windowed)

    def _window_step(self, windowed: np.ndarray) -> None:
        """After a step: the window's steps unscored; the envs whose window just ended (and that
        did not fail in it) restarted at rest at their starting point, as the reset started them."""
        win.unscore(self.s, windowed, self.task.reward)
        ended = np.flatnonzero(windowed & (self.s.t_idx == self.n_window) & (self.s.reasons == 0))
        if ended.size:
            self.task.start(self.s, ended, self.s.initial[ended].copy())
            self.s.t_idx[ended] = self.n_window
            self.s.prev_action[ended] = 0.0
            self.queue[:, ended] = 0.0
            self._observe()

    def window_info(self, scored: bool) -> dict[str, np.ndarray]:
        """``{"window": per-env bool}`` when the task has an identification window (else empty):
        the step just taken (``scored``; after a reset: the next one) is in it."""
        if not self.n_window:
            return {}
        return {win.INFO_KEY: win.in_window(self.s.t_idx, self.n_window, scored)}

    def schedule_info(self, scored: bool) -> dict[str, np.ndarray]:
        """The task's declared schedules (:mod:`cepam_gym.tasks.schedule`) at the step just taken
        (``scored``; after a reset: the next one), per env and SI; empty without any."""
        return self.planned.info(self.s.t_idx, scored) if self.planned else {}

    def current_targets(self):
        """(target length, target stiffness, load) each env is asked for at its current step."""
        k = np.minimum(self.s.t_idx, self.n_steps - 1)
        r = np.arange(self.num_envs)
        return self.s.target_l[r, k], self.s.target_k[r, k], self.s.load[r, k]


def _state_field(name: str) -> property:
    return property(lambda self: getattr(self.s, name), doc=f"``s.{name}`` (:class:`EnvState`)")


# the env state's fields read as the core's attributes (core.state, core.params, ...), read-only:
# the arrays are written in place, never replaced
for _name in EnvState._fields:
    setattr(CEPAMBatch, _name, _state_field(_name))
