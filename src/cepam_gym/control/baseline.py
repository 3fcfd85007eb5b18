"""Model-based baseline: inverse static model + load estimate + pressure loop.

Uses the *nominal* plant parameters (the env may run randomized ones: that is the point of the
comparison) and the same physics functions as the plant (:mod:`cepam_gym.physics.api`).

Per control step, for every env of a batch (shape ``(N, obs_dim)`` or a single ``(obs_dim,)``):

1. **Measure** length, pressures and targets from the observation (what a rig has).
2. **Load estimate**: in quasi-static equilibrium ``F(L, Pc, Pe) + (m_end + m_load) g = 0`` (paper
   Eq. 25 with Eq. 41/45 via :func:`~cepam_gym.physics.api.force`), so the hanging weight is
   ``-F`` from the measured length and pressures, low-pass filtered (``load_filter_s``). Because
   it is computed at the *measured* length, it also absorbs force-model error: at steady state
   the set-points that balance ``-F_nominal(L, P)`` at ``L*`` can only hold if ``L = L*``
   (the nominal force is monotone in L), so the length error goes to zero even on a wrong model.
3. **Inverse static model**: the pressures that hold ``L*`` with stiffness ``K*`` under that
   weight, a 2x2 solve (:func:`~cepam_gym.physics.api.static_pressures`). **Infeasible targets**
   are projected with this rule: the force balance is kept exact and ``K*`` is moved to the
   nearest reachable stiffness at ``(L*, W)``
   (:func:`~cepam_gym.planning.schedules.stiffness_interval`); if no stiffness is reachable the
   pressures are clipped to ``[0, min(supply, burst)]``. Without a stiffness target (the length
   task) the middle of the reachable interval is used.
4. **Pressure loop** per chamber, by action mode: ``"pressure"`` sends the set-points;
   ``"valve"``/``"pwm"`` compute the valve opening that would close a fraction of the pressure gap
   in one control period from the ISO 6358 flow model (feedforward) plus a PI on the pressure
   error with conditional-integration anti-windup.
"""

from __future__ import annotations

import numpy as np

from .. import plant as pl
from ..envs.model import EnvModel, NoModelError, model_of
from ..physics import api
from ..physics import layout as ix
from ..planning.schedules import stiffness_interval
from ..plant.actions import pressure_actions
from .friction_observer import FrictionObserver


class InverseStaticController:
    """Baseline policy for the CE-PAM envs; ``act(obs, info=None)`` works on single and batched
    observations. Build it from an env (single, vector or SB3 adapter) so it knows the
    observation scaling, the action mode and the nominal parameters."""

    friction: FrictionObserver | None = None

    def __init__(
        self,
        env,
        gap_fraction: float = 0.5,
        kp: float = 0.2,
        ki: float = 0.5,
        load_filter_s: float = 0.15,
        friction_observer: bool = False,
    ):
        # friction_observer: the load estimate balances the friction elements' force too
        # (:mod:`.friction_observer`); off, the air's force alone (the registered baseline)
        self.friction = FrictionObserver() if friction_observer else None
        model = rig_model_of(env)
        self.task = model.task_spec
        self.layout = model.obs_layout
        self.mechanism = model.mechanism
        self.setpoint_max = model.nominal.pressure_cap
        self._configure(
            model.nominal,
            model.nominal.to_array(),
            model.action_mode,
            model.control_dt,
            gap_fraction,
            kp,
            ki,
            load_filter_s,
        )

    def _configure(self, nominal, params_row, mode, dt, gap_fraction, kp, ki, load_filter_s) -> None:
        """Plant model, loop gains and filter shared by every controller built on this one."""
        self.params = params_row  # nominal, never the randomized rows
        self.nominal = nominal
        self.mode = mode
        self.dt = dt
        self.gap_fraction = gap_fraction
        self.kp, self.ki = kp, ki
        self.alpha = 1.0 - np.exp(-dt / load_filter_s)
        self.p_cap = nominal.pressure_cap
        self.reset()

    def reset(self, indices=None) -> None:
        """Forget the filter and integrator states (all envs, or ``indices``)."""
        if indices is None or getattr(self, "_weight", None) is None:
            self._weight = None
            self._integral = None
        else:
            self._weight[indices] = np.nan
            self._integral[indices] = 0.0
        if self.friction is not None:
            self.friction.reset(indices)

    def get_state(self):
        """A copy of the per-env filter, integrator and friction-observer states (``None`` before
        the first act), for :meth:`set_state`: code that runs the controller on trial
        observations and rewinds it."""
        if self._weight is None:
            return None
        friction = None if self.friction is None else self.friction.get_state()
        return self._weight.copy(), self._integral.copy(), friction

    def set_state(self, state) -> None:
        """Restore what :meth:`get_state` returned."""
        if state is None:
            self._weight = self._integral = None
            if self.friction is not None:
                self.friction.set_state(None)
        else:
            self._weight, self._integral = state[0].copy(), state[1].copy()
            if self.friction is not None:
                self.friction.set_state(state[2])

    # ------------------------------------------------------------------ helpers
    def _decode(self, obs: np.ndarray):
        """Measured position, pressures and targets (SI, the mechanism's coordinates: the rig's
        length) from the observation, by column name."""
        v, m = self.layout.decode(obs), self.mechanism
        target_k = v["target_stiffness"] if self.layout.has("target_stiffness") else None
        return v[m.position], v["pressure_c"], v["pressure_e"], v[m.target], target_k

    def setpoints(self, L_target, K_target, weight, params=None):
        """Projected inverse static model: gauge pressures ``(Pc*, Pe*)`` [Pa] (arrays) of the
        nominal plant, or of ``params`` (one row per element of the 1-D arguments)."""
        p = self.params if params is None else params
        L_target = np.asarray(L_target, dtype=float)
        k_lo, k_hi = stiffness_interval(L_target, weight, weight, p, self.task)
        reachable = k_hi > k_lo
        if K_target is None:
            K = 0.5 * (k_lo + k_hi)
        else:
            K = np.clip(K_target, k_lo, np.maximum(k_lo, k_hi))
        K = np.where(reachable, K, np.nan_to_num(K_target if K_target is not None else 800.0))
        # exact for plant v2's stretching threads (its set-points 8 % off in stiffness otherwise);
        # v0 and v1: the same numbers as the affine solve the reachable interval uses
        pc, pe, _ = api.static_pressures_exact(L_target, K, weight, p)
        return np.clip(pc, 0.0, self.p_cap), np.clip(pe, 0.0, self.p_cap)

    def _valve_command(self, p_set, p_meas, vol, integral):
        """Spool opening in [-1, 1] closing ``gap_fraction`` of the pressure gap in one period."""
        p = self.params
        patm, psup = p[ix.P_ATM], p[ix.P_SUP]
        t = p[ix.T_AMB]
        err = p_set - p_meas
        # mass the chamber needs (isothermal estimate) and the flow a fully open valve gives now
        dm = self.gap_fraction * err * vol / (ix.R_AIR * t)
        c = p[ix.C_ONOFF] if self.mode == "pwm" else p[ix.C_PROP]
        pa = p_meas + patm
        full_in = api.iso6358_flow(psup, np.minimum(pa, psup), p[ix.T_SUP], c, p[ix.B_CRIT], p[ix.R_LAM])
        full_out = api.iso6358_flow(np.maximum(pa, patm), patm, t, c, p[ix.B_CRIT], p[ix.R_LAM])
        full = np.where(err > 0, full_in, full_out) * self.dt
        ff = np.sign(err) * np.minimum(np.abs(dm) / np.maximum(full, 1e-12), 1.0)
        scale = max(self.p_cap, 1.0)
        u = ff + self.kp * err / scale + self.ki * integral
        saturated = np.abs(u) >= 1.0
        # conditional integration: integrate only while not pushing further into saturation
        integral = np.where(
            saturated & (np.sign(err) == np.sign(u)), integral, integral + err / scale * self.dt
        )
        return np.clip(u, -1.0, 1.0), integral

    # --------------------------------------------------------------------- act
    def act(self, obs, info=None) -> np.ndarray:
        single = np.ndim(obs) == 1
        obs = np.atleast_2d(np.asarray(obs, dtype=float))
        x, pc, pe, x_t, k_t = self._decode(obs)
        p, m = self.params, self.mechanism
        L = m.muscle_length(x, p)
        # the load whose static balance the measured force is (Eq. 25 on the rig: weight = -F)
        load_now = m.load_from_force(self.measured_force(L, pc, pe, p[None]), x, p)
        weight = m.muscle_weight(x_t, self._filtered(load_now), p)
        pc_set, pe_set = self.setpoints(m.muscle_length(x_t, p), m.muscle_stiffness(k_t), weight)
        return self._drive(pc_set, pe_set, L, pc, pe, self.setpoint_max, single)

    def measured_force(self, L, pc, pe, rows) -> np.ndarray:
        """The model's force (N,) [N] at the measured length and pressures, whose static balance
        is the load estimate: the air's, plus the friction elements' with the observer on.
        ``rows``: (1, N_PARAMS) the nominal plant, or one row per env."""
        f = api.force(L, pc, pe, rows if len(rows) > 1 else rows[0])
        return f if self.friction is None else f + self.friction.force(L, pc, pe, rows)

    def _filtered(self, load_now: np.ndarray) -> np.ndarray:
        """Low-pass filter of the load estimate (in the mechanism's units: the rig's hanging
        weight, the joint's external torque); an env that just started takes the estimate as is."""
        n = load_now.shape[0]
        if self._weight is None or self._weight.shape[0] != n:
            self._weight = np.full(n, np.nan)
            self._integral = np.zeros((n, 2))
        self._weight = low_pass(self._weight, load_now, self.alpha)
        return self._weight

    @property
    def last_gap(self) -> np.ndarray:
        """The set-point gaps (N, 2) [Pa] of the last action, contractor then extensor: what the
        nominal model says each chamber still needs (agents read them as a feature)."""
        pc_set, pc, pe_set, pe = self._last
        return np.stack([np.asarray(pc_set - pc, float), np.asarray(pe_set - pe, float)], axis=1)

    def _drive(self, pc_set, pe_set, L, pc, pe, setpoint_max: float, single: bool) -> np.ndarray:
        """Actions that bring the chambers to the set-points, by action mode (step 4 above).
        Keeps the set-points and measured pressures for :attr:`last_gap`."""
        self._last = (pc_set, pc, pe_set, pe)
        if self.mode == "pressure":
            action = pressure_actions(pc_set, pe_set, setpoint_max)
        else:
            vc, ve, _, _ = api.chamber_volumes(L, self.params)
            uc, self._integral[:, 0] = self._valve_command(pc_set, pc, vc, self._integral[:, 0])
            ue, self._integral[:, 1] = self._valve_command(pe_set, pe, ve, self._integral[:, 1])
            action = np.stack([uc, ue], axis=1)
        action = np.clip(action, -1.0, 1.0).astype(np.float32)
        return action[0] if single else action


def low_pass(previous: np.ndarray, now: np.ndarray, alpha: float) -> np.ndarray:
    """One step of the load estimate's first-order filter: ``now`` where an env has no estimate
    yet (NaN: its episode just started), else ``previous`` moved ``alpha`` of the way to ``now``."""
    return np.where(np.isnan(previous), now, previous + alpha * (now - previous))


class FrictionAwareBaseline(InverseStaticController):
    """The baseline whose load estimate balances the friction elements' force too, tracked from
    the measured length (:class:`~cepam_gym.control.friction_observer.FrictionObserver`)."""

    def __init__(self, env, **kwargs):
        super().__init__(env, friction_observer=True, **kwargs)


class UnsupportedEnvError(TypeError):
    """A controller was asked to drive an env it is not built for (the rig's model-based
    controllers on the joint): the benchmark skips such pairs and says so."""


def rig_model_of(env) -> EnvModel:
    """The plant model (:class:`~cepam_gym.envs.model.EnvModel`) of a rig env (single, vector,
    wrapped or the SB3 adapter): its task, observation layout, nominal plant and timing.
    :class:`UnsupportedEnvError` when the env has none (the MuJoCo joint) or drives the hinge
    (``cepam_gym/CEPAMJoint-v1``): the rig's model and task do not apply; the joint's controller
    is ``joint_baseline``."""
    try:
        model = model_of(env)
    except NoModelError as e:
        raise UnsupportedEnvError(f"this controller drives the rig envs only ({e})") from None
    if model.mech != pl.RIG:
        raise UnsupportedEnvError(
            "this controller drives the rig envs only; on the joint env use 'baseline' "
            "(make_controller resolves it to joint_baseline), 'zero' or 'random'"
        )
    return model
