"""Domain randomization that never kills a run.

``randomize={plant key: [low, high]}`` draws a plant per episode. Three things can go wrong with a
draw: the parameter set is impossible (``PlantParams.validate``), the explicit integration is
unstable at the env's sub-step (:func:`cepam_gym.plant.stability_number`), or the task finds no
reachable target for the plant (the schedule code's "found no reachable target"). Met inside
``step()``'s autoreset, any of them used to raise on every later step.

So :class:`Randomizer` checks the ranges when the env is built, naming the key: each key alone at
both ends of its range, then corners of the joint box and a small fixed random sample. A draw
that still fails at reset (the box is checked at a few points only) is redrawn from the env's own
stream, at most :data:`MAX_REDRAWS` times, and counted (``info["redraws"]``); past that the
nominal plant (checked when the env was built) is used.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping

import numpy as np

from .. import plant as pl
from ..errors import InputError
from ..physics import layout as ix
from ..plant.params import PlantParams
from ..tasks.spec import TaskSpec
from .schedules import stiffness_interval

MAX_REDRAWS = 16
STABILITY_LIMIT = 1.2  # as plant.check_stability
_FULL_CORNERS_UP_TO = 5  # keys; beyond, a fixed random subset of the 2^k corners
_N_CORNERS, _N_SAMPLES = 16, 8


def unreachable_load(row: np.ndarray, task: TaskSpec) -> float | None:
    """A hanging load [kg] of the task's range for which no target length of the task has a
    reachable stiffness on this plant (``None`` when both ends of the load range are feasible).
    Constant loads at the two ends: a necessary condition for the schedules to be solvable."""
    if task.fixed_length is not None:
        lengths = np.array([task.fixed_length])
    else:
        lengths = np.linspace(*task.length_range, 33)
    for load in task.load_range:
        w = (row[ix.M_END] + load) * row[ix.GRAV]
        k_lo, k_hi = stiffness_interval(lengths, w, w, row, task)
        if not np.any(k_hi > k_lo):
            return float(load)
    return None


def unstable(row: np.ndarray, sub_dt: float) -> str | None:
    """Why the explicit integration of this parameter row is unstable at ``sub_dt`` (``None``
    if it is not)."""
    s = float(pl.stability_number(row, sub_dt)[0])
    if s > STABILITY_LIMIT:
        return (
            f"the integration is unstable at sub_dt {sub_dt * 1e3:.3g} ms (stability number "
            f"{s:.2f} > {STABILITY_LIMIT}; valve conductance and heat transfer against the "
            "smallest chamber volume)"
        )
    return None


def check_plant(row: np.ndarray, task: TaskSpec, sub_dt: float) -> str | None:
    """Why this parameter row cannot run the task (``None`` if it can)."""
    why = unstable(row, sub_dt)
    if why:
        return why
    load = unreachable_load(row, task)
    if load is not None:
        return (
            f"task {task.name!r} has no reachable target for a load of {load:.3g} kg (its "
            "pressures cannot hold it between the contact pressure and "
            f"{task.pressure_margin:g} x min(supply, burst))"
        )
    return None


def sample_params(
    nominal: PlantParams,
    randomize: Mapping[str, tuple[float, float]],
    rng: np.random.Generator,
    nominal_row: np.ndarray | None = None,
) -> np.ndarray:
    """A parameter row for a new episode: ``nominal`` (its row ``nominal_row`` itself when given
    and nothing is randomised) with each key of ``randomize`` drawn uniformly from its range."""
    if not randomize:
        return nominal.to_array() if nominal_row is None else nominal_row
    draw = {k: rng.uniform(lo, hi) for k, (lo, hi) in randomize.items()}
    return PlantParams.from_dict(draw, base=nominal, where="randomize").to_array()


class Randomizer:
    """Checked ranges of ``randomize`` and the per-env draws (see the module doc). ``check``:
    why a parameter row cannot run the env (``None`` if it can); default :func:`check_plant` of
    the rig task ``task`` (the joint env passes its own)."""

    def __init__(
        self,
        ranges: Mapping[str, tuple[float, float]],
        nominal: PlantParams,
        task: TaskSpec,
        sub_dt: float,
        check=None,
    ):
        self.ranges = dict(ranges)
        self.nominal = nominal
        self.nominal_row = nominal.to_array()
        self.task, self.sub_dt = task, sub_dt
        self.check = check if check is not None else self._check_rig
        why = self.check(self.nominal_row)
        if why:
            raise InputError(f"the nominal plant cannot run this env: {why}")
        if self.ranges:
            self._check_ranges()

    def _check_rig(self, row: np.ndarray) -> str | None:
        return check_plant(row, self.task, self.sub_dt)

    def _row(self, values: Mapping[str, float], what: str) -> np.ndarray:
        try:
            return PlantParams.from_dict(dict(values), base=self.nominal, where="randomize").to_array()
        except ValueError as e:
            raise InputError(f"randomize: {what} is not a valid plant: {e}") from None

    def _check(self, values: Mapping[str, float], what: str) -> None:
        why = self.check(self._row(values, what))
        if why:
            raise InputError(f"randomize: {what}: {why}; narrow that range")

    def _check_ranges(self) -> None:
        keys = list(self.ranges)
        for key in keys:  # one key at a time: the message names the culprit
            for end, v in zip(("low", "high"), self.ranges[key]):
                self._check({key: v}, f"{key!r} at the {end} end of its range ({v:g})")
        if len(keys) < 2:
            return
        rng = np.random.default_rng(0)  # fixed: the check is the same at every build
        if len(keys) <= _FULL_CORNERS_UP_TO:
            corners = list(itertools.product((0, 1), repeat=len(keys)))
        else:
            corners = [tuple(c) for c in rng.integers(0, 2, (_N_CORNERS, len(keys)))]
        points = [{k: self.ranges[k][c] for k, c in zip(keys, corner)} for corner in corners]
        points += [{k: rng.uniform(*self.ranges[k]) for k in keys} for _ in range(_N_SAMPLES)]
        for values in points:
            shown = ", ".join(f"{k}={v:g}" for k, v in values.items())
            self._check(values, f"the combination {{{shown}}} of the ranges of {keys}")

    # ------------------------------------------------------------------ draws
    def _valid_draw(self, rng: np.random.Generator) -> tuple[np.ndarray | None, int]:
        """A valid parameter row (or None after MAX_REDRAWS failures) and the failures."""
        for tries in range(MAX_REDRAWS + 1):
            try:
                return sample_params(self.nominal, self.ranges, rng), tries
            except ValueError:
                continue
        return None, MAX_REDRAWS + 1

    def draw(self, rngs: list[np.random.Generator]) -> tuple[np.ndarray, np.ndarray]:
        """``(rows, redraws)``: one valid, stable parameter row per generator and how many draws
        were rejected. Each env's sequence of draws depends only on its own generator."""
        m = len(rngs)
        rows = np.empty((m, ix.N_PARAMS))
        redraws = np.zeros(m, dtype=np.int64)
        if not self.ranges:
            rows[:] = self.nominal_row
            return rows, redraws
        pending = np.arange(m)
        while len(pending):
            for j in pending:
                row, failed = self._valid_draw(rngs[j])
                redraws[j] += failed
                rows[j] = self.nominal_row if row is None else row
            unstable = pl.stability_number(rows[pending], self.sub_dt) > STABILITY_LIMIT
            redraws[pending[unstable]] += 1
            exhausted = unstable & (redraws[pending] > MAX_REDRAWS)
            rows[pending[exhausted]] = self.nominal_row
            pending = pending[unstable & ~exhausted]
        return rows, redraws

    def fallback(self) -> np.ndarray:
        """The row used when redraws are exhausted: the nominal plant, checked at build."""
        return self.nominal_row
