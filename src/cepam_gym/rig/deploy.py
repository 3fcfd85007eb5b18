"""The real-time deploy loop: a controller (a registered one, or an exported policy) on a rig,
under the safety supervisor, at the env's control rate (``cepam-gym deploy``, docs/deploy.md).

Each control step ``k``, released at ``t0 + k * dt`` on the host's monotonic clock:

1. read the newest sensor packet (:meth:`~cepam_gym.rig.protocol.Rig.read`);
2. encode it as the env's observation (:class:`~cepam_gym.rig.observation.RigObserver`: the
   episode's targets of step ``k``, the command last sent);
3. the controller's action for it;
4. the supervisor's command (:class:`~cepam_gym.rig.supervisor.Supervisor`), sent to the rig;
   on a trip, the rig is stopped and the loop ends.

Timing: the step's *lateness* is how long after its release it woke; its *compute* is wake to
command sent. A step misses its deadline when its command goes out after the next step's release;
a step whose release has passed by a whole period before it could start is skipped (a miss too),
so the loop never bursts to catch up. Other processes on the machine delay the wake-ups by
milliseconds; under the real-time scheduler (:func:`set_realtime`, ``deploy --realtime``) by
microseconds. The *capacity* is ``1 / p99(compute)``: the highest rate
the loop could hold on this machine with this controller.

The log is ``identify``'s CSV (:func:`cepam_gym.identify.logs.write_log`): each step's host time
since the start, the command sent, the newest measurement, the hanging load and the supply, so a
deployment log feeds the next identification (the sensors' latency is one of the parameters
``identify`` fits).
"""

from __future__ import annotations

import copy
import gc
import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from .protocol import Reading
from .steplog import StepLog
from .stop import (
    EXIT_CLEAN,
    EXIT_CONNECT,
    EXIT_CRASH,
    EXIT_STOP_NOT_CONFIRMED,
    EXIT_TRIP,
    ConnectError,
    StopReport,
    connect,
    stop_and_confirm,
)
from .supervisor import Supervisor, Trip

SPIN_S = 0.0015  # the last stretch before a release is busy-waited: sleep() overshoots by ~0.1-1 ms


@dataclass
class DeployResult:
    """What a deployment measured (times in seconds)."""

    steps: int
    planned_steps: int
    deadline_misses: int
    skipped: int
    lateness_p50: float
    lateness_p99: float
    lateness_max: float
    compute_p50: float
    compute_p99: float
    capacity_hz: float
    rate_hz: float
    stopped_by: str  # "end", "trip", "signal", "connect" (the rig did not arm), "exception"
    trip: dict | None
    missing_readings: int
    length_rmse_mm: float  # over the steps whose readings were finite
    stop: dict  # the rig's stop (:class:`~cepam_gym.rig.stop.StopReport`)
    error: str | None = None  # why the rig did not arm, or the exception that ended the loop
    nonfinite_rows: int = 0  # logged steps with a measured value that is not finite
    exit_code: int = EXIT_CLEAN

    def summary(self) -> str:
        head = (
            f"{self.steps}/{self.planned_steps} steps at {self.rate_hz:g} Hz, "
            f"{self.deadline_misses} deadline misses ({self.skipped} skipped), "
            f"lateness p50 {self.lateness_p50 * 1e3:.3f} ms p99 {self.lateness_p99 * 1e3:.3f} ms "
            f"max {self.lateness_max * 1e3:.3f} ms, compute p99 {self.compute_p99 * 1e3:.3f} ms "
            f"(capacity {self.capacity_hz:.0f} Hz), length RMSE {self.length_rmse_mm:.2f} mm"
        )
        if self.nonfinite_rows:
            head += f" over the finite steps ({self.nonfinite_rows} steps read a non-finite value)"
        if self.trip:
            why = f"SAFETY TRIP {self.trip['reason']}: {self.trip['detail']}"
        elif self.stopped_by == "connect":
            why = f"RIG NOT ARMED: {self.error}"
        elif self.stopped_by == "exception":
            why = f"LOOP FAILED: {self.error}"
        else:
            why = f"ended: {self.stopped_by}"
        return f"{head}\n{why}\n{StopReport(**self.stop).sentence()} (exit code {self.exit_code})"


class DeployAborted(RuntimeError):
    """The loop raised; the rig was stopped first (``result.stop`` says whether it confirmed) and
    the summary written. The exception is the ``__cause__``."""

    def __init__(self, result: DeployResult):
        super().__init__(f"{result.error}; {StopReport(**result.stop).sentence()}")
        self.result = result


def set_realtime(priority: int) -> str:
    """Run this process (and the processes it starts) under the real-time scheduler ``SCHED_FIFO``
    at ``priority`` (1-99), so that other processes no longer delay its wake-ups; needs the
    privilege to (root, CAP_SYS_NICE or an ``rtprio`` limit). Returns what was done, in words;
    ``InputError`` when the system refuses."""
    import os

    if not 1 <= int(priority) <= 99:
        raise InputError(f"the real-time priority must lie in [1, 99], got {priority}")
    if not hasattr(os, "sched_setscheduler"):
        raise InputError("this system has no real-time scheduler (os.sched_setscheduler)")
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(int(priority)))
    except PermissionError:
        raise InputError(
            "the real-time scheduler needs the privilege (root, CAP_SYS_NICE or an rtprio limit); "
            "run without --realtime"
        ) from None
    return f"SCHED_FIFO priority {int(priority)}"


def sleep_until(t: float) -> None:
    """Until ``time.perf_counter() >= t``: sleep, then spin the last :data:`SPIN_S`."""
    while True:
        left = t - time.perf_counter()
        if left <= 0:
            return
        if left > SPIN_S:
            time.sleep(left - SPIN_S)


def warm_up(controller, observer, supervisor: Supervisor) -> None:
    """Compile or load what a step needs before the rig is armed, so the first step comes one
    period after the rig answers and no step of the timed loop stalls: the controller acts on
    readings at rest and pressurised, over a few steps (a first call of a branch compiles it: on a
    cold cache a controller's first pressurised steps stalled the loop by 0.1 s, long enough for
    the supervisor's energy balance to read a leak), and a copy of the supervisor filters them."""
    nominal = observer.model.nominal
    mid = 0.5 * (nominal.min_length + nominal.max_length)
    p = 0.5 * nominal.supply_pressure
    readings = [Reading(0.0, 0.0, 0.0, nominal.min_length, nominal.supply_pressure)]
    readings += [
        Reading(0.002 * k, p * (1 + 0.01 * k), 0.5 * p, mid, nominal.supply_pressure) for k in range(1, 6)
    ]
    shadow = copy.deepcopy(supervisor)
    prev = np.zeros(2)
    for k, reading in enumerate(readings):
        action = np.asarray(controller.act(observer.observe(reading, k, prev)), dtype=float).reshape(2)
        prev = np.clip(action, -1.0, 1.0)
        shadow.filter(reading, (float(prev[0]), float(prev[1])), now=k * observer.dt)
    observer.reset()
    controller.reset()


@dataclass
class _Loop:
    """The timed loop's state over ``n`` steps of ``dt``."""

    n: int
    dt: float
    lateness: np.ndarray = field(init=False)
    compute: np.ndarray = field(init=False)
    missing: int = 0
    misses: int = 0
    skipped: int = 0
    trip: Trip | None = None

    def __post_init__(self):
        self.lateness, self.compute = np.full(self.n, np.nan), np.full(self.n, np.nan)


def _steps(loop: _Loop, rig, controller, observer, supervisor, log: StepLog, latest, should_stop, on_step):
    """The timed loop (the module docstring); returns how it ended: "end", "trip" or "signal"."""
    dt, n = loop.dt, loop.n
    prev = np.zeros(2)
    t0 = time.perf_counter() + dt
    k = 0
    while k < n:
        release = t0 + k * dt
        sleep_until(release)
        wake = time.perf_counter()
        if should_stop():
            return "signal"
        if wake - release > dt:  # a whole period late: skip to the step now due
            behind = int((wake - release) // dt)
            loop.skipped += behind
            loop.misses += behind
            k += behind
            if k >= n:
                break
            release = t0 + k * dt
        new = rig.read()
        if new is None:
            loop.missing += 1
        else:
            latest = new
        obs = observer.observe(latest, k, prev)
        action = np.asarray(controller.act(obs), dtype=float).reshape(2)
        command, tripped = supervisor.filter(new, (float(action[0]), float(action[1])), now=wake)
        rig.write(*command)
        if tripped is not None:
            rig.stop()  # at once; the stop's confirmation follows the loop
        sent = time.perf_counter()
        loop.lateness[k], loop.compute[k] = wake - release, sent - wake
        if sent > release + dt:
            loop.misses += 1
        prev = np.asarray(command)
        log.step(wake - t0, command, latest, observer.targets(k)[0])
        if on_step is not None:
            on_step(k)
        k += 1
        if tripped is not None:
            loop.trip = tripped
            return "trip"
    return "end"


def run(
    rig,
    controller,
    observer,
    supervisor: Supervisor,
    load_kg: float,
    n_steps: int | None = None,
    should_stop=lambda: False,
    log_path: str | Path | None = None,
    on_step=None,
) -> DeployResult:
    """Drive ``rig`` with ``controller`` for ``n_steps`` control steps (default: the observer's
    episode) at the observer's control period, logging each step to ``log_path``; every way out
    stops the rig and waits for its confirmation (the result's ``stop``). A rig that does not arm
    ends the run (``stopped_by == "connect"``); an exception in the loop is raised again as
    :class:`DeployAborted` (KeyboardInterrupt as itself) once the rig is stopped and the summary
    written. ``on_step(k)`` is called once per step after the command is sent (tests inject
    faults there)."""
    n = observer.n_steps if n_steps is None else int(n_steps)
    warm_up(controller, observer, supervisor)  # before the rig is armed
    loop = _Loop(n, observer.dt)
    log = StepLog(log_path, load_kg)
    log.summary({"stopped_by": "running", "planned_steps": n, "rate_hz": 1.0 / loop.dt})
    stopped_by, error, raised = "end", None, None
    gc_was_on = gc.isenabled()
    try:
        latest = connect(rig)
        gc.disable()  # a collection's pause would land in some step; refcounting frees the garbage
        stopped_by = _steps(loop, rig, controller, observer, supervisor, log, latest, should_stop, on_step)
    except ConnectError as e:
        stopped_by, error = "connect", str(e)
    except BaseException as e:  # noqa: BLE001 (the rig is stopped first, then it is raised again)
        stopped_by = "signal" if isinstance(e, KeyboardInterrupt) else "exception"
        error, raised = f"{type(e).__name__}: {e}", e
    finally:
        stop = stop_and_confirm(rig)
        if gc_was_on:
            gc.enable()
        log.close()
    result = _result(loop, log, stopped_by, error, stop)
    log.summary(asdict(result))
    if isinstance(raised, Exception):
        raise DeployAborted(result) from raised
    if raised is not None:
        raise raised
    return result


def _result(loop: _Loop, log: StepLog, stopped_by: str, error, stop: StopReport) -> DeployResult:
    done = ~np.isnan(loop.lateness)
    lat, comp = loop.lateness[done], loop.compute[done]
    p99c = float(np.percentile(comp, 99)) if comp.size else math.nan
    if not stop.confirmed:
        code = EXIT_STOP_NOT_CONFIRMED
    else:
        code = {"trip": EXIT_TRIP, "connect": EXIT_CONNECT, "exception": EXIT_CRASH}.get(
            stopped_by, EXIT_CLEAN
        )
    return DeployResult(
        steps=int(done.sum()),
        planned_steps=loop.n,
        deadline_misses=loop.misses,
        skipped=loop.skipped,
        lateness_p50=float(np.percentile(lat, 50)) if lat.size else math.nan,
        lateness_p99=float(np.percentile(lat, 99)) if lat.size else math.nan,
        lateness_max=float(lat.max()) if lat.size else math.nan,
        compute_p50=float(np.percentile(comp, 50)) if comp.size else math.nan,
        compute_p99=p99c,
        capacity_hz=1.0 / p99c if p99c > 0 else math.inf,
        rate_hz=1.0 / loop.dt,
        stopped_by=stopped_by,
        trip=asdict(loop.trip) if loop.trip is not None else None,
        missing_readings=loop.missing,
        length_rmse_mm=log.length_rmse_m * 1e3,
        stop=asdict(stop),
        error=error,
        nonfinite_rows=log.nonfinite_rows,
        exit_code=code,
    )
