"""Receding-horizon planning through the plant kernel: the cross-entropy method, iCEM-style.

A plan is a sequence of valve commands over ``horizon_steps`` control steps. Each iteration
samples a population of plans around the current mean with time-correlated ("coloured", power
spectrum ``1/f^noise_beta``) noise, simulates every sample through the plant's own block kernel
(:func:`cepam_gym.control.rollout.rollout_cost`, all envs' populations in one compiled call),
scores it with the benchmark's objective (:mod:`cepam_gym.control.objective`), and refits the mean
and spread to the best ``elites`` (Rubinstein 1999; iCEM: Pinneri et al. 2020, whose coloured
noise, kept elites and momentum this follows). After the last iteration the first command of the
best plan simulated is sent (``CEMConfig.send="mean"``: the first command of the refined mean, a
smoother label for a student, whose plan as a whole was never simulated).

Why more search can only help: every iteration's population contains the current mean, the plan
of closed valves and the best plans kept from the previous iteration (the first iteration: the
previous control step's, shifted by one step), and the plan sent is the best ever simulated. So
a larger population or more iterations adds candidates and removes none (with ``send="mean"`` this
holds for the best plan found, not for the command sent).

The cost of a plan is the sum over its steps of ``w (e_L / L_norm)^2 + w (e_K / K* / 20 %)^2``
(the stiffness term only where the task tracks it) plus a large penalty on a step where a chamber
passes the burst pressure, plus a small effort term that only breaks ties (closed valves when
nothing else matters). ``w`` is 1 on the steps the benchmark scores and ``allowance_weight``
within its settling allowance after a jump of the target (a privileged planner knows the schedule:
:func:`~cepam_gym.control.objective.scored_steps`). Who supplies the state, parameters, loads and
targets makes the planner an oracle (the true ones, :mod:`cepam_gym.control.oracle`) or a practical
controller (estimates, :mod:`cepam_gym.control.mpc`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numba import njit

from .. import plant as pl
from ..envs import step_kernel as tk
from ..errors import InputError
from .objective import RIG, STIFFNESS_NORM, TraceSpec
from .rollout import rollout_cost

BURST_COST = 1e3  # per step on which a chamber passes the burst pressure


@dataclass(frozen=True)
class CEMConfig:
    """Search settings. Costs per control step and env: ``population * iterations`` simulated
    plants of ``horizon_steps`` control steps. The defaults are the practical MPC's (a 0.2 s
    horizon: its preview); the oracle's are :data:`cepam_gym.control.oracle.ORACLE_CONFIG`."""

    horizon_steps: int = 10
    population: int = 48
    elites: int = 6
    iterations: int = 6
    init_std: float = 0.3
    min_std: float = 0.005
    noise_beta: float = 2.0  # exponent of the noise's power spectrum: 0 white, 2 iCEM's default
    keep_elites: float = 0.5  # fraction of the elites carried into the next iteration and step
    momentum: float = 0.1  # share of the previous mean and spread kept at each refit (iCEM's alpha)
    effort_weight: float = 0.1  # cost per unit squared command and step: holds still at rest
    allowance_weight: float = 0.0  # weight of errors within the settling allowance (score: 0)
    seed: int = 0
    # sub-steps per control step of the planner's own simulation; None: the env's integration.
    # Fewer, longer sub-steps make a plan cheaper and its model coarser (the sub-step must stay
    # stable: :meth:`CEMPlanner.check_stability` asks it of every new set of parameter rows)
    plan_substeps: int | None = None
    # what is sent: "best", the first command of the best plan simulated; "mean", the first
    # command of the refitted mean (averaged over the elites, so it varies less from one step's
    # draws to the next: smoother labels for a student to imitate; never simulated as a whole)
    send: str = "best"

    def __post_init__(self):
        for name in ("horizon_steps", "population", "elites", "iterations"):
            v = getattr(self, name)
            if int(v) != v or v < 1:
                raise InputError(f"CEMConfig.{name} must be a positive integer, got {v!r}")
        v = self.plan_substeps
        if v is not None and (isinstance(v, bool) or int(v) != v or v < 1):
            raise InputError(f"CEMConfig.plan_substeps must be a positive integer or None, got {v!r}")
        if self.send not in ("best", "mean"):
            raise InputError(f"CEMConfig.send must be 'best' or 'mean', got {self.send!r}")
        if self.elites > self.population:
            raise InputError(
                f"CEMConfig.elites ({self.elites}) must not exceed population ({self.population})"
            )
        if not (0 < self.min_std <= self.init_std):
            raise InputError(f"CEMConfig needs 0 < min_std <= init_std, got {self.min_std}, {self.init_std}")
        for name, lo, hi in (("noise_beta", 0.0, 4.0), ("keep_elites", 0.0, 1.0), ("momentum", 0.0, 0.99)):
            v = getattr(self, name)
            if not lo <= v <= hi:
                raise InputError(f"CEMConfig.{name} must lie in [{lo}, {hi}], got {v!r}")
        for name in ("effort_weight", "allowance_weight"):
            if not getattr(self, name) >= 0:
                raise InputError(f"CEMConfig.{name} must be >= 0, got {getattr(self, name)!r}")

    def scaled(self, effort: float) -> CEMConfig:
        """The same search with ``effort`` times the iterations (what refines the plan: the
        convergence study's "x2, x4")."""
        return dataclasses.replace(self, iterations=max(1, int(round(self.iterations * effort))))


def coloured_noise(rng: np.random.Generator, shape: tuple, beta: float, draws: int = 1) -> np.ndarray:
    """Unit-variance Gaussian noise along the last axis with power spectrum ``1/f^beta``
    (Timmer and Koenig 1995, as iCEM samples it); ``beta = 0`` is white noise. ``draws > 1``
    returns ``(draws,) + shape``: the same numbers as ``draws`` calls in a row, from one call to
    the generator and one transform (the planner draws all its iterations' noise at once)."""
    h = shape[-1]
    lead = (draws,) if draws > 1 else ()
    if beta == 0.0 or h < 2:
        return rng.standard_normal(lead + tuple(shape))
    f = np.fft.rfftfreq(h)
    f[0] = f[1]  # no infinite power at zero frequency
    s = f ** (-beta / 2.0)
    w = s[1:].copy()
    w[-1] *= (1 + (h % 2)) / 2.0
    sigma = 2.0 * np.sqrt(np.sum(w**2)) / h
    # each draw takes its real parts, then its imaginary parts, from the stream
    z = rng.standard_normal(lead + (2,) + tuple(shape[:-1]) + (f.size,))
    spec = np.take(z, 0, axis=len(lead)) + 1j * np.take(z, 1, axis=len(lead))
    spec.imag[..., 0] = 0.0
    if h % 2 == 0:
        spec.imag[..., -1] = 0.0
    return np.fft.irfft(spec * s, n=h, axis=-1) / sigma


def _shift(a: np.ndarray) -> np.ndarray:
    """Plans one control step on (time is axis -2): drop the first command, repeat the last."""
    return np.concatenate([a[..., 1:, :], a[..., -1:, :]], axis=-2)


class CEMPlanner:
    """The search of the module docstring for a batch of N plants.

    ``mode``, ``sub_dt``, ``n_sub``: the env's valve mode and integration; ``setpoint_max`` [Pa]:
    the pressure a command of +1 means in ``pressure`` mode (as the env maps it); ``mech`` and
    ``hinge``: the rig (default) or a hinge with its rows of constants; ``length_norm`` [m]: the
    muscle-length error that scores 1 (the rig's 5 mm by default; a hinge's angle norm times its
    lever arm)."""

    def __init__(
        self,
        cfg: CEMConfig,
        mode: int,
        sub_dt: float,
        n_sub: int,
        setpoint_max: float,
        track_stiffness: bool = True,
        mech: int = pl.RIG,
        hinge: np.ndarray | None = None,
        length_norm: float | None = None,
    ):
        self.cfg = cfg
        self.mode, self.sub_dt, self.n_sub = int(mode), float(sub_dt), int(n_sub)
        self.setpoint_max = float(setpoint_max)
        self.track_stiffness = bool(track_stiffness)
        self.mech = int(mech)
        self.hinge = tk.no_hinge() if hinge is None else np.atleast_2d(np.asarray(hinge, dtype=float))
        self.length_norm = RIG.position_norm if length_norm is None else float(length_norm)
        self.rng = np.random.default_rng(cfg.seed)
        # a coarser integration than the env's (CEMConfig.plan_substeps) is checked for stability
        # on every new set of parameter rows: randomized plants arrive at reset, after the build
        self.check_rows = False
        self._checked_rows: np.ndarray | None = None
        self.mean: np.ndarray | None = None  # (N, H, 2) warm start: the last best plan, shifted
        self.kept: np.ndarray | None = None  # (N, k, H, 2) the last elites kept, shifted
        self.last_cost: np.ndarray | None = None

    def reset(self, indices=None) -> None:
        """Forget the warm start of all envs, or of ``indices``."""
        if indices is None or self.mean is None:
            self.mean = self.kept = None
        else:
            self.mean[np.asarray(indices)] = 0.0
            if self.kept is not None:
                self.kept[np.asarray(indices)] = 0.0

    def rollout_cost(self, state, params, actions, target_l, target_k, load, weight=None) -> np.ndarray:
        """Cost (M,) of action sequences ``actions`` (M, H, 2) from states (M, N_STATE) with
        parameter rows (M or 1, N_PARAMS), targets, loads and step weights (M, H; default 1)."""
        return self._rollout(state, params, target_l, target_k, load, weight)(actions).copy()

    def plan(self, state, params, target_l, target_k, load, weight=None) -> np.ndarray:
        """First actions (N, 2) of the plans for N plants: ``state`` (N, N_STATE), ``params``
        (N or 1, N_PARAMS), ``target_l``, ``target_k``, ``load`` and ``weight`` (N, H) over the
        horizon (muscle coordinates; ``weight`` default 1)."""
        cfg = self.cfg
        n, h, p = state.shape[0], cfg.horizon_steps, cfg.population
        if self.mean is None or self.mean.shape[0] != n:
            self.mean, self.kept = np.zeros((n, h, 2)), None
        mean, kept = self.mean.copy(), self.kept
        std = np.full((n, h, 2), cfg.init_std)
        n_keep = min(int(round(cfg.keep_elites * cfg.elites)), max(p - 2, 0))
        rep = lambda a: np.repeat(a, p, axis=0)  # noqa: E731  (each env's rows, once per sample)
        xs, tl, tkk, ld = rep(state), rep(target_l), rep(target_k), rep(load)
        ws = None if weight is None else rep(weight)
        prow = params if params.shape[0] == 1 else rep(params)
        best, best_cost = mean.copy(), np.full(n, np.inf)
        elites = np.empty((n, max(n_keep, 1), h, 2))
        # every iteration's noise at once (the same numbers as one draw per iteration)
        noise = coloured_noise(self.rng, (n, p, 2, h), cfg.noise_beta, draws=cfg.iterations)
        noise = noise.reshape((cfg.iterations, n, p, 2, h)).transpose(0, 1, 2, 4, 3)
        rollout = self._rollout(xs, prow, tl, tkk, ld, ws)
        for it in range(cfg.iterations):
            samples = np.clip(mean[:, None] + std[:, None] * noise[it], -1.0, 1.0)
            samples[:, 0] = np.clip(mean, -1.0, 1.0)  # the mean itself is always a candidate ...
            if p > 1:
                # ... and so are closed valves (hold the air; in pressure mode: mid set-points) ...
                samples[:, 1] = 0.0
            if kept is not None and n_keep:
                samples[:, 2 : 2 + n_keep] = kept[:, :n_keep]  # ... and the best plans found so far
            cost = rollout(samples.reshape(n * p, h, 2)).reshape(n, p)
            _refit(
                samples,
                cost,
                cfg.elites,
                n_keep,
                cfg.momentum,
                cfg.min_std,
                mean,
                std,
                best,
                best_cost,
                elites,
            )
            kept = elites[:, :n_keep]
        # the best simulated plan, not the elite mean (an average of samples that was never
        # simulated); it and the elites warm-start the next step, one step on
        self.mean = _shift(best)
        self.kept = _shift(kept) if n_keep else None
        # (N,) the cost of the best plans simulated (with send="mean" not of the command sent)
        self.last_cost = best_cost
        if cfg.send == "mean":
            return np.clip(mean[:, 0], -1.0, 1.0)
        return best[:, 0].copy()

    def check_stability(self, params) -> None:
        """With :attr:`check_rows` (a coarser sub-step than the env's): refuse parameter rows
        for which the planner's sub-step is unstable, naming ``plan_substeps``; each new set of
        rows is checked once."""
        from ..plant.state import check_stability

        if not self.check_rows or (
            self._checked_rows is not None and np.array_equal(params, self._checked_rows)
        ):
            return
        try:
            check_stability(np.asarray(params, dtype=float), self.sub_dt)
        except InputError as e:
            raise InputError(f"CEMConfig.plan_substeps={self.cfg.plan_substeps}: {e}") from None
        self._checked_rows = np.array(params, dtype=float)

    def _rollout(self, state, params, target_l, target_k, load, weight):
        """``cost = f(actions)`` for fixed start states, parameters, targets, loads and weights
        (the compiled rollout with its arguments converted once, for all of a step's iterations;
        ``f`` reuses its output array)."""
        self.check_stability(params)
        m, h = np.shape(target_l)
        params = np.ascontiguousarray(np.broadcast_to(params, (m, params.shape[1])))
        weight = np.ones((m, h)) if weight is None else np.ascontiguousarray(weight, dtype=float)
        state, target_l, target_k, load = (
            np.ascontiguousarray(a, dtype=float) for a in (state, target_l, target_k, load)
        )
        cost = np.empty(m)

        def f(actions):
            rollout_cost(
                state, params, self.hinge, self.mech, self.mode, self.sub_dt, self.n_sub,
                self.setpoint_max, np.ascontiguousarray(actions, dtype=float), target_l, target_k,
                load, weight, self.track_stiffness, self.length_norm, STIFFNESS_NORM, BURST_COST,
                self.cfg.effort_weight, cost,
            )  # fmt: skip
            return cost

        return f


@njit(cache=True, error_model="numpy")
def _refit(samples, cost, n_elites, n_keep, momentum, min_std, mean, std, best, best_cost, elites):
    """One iteration's refit, per env, in place: rank the samples (N, P, H, 2) by ``cost``
    (N, P); keep the best ever simulated (``best``, ``best_cost``); blend the elites' mean and
    spread into ``mean`` and ``std`` with ``momentum``; write the first ``n_keep`` elites, best
    first, to ``elites``. Sums run over the elites in rank order, as numpy's reductions do, so
    the plans are bit-identical to the array version's."""
    n, _, h, _ = samples.shape
    a = momentum
    for i in range(n):
        order = np.argsort(cost[i])
        c0 = cost[i, order[0]]
        if c0 < best_cost[i]:
            best[i] = samples[i, order[0]]
            best_cost[i] = c0
        for t in range(h):
            for k in range(2):
                s = samples[i, order[0], t, k]
                for e in range(1, n_elites):
                    s += samples[i, order[e], t, k]
                m = s / n_elites
                d = samples[i, order[0], t, k] - m
                v = d * d
                for e in range(1, n_elites):
                    d = samples[i, order[e], t, k] - m
                    v += d * d
                sd = np.sqrt(v / n_elites)
                mean[i, t, k] = a * mean[i, t, k] + (1 - a) * m
                std[i, t, k] = max(a * std[i, t, k] + (1 - a) * sd, min_std)
        for e in range(n_keep):
            elites[i, e] = samples[i, order[e]]


def planner_for(
    model, config: CEMConfig | None = None, spec: TraceSpec | None = None, **overrides
) -> CEMPlanner:
    """A planner for the envs of ``model`` (their :class:`~cepam_gym.envs.model.EnvModel`): its
    valve mode, integration, pressure range, task and mechanism; ``spec`` the benchmark's scoring
    of it (:func:`~cepam_gym.control.objective.spec_of_core` by default); ``overrides`` replace
    fields of ``config``."""
    from .objective import spec_of_core

    spec = spec or spec_of_core(model)
    cfg = dataclasses.replace(config or CEMConfig(), **overrides)
    sub_dt, n_sub = model.sub_dt, model.n_sub
    coarse = cfg.plan_substeps is not None and cfg.plan_substeps != n_sub
    if coarse:  # the same control period in fewer (or more) sub-steps
        sub_dt, n_sub = sub_dt * n_sub / cfg.plan_substeps, int(cfg.plan_substeps)
    hinge = np.array(model.hinge, dtype=float)  # the planner's own (writable) copy of the constants
    norm = spec.position_norm
    if model.mech == pl.HINGE:
        norm *= float(hinge[0, tk.H_R])  # an angle error of theta is a length error of r theta
    planner = CEMPlanner(
        cfg,
        model.mode,
        sub_dt,
        n_sub,
        model.setpoint_max,
        track_stiffness=model.track_stiffness,
        mech=model.mech,
        hinge=hinge,
        length_norm=norm,
    )
    planner.check_rows = coarse
    planner.check_stability(np.asarray(model.params, dtype=float))  # a misfit setting fails here
    return planner
