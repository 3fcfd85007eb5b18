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
import json
import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from .protocol import SAFE_COMMANDS, Reading
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
    stopped_by: str  # "end", "trip", "signal"
    trip: dict | None
    missing_readings: int
    length_rmse_mm: float

    def summary(self) -> str:
        head = (
            f"{self.steps}/{self.planned_steps} steps at {self.rate_hz:g} Hz, "
            f"{self.deadline_misses} deadline misses ({self.skipped} skipped), "
            f"lateness p50 {self.lateness_p50 * 1e3:.3f} ms p99 {self.lateness_p99 * 1e3:.3f} ms "
            f"max {self.lateness_max * 1e3:.3f} ms, compute p99 {self.compute_p99 * 1e3:.3f} ms "
            f"(capacity {self.capacity_hz:.0f} Hz), length RMSE {self.length_rmse_mm:.2f} mm"
        )
        if self.trip:
            return (
                f"{head}\nSAFETY TRIP {self.trip['reason']}: {self.trip['detail']} (rig stopped, safe state)"
            )
        return f"{head}\nstopped: {self.stopped_by} (rig stopped, safe state)"


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


def connect(rig, timeout_s: float = 3.0):
    """Arm the rig and wait for its first reading that is not stopped; ``InputError`` if none
    comes within ``timeout_s``. Returns that reading."""
    deadline = time.perf_counter() + timeout_s
    last_arm = -math.inf
    while time.perf_counter() < deadline:
        if time.perf_counter() - last_arm > 0.2:
            rig.arm()
            last_arm = time.perf_counter()
        r = rig.read()
        if r is not None and not r.stopped:
            return r
        time.sleep(0.002)
    raise InputError(f"no reading from the rig at {getattr(rig, 'address', rig)} within {timeout_s:g} s")


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
    episode) at the observer's control period; always ends with the rig stopped. ``on_step(k)``
    is called once per step after the command is sent (tests inject faults there)."""
    dt = observer.dt
    n = observer.n_steps if n_steps is None else int(n_steps)
    warm_up(controller, observer, supervisor)
    latest = connect(rig)
    prev = np.zeros(2)
    lateness, compute = np.full(n, np.nan), np.full(n, np.nan)
    rows = np.full((n, 8), np.nan)  # time, command c/e, pressure c/e, length, supply, target length
    missing = misses = skipped = 0
    stopped_by = "end"
    trip: Trip | None = None
    t0 = time.perf_counter() + dt
    k = 0
    gc_was_on = gc.isenabled()
    gc.disable()  # a collection's pause would land in some step; refcounting frees the loop's garbage
    try:
        while k < n:
            release = t0 + k * dt
            sleep_until(release)
            wake = time.perf_counter()
            if should_stop():
                stopped_by = "signal"
                break
            if wake - release > dt:  # a whole period late: skip to the step now due
                behind = int((wake - release) // dt)
                skipped += behind
                misses += behind
                k += behind
                if k >= n:
                    break
                release = t0 + k * dt
            new = rig.read()
            if new is None:
                missing += 1
            else:
                latest = new
            obs = observer.observe(latest, k, prev)
            action = np.asarray(controller.act(obs), dtype=float).reshape(2)
            command, tripped = supervisor.filter(new, (float(action[0]), float(action[1])), now=wake)
            rig.write(*command)
            if tripped is not None:
                rig.stop()
            sent = time.perf_counter()
            lateness[k], compute[k] = wake - release, sent - wake
            if sent > release + dt:
                misses += 1
            prev = np.asarray(command)
            rows[k] = (
                wake - t0,
                command[0],
                command[1],
                latest.pressure_c,
                latest.pressure_e,
                latest.length,
                latest.supply,
                observer.targets(k)[0],
            )
            if on_step is not None:
                on_step(k)
            k += 1
            if tripped is not None:
                trip, stopped_by = tripped, "trip"
                break
    finally:
        rig.write(*SAFE_COMMANDS)
        rig.stop()
        if gc_was_on:
            gc.enable()
    done = ~np.isnan(lateness)
    rows = rows[~np.isnan(rows[:, 0])]
    if log_path is not None and len(rows) >= 1:
        write_deploy_log(log_path, rows, load_kg)
    lat, comp = lateness[done], compute[done]
    p99c = float(np.percentile(comp, 99)) if comp.size else math.nan
    err = rows[:, 5] - rows[:, 7]
    result = DeployResult(
        steps=int(done.sum()),
        planned_steps=n,
        deadline_misses=misses,
        skipped=skipped,
        lateness_p50=float(np.percentile(lat, 50)) if lat.size else math.nan,
        lateness_p99=float(np.percentile(lat, 99)) if lat.size else math.nan,
        lateness_max=float(lat.max()) if lat.size else math.nan,
        compute_p50=float(np.percentile(comp, 50)) if comp.size else math.nan,
        compute_p99=p99c,
        capacity_hz=1.0 / p99c if p99c > 0 else math.inf,
        rate_hz=1.0 / dt,
        stopped_by=stopped_by,
        trip=asdict(trip) if trip is not None else None,
        missing_readings=missing,
        length_rmse_mm=float(np.sqrt(np.mean(err**2)) * 1e3) if err.size else math.nan,
    )
    if log_path is not None:
        Path(log_path).with_suffix(".json").write_text(json.dumps(asdict(result), indent=2))
    return result


def write_deploy_log(path, rows: np.ndarray, load_kg: float) -> Path:
    """The steps in ``identify``'s CSV format (edge units)."""
    from ..identify.logs import write_log

    return write_log(
        path,
        {
            "time_s": rows[:, 0],
            "command_c": rows[:, 1],
            "command_e": rows[:, 2],
            "pressure_c_kpa": rows[:, 3] / 1e3,
            "pressure_e_kpa": rows[:, 4] / 1e3,
            "length_cm": rows[:, 5] * 1e2,
            "load_g": np.full(len(rows), load_kg * 1e3),
            "supply_kpa": rows[:, 6] / 1e3,
        },
    )
