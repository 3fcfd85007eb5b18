"""Schedules of plant inputs a task declares: a parameter of the plant driven step by step.

Every rig task plans three schedules of its own (the position target, the stiffness target and the
load, :meth:`~cepam_gym.envs.task.Task.plan`), which the compiled step reads. A task may declare
any number of further ones, each a :class:`Schedule`: a column of the plant's parameter row
(:data:`cepam_gym.physics.layout.NAMES`, e.g. ``"P_SUP"``, the absolute supply pressure) and the
function that plans its value at every control step of an episode. The env
(:class:`cepam_gym.envs.core.CEPAMBatch`) plans each declared schedule at every reset, from the
env's own random stream (a third child of its seed sequence, so the draws of the targets, loads
and sensor noise are those of the same task without it), writes the step's value into the env's
parameter row before each control step and reports it as ``info[<name>]`` (SI). What a parameter
does to the plant is the plant's business: a supply pressure that drops slows the filling valve
(ISO 6358) and caps the pressures a chamber can reach; the observation's ``supply`` column shows the
measured supply as it does on a rig.

A task "hold a length while the supply drops" is then a :class:`~cepam_gym.tasks.spec.TaskSpec`
with ``schedules=(Schedule("supply_pressure", "P_SUP", plan),)``: see the docs page "Write your own
task".
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..physics import layout as ix

# the plan of one env: (its random generator, its parameter row at the reset, the episode's control
# steps, the control period [s]) -> the parameter's value at every step (SI, the column's unit)
PlanFn = Callable[[np.random.Generator, np.ndarray, int, float], np.ndarray]


@dataclass(frozen=True)
class Schedule:
    """A plant parameter ``column`` (a name of :data:`cepam_gym.physics.layout.NAMES`) set at every
    control step to the values ``plan`` returns for the episode; reported as ``info[name]``."""

    name: str
    column: str
    plan: PlanFn
    doc: str = ""

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise InputError(f"a schedule's name must be an identifier (its info key), got {self.name!r}")
        if self.column not in ix.NAMES:
            raise InputError(
                f"schedule {self.name!r}: column must be a plant parameter of physics.layout.NAMES "
                f"(e.g. 'P_SUP'), got {self.column!r}"
            )
        if not callable(self.plan):
            raise InputError(f"schedule {self.name!r}: plan must be callable, got {self.plan!r}")

    @property
    def index(self) -> int:
        """The column's index in a parameter row."""
        return ix.NAMES.index(self.column)

    def values(self, rng, row: np.ndarray, n_steps: int, control_dt: float) -> np.ndarray:
        """The planned values of one env, checked: ``n_steps`` finite numbers (``InputError`` naming
        the schedule otherwise; a wrong plan is a user's mistake, not a NaN deep in a trajectory)."""
        out = np.asarray(self.plan(rng, row.copy(), n_steps, control_dt), dtype=float)
        if out.shape != (n_steps,):
            raise InputError(
                f"schedule {self.name!r}: plan must return one value per control step, shape "
                f"({n_steps},), got shape {out.shape}"
            )
        if not np.isfinite(out).all():
            raise InputError(f"schedule {self.name!r}: plan returned values that are not finite")
        return out


def check_schedules(schedules, reserved: tuple[str, ...] = ()) -> tuple[Schedule, ...]:
    """``schedules`` as a tuple of :class:`Schedule` with distinct names and columns, none of
    their names among the ``reserved`` info keys (``InputError`` naming what clashes)."""
    if isinstance(schedules, Schedule) or not isinstance(schedules, (tuple, list)):
        raise InputError(f"schedules must be a tuple of tasks.schedule.Schedule, got {schedules!r}")
    out = tuple(schedules)
    for s in out:
        if not isinstance(s, Schedule):
            raise InputError(f"schedules must hold tasks.schedule.Schedule objects, got {s!r}")
    for what in ("name", "column"):
        seen = [getattr(s, what) for s in out]
        twice = sorted({v for v in seen if seen.count(v) > 1})
        if twice:
            raise InputError(f"schedules: each {what} at most once, got {twice} twice")
    clash = sorted({s.name for s in out} & set(reserved))
    if clash:
        raise InputError(f"schedules: names {clash} are info keys the task already reports")
    return out


class PlannedSchedules:
    """The declared schedules' values of N envs (``values[env, schedule, step]``), planned at the
    resets and written into the parameter rows before each step."""

    def __init__(self, schedules: tuple[Schedule, ...], num_envs: int, n_steps: int, n_window: int):
        self.schedules = schedules
        self.columns = np.array([s.index for s in schedules], dtype=np.int64)
        self.n_window = n_window
        self.values = np.zeros((num_envs, len(schedules), n_steps))

    def plan(self, idx: np.ndarray, rngs, params: np.ndarray, control_dt: float) -> None:
        """Plan envs ``idx`` (their generators ``rngs`` and parameter rows ``params[idx]``) and write
        each schedule's first value into their rows. The identification window's steps (in front)
        hold the first value."""
        n_tracked = self.values.shape[2] - self.n_window
        for i, rng in zip(idx, rngs):
            row = params[i]
            for j, s in enumerate(self.schedules):
                v = s.values(rng, row, n_tracked, control_dt)
                self.values[i, j, : self.n_window] = v[0]
                self.values[i, j, self.n_window :] = v
                params[i, self.columns[j]] = v[0]

    def apply(self, params: np.ndarray, t_idx: np.ndarray) -> None:
        """Write each env's value at its step ``t_idx`` into its parameter row."""
        k = np.minimum(t_idx, self.values.shape[2] - 1)
        r = np.arange(self.values.shape[0])
        for j, col in enumerate(self.columns):
            params[:, col] = self.values[r, j, k]

    def info(self, t_idx: np.ndarray, scored: bool) -> dict[str, np.ndarray]:
        """``{name: value of the step just taken}`` per env (``scored``; after a reset: the next)."""
        k = np.clip(np.asarray(t_idx) - (1 if scored else 0), 0, self.values.shape[2] - 1)
        r = np.arange(self.values.shape[0])
        return {s.name: self.values[r, j, k] for j, s in enumerate(self.schedules)}
