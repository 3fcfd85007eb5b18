"""A practical model-predictive controller: what a controls engineer would ship.

Per control step, from the observation only (what a rig measures) and the *nominal* plant:

1. **State estimate**: length, rate and both chamber pressures are measured; the air is taken at
   the ambient temperature (:func:`cepam_gym.plant.initial_state` turns pressures into air mass
   and energy at the measured length); the valve spools are taken where the previous command put
   them (a 5 ms spool settles within one 20 ms control period).
2. **Load estimate**: the baseline's (:class:`~cepam_gym.control.baseline.InverseStaticController`):
   the hanging weight that balances the nominal force at the measured length and pressures,
   low-pass filtered.
3. **Reference over the horizon**: the current target held (the v0 observation announces no
   future targets).
4. **Plan**: the cross-entropy method through the nominal plant kernel
   (:class:`~cepam_gym.control.planner.CEMPlanner`, the oracle's planner with estimates instead
   of the truth), first command sent, plan warm-started.

Against the oracle it lacks the true parameters (randomized plants), the true temperatures and
the future of the load and of the targets; against the baseline it adds the plant's dynamics.
"""

from __future__ import annotations

import numpy as np

from .. import plant as pl
from ..physics import api
from ..physics import layout as ix
from ..tasks import kernel as tk
from .baseline import InverseStaticController, core_of
from .planner import CEMConfig, CEMPlanner


class ModelPredictiveController(InverseStaticController):
    """``reset(indices=None)`` / ``act(obs, info=None)`` on single or batched observations."""

    def __init__(self, env, config: CEMConfig | None = None, **overrides):
        super().__init__(env)
        core = core_of(env)
        cfg = config or CEMConfig()
        if overrides:
            import dataclasses

            cfg = dataclasses.replace(cfg, **overrides)
        self.cfg = cfg
        self.planner = CEMPlanner(
            cfg,
            core.mode,
            core.sub_dt,
            core.n_sub,
            float(core.task_vec[tk.T_SETPOINT_MAX]),
            track_stiffness=self.task.track_stiffness,
        )
        self._mode_id = core.mode

    def reset(self, indices=None) -> None:
        super().reset(indices)
        if hasattr(self, "planner"):
            self.planner.reset(indices)

    def estimate_state(self, obs: np.ndarray, L, pc, pe) -> np.ndarray:
        """Plant states (N, N_STATE) of the nominal model from measured quantities."""
        p = self.params
        x = pl.initial_state(
            p[None],
            np.clip(L, p[ix.L_MIN], p[ix.L_MAX]),
            np.maximum(pc, -0.9 * p[ix.P_ATM]),
            np.maximum(pe, -0.9 * p[ix.P_ATM]),
        )
        x[:, pl.S_V] = self.layout.value(obs, "velocity")
        if self._mode_id == pl.PROPORTIONAL:
            x[:, pl.S_SC] = self.layout.value(obs, "previous_action_c")
            x[:, pl.S_SE] = self.layout.value(obs, "previous_action_e")
        return x

    def act(self, obs, info=None) -> np.ndarray:
        single = np.ndim(obs) == 1
        obs = np.atleast_2d(np.asarray(obs, dtype=float))
        L, pc, pe, L_t, K_t = self._decode(obs)
        p = self.params
        w_min = p[ix.M_END] * p[ix.GRAV]
        weight = np.maximum(self._filtered(-api.force(L, pc, pe, p)), w_min)
        load = weight / p[ix.GRAV] - p[ix.M_END]
        h = self.cfg.horizon_steps
        K_ref = K_t if K_t is not None else np.full_like(L_t, 1000.0)
        ones = np.ones((obs.shape[0], h))
        a = self.planner.plan(
            self.estimate_state(obs, L, pc, pe),
            p[None],
            L_t[:, None] * ones,
            K_ref[:, None] * ones,
            load[:, None] * ones,
        ).astype(np.float32)
        return a[0] if single else a
