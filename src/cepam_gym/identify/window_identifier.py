"""The identification window's side of a sensor-only controller: excite, log, fit.

On an env whose episodes start with an identification window (:mod:`cepam_gym.envs.id_window`),
per env and from the sensors only:

1. **in the window** it plays the project's excitation (:func:`cepam_gym.identify.excite.schedule`
   at the control rate: chamber exhaust, valve anchors, pressure steps, chirps, pseudo-random
   binary sequences) and logs what it sent and what the sensors read (both pressures, the length,
   the supply). A guard keeps the excitation within the bladder's limits: a chamber measured
   above :data:`GUARD` of the nominal burst pressure is vented, and within 10 % below it may not
   be filled (the log keeps the commands actually sent, so the fit sees them);
2. **at the window's end** it fits the plant to the log:
   :func:`cepam_gym.identify.window_fit.fit_window`, the project's output-error identification
   with the static parameters that carry the randomization's gap freed, the moving mass (the load
   is not announced) and the valve, friction, volume and damping parameters. A fit without a time
   budget is remembered by its log and settings (:mod:`~cepam_gym.identify.fit_memo`): the next
   controller on the same episode reuses it.

Two controllers use it: ``identify_mpc`` (the MPC planning through the fitted plant) and a trained
agent given the plant (``agent.plant_features``: :func:`plant_columns` of the fitted row). It reads
only the env model's fixed facts (the nominal plant, the timing, the window's length, the
observation layout), never the privileged rows.
"""

from __future__ import annotations

import time

import numpy as np

from ..control.baseline import UnsupportedEnvError
from ..physics import api
from ..physics import layout as ix
from ..plant.params import PlantParams
from .excite import EXHAUST_S, schedule
from .fit_memo import FITS, fit_key
from .window_fit import FREE, fit_window, fit_window_staged, window_recording

GUARD = 0.75  # vent a chamber measured above this fraction of the nominal burst pressure
VENT = -0.5  # the venting command
NO_WINDOW = (
    "needs episodes that start with an identification window (task option id_window_s, e.g. the "
    "suite randomized-id-v2)"
)


class WindowIdentifier:
    """``step(obs)`` once per control step on a batch of observations; ``rows`` (N, N_PARAMS) the
    plant each env is believed to be (the nominal row until its window has been fitted, then the
    fit with the nominal end cap: the fitted moving mass carried the window's load, which a
    controller estimates on its own). ``max_nfev``, ``budget_s``, ``starts``, ``free``: the fit's
    (:func:`~cepam_gym.identify.window_fit.fit_window`); ``staged``: the better of that fit and a
    staged one (:func:`~cepam_gym.identify.window_fit.fit_window_staged`)."""

    def __init__(
        self,
        model,
        who: str = "this controller",
        budget_s: float | None = None,
        max_nfev: int = 100,
        starts: int = 1,
        free: tuple[str, ...] = FREE,
        seed: int = 0,
        staged: bool = True,
    ):
        self.window = int(model.window_steps)
        if self.window < 2:
            raise UnsupportedEnvError(f"{who} {NO_WINDOW}")
        self.layout = model.obs_layout
        self.nominal = model.nominal
        self.params = model.nominal.to_array()
        self.dt = float(model.control_dt)
        self.action_mode, self.sub_dt = model.action_mode, model.sub_dt
        seconds = self.window * self.dt
        # the schedule's shortest is its exhaust and a second more; a shorter window plays its start
        seconds = max(seconds, EXHAUST_S + 1.0) + self.dt
        cols = schedule(duration_s=seconds, rate_hz=1.0 / self.dt, mode=self.action_mode, seed=seed)
        self.excitation = np.column_stack([cols["command_c"], cols["command_e"]])[: self.window]
        self.budget_s = None if budget_s is None else float(budget_s)
        self.max_nfev, self.free, self.starts = int(max_nfev), tuple(free), int(starts)
        self.staged = bool(staged)
        self.p_guard = GUARD * self.nominal.burst_pressure
        self.fits: list = []  # every fit of its life (WindowFit), for reports
        self.fit_seconds = 0.0
        self.k = None  # control steps each env has taken in its episode

    def reset(self, indices=None) -> None:
        """Start new episodes: all envs, or ``indices``."""
        if indices is None or self.k is None:
            self.k = None
            return
        idx = np.asarray(indices)
        self.k[idx] = 0
        self.rows[idx] = self.params

    def _init(self, n: int) -> None:
        self.k = np.zeros(n, dtype=np.int64)
        self._cmd = np.zeros((n, self.window, 2))
        self._meas = np.zeros((n, self.window, 3))
        self._supply = np.zeros((n, self.window))
        self.rows = np.repeat(self.params[None], n, axis=0)

    def step(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Advance every env one control step on ``obs`` (N, obs_dim): ``(actions (N, 2), in the
        window (N,) bool, tracking starts now (N,) bool)``. The actions are the excitation's for
        the envs in their window (zero elsewhere); an env whose window has just ended is fitted
        here, before its first tracking step."""
        n = obs.shape[0]
        if self.k is None or len(self.k) != n:
            self._init(n)
        v = self.layout.decode(obs)
        pc, pe, L = v["pressure_c"], v["pressure_e"], v["length"]
        out = np.zeros((n, 2), dtype=np.float32)
        k = self.k
        in_window = k < self.window
        win = np.flatnonzero(in_window)
        if win.size:
            kw = k[win]
            self._meas[win, kw] = np.column_stack([pc[win], pe[win], L[win]])
            self._supply[win, kw] = v["supply_pressure"][win]
            a = self._excite(kw, pc[win], pe[win])
            self._cmd[win, kw] = a
            out[win] = a
        starts = k == self.window
        t0 = time.perf_counter()
        for i in np.flatnonzero(starts):
            self._fit(int(i))
        if starts.any():
            self.fit_seconds = time.perf_counter() - t0
        self.k += 1
        return out, in_window, starts

    def _excite(self, k, pc, pe) -> np.ndarray:
        """The excitation's commands of steps ``k``, guarded against bursts."""
        a = self.excitation[k].copy()
        for c, p in ((0, pc), (1, pe)):
            near = p > self.p_guard - 0.1 * self.nominal.burst_pressure
            a[:, c] = np.where(p > self.p_guard, VENT, np.where(near, np.minimum(a[:, c], 0.0), a[:, c]))
        return a

    def start_of(self, first) -> PlantParams:
        """The plant a fit starts from, given the window's first sample ``(pc, pe, L)`` (at rest):
        the nominal plant holding the weight its static balance reads there (the load, not
        announced, is most of the moving mass)."""
        pc, pe, L = first
        hanging = -float(api.force(np.array([L]), np.array([pc]), np.array([pe]), self.params)[0])
        return self.nominal.replace(end_mass=float(np.clip(hanging / self.params[ix.GRAV], 0.005, 0.4)))

    def _fit(self, i: int) -> None:
        start = self.start_of(self._meas[i, 0])
        key = None
        if self.budget_s is None:  # a timed fit depends on the machine: never remembered
            how = (self.dt, self.action_mode, self.sub_dt, self.free, self.max_nfev, self.starts, self.staged)
            key = fit_key(self._cmd[i], self._meas[i], self._supply[i], start.to_array(), how)
        fit = None if key is None else FITS.get(key)
        if fit is None:
            rec = window_recording(self._cmd[i], self._meas[i], self._supply[i], self.dt)
            fit = (fit_window_staged if self.staged else fit_window)(
                rec,
                start,
                self.action_mode,
                self.sub_dt,
                self.free,
                budget_s=self.budget_s,
                max_nfev=self.max_nfev,
                starts=self.starts,
            )
            if key is not None:
                FITS.put(key, fit)
        row = fit.params.to_array()
        row[ix.M_END] = self.params[ix.M_END]
        self.rows[i] = row
        self.fits.append(fit)


_COLUMNS: dict[bytes, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


def _columns(nominal) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The parameter row's columns the window's fit moves (its free names but the moving mass,
    which carries the load), found by moving each name: ``(ratio columns, linear columns, their
    units)``. A column with a positive nominal value is told as a log ratio; one whose nominal
    value is 0 (the guide's Coulomb friction) in units of the row's value at the name's
    :data:`~cepam_gym.identify.window_fit.TOLERANCE`. Columns that move by rounding alone are not
    told."""
    from ..validation.fitcore import apply
    from .dynamic_params import ALL_PARAMS
    from .window_fit import TOLERANCE

    base = nominal.to_array()
    key = base.tobytes()
    if key not in _COLUMNS:
        ratio: set[int] = set()
        linear: dict[int, float] = {}
        for name in FREE:
            if name == "end_mass":
                continue
            value = ALL_PARAMS[name].get(nominal)
            moved = apply(
                ALL_PARAMS, nominal, [name], [value * 1.05 if value else TOLERANCE[name]]
            ).to_array()
            changed = np.abs(moved - base) > 1e-9 * np.maximum(np.abs(base), 1e-30)
            for c in np.flatnonzero(changed):
                if c == ix.M_END:
                    continue
                if base[c] > 0:
                    ratio.add(int(c))
                elif base[c] == 0.0:
                    linear[int(c)] = float(moved[c])
        lin = sorted(linear)
        _COLUMNS[key] = (
            np.array(sorted(ratio)),
            np.array(lin, dtype=int),
            np.array([linear[c] for c in lin]),
        )
    return _COLUMNS[key]


def told_rows(rows: np.ndarray, nominal, supply_pa) -> np.ndarray:
    """The plant a policy is told, as parameter rows (N, N_PARAMS): ``rows`` (the true plant in
    training, the window's fit deployed) with the nominal end cap (the moving mass carries the
    load, which no one announces) and the supply measured now (``supply_pa``, gauge)."""
    out = np.array(rows, dtype=float)
    base = nominal.to_array()
    out[:, ix.M_END] = base[ix.M_END]
    out[:, ix.P_SUP] = np.asarray(supply_pa, dtype=float) + base[ix.P_ATM]
    return out


def plant_columns(rows: np.ndarray, nominal) -> np.ndarray:
    """What a policy is told of the plant (N, k) float32: the columns the window's fit moves, as
    ``log(row / nominal)`` (0 for the nominal plant) and, for a column whose nominal value is 0,
    the value over its unit (:func:`_columns`); clipped to +-2. Training reads the true rows, a
    deployed agent its window's fitted rows (:class:`WindowIdentifier`)."""
    ratio, linear, units = _columns(nominal)
    rows = np.asarray(rows, dtype=float)
    base = nominal.to_array()
    r = np.log(np.maximum(rows[:, ratio], 1e-300) / base[ratio])
    out = np.concatenate([r, rows[:, linear] / units], axis=1)
    return np.clip(np.nan_to_num(out), -2.0, 2.0).astype(np.float32)


def rows_of_columns(columns: np.ndarray, nominal) -> np.ndarray:
    """The parameter rows (N, N_PARAMS) whose :func:`plant_columns` are ``columns`` (within the
    clip): the nominal row with each told column set, the rest (the end cap, the supply) nominal.
    An estimate of the columns (:mod:`cepam_gym.policies.plant_estimate`) is told as these rows."""
    ratio, linear, units = _columns(nominal)
    c = np.asarray(columns, dtype=float)
    base = nominal.to_array()
    rows = np.repeat(base[None], len(c), axis=0)
    rows[:, ratio] = base[ratio] * np.exp(c[:, : len(ratio)])
    rows[:, linear] = c[:, len(ratio) :] * units
    return rows


def plant_dim(nominal) -> int:
    """The number of :func:`plant_columns`."""
    ratio, linear, _ = _columns(nominal)
    return len(ratio) + len(linear)
