"""The oracle: a privileged receding-horizon planner, the benchmark's headroom yardstick.

It reads what no real controller has: the env's true plant state (air masses and energies, spool
positions, length and velocity, friction slips), the episode's true (possibly randomized) plant
parameters, the load schedule and the target schedule of the coming ``horizon_steps``. It plans
valve commands through the plant kernel itself (:class:`~cepam_gym.control.planner.CEMPlanner`)
against exactly what the benchmark scores (:mod:`cepam_gym.control.objective`: the same norms,
the same settling-allowance windows, read off the true schedule) and sends the first. It is not a
practical controller: it measures how good control can get on a suite, so that a score can be
normalised between the zero controller (0) and the oracle (100), as D4RL normalises between a
random and an expert policy (Fu et al. 2020).

It drives the rig envs and the batched hinge (``cepam_gym/CEPAMJoint-v1``: the hinge kernel,
targets mapped to muscle coordinates). Its settings (:data:`ORACLE_CONFIG`) were chosen by the
convergence study ``benchmarks/oracle_convergence.py`` (docs/benchmark.md); anyone can challenge
them: ``OracleController(env, horizon_steps=..., population=...)``. What it does not see: sensor
noise (it needs no sensors), future supply drift, and action latency (it plans as if its command
acted now).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .. import plant as pl
from ..envs import step_kernel as tk
from ..envs.model import NoModelError, model_of
from ..physics import layout as ix
from .baseline import UnsupportedEnvError
from .objective import scored_steps, spec_of_core, version_of_core
from .planner import CEMConfig, planner_for

# 0.1 s of look-ahead refined over 20 iterations: at a fixed cost, a short horizon searched well
# beats a long one searched coarsely (benchmarks/oracle_convergence.py, docs/benchmark.md); the
# effort weight is small: the score does not count it, it only breaks ties towards closed valves
ORACLE_CONFIG = CEMConfig(
    horizon_steps=5,
    population=48,
    elites=6,
    iterations=20,
    init_std=0.3,
    min_std=0.005,
    effort_weight=1e-3,
    allowance_weight=0.0,
)
# the hinge's link adds inertia and a slower mode: 0.2 s of look-ahead, refined twice as long
# (the convergence study: 0.2 s with 20 iterations scored 3 times the error of 40 iterations)
JOINT_ORACLE_CONFIG = dataclasses.replace(ORACLE_CONFIG, horizon_steps=10, iterations=40)


# the v0 suites score every step, the transients after unannounced jumps included: looking 0.2 s
# ahead lets the oracle start before a jump (nominal, 4 episodes: 0.660 against 0.748 at 0.1 s and
# 0.667 for a cross-entropy oracle without iCEM's refinements)
V0_ORACLE_CONFIG = dataclasses.replace(ORACLE_CONFIG, horizon_steps=10)
# plant v2 (the v2 rig ids): 0.1 s was not enough on one randomized-v2 episode of four (0.11
# against 0.0075 at 0.2 s; more iterations at 0.1 s did not help), 0.16 s is the shortest tried
# that holds it, and 40 iterations keep nominal-v2 within 0.1 normalized points of the best
# setting found (4 episodes each: docs/benchmark.md, "Convergence on plant v2")
V2_ORACLE_CONFIG = dataclasses.replace(ORACLE_CONFIG, horizon_steps=8, iterations=40)


# the shipped settings by the name the version table gives each id (cepam_gym.versions: its
# ``oracle`` column)
ORACLE_CONFIGS: dict[str, CEMConfig] = {
    "v0": V0_ORACLE_CONFIG,
    "v1": ORACLE_CONFIG,
    "v2": V2_ORACLE_CONFIG,
    "joint": JOINT_ORACLE_CONFIG,
}


def oracle_config(model) -> CEMConfig:
    """The shipped search settings for the envs of ``model`` (their
    :class:`~cepam_gym.envs.model.EnvModel`, or their core): those the version table names for
    the id they run (:mod:`cepam_gym.versions`). With a task or plant of one's own: the hinge's
    on a hinge, else the rig's for how the task is scored (every step: v0's; with a settling
    allowance: v1's); ``config=`` chooses others."""
    row = version_of_core(model)
    if row is not None and row.oracle is not None:
        return ORACLE_CONFIGS[row.oracle]
    if model.mech == pl.HINGE:
        return JOINT_ORACLE_CONFIG
    return V0_ORACLE_CONFIG if spec_of_core(model).allowance_s <= 0 else ORACLE_CONFIG


class OracleController:
    """``reset(indices=None)`` / ``act(obs, info=None)`` like every controller; built from a
    native CE-PAM env (single, vector or SB3 adapter; rig or batched hinge), whose true state it
    reads every step: privileged, it reads every live fact of the env's
    :class:`~cepam_gym.envs.model.EnvModel` (state, parameter rows, schedules, current step).
    ``config`` replaces the shipped settings (:func:`oracle_config`), ``overrides`` replace some
    of their fields."""

    def __init__(self, env, config: CEMConfig | None = None, **overrides):
        try:
            self.model = model = model_of(env)
        except NoModelError as e:  # the MuJoCo joint (v0): no batched kernel to plan through
            raise UnsupportedEnvError(
                f"the oracle plans through the batched kernel; this env has none ({e})"
            ) from None
        self.spec = spec_of_core(model)
        self.planner = planner_for(model, config or oracle_config(model), self.spec, **overrides)
        self.cfg = self.planner.cfg
        self.hinge = model.mech == pl.HINGE

    def reset(self, indices=None) -> None:
        self.planner.reset(indices)

    def horizon(self):
        """True targets, loads and step weights over the planning horizon from each env's current
        step in muscle coordinates: ``(target_l, target_k, load, weight)``, each (N, H); the
        last value holds past the episode end."""
        m, cfg = self.model, self.cfg
        k = np.minimum(m.t_idx[:, None] + np.arange(cfg.horizon_steps), m.n_steps - 1)
        rows = np.arange(m.num_envs)[:, None]
        target_l, target_k = m.target_l, m.target_k
        scored = scored_steps(target_l.T, target_k.T, m.track_stiffness, self.spec, m.control_dt).T
        weight = np.where(scored[rows, k], 1.0, cfg.allowance_weight)
        tl, tkk, load = target_l[rows, k], target_k[rows, k], m.load[rows, k]
        if self.hinge:  # angle, joint stiffness, torque -> muscle length, stiffness, force
            hinge = m.hinge
            r = hinge[:, tk.H_R][:, None] if hinge.shape[0] > 1 else hinge[0, tk.H_R]
            l_max = m.params[:, ix.L_MAX][:, None]
            tl, tkk, load = l_max - r * tl, tkk / r**2, load / r
        return tl, tkk, load, weight

    def act(self, obs, info=None) -> np.ndarray:
        m = self.model
        if m.window_steps and (m.t_idx < m.window_steps).all():
            # an identification window (envs.id_window) is not scored and the plant restarts at rest
            # after it, whatever was done in it: the valves stay shut, nothing is planned
            a = np.zeros((m.num_envs, 2), dtype=np.float32)
        else:
            tl, tkk, load, w = self.horizon()
            a = self.planner.plan(m.state, m.params, tl, tkk, load, w).astype(np.float32)
        return a[0] if np.ndim(obs) == 1 else a


class CausalOracle(OracleController):
    """The oracle without foresight of the load: it plans with the load of the current step held
    over its horizon, as any causal controller must (it still reads the true state, parameters
    and targets; the targets are announced by the v1 preview anyway). Where the load is constant
    it is the oracle itself. What a student imitating the oracle could at best reach
    (docs/benchmark.md, "What the oracle's privileges are worth")."""

    def horizon(self):
        tl, tkk, load, w = super().horizon()
        return tl, tkk, np.repeat(load[:, :1], load.shape[1], axis=1), w
