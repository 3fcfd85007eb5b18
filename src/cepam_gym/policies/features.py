"""What a learned policy sees and sends (:class:`~.spec.FeatureSpec`): one code path for training
(the training package's VecEnv wrapper and its native learners), deployment (its loader of trained
agents as controllers) and export, so that all run exactly the same arithmetic.

:class:`Features` turns a batch of env observations into the policy's input (the observation, the
baseline's action and set-point gaps, the target shifts' filter state, low-passed copies, a
history of frames, the plant's columns, the privileged columns) and the policy's action into the
env's (target shifts through the inverse-model baseline, a residual on its valve commands).

* The plant's columns (``plant_features``) are the true plant's during training
  (:meth:`Features.use_true_plant`); deployed, the fit of the episode's identification window
  (:class:`cepam_gym.identify.window_identifier.WindowIdentifier`, whose excitation drives the
  window: :attr:`Features.window`), or on episodes without a window the estimate of the run's
  adaptation module (:attr:`Features.plant_estimator`, :mod:`.plant_estimate`).
* The privileged columns (``privileged_critic``, :mod:`.privileged`) follow, for the critic only:
  read from the env during training (:attr:`Features.privileged` set by the training env), NaN
  when deployed (the asymmetric policy masks them from the actor).

The baseline (:class:`cepam_gym.control.InverseStaticController`) keeps filter and integrator
state per env; :meth:`Features.reset` forgets it for finished episodes. Pure numpy.

:func:`obs_batch` is the check of the observation every deployed policy (a trained agent's, a
behaviour-cloning one's) makes before acting.
"""

from __future__ import annotations

import numpy as np

from cepam_gym.errors import InputError

from .load_estimate import LoadEstimate
from .spec import GAP_UNIT_PA, FeatureSpec


def obs_batch(obs, obs_dim: int) -> tuple[np.ndarray, bool]:
    """``(batch (N, obs_dim) float32, was a single observation)``; ``InputError`` naming the shape
    otherwise. Every policy a run loads checks its input here."""
    single = np.ndim(obs) == 1
    o = np.atleast_2d(np.asarray(obs, dtype=np.float32))
    if o.shape[1] != obs_dim:
        raise InputError(f"observation must have shape ({obs_dim},) or (N, {obs_dim}), got {np.shape(obs)}")
    return o, single


class Features:
    def __init__(self, env, spec: FeatureSpec, raw_dim: int):
        self.spec = spec
        self.raw_dim = int(raw_dim)
        self.baseline = None
        self.n_shift = 0
        if spec.uses_baseline:
            from cepam_gym import plant as pl
            from cepam_gym.control import InverseStaticController, make_controller
            from cepam_gym.envs.model import model_of

            if spec.base_controller == "baseline" and model_of(env).mech == pl.RIG:
                self.baseline = InverseStaticController(env, friction_observer=spec.friction_observer)
            else:  # another registered controller under the residual (an InverseStaticController
                # too), or the joint's baseline (make_controller resolves ``baseline`` to it)
                self.baseline = make_controller(spec.base_controller, env)
            if spec.target_shift:
                self._shift_targets(spec)
        # target shifts, then two valve commands (residual, or the valves themselves without a
        # baseline in the loop)
        self.n_actions = self.n_shift + (2 if (spec.residual or not spec.target_shift) else 0)
        # with filtered shifts, the filter state is observed too (else the policy cannot know it)
        self._shift_obs = self.n_shift if (spec.target_shift and spec.target_shift_filter_s > 0) else 0
        self.frame_dim = (
            self.raw_dim
            + (2 if spec.baseline_in_obs else 0)
            + (2 if spec.setpoint_gaps_in_obs else 0)
            + (2 if spec.setpoint_gaps_in_obs and spec.plant_features else 0)
            + (LoadEstimate.dim if spec.load_estimate_in_obs else 0)
            + self._shift_obs
            + self.raw_dim * len(spec.obs_filters_s)
        )
        self.load_estimate = LoadEstimate(env, self.baseline) if spec.load_estimate_in_obs else None
        if spec.obs_filters_s:
            from cepam_gym.envs.model import model_of

            dt = model_of(env).control_dt
            self._ema_alpha = np.array([1.0 - np.exp(-dt / tau) for tau in spec.obs_filters_s])
        self._ema: np.ndarray | None = None  # (n_filters, N, raw_dim)
        self._ema_fresh: np.ndarray | None = None
        # privileged columns (training: a PrivilegedView of the env; deployed: NaN)
        self.privileged = None  # the view the columns are read from: set for training only
        self.priv_dim = 0
        if spec.privileged_critic:
            from cepam_gym.control.baseline import rig_model_of

            from .privileged import PrivilegedView

            self._view = PrivilegedView(rig_model_of(env))
            self.priv_dim = self._view.dim
        # the plant's columns (training: the true rows; deployed: the window's fit)
        self.plant_dim, self._rig, self._true_plant, self.identifier = 0, None, False, None
        self.window = None  # deployed with plant_features: (in the window (N,), its actions (N, 2))
        self.plant_estimator = None  # deployed without a window: the run's adaptation module
        if spec.plant_features:
            from cepam_gym.control.baseline import rig_model_of
            from cepam_gym.identify.window_identifier import plant_dim

            self._rig = rig_model_of(env)
            self.plant_dim = plant_dim(self._rig.nominal)
        self._plant_last: np.ndarray | None = None
        self._plant_rows_now: np.ndarray | None = None  # the told plant's rows (N, N_PARAMS)
        self._plant_true: np.ndarray | None = None  # training: the true rows of the last frame
        self._plant_weight: np.ndarray | None = None  # its filtered load estimate [N]; NaN: new episode
        self.actor_dim = self.frame_dim * spec.history + self.plant_dim
        self.dim = self.actor_dim + self.priv_dim
        self._priv_last: np.ndarray | None = None  # the rows before the latest autoreset
        self._hist: np.ndarray | None = None  # (N, history, frame_dim)
        self._fresh: np.ndarray | None = None  # (N,) bool: next frame starts an episode
        self._obs: np.ndarray | None = None  # the last raw observation (target_shift acts on it)
        self._shift: np.ndarray | None = None  # filtered target shifts (N, n_shift); NaN: new episode
        self._peeking = False

    def _shift_targets(self, spec: FeatureSpec) -> None:
        """The target shift's observation columns and scalings (tasks.layout): the rig's length
        target or the hinge's angle target [rad], and the stiffness target where it is tracked."""
        track_k = self.baseline.task.track_stiffness
        self.n_shift = 2 if track_k else 1
        layout = self.baseline.layout
        if layout.has("target_length"):
            position, shift_si = "target_length", spec.target_shift_length_mm * 1e-3
        else:
            position, shift_si = "target_angle", np.deg2rad(spec.target_shift_angle_deg)
        self._col_l = layout.column(position)
        self._col_k = layout.column("target_stiffness") if track_k else None
        self._dl = shift_si / layout.scale(position)
        tau = spec.target_shift_filter_s
        self._alpha = 1.0 - np.exp(-self.baseline.dt / tau) if tau > 0 else 1.0

    @property
    def trivial(self) -> bool:
        """True when features are the raw observation and actions pass through unchanged."""
        return (
            self.baseline is None
            and self.spec.history == 1
            and not self.spec.obs_filters_s
            and not self.priv_dim
            and not self.plant_dim
        )

    @property
    def acts_late(self) -> bool:
        """The baseline acts in :meth:`action` (after the policy), not in :meth:`__call__`."""
        return self.spec.target_shift

    def use_true_plant(self) -> None:
        """Training: the plant columns are the env's true plant (read from its model each step)."""
        self._true_plant = True

    def reset(self, indices=None) -> None:
        """Forget the state of all envs, or of ``indices`` (their episodes ended)."""
        if self.identifier is not None:
            self.identifier.reset(indices)
        self._forget(indices)

    def _forget(self, indices=None) -> None:
        """Forget the frames' state (history, filters, baseline) of all envs or of ``indices``."""
        if self.baseline is not None:
            self.baseline.reset(indices)
        if self.load_estimate is not None:
            self.load_estimate.reset(indices)
        if indices is None or self._fresh is None:
            self._hist = self._fresh = None
        else:
            self._fresh[np.asarray(indices)] = True
        if indices is None or self._ema is None:
            self._ema = self._ema_fresh = None
        else:
            self._ema_fresh[np.asarray(indices)] = True
        if indices is None or self._shift is None:
            self._shift = None
        else:
            self._shift[np.asarray(indices)] = np.nan
        if indices is None or self._plant_weight is None:
            self._plant_weight = None
        else:
            self._plant_weight[np.asarray(indices)] = np.nan

    def __call__(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Features (N, dim) float32 and the baseline's action (N, 2) (None without a baseline)
        of a batch of env observations (N, raw_dim). Advances the per-env state by one step."""
        obs = np.asarray(obs, dtype=np.float32)
        if obs.ndim != 2 or obs.shape[1] != self.raw_dim:
            raise ValueError(f"observation must have shape (N, {self.raw_dim}), got {obs.shape}")
        self._obs = obs
        plant = self._plant_rows(obs) if self.plant_dim else None
        base = self.baseline.act(obs) if (self.baseline is not None and not self.acts_late) else None
        frame = np.concatenate([obs, base], axis=1) if self.spec.baseline_in_obs else obs
        if self.spec.setpoint_gaps_in_obs:
            gap = (self.baseline.last_gap / GAP_UNIT_PA).astype(np.float32)
            frame = np.concatenate([frame, gap], axis=1)
            if plant is not None:
                frame = np.concatenate([frame, self._plant_gaps(obs)], axis=1)
        if self.load_estimate is not None:
            frame = np.concatenate([frame, self.load_estimate(obs)], axis=1)
        if self._shift_obs:
            state = (
                np.zeros((obs.shape[0], self.n_shift))
                if self._shift is None or self._shift.shape[0] != obs.shape[0]
                else np.nan_to_num(self._shift)
            )
            frame = np.concatenate([frame, state.astype(np.float32)], axis=1)
        if self.spec.obs_filters_s:
            n = obs.shape[0]
            if self._ema is None or self._ema.shape[1] != n:
                self._ema = np.repeat(obs[None].astype(np.float64), len(self._ema_alpha), axis=0)
                self._ema_fresh = np.zeros(n, dtype=bool)
            else:
                self._ema[:, self._ema_fresh] = obs[self._ema_fresh]
                self._ema_fresh[:] = False
                self._ema += self._ema_alpha[:, None, None] * (obs[None] - self._ema)
            frame = np.concatenate([frame, *self._ema.astype(np.float32)], axis=1)
        n = obs.shape[0]
        if self.spec.history == 1:
            f = frame.astype(np.float32)
        else:
            if self._hist is None or self._hist.shape[0] != n:
                self._hist = np.repeat(frame[:, None], self.spec.history, axis=1)
                self._fresh = np.zeros(n, dtype=bool)
            else:
                self._hist[self._fresh] = frame[self._fresh, None]
                self._fresh[:] = False
                self._hist = np.concatenate([self._hist[:, 1:], frame[:, None]], axis=1)
            f = self._hist.reshape(n, self.frame_dim * self.spec.history).astype(np.float32)
        if plant is not None:
            f = np.concatenate([f, plant], axis=1)
        if self.priv_dim:
            f = np.concatenate([f, self._privileged_rows(n)], axis=1)
        return f, base

    def _plant_gaps(self, obs: np.ndarray) -> np.ndarray:
        """The set-point gaps (N, 2) [100 kPa] of the told plant's inverse static model: its load
        estimate from the measured force, filtered as the baseline's, its set-points for the
        targets, minus the measured pressures."""
        from cepam_gym.control.baseline import low_pass
        from cepam_gym.physics import api
        from cepam_gym.physics import layout as ix

        b, rows = self.baseline, self._plant_rows_now
        L, pc, pe, L_t, K_t = b._decode(np.asarray(obs, dtype=float))
        w_now = -api.force(L, pc, pe, rows)
        w = self._plant_weight
        if w is None or w.shape[0] != len(w_now):
            w = np.full(len(w_now), np.nan)
        self._plant_weight = w = low_pass(w, w_now, b.alpha)  # the baseline's filter, the told plant
        weight = np.maximum(w, rows[:, ix.M_END] * rows[:, ix.GRAV])
        pc_set, pe_set = b.setpoints(L_t, K_t, weight, rows)
        return (np.stack([pc_set - pc, pe_set - pe], axis=1) / GAP_UNIT_PA).astype(np.float32)

    def _plant_rows(self, obs: np.ndarray) -> np.ndarray:
        """The plant's columns (N, plant_dim) for this step; deployed, steps the window's
        identification first (its excitation in :attr:`window`; an env whose tracking starts now
        begins its frames afresh: the window's frames are another episode's)."""
        from cepam_gym.identify.window_identifier import WindowIdentifier, plant_columns, told_rows

        supply = self._rig.obs_layout.value(np.asarray(obs, dtype=np.float64), "supply_pressure")
        if self._true_plant:
            if not (self._peeking and self._plant_last is not None):
                self._plant_last = plant_columns(self._rig.params, self._rig.nominal)
                self._plant_true = np.array(self._rig.params)
            # the finished episode's plant for a terminal observation, the supply as measured
            self._plant_rows_now = told_rows(self._plant_true, self._rig.nominal, supply)
            return self._plant_last
        if self.identifier is None:
            if self.plant_estimator is not None and self._rig.window_steps < 2:
                from .plant_estimate import EstimatedPlant

                self.identifier = EstimatedPlant(self._rig, self.plant_estimator)
            else:
                who = "an agent with agent.plant_features and no plant estimator"
                self.identifier = WindowIdentifier(self._rig, who)  # without a window: who needs one
        actions, in_window, starts = self.identifier.step(np.asarray(obs, dtype=np.float64))
        if starts.any():
            self._forget(np.flatnonzero(starts))
        self.window = (in_window, actions)
        self._plant_rows_now = told_rows(self.identifier.rows, self._rig.nominal, supply)
        return plant_columns(self.identifier.rows, self._rig.nominal)

    def _privileged_rows(self, n: int) -> np.ndarray:
        if self.privileged is None:  # deployed: nothing privileged exists
            return np.full((n, self.priv_dim), np.nan, dtype=np.float32)
        if self._peeking and self._priv_last is not None:
            # a terminal observation: the env has already reset, so the finished episode's rows
            # are the ones of the step before (the plant is the same; the load one step older)
            return self._priv_last
        self._priv_last = self.privileged.view()
        return self._priv_last

    def after_step(self, obs: np.ndarray, done: np.ndarray, last: np.ndarray):
        """``(features, baseline action, features of the finished envs' last observations)`` after a
        vector step: ``obs`` (N, raw_dim) the new observations, ``done`` the indices of the envs
        whose episode ended, ``last`` (len(done), raw_dim) their episodes' last observations (None
        when none ended). The
        last observations are featurised first (their episodes' state), then that state is
        forgotten, then every env's new observation advances the state. The agent wrapper's
        ``step_wait`` and the native learners (the training package's native learners) both call it."""
        term = np.zeros((0, self.dim), np.float32)
        if len(done):
            full = np.array(obs, copy=True)
            full[done] = last
            term = self.peek(full)[done]
            self.reset(done)
        f, base = self(obs)
        return f, base, term

    def peek(self, obs: np.ndarray) -> np.ndarray:
        """Features of ``obs`` without changing any state (terminal observations)."""
        saved = self._save()
        self._peeking = True
        try:
            return self(obs)[0]
        finally:
            self._peeking = False
            self._restore(saved)

    def _save(self):
        b = self.baseline

        def copy(a):
            return None if a is None else a.copy()

        return (
            copy(self._hist),
            copy(self._fresh),
            None if b is None else b.get_state(),
            self._obs,
            copy(self._shift),
            copy(self._ema),
            copy(self._ema_fresh),
            self._priv_last,
            self._plant_last,
            copy(self._plant_weight),
            self._plant_true,
            None if self.load_estimate is None else self.load_estimate.get_state(),
        )

    def _restore(self, saved) -> None:
        (
            self._hist,
            self._fresh,
            b,
            self._obs,
            self._shift,
            self._ema,
            self._ema_fresh,
            self._priv_last,
            self._plant_last,
            self._plant_weight,
            self._plant_true,
            load,
        ) = saved
        if self.baseline is not None:
            self.baseline.set_state(b)
        if self.load_estimate is not None:
            self.load_estimate.set_state(load)

    def action(self, a: np.ndarray, base: np.ndarray | None) -> np.ndarray:
        """The env action (N, 2) for the policy's action ``a`` (N, n_actions) on the observation
        last passed to :meth:`__call__`."""
        a = np.asarray(a, dtype=np.float32)
        if a.ndim != 2 or a.shape[1] != self.n_actions:
            raise ValueError(f"policy action must have shape (N, {self.n_actions}), got {a.shape}")
        a = np.clip(a, -1.0, 1.0)
        if self.spec.target_shift:
            shift = a[:, : self.n_shift].astype(np.float64)
            if self._alpha < 1.0:
                if self._shift is None or self._shift.shape != shift.shape:
                    self._shift = shift.copy()
                fresh = np.isnan(self._shift[:, 0])
                self._shift = np.where(
                    fresh[:, None], shift, self._shift + self._alpha * (shift - self._shift)
                )
                shift = self._shift
            o = np.array(self._obs, dtype=np.float64)
            o[:, self._col_l] += self._dl * shift[:, 0]
            if self._col_k is not None:
                o[:, self._col_k] *= np.exp(self.spec.target_shift_stiffness * shift[:, 1])
            base = self.baseline.act(o)
        if self.spec.residual:
            return np.clip(base + self.spec.residual_scale * a[:, self.n_shift :], -1.0, 1.0).astype(
                np.float32
            )
        if self.spec.target_shift:
            return base.astype(np.float32)
        return a
