"""The dynamic fit: the plant's dynamic parameters and the sensors, jointly over recordings.

Residuals: every sample after the warm-up of every recording, per channel ``(predicted -
measured) / s_c`` with ``s_c`` the channel's spread over all fitted data, so each channel weighs
by its normalised error (what the report scores). A prediction is a free-run simulation of the
whole recording from rest at its first sample (an output-error fit: errors accumulate as they
would in a simulator, Ljung 1999, ch. 7), passed through the sensor model.

Solver: the fitting core's bounded trust-region least squares (:func:`..validation.fitcore.solve`)
on ``z`` in [0, 1]. The Jacobian's physics columns come from one batched run of the plant with a
row per forward-differenced parameter (:func:`.simulate.replay`); the sensor columns only re-apply
the sensor model. Several starts (the preset, then seeded random points in ``z``) run a short
budget each; the best is polished (a cheap global stage: the problem has local minima where a
sensor delay stands in for a valve lag).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import plant as pl
from .. import progress
from ..errors import InputError
from ..plant.params import PlantParams
from ..validation import fitcore
from .dynamic_params import ALL_PARAMS, SENSOR_NEUTRAL, SENSOR_PARAMS
from .logs import Recording
from .simulate import plant_commands, refinement, replay, sensed

SENSOR_NAMES = tuple(SENSOR_PARAMS)
_FD_STEP = 2e-3  # forward-difference step in z (0.2 % of the log-span: about 1 % of a conductance)
# with the sampled PWM timing (a plant's ``pwm_timing: substep``) the on/off valves' dead times move
# a valve edge only by whole sub-steps: a step smaller than two sub-steps sees a staircase, a zero
# or a huge slope. ``identify`` fits pwm logs with exact timing (``run.model_plant``), where the
# ordinary step serves.
_QUANTIZED_MS = ("onoff_open_delay", "onoff_close_delay")


def sensor_si(values: dict[str, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(delay [s], gain, bias [Pa, Pa, m])`` per channel of sensor values in edge units."""
    chans = ("pressure_c", "pressure_e", "length")
    delay = np.array([values[f"{c}_delay"] * 1e-3 for c in chans])
    gain = np.array([values[f"{c}_gain"] for c in chans])
    bias = np.array([values[f"{c}_bias"] * s for c, s in zip(chans, (1e3, 1e3, 1e-2))])
    return delay, gain, bias


def scaling(names: tuple[str, ...], bounds: dict | None) -> fitcore.Scaling:
    """The scaling of plant parameters ``names`` and the sensors; ``ValueError`` for an unknown
    name, two names writing one field, a bound on something not fitted, or ``lo >= hi``."""
    fitcore.check_names(ALL_PARAMS, names)
    unknown = sorted(set(bounds or {}) - set(names) - set(SENSOR_NAMES))
    if unknown:
        raise InputError(f"--bounds names {unknown}, which are not fitted (fitted: {list(names)})")
    return fitcore.Scaling([ALL_PARAMS[n] for n in names] + [SENSOR_PARAMS[n] for n in SENSOR_NAMES], bounds)


@dataclass
class Problem:
    """Recordings on their grids, the base plant, the action mode and what is free."""

    recordings: list[Recording]  # resampled: even grids of n_sub sub-steps
    n_sub: list[int]
    sub_dt: float
    base: PlantParams
    mode: str
    names: tuple[str, ...]  # free plant parameters (ALL_PARAMS); the sensors follow them in z
    warmup_s: float = 1.0
    bounds: dict | None = None

    def __post_init__(self):
        self.scale = scaling(self.names, self.bounds)
        self.k = len(self.names)
        self.fd = np.full(self.scale.lo.size, _FD_STEP)
        for j, n in enumerate(self.names):
            if n in _QUANTIZED_MS and self.base.pwm_timing == "substep":
                self.fd[j] = max(_FD_STEP, 2.0 * self.sub_dt * 1e3 / (self.scale.hi[j] - self.scale.lo[j]))
        self.spread = np.std(np.concatenate([r.measured[self._scored(r)] for r in self.recordings]), axis=0)
        self.spread = np.maximum(self.spread, [1e3, 1e3, 1e-4])  # a channel that never moves: 1 kPa, 0.1 mm

    # ------------------------------------------------------------------ pieces
    def _scored(self, rec: Recording) -> slice:
        return slice(int(np.ceil(self.warmup_s / (rec.time[1] - rec.time[0]))), None)

    def plant(self, z_phys: np.ndarray) -> PlantParams:
        return fitcore.apply(
            ALL_PARAMS, self.base, self.names, self.scale.to_edge(self._full(z_phys))[: self.k]
        )

    def _full(self, z_phys):
        z = np.zeros(self.scale.lo.size)
        z[: self.k] = z_phys
        return z

    def sensors(self, z: np.ndarray):
        x = self.scale.to_edge(z)[self.k :]
        return sensor_si(dict(zip(SENSOR_NAMES, x)))

    def run(self, rows: list[PlantParams], rec_i: int) -> np.ndarray:
        """Plant channels (N, T, 3) of recording ``rec_i`` for the plants ``rows``."""
        rec = self.recordings[rec_i]
        if rec.supply is not None:  # the log's own supply pressure
            rows = [p.replace(supply_pressure=rec.supply) for p in rows]
        arr = np.array([p.to_array() for p in rows])
        n_ref = refinement(arr, self.sub_dt)
        n_sub = self.n_sub[rec_i] * n_ref
        cmds = plant_commands(rec.commands, pl.MODES[self.mode], self.base.pressure_cap)
        p0 = rows[0]
        start = (float(np.clip(rec.measured[0, 2], p0.min_length, p0.max_length)), *rec.measured[0, :2])
        mode = pl.MODES[self.mode]
        return replay(arr, cmds, rec.loads, mode, self.sub_dt / n_ref, n_sub, start, rec.supply_trace)

    def predict(self, z: np.ndarray, rec_i: int, y: np.ndarray | None = None) -> np.ndarray:
        """What the sensors report (T, 3) for parameters ``z``; ``y`` the plant channels if known."""
        rec = self.recordings[rec_i]
        if y is None:
            y = self.run([self.plant(z[: self.k])], rec_i)[0]
        return sensed(y, rec.time[1] - rec.time[0], *self.sensors(z))

    def _residual(self, pred: np.ndarray, rec_i: int) -> np.ndarray:
        rec = self.recordings[rec_i]
        sl = self._scored(rec)
        r = (pred[..., sl, :] - rec.measured[sl]) / self.spread
        return r.reshape(*pred.shape[:-2], -1)

    # ------------------------------------------------------------------ least squares
    def residuals(self, z: np.ndarray) -> np.ndarray:
        try:
            plant = self.plant(z[: self.k])
        except ValueError:  # an impossible parameter set: as bad as predicting nothing
            return np.concatenate(
                [np.full(self._residual(r.measured, i).size, 10.0) for i, r in enumerate(self.recordings)]
            )
        out = []
        for i in range(len(self.recordings)):
            pred = self.predict(z, i, self.run([plant], i)[0])
            out.append(np.nan_to_num(self._residual(pred, i), nan=10.0, posinf=10.0, neginf=-10.0))
        return np.concatenate(out)

    def jacobian(self, z: np.ndarray) -> np.ndarray:
        """Forward differences (backward at an upper bound): the plant columns from one batched
        run per recording, the sensor columns from the sensor model alone."""
        steps = np.where(z + self.fd <= 1.0, self.fd, -self.fd)
        rows, cols = [self.plant(z[: self.k])], []
        for j in range(self.k):
            zj = z[: self.k].copy()
            zj[j] += steps[j]
            try:
                rows.append(self.plant(zj))
                cols.append(j)
            except ValueError:  # the step leaves the valid set: the column stays 0
                pass
        blocks = []
        for i in range(len(self.recordings)):
            y = self.run(rows, i)
            r0 = self._residual(self.predict(z, i, y[0]), i)
            J = np.zeros((r0.size, z.size))
            for c, j in enumerate(cols):
                J[:, j] = (self._residual(self.predict(z, i, y[c + 1]), i) - r0) / steps[j]
            for j in range(self.k, z.size):
                zj = z.copy()
                zj[j] += steps[j]
                J[:, j] = (self._residual(self.predict(zj, i, y[0]), i) - r0) / steps[j]
            blocks.append(np.nan_to_num(J))
        return np.concatenate(blocks)

    def start(self) -> np.ndarray:
        """``z`` of the base plant with neutral sensors (a 1 ms delay: off the bound)."""
        x = [ALL_PARAMS[n].get(self.base) for n in self.names]
        x += [SENSOR_NEUTRAL[n] if not n.endswith("_delay") else 1.0 for n in SENSOR_NAMES]
        return self.scale.to_z(np.array(x))


def solve(problem: Problem, starts: int = 4, seed: int = 0, budget: int = 12, polish: int = 60):
    """The best of ``starts`` short fits (the base plant first, then seeded random points in
    ``z`` with neutral sensors), polished; scipy's result. A progress bar (on a terminal) counts
    the residual evaluations against their budget: ``budget`` per start, ``polish`` for the
    polish; a stage that converges early jumps to its end."""
    rng = np.random.default_rng(seed)
    z0 = problem.start()
    z0s = [z0]
    for _ in range(starts - 1):
        z = z0.copy()
        z[: problem.k] = rng.uniform(0.1, 0.9, problem.k)
        z0s.append(z)
    stages = [([z], budget) for z in z0s] if starts > 1 else []
    used = [0]

    def counted(z: np.ndarray) -> np.ndarray:
        used[0] += 1
        progress.advance(1)
        return problem.residuals(z)

    def stage(z_starts: list, nfev: int):
        used[0] = 0
        sol = fitcore.solve(counted, z_starts, jac=problem.jacobian, tol=1e-8, max_nfev=nfev)
        progress.advance(max(0, nfev - used[0]))  # converged early: the stage is done
        return sol

    with progress.runs(budget * len(stages) + polish, "cepam-gym identify", unit="evaluations"):
        fits = [sol for sol in (stage(zs, n) for zs, n in stages) if sol is not None]
        best = min(fits, key=lambda sol: sol.cost, default=None)
        return stage([best.x if best is not None else z0], polish)
