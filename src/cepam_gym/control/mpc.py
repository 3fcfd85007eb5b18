"""A practical model-predictive controller: what a controls engineer would ship.

Per control step, from the observation only (what a rig measures) and the *nominal* plant:

1. **State estimate**: length, rate and both chamber pressures are measured; the air is taken at
   the ambient temperature (:func:`cepam_gym.plant.initial_state` turns pressures into air mass
   and energy at the measured length); the valve spools are taken where the previous command put
   them (a 5 ms spool settles within one 20 ms control period).
2. **Load estimate**: the baseline's (:class:`~cepam_gym.control.baseline.InverseStaticController`):
   the hanging weight that balances the nominal force at the measured length and pressures,
   low-pass filtered.
3. **Reference over the horizon**: the preview columns of the observation (v1 ids:
   ``target_length_+j``, ``target_stiffness_+j``), the last one held beyond them; without a
   preview (v0) the current target held.
4. **Plan**: the cross-entropy method through the nominal plant kernel
   (:class:`~cepam_gym.control.planner.CEMPlanner`, the oracle's planner with estimates instead
   of the truth), first command sent, plan warm-started.

Against the oracle it lacks the true parameters (randomized plants), the true temperatures, the
friction state and the future of the load; against the baseline it adds the plant's dynamics and
the preview.
"""

from __future__ import annotations

import numpy as np

from .. import plant as pl
from ..physics import layout as ix
from .baseline import InverseStaticController, rig_model_of
from .planner import CEMConfig, planner_for


class ModelPredictiveController(InverseStaticController):
    """``reset(indices=None)`` / ``act(obs, info=None)`` on single or batched observations."""

    def __init__(self, env, config: CEMConfig | None = None, friction_observer: bool = False, **overrides):
        super().__init__(env, friction_observer=friction_observer)
        model = rig_model_of(env)
        self.planner = planner_for(model, config, **overrides)
        self.cfg = self.planner.cfg
        self._mode_id = model.mode

    def reset(self, indices=None) -> None:
        super().reset(indices)
        if hasattr(self, "planner"):
            self.planner.reset(indices)

    def model_rows(self, n: int) -> np.ndarray:
        """The parameter rows the model plans with: (1, N_PARAMS) the nominal plant for all ``n``
        envs (:class:`KnownParamsMPC`: each env's true row)."""
        return self.params[None]

    def estimate_state(self, obs: np.ndarray, L, pc, pe, params=None) -> np.ndarray:
        """Plant states (N, N_STATE) of the model (the nominal one, or ``params`` rows (N,
        N_PARAMS)) from measured quantities."""
        p = self.params
        x = pl.initial_state(
            p[None] if params is None else params,
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
        rows = self.model_rows(obs.shape[0])
        p = rows.T  # columns by index: one value, or one per env
        w_min = p[ix.M_END] * p[ix.GRAV]
        weight = np.maximum(self._filtered(-self.measured_force(L, pc, pe, rows)), w_min)
        load = weight / p[ix.GRAV] - p[ix.M_END]
        ref_l, ref_k = self.reference(obs, L_t, K_t)
        ones = np.ones((obs.shape[0], self.cfg.horizon_steps))
        x = self.estimate_state(obs, L, pc, pe, None if len(rows) == 1 else rows)
        a = self.planner.plan(x, rows, ref_l, ref_k, load[:, None] * ones).astype(np.float32)
        return a[0] if single else a

    def reference(self, obs, L_t, K_t):
        """Target length and stiffness over the horizon (N, H): the target, then the preview
        columns, the last value held (no preview: the target held)."""
        h = self.cfg.horizon_steps
        steps = self.layout.preview_steps
        K_t = K_t if K_t is not None else np.full_like(L_t, 1000.0)  # no stiffness tracked: unused
        cols_l, cols_k = [L_t], [K_t]
        for j in range(1, min(steps, h - 1) + 1):
            cols_l.append(self.layout.value(obs, f"target_length_+{j}"))
            if self.layout.has(f"target_stiffness_+{j}"):
                cols_k.append(self.layout.value(obs, f"target_stiffness_+{j}"))
            else:
                cols_k.append(K_t)
        ref_l, ref_k = np.stack(cols_l, axis=1), np.stack(cols_k, axis=1)
        pad = h - ref_l.shape[1]
        return (
            np.concatenate([ref_l, np.repeat(ref_l[:, -1:], pad, axis=1)], axis=1),
            np.concatenate([ref_k, np.repeat(ref_k[:, -1:], pad, axis=1)], axis=1),
        )


class FrictionObserverMPC(ModelPredictiveController):
    """The MPC with the model's friction elements tracked from the measured length
    (:class:`~cepam_gym.control.friction_observer.FrictionObserver`), so the load estimate is the
    balance of the air's force *and* the friction's (the plain MPC's static balance leaves out the
    part of the weight friction holds), and the plan starts from the tracked deflections. On
    ``nominal-v1`` the friction left out of the balance is what separates the MPC from the causal
    oracle (docs/benchmark.md, "What the oracle's privileges are worth")."""

    def __init__(self, env, config: CEMConfig | None = None, **overrides):
        super().__init__(env, config, friction_observer=True, **overrides)

    def estimate_state(self, obs, L, pc, pe, params=None) -> np.ndarray:
        x = super().estimate_state(obs, L, pc, pe, params)
        z = self.friction.z
        if z is not None and len(z) == len(x):
            x[:, [pl.S_Z1, pl.S_Z2, pl.S_Z3]] = z
        return x


class KnownParamsMPC(ModelPredictiveController):
    """The MPC given each env's true parameter row (randomized plants included); its state and
    load are still estimated from the sensors. Not a practical controller: the ceiling of adapting
    to the plant by identifying its parameters, the yardstick of an agent that must infer them
    (docs/benchmark.md, "What the oracle's privileges are worth"), and the shipped student's
    teacher (configs/student.yaml). Privileged: it reads the true rows of the env's model
    (:attr:`cepam_gym.envs.model.EnvModel.params`)."""

    def __init__(self, env, config: CEMConfig | None = None, **overrides):
        super().__init__(env, config, **overrides)
        self.model = rig_model_of(env)

    def model_rows(self, n: int) -> np.ndarray:
        rows = np.array(self.model.params)  # writable: a read-only array is another numba type
        return rows if len(rows) == n else np.broadcast_to(rows, (n, rows.shape[1]))


class KnownParamsFrictionMPC(KnownParamsMPC, FrictionObserverMPC):
    """``mpc_friction`` given each env's true parameter row (its friction elements tracked with
    the true friction parameters): the residual student's teacher (configs/student_residual.yaml).
    On the nominal plant it is ``mpc_friction``."""
