"""Receding-horizon planning through the plant kernel: the cross-entropy method (CEM).

A plan is a sequence of valve commands over ``horizon_steps`` control steps. Each iteration
samples a population of plans around the current mean (noise held constant over ``hold_steps``
control steps, so the search has few dimensions while the mean stays per step), simulates every
sample with :func:`cepam_gym.plant.step` (the plant's own kernel, all envs' populations in one
batched call), scores it with the benchmark's error norms, and refits the mean and spread to the
best ``elites`` (Rubinstein 1999; as in sampling-based MPC for robotics, e.g. Williams et al. 2017
and Pinneri et al. 2020). After the last iteration the first command of the best simulated plan is
sent, and that plan, shifted by one step, warm-starts the next control step.

The cost of a step is ``(e_L / 5 mm)^2 + (e_K / K* / 20 %)^2`` (the stiffness term only where the
task tracks it) plus a large penalty when a chamber passes the burst pressure: the squared form
of the benchmark's combined score (:mod:`cepam_gym.bench.metrics`), so the planner optimises what
the benchmark measures. Who supplies the state, parameters, loads and targets makes the planner an
oracle (the true ones, :mod:`cepam_gym.control.oracle`) or a practical controller (estimates).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import plant as pl
from ..tasks import kernel as tk

LENGTH_NORM = 5e-3  # m: the benchmark's score counts 5 mm of length error as 1 ...
STIFFNESS_NORM = 0.2  # ... and 20 % of stiffness error as 1
BURST_COST = 1e3  # per step on which a chamber passes the burst pressure


@dataclass(frozen=True)
class CEMConfig:
    """Search settings. Costs per control step and env: ``population * iterations`` simulated
    plants of ``horizon_steps`` control steps."""

    # 0.2 s at 50 Hz, noise held over 2 steps, 6 refinements down to a spread of 0.005: chosen
    # by measurement (nominal-v1, 6 episodes: score 0.38 with 15/3/3 iterations/0.05, 0.10 here)
    horizon_steps: int = 10
    hold_steps: int = 2
    population: int = 48
    elites: int = 6
    iterations: int = 6
    init_std: float = 0.3
    min_std: float = 0.005
    effort_weight: float = 0.1  # cost per unit squared command and step: holds still at rest
    seed: int = 0

    def __post_init__(self):
        for name in ("horizon_steps", "hold_steps", "population", "elites", "iterations"):
            v = getattr(self, name)
            if int(v) != v or v < 1:
                raise ValueError(f"CEMConfig.{name} must be a positive integer, got {v!r}")
        if self.elites > self.population:
            raise ValueError(
                f"CEMConfig.elites ({self.elites}) must not exceed population ({self.population})"
            )
        if not (0 < self.min_std <= self.init_std):
            raise ValueError(f"CEMConfig needs 0 < min_std <= init_std, got {self.min_std}, {self.init_std}")


class CEMPlanner:
    """CEM over valve commands for a batch of N plants (see the module docstring).

    ``mode``, ``sub_dt``, ``n_sub``: the env's valve mode and integration; ``setpoint_max`` [Pa]:
    the pressure a command of +1 means in ``pressure`` mode (as the env maps it)."""

    def __init__(
        self,
        cfg: CEMConfig,
        mode: int,
        sub_dt: float,
        n_sub: int,
        setpoint_max: float,
        track_stiffness: bool = True,
    ):
        self.cfg = cfg
        self.mode, self.sub_dt, self.n_sub = int(mode), float(sub_dt), int(n_sub)
        self.setpoint_max = float(setpoint_max)
        self.track_stiffness = bool(track_stiffness)
        self.rng = np.random.default_rng(cfg.seed)
        self.mean: np.ndarray | None = None  # (N, H, 2) warm start

    def reset(self, indices=None) -> None:
        """Forget the warm start of all envs, or of ``indices``."""
        if indices is None or self.mean is None:
            self.mean = None
        else:
            self.mean[np.asarray(indices)] = 0.0

    def _commands(self, a: np.ndarray) -> np.ndarray:
        """Plant valve commands (M, 2) of env actions (M, 2) in [-1, 1]: the env kernel's mapping."""
        if self.mode != pl.PRESSURE:
            return a
        c, e = tk.valve_commands(self.mode, a[:, 0], a[:, 1], self.setpoint_max)
        return np.stack([c, e], axis=1)

    def rollout_cost(self, state, params, actions, target_l, target_k, load) -> np.ndarray:
        """Cost (M,) of action sequences ``actions`` (M, H, 2) from states (M, N_STATE) with
        parameter rows (M or 1, N_PARAMS), targets and loads (M, H)."""
        m, h = actions.shape[:2]
        x = state.copy()
        inputs = np.zeros((m, pl.N_INPUT))
        aux = np.empty((m, pl.N_AUX))
        cost = np.zeros(m)
        for t in range(h):
            inputs[:, :2] = self._commands(actions[:, t])
            inputs[:, pl.I_LOAD] = load[:, t]
            pl.step(x, inputs, params, self.mode, self.sub_dt, self.n_sub, out=x, aux=aux)
            cost += ((x[:, pl.S_L] - target_l[:, t]) / LENGTH_NORM) ** 2
            if self.track_stiffness:
                cost += ((aux[:, pl.A_STIFF] - target_k[:, t]) / (STIFFNESS_NORM * target_k[:, t])) ** 2
            cost += BURST_COST * aux[:, pl.A_BURST]
            cost += self.cfg.effort_weight * (actions[:, t] ** 2).sum(axis=1)
        return np.where(np.isfinite(cost), cost, np.inf)

    def plan(self, state, params, target_l, target_k, load) -> np.ndarray:
        """First actions (N, 2) of the plans for N plants: ``state`` (N, N_STATE), ``params``
        (N or 1, N_PARAMS), ``target_l``, ``target_k``, ``load`` (N, H) over the horizon."""
        cfg = self.cfg
        n, h, p = state.shape[0], cfg.horizon_steps, cfg.population
        if self.mean is None or self.mean.shape[0] != n:
            self.mean = np.zeros((n, h, 2))
        mean = self.mean
        std = np.full((n, 1, 2), cfg.init_std)
        n_blocks = -(-h // cfg.hold_steps)
        block_of_step = np.arange(h) // cfg.hold_steps
        xs = np.repeat(state, p, axis=0)
        prow = params if params.shape[0] == 1 else np.repeat(params, p, axis=0)
        tl, tk, ld = (np.repeat(a, p, axis=0) for a in (target_l, target_k, load))
        for _ in range(cfg.iterations):
            noise = self.rng.standard_normal((n, p, n_blocks, 2))[:, :, block_of_step]
            noise[:, 0] = 0.0  # the mean itself is always a candidate ...
            samples = np.clip(mean[:, None] + std[:, None] * noise, -1.0, 1.0)
            if self.mode != pl.PRESSURE:
                samples[:, 1] = 0.0  # ... and so are closed valves (hold the air as it is)
            cost = self.rollout_cost(xs, prow, samples.reshape(n * p, h, 2), tl, tk, ld).reshape(n, p)
            order = np.argsort(cost, axis=1)
            chosen = np.take_along_axis(samples, order[:, : cfg.elites, None, None], axis=1)  # (N, E, H, 2)
            best = chosen[:, 0]
            mean = chosen.mean(axis=1)
            std = np.maximum(chosen.std(axis=1).mean(axis=1, keepdims=True), cfg.min_std)
        # the best simulated plan, not the elite mean (an average of noisy samples that was never
        # simulated and chatters at steady state); it warm-starts the next step, one step on
        self.mean = np.concatenate([best[:, 1:], best[:, -1:]], axis=1)
        return best[:, 0].copy()


def planner_for(core, config: CEMConfig | None = None, **overrides) -> CEMPlanner:
    """A planner for the envs of ``core`` (a :class:`~cepam_gym.envs.core.CEPAMBatch`): its valve
    mode, integration, pressure range and task; ``overrides`` replace fields of ``config``."""
    import dataclasses

    cfg = dataclasses.replace(config or CEMConfig(), **overrides)
    return CEMPlanner(
        cfg,
        core.mode,
        core.sub_dt,
        core.n_sub,
        float(core.task_vec[tk.T_SETPOINT_MAX]),
        track_stiffness=core.task.track_stiffness,
    )
