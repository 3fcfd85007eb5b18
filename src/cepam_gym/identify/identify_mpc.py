"""Identify, then control: the MPC on a plant fitted to the episode's identification window.

On an env whose episodes start with an identification window (:mod:`cepam_gym.tasks.window`), per
env and from the sensors only:

1. **the window**: it plays the project's excitation (:func:`cepam_gym.identify.excite.schedule`
   at the control rate: chamber exhaust, valve anchors, pressure steps, chirps, pseudo-random
   binary sequences) and logs what it sent and what the sensors read (both pressures, the length,
   the supply). A guard keeps the excitation within the bladder's limits: a chamber measured
   above :data:`GUARD` of the nominal burst pressure is vented, and within 10 % below it may not
   be filled (the log keeps the commands actually sent, so the fit sees them);
2. **the fit**, at the window's end: :func:`cepam_gym.identify.window_fit.fit_window`, the
   project's output-error identification with the static parameters that carry the
   randomization's gap freed (the braid angles, the bladder's wall and modulus), the moving mass
   (the load is not announced) and the valve, friction, volume and damping parameters, within a
   per-episode budget of evaluations and seconds;
3. **the tracking**: the practical MPC (:class:`~cepam_gym.control.mpc.ModelPredictiveController`,
   the planner of ``mpc`` and ``mpc_known_params``) planning through each env's fitted plant, its
   supply pressure the measured one, its load estimated from the sensors as the MPC's.

It reads only what a rig's engineer knows of the env (:class:`~cepam_gym.envs.model.EnvModel`'s
fixed facts: the nominal plant, the timing, the window's length, the observation layout), never
its privileged rows, states or schedules. It lives with the identification it runs (the
controller registry names it lazily, ``identify_mpc``).
"""

from __future__ import annotations

import time

import numpy as np

from ..control.baseline import UnsupportedEnvError, rig_model_of
from ..control.mpc import ModelPredictiveController
from ..physics import api
from ..physics import layout as ix
from .excite import EXHAUST_S, schedule
from .window_fit import FREE, fit_window, window_recording

GUARD = 0.75  # vent a chamber measured above this fraction of the nominal burst pressure
VENT = -0.5  # the venting command


class IdentifyMPC(ModelPredictiveController):
    """``reset(indices=None)`` / ``act(obs, info=None)`` on batched (or single) observations.
    ``max_nfev``: the evaluations of the log each env's fit may take; ``budget_s``: optionally,
    its seconds (None: no time budget, so the score does not depend on the machine);
    ``starts``: its starting points (the nominal plant, then random ones); ``free``: the
    parameters fitted (:data:`cepam_gym.identify.window_fit.FREE`)."""

    def __init__(
        self,
        env,
        config=None,
        budget_s: float | None = None,
        max_nfev: int = 100,
        starts: int = 1,
        free: tuple[str, ...] = FREE,
        seed: int = 0,
        **overrides,
    ):
        super().__init__(env, config, **overrides)
        model = rig_model_of(env)
        self.window = int(model.window_steps)
        if self.window < 2:
            raise UnsupportedEnvError(
                "identify_mpc needs episodes that start with an identification window "
                "(task option id_window_s, e.g. the suite randomized-id-v2)"
            )
        self.action_mode, self.sub_dt = model.action_mode, model.sub_dt
        seconds = self.window * self.dt
        # the schedule's shortest is its exhaust and a second more; a shorter window plays its start
        seconds = max(seconds, EXHAUST_S + 1.0) + self.dt
        cols = schedule(duration_s=seconds, rate_hz=1.0 / self.dt, mode=self.action_mode, seed=seed)
        self.excitation = np.column_stack([cols["command_c"], cols["command_e"]])[: self.window]
        self.budget_s = None if budget_s is None else float(budget_s)
        self.max_nfev, self.free = int(max_nfev), tuple(free)
        self.starts = int(starts)
        self.p_guard = GUARD * self.nominal.burst_pressure
        self.fits: list = []  # every fit of the controller's life (WindowFit), for reports
        self._k = None

    # ------------------------------------------------------------------ episode bookkeeping
    def _init(self, n: int) -> None:
        self._k = np.zeros(n, dtype=np.int64)  # control steps taken in the episode
        self._cmd = np.zeros((n, self.window, 2))
        self._meas = np.zeros((n, self.window, 3))
        self._supply = np.zeros((n, self.window))
        self._rows = np.repeat(self.params[None], n, axis=0)

    def reset(self, indices=None) -> None:
        super().reset(indices)
        if getattr(self, "_k", None) is None:
            return
        if indices is None:
            self._k = None
            return
        idx = np.asarray(indices)
        self._k[idx] = 0
        self._rows[idx] = self.params

    def model_rows(self, n: int) -> np.ndarray:
        return self._rows

    # ------------------------------------------------------------------ the window
    def _excite(self, idx, k, pc, pe) -> np.ndarray:
        """The excitation's commands of step ``k`` for envs ``idx``, guarded against bursts."""
        a = self.excitation[k].copy()
        for c, p in ((0, pc), (1, pe)):
            near = p > self.p_guard - 0.1 * self.nominal.burst_pressure
            a[:, c] = np.where(p > self.p_guard, VENT, np.where(near, np.minimum(a[:, c], 0.0), a[:, c]))
        return a

    def _fit(self, i: int) -> None:
        """Env ``i``'s plant from its window's log: the fitted row, the nominal end cap (the
        fitted moving mass carried the window's load, which the MPC estimates on its own)."""
        rec = window_recording(self._cmd[i], self._meas[i], self._supply[i], self.dt)
        # the fit starts from the nominal plant holding the weight its static balance reads at the
        # window's first sample (at rest): the load, unannounced, is most of the moving mass
        pc, pe, L = self._meas[i, 0]
        hanging = -float(api.force(np.array([L]), np.array([pc]), np.array([pe]), self.params)[0])
        start = self.nominal.replace(end_mass=float(np.clip(hanging / self.params[ix.GRAV], 0.005, 0.4)))
        fit = fit_window(
            rec,
            start,
            self.action_mode,
            self.sub_dt,
            self.free,
            budget_s=self.budget_s,
            max_nfev=self.max_nfev,
            starts=self.starts,
        )
        row = fit.params.to_array()
        row[ix.M_END] = self.params[ix.M_END]
        self._rows[i] = row
        self.fits.append(fit)

    def act(self, obs, info=None) -> np.ndarray:
        single = np.ndim(obs) == 1
        obs = np.atleast_2d(np.asarray(obs, dtype=float))
        n = obs.shape[0]
        if self._k is None or len(self._k) != n:
            self._init(n)
        L, pc, pe, _, _ = self._decode(obs)
        supply = self.layout.value(obs, "supply_pressure")
        out = np.zeros((n, 2), dtype=np.float32)
        k = self._k
        win = np.flatnonzero(k < self.window)
        if win.size:
            kw = k[win]
            self._meas[win, kw] = np.column_stack([pc[win], pe[win], L[win]])
            self._supply[win, kw] = supply[win]
            a = self._excite(win, kw, pc[win], pe[win])
            self._cmd[win, kw] = a
            out[win] = a
        ended = np.flatnonzero(k == self.window)
        t0 = time.perf_counter()
        for i in ended:
            self._fit(int(i))
        self.fit_seconds = time.perf_counter() - t0 if ended.size else getattr(self, "fit_seconds", 0.0)
        track = np.flatnonzero(k >= self.window)
        if track.size:
            self._rows[:, ix.P_SUP] = supply + self.params[ix.P_ATM]  # the supply as measured now
            out[track] = self._plan_all(obs)[track]
        self._k += 1
        return out[0] if single else out

    def _plan_all(self, obs) -> np.ndarray:
        """The MPC's actions for every env (those still in their window are planned and ignored:
        the planner runs the batch as one)."""
        return np.atleast_2d(super().act(obs))
