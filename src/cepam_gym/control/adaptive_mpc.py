"""The adaptive MPC: the practical MPC plus an online estimate of the load (and, optionally, of
plant parameters) from measurements only.

An extended Kalman filter per env on the state ``(m_load, theta)``, each a random walk (the
load's fast: it steps; the parameters' slow). Its measurement is the end cap's equation of motion
(Eq. 25 with the force of Eq. 41/45), which must balance at every step:

    0 = F(L, Pc, Pe; theta) + (m_end + m_load) (g - a) - c v

with ``L``, ``Pc``, ``Pe``, ``v`` measured and ``a`` the difference of measured velocities; the
residual's noise covers sensor noise and the friction the model leaves out. The parameters'
Jacobian is taken by finite differences of :func:`cepam_gym.physics.api.force` through a linear
map from ``theta`` to the parameter row (derived once at the nominal plant). The MPC then plans
through each env's estimated plant (its row refreshed exactly every ``refresh_steps``) under the
estimated load, which, unlike the MPC's low-pass of the static balance, accounts for the end
cap's acceleration and damping.

By default ``theta`` is empty (``keys=()``): the parameters of :data:`KEYS` (braid angles, the
bladder's wall and modulus: what sets the stiffness at given pressures) are not identifiable from
this balance on the v1 plant, whose braid friction grows with the pressures and so mimics an
error of the pressure areas. Measured on randomized-v1 (2 episodes): estimating the CPAM braid
angle raised the stiffness error from 3.8 % to 9.4 %; the four keys together, to 12.6 %.
``AdaptiveMPC(env, keys=[...])`` turns them on for experiments.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..physics import api
from ..physics import layout as ix
from ..plant.params import PlantParams
from .baseline import rig_model_of
from .mpc import KnownParamsMPC, ModelPredictiveController

# parameters it can estimate -> (prior standard deviation, finite-difference step), in the key's
# own units: a maker's tolerance, not the benchmark's randomization ranges
KEYS: dict[str, tuple[float, float]] = {
    "cpam_rest_angle_deg": (0.5, 0.05),
    "epam_sleeve_free_angle_deg": (1.0, 0.05),
    "bladder_thickness_mm": (0.02, 0.002),
    "bladder_shear_modulus_kpa": (200.0, 10.0),
}
LOAD_PRIOR_SD = 0.1  # kg: the first estimate comes from the nominal force balance
LOAD_WALK = 0.01  # kg per control step: load steps are followed within a few steps
THETA_WALK = 1e-3  # of the prior sd per control step
FORCE_NOISE = 0.1  # N: sensor noise through the force model plus unmodelled friction


class AdaptiveMPC(ModelPredictiveController):
    """``reset(indices=None)`` / ``act(obs, info=None)``; observations only (as the MPC)."""

    def __init__(self, env, config=None, refresh_steps: int = 10, keys=(), **overrides):
        super().__init__(env, config, **overrides)
        nominal: PlantParams = self.nominal
        edge = nominal.to_dict()  # unit-named keys, as randomize= and from_dict take them
        unknown = [k for k in keys if k not in KEYS]
        if unknown:
            raise InputError(f"adaptive_mpc cannot estimate {unknown}; it knows {sorted(KEYS)}")
        self.keys = keys = {k: KEYS[k] for k in keys}
        base = {k: float(edge[k]) for k in keys}
        self.theta0 = np.array(list(base.values()))
        self.prior_sd = np.array([sd for sd, _ in keys.values()])
        row0 = nominal.to_array()
        # d(row)/d(theta_j): the derived columns (1/b, t_a b / n, ...) follow each key
        self.drow = np.array(
            [(self._row({**base, k: base[k] + step}) - row0) / step for k, (_, step) in keys.items()]
        ).reshape(len(keys), row0.size)
        self.fd_steps = np.array([step for _, step in keys.values()])
        self.refresh_steps = int(refresh_steps)
        self._reset_filter(None)

    def _row(self, values: dict) -> np.ndarray:
        return PlantParams.from_dict(values, base=self.nominal, where="adaptive_mpc").to_array()

    def _reset_filter(self, indices) -> None:
        self._x = None if indices is None or getattr(self, "_x", None) is None else self._x
        if self._x is not None:
            idx = np.asarray(indices)
            self._x[idx] = np.nan  # re-initialised on the env's next observation
            self._v_prev[idx] = np.nan

    def reset(self, indices=None) -> None:
        super().reset(indices)
        if hasattr(self, "theta0"):
            self._reset_filter(indices)

    def _init(self, n: int) -> None:
        k = self.theta0.size
        self._x = np.full((n, 1 + k), np.nan)
        self._P = np.zeros((n, 1 + k, 1 + k))
        self._v_prev = np.full(n, np.nan)
        self._rows = np.array(np.broadcast_to(self.model_rows(n), (n, self.params.size)))
        self._age = np.zeros(n, dtype=np.int64)

    def _start(self, fresh, base, L, pc, pe) -> None:
        """Envs ``fresh`` (bool mask) start from the prior: their model's parameters (``base``, the
        rows of :meth:`model_rows`: the nominal plant's) and the load that balances that model's
        force at the measured state."""
        b = base[fresh]
        m0 = -api.force(L[fresh], pc[fresh], pe[fresh], b) / b[:, ix.GRAV] - b[:, ix.M_END]
        self._x[fresh, 0] = np.maximum(m0, 0.0)
        self._x[fresh, 1:] = self.theta0
        self._P[fresh] = np.diag(np.r_[LOAD_PRIOR_SD, self.prior_sd] ** 2)
        self._rows[fresh] = b
        self._age[fresh] = 0

    def estimate(self, L, pc, pe, v) -> None:
        """One EKF step for every env from the measured length, pressures and velocity."""
        n = L.shape[0]
        if self._x is None or self._x.shape[0] != n:
            self._init(n)
        base = np.broadcast_to(self.model_rows(n), (n, self.params.size))
        fresh = np.isnan(self._x[:, 0])
        if fresh.any():
            self._start(fresh, base, L, pc, pe)
        k = self.theta0.size
        a = np.where(np.isnan(self._v_prev), 0.0, (v - self._v_prev) / self.dt)
        self._v_prev = v.copy()
        # predict: random walks
        q = np.r_[LOAD_WALK, THETA_WALK * self.prior_sd] ** 2
        self._P += np.diag(q)[None]
        # measurement: the force balance and its Jacobian
        rows = base + (self._x[:, 1:] - self.theta0) @ self.drow
        m_tot = base[:, ix.M_END] + self._x[:, 0]
        F = api.force(L, pc, pe, rows)
        h = F + m_tot * (base[:, ix.GRAV] - a) - base[:, ix.DAMP] * v
        H = np.empty((n, 1 + k))
        H[:, 0] = base[:, ix.GRAV] - a
        for j in range(k):
            H[:, 1 + j] = (api.force(L, pc, pe, rows + self.fd_steps[j] * self.drow[j]) - F) / self.fd_steps[
                j
            ]
        PH = np.einsum("nij,nj->ni", self._P, H)
        s = np.einsum("ni,ni->n", H, PH) + FORCE_NOISE**2
        gain = PH / s[:, None]
        ok = np.isfinite(h) & ~fresh
        self._x[ok] -= gain[ok] * h[ok, None]  # the measurement says h = 0
        self._P[ok] -= np.einsum("ni,nj->nij", gain[ok], PH[ok])
        lo, hi = self.theta0 - 3 * self.prior_sd, self.theta0 + 3 * self.prior_sd
        self._x[:, 1:] = np.clip(self._x[:, 1:], lo, hi)  # the filter stays within the maker's tolerance
        self._x[:, 0] = np.maximum(self._x[:, 0], 0.0)
        self._age += 1
        due = (self._age % self.refresh_steps == 0) | fresh
        for i in np.flatnonzero(due) if self.keys else ():
            self._rows[i] = self._row(dict(zip(self.keys, self._x[i, 1:])))
        if not self.keys:  # the model's rows themselves (a known-parameters model follows its env's plant)
            self._rows[:] = base

    def act(self, obs, info=None) -> np.ndarray:
        single = np.ndim(obs) == 1
        obs = np.atleast_2d(np.asarray(obs, dtype=float))
        L, pc, pe, L_t, K_t = self._decode(obs)
        v = self.layout.value(obs, "velocity")
        self.estimate(L, pc, pe, v)
        ref_l, ref_k = self.reference(obs, L_t, K_t)
        h = self.cfg.horizon_steps
        x = self.estimate_state(obs, L, pc, pe, self._rows)
        load = np.repeat(self._x[:, :1], h, axis=1)
        a = self.planner.plan(x, self._rows, ref_l, ref_k, load).astype(np.float32)
        return a[0] if single else a


class KnownParamsAdaptiveMPC(AdaptiveMPC):
    """``adaptive_mpc`` given each env's true parameter row: its filter balances the true plant's
    force and it plans through the true plant; the load and the state are still estimated from
    the sensors. On the nominal plant it is ``adaptive_mpc``. Not a practical controller: the
    teacher of a student told the plant (``agent.plant_features``), which it asks for nothing that
    student is not told. Privileged: it reads the true rows of the env's model, as
    :class:`~cepam_gym.control.mpc.KnownParamsMPC` does."""

    model_rows = KnownParamsMPC.model_rows

    def __init__(self, env, config=None, refresh_steps: int = 10, keys=(), **overrides):
        if keys:
            raise InputError(
                f"adaptive_mpc_known_params is given the true parameters and estimates only the load: "
                f"keys must be empty, got {list(keys)}"
            )
        self.model = rig_model_of(env)
        super().__init__(env, config, refresh_steps, (), **overrides)
