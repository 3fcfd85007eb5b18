"""The oracle: a privileged receding-horizon planner, the benchmark's headroom yardstick.

It reads what no real controller has: the env's true plant state (air masses and energies, spool
positions, length and velocity), the episode's true (possibly randomized) plant parameters, the
load schedule and the target schedule of the coming ``horizon_steps``. It plans valve commands
through the plant kernel itself (:class:`~cepam_gym.control.planner.CEMPlanner`) and sends the
first. It is not a practical controller: it measures how good control can get on a suite, so that
a score can be normalised between the zero controller (0) and the oracle (100), as D4RL
normalises between a random and an expert policy (Fu et al. 2020).

Cost per control step (default :class:`~cepam_gym.control.planner.CEMConfig`): ``population x
iterations = 288`` simulated plants over 10 control steps, i.e. about 2 900 plant control steps
per env step; all envs of a batch are planned in one batched plant call per horizon step. What it
does not see: sensor noise (it needs no sensors), future supply drift, and action latency (it
plans as if its command acted now).
"""

from __future__ import annotations

import numpy as np

from .baseline import core_of
from .planner import CEMConfig, planner_for


class OracleController:
    """``reset(indices=None)`` / ``act(obs, info=None)`` like every controller; built from a
    native CE-PAM env (single, vector or SB3 adapter), whose true state it reads every step."""

    def __init__(self, env, config: CEMConfig | None = None, **overrides):
        self.core = core = core_of(env)
        self.planner = planner_for(core, config, **overrides)
        self.cfg = self.planner.cfg

    def reset(self, indices=None) -> None:
        self.planner.reset(indices)

    def horizon(self):
        """True targets and loads over the planning horizon from each env's current step:
        ``(target_l, target_k, load)``, each (N, H); the last value holds past the episode end."""
        core = self.core
        k = np.minimum(core.t_idx[:, None] + np.arange(self.cfg.horizon_steps), core.n_steps - 1)
        rows = np.arange(core.num_envs)[:, None]
        return core.target_l[rows, k], core.target_k[rows, k], core.load[rows, k]

    def act(self, obs, info=None) -> np.ndarray:
        core = self.core
        tl, tkk, load = self.horizon()
        a = self.planner.plan(core.state, core.params, tl, tkk, load).astype(np.float32)
        return a[0] if np.ndim(obs) == 1 else a
