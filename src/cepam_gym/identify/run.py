"""One identification end to end: read, resample, fit, judge, score (:func:`identify`).

Scores follow the nonlinear_benchmarks convention (Beintema, Schoukens and Toth 2023): a free-run
simulation from the recording's start, the first ``warmup_s`` seconds not scored, then per
channel ``NRMSE = RMS(predicted - measured) / std(measured)`` and ``R^2 = 1 - SSE / SST``.
Held-out data are a ``holdout`` log, or else the last quarter of each recording (fitted on the
first three quarters).

Uncertainty: the fitting core's ``s^2 (J^T J)^-1``, widened by ``(1 + rho) / (1 - rho)`` with
``rho`` the largest lag-1 autocorrelation of the residuals over the channels: residuals that are
model error rather than sensor noise are correlated in time, and hold fewer independent samples
than rows. A plant parameter is called identifiable when the Jacobian sees it, it is off its
bounds and its approximate 95 % interval (2 sd) is within 10 % of its value, and the residuals
are close to white (``rho`` at most 0.82): else the fit has not reached the sensor noise, and a
local interval vouches for nothing.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..plant.params import PlantParams, preset
from ..validation import fitcore
from .dynamic_params import ALL_PARAMS, DEFAULT_FREE, SENSOR_NEUTRAL, SENSOR_PARAMS
from .fit import SENSOR_NAMES, Problem, scaling, solve
from .logs import Recording, grid_steps, read_log, resample
from .simulate import CHANNELS

HOLDOUT_FRACTION = 0.25
REL_CI = 0.10  # identifiable: 2 sd within 10 % of the value
# residuals this correlated (lag-1 rho above 0.82) are model error or a local minimum, not sensor
# noise: intervals from the local Jacobian then vouch for nothing (a wrong minimum can be sharp)
MAX_INFLATION = 10.0


def scores(pred: np.ndarray, meas: np.ndarray) -> dict[str, dict[str, float]]:
    """Per channel ``{"nrmse", "r2"}`` of predicted against measured (T, 3) samples."""
    out = {}
    for c, name in enumerate(CHANNELS):
        err = pred[:, c] - meas[:, c]
        sst = float(np.sum((meas[:, c] - meas[:, c].mean()) ** 2))
        sse = float(np.sum(err**2))
        std = float(np.std(meas[:, c]))
        out[name] = {
            "nrmse": float(np.sqrt(np.mean(err**2)) / std) if std > 0 else float("nan"),
            "r2": 1.0 - sse / sst if sst > 0 else float("nan"),
        }
    return out


@dataclass
class Scored:
    name: str
    role: str  # "fitted" | "held out"
    time: np.ndarray
    measured: np.ndarray
    predicted: np.ndarray
    preset: np.ndarray  # the base plant with ideal sensors
    scored_from: int  # first scored sample
    fit: dict = field(default_factory=dict)  # scores of the fit
    base: dict = field(default_factory=dict)  # scores of the preset alone


@dataclass
class Identification:
    preset: str
    mode: str
    data: list[str]
    holdout: list[str]
    names: tuple[str, ...]  # plant parameters, then SENSOR_NAMES
    units: list[str]
    start: np.ndarray
    values: np.ndarray
    std: np.ndarray
    at_bound: np.ndarray
    identifiable: np.ndarray
    cov: np.ndarray
    bounds: dict
    params: PlantParams
    records: list[Scored]
    seconds: float
    cost: float
    message: str
    starts: int
    inflation: float
    notes: list[str]
    k: int  # number of plant parameters

    def fields(self) -> list[str]:
        """The PlantParams fields the identification sets (the supply when the logs measured it)."""
        out = [f for n in self.names[: self.k] for f in ALL_PARAMS[n].fields]
        if self.params.pwm_timing != preset(self.preset).pwm_timing:
            out.append("pwm_timing")
        measured = self.params.supply_pressure != preset(self.preset).supply_pressure
        return out + (["supply_pressure"] if measured and "supply_pressure" not in out else [])

    def worst(self, role: str) -> dict[str, float]:
        """The largest NRMSE per channel over the recordings of ``role``."""
        rs = [r.fit for r in self.records if r.role == role]
        return {c: max(r[c]["nrmse"] for r in rs) for c in CHANNELS} if rs else {}


def model_plant(base: PlantParams, mode: str) -> PlantParams:
    """The plant a fit in ``mode`` simulates: in ``pwm`` mode the on/off valves switch at their
    exact PWM edges and dead times (``pwm_timing: exact``). A rig's solenoids do; and read once
    per sub-step instead, the error is a staircase in the dead times that the fit cannot descend
    (docs/identify.md, "pwm mode"). The identified plant keeps the option, so what trains on it
    sees the same valves."""
    return base.replace(pwm_timing="exact") if mode == "pwm" else base


def _grid(recs: list[Recording], sub_dt: float) -> tuple[list[Recording], list[int]]:
    n = [grid_steps(r, sub_dt) for r in recs]
    return [resample(r, k * sub_dt) for r, k in zip(recs, n)], n


def identify(
    data: list[str | Path] | list[Recording],
    base: str = "balloon",
    mode: str = "valve",
    free: tuple[str, ...] = (),
    holdout: list[str | Path] | list[Recording] = (),
    warmup_s: float = 1.0,
    starts: int = 4,
    seed: int = 0,
    sub_dt: float = 5e-4,
    bounds: dict | None = None,
    only: tuple[str, ...] = (),
) -> Identification:
    """Fit the dynamic parameters of ``mode`` (plus ``free`` ones) and the sensors to ``data``;
    ``only``: these plant parameters instead of the mode's (a short fit of what a rig may differ in)."""
    t0 = time.perf_counter()
    if mode not in DEFAULT_FREE:
        raise InputError(f"mode must be one of {sorted(DEFAULT_FREE)}, got {mode!r}")
    names = tuple(dict.fromkeys((tuple(only) or DEFAULT_FREE[mode]) + tuple(free)))
    scaling(names, bounds)  # bad options: refused before any file is read
    recs = [r if isinstance(r, Recording) else read_log(r) for r in data]
    held = [r if isinstance(r, Recording) else read_log(r) for r in holdout]
    if not recs:
        raise InputError("no recording to fit: give one or more --data files")
    if not held:
        recs, held = map(list, zip(*(r.split(1.0 - HOLDOUT_FRACTION) for r in recs)))
    for r in recs + held:
        if r.duration <= warmup_s + 1.0:
            raise InputError(
                f"{r.name}: {r.duration:.3g} s; needs more than the {warmup_s:g} s warm-up + 1 s"
            )
    base_params = model_plant(preset(base), mode)
    fit_recs, n_fit = _grid(recs, sub_dt)
    problem = Problem(fit_recs, n_fit, sub_dt, base_params, mode, names, warmup_s, bounds)
    sol = solve(problem, starts=starts, seed=seed)
    k = problem.k
    z = sol.x
    r = problem.residuals(z)
    J = problem.jacobian(z)
    inflation = _inflation(r, problem)
    unc = fitcore.uncertainty(J, r, problem.scale.dx_dz(z), problem.scale.names, inflation)
    values = problem.scale.to_edge(z)
    at_bound = fitcore.at_bounds(sol)
    ident = unc.rank_ok & ~at_bound & (2.0 * unc.std <= REL_CI * np.abs(values))
    if inflation > MAX_INFLATION:
        ident[:] = False
    params = problem.plant(z[:k])
    supplies = [r.supply for r in recs if r.supply is not None]
    if supplies:  # the logs' supply (their mean) goes into the plant the env will run
        params = params.replace(supply_pressure=float(np.mean(supplies)))
    records = _scored_records(problem, z, held)
    notes = _fit_notes(problem, unc, inflation, at_bound)
    return Identification(
        preset=base,
        mode=mode,
        data=[r.name for r in recs],
        holdout=[r.name for r in held],
        names=problem.scale.names,
        units=[(ALL_PARAMS.get(n) or SENSOR_PARAMS[n]).unit for n in problem.scale.names],
        start=problem.scale.to_edge(problem.start()),
        values=values,
        std=unc.std,
        at_bound=at_bound,
        identifiable=ident,
        cov=unc.cov,
        bounds=problem.scale.bounds(),
        params=params,
        records=records,
        seconds=time.perf_counter() - t0,
        cost=float(sol.cost),
        message=str(sol.message),
        starts=starts,
        inflation=inflation,
        notes=notes,
        k=k,
    )


def _scored_records(problem: Problem, z: np.ndarray, held: list) -> list:
    """Every recording, fitted (``problem``'s) and ``held`` out, scored by the fit ``z`` and by the
    preset alone."""
    fit_recs = problem.recordings
    held_recs, n_held = _grid(held, problem.sub_dt)
    score = dataclasses.replace(problem, recordings=fit_recs + held_recs, n_sub=problem.n_sub + n_held)
    z_base = problem.start()
    z_base[problem.k :] = _neutral_z(problem)
    records = []
    for i, rec in enumerate(score.recordings):
        pred, pre = score.predict(z, i), score.predict(z_base, i)
        s = score._scored(rec).start
        role = "fitted" if i < len(fit_recs) else "held out"
        sc = Scored(rec.name, role, rec.time, rec.measured, pred, pre, s)
        sc.fit, sc.base = scores(pred[s:], rec.measured[s:]), scores(pre[s:], rec.measured[s:])
        records.append(sc)
    return records


def _fit_notes(problem, unc, inflation: float, at_bound: np.ndarray) -> list[str]:
    """What a reader of the fit must know: correlated residuals, values at a bound, correlations."""
    notes = list(unc.notes)
    if inflation > MAX_INFLATION:
        notes.append(
            f"the residuals are correlated in time (intervals widened x{np.sqrt(inflation):.2g}): the fit "
            "did not reach the sensor noise (a model structure that differs from the rig's, or a local "
            "minimum: try more --starts, --free the parameters the rig may differ in), so no value is "
            "called identifiable"
        )
    if np.any(at_bound):
        notes.append(
            "at a bound (no confidence interval): " + ", ".join(np.array(problem.scale.names)[at_bound])
        )
    notes += fitcore.correlation_notes(problem.scale.names, unc.cov, at_bound)
    return notes


def _neutral_z(problem: Problem) -> np.ndarray:
    """``z`` of ideal sensors (no delay, unit gain, no bias)."""
    x = problem.scale.to_edge(problem.start())
    x[problem.k :] = [SENSOR_NEUTRAL[n] for n in SENSOR_NAMES]
    return problem.scale.to_z(x)[problem.k :]


def _inflation(r: np.ndarray, problem: Problem) -> float:
    """``(1 + rho) / (1 - rho)``, ``rho`` the largest lag-1 autocorrelation of a channel's residuals."""
    rho = 0.0
    at = 0
    for rec in problem.recordings:
        n = (len(rec.time) - problem._scored(rec).start) * 3
        block = r[at : at + n].reshape(-1, 3)
        at += n
        for c in range(3):
            x = block[:, c] - block[:, c].mean()
            d = float(x @ x)
            if d > 0:
                rho = max(rho, float(x[1:] @ x[:-1]) / d)
    rho = min(max(rho, 0.0), 0.999)
    return (1.0 + rho) / (1.0 - rho)
