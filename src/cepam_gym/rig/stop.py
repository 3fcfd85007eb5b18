"""The two handshakes of a run on a rig (docs/deploy.md, "For firmware authors"): arming it
(:func:`connect`) and stopping it with the rig's confirmation (:func:`stop_and_confirm`), and the
exit codes of the commands that drive a rig.

Arming: an arm packet every :data:`ARM_INTERVAL_S` until a reading arrives whose stopped flag is
clear, for at most :data:`CONNECT_TIMEOUT_S`; a rig that stays silent and one that answers but
stays stopped fail with different sentences (:class:`ConnectError`).

Stopping: a stop packet every :data:`STOP_INTERVAL_S` until a reading read after the first one
carries the stopped flag, for at most :data:`STOP_DEADLINE_S`, longer than the rig's own watchdog
(:data:`~cepam_gym.rig.protocol.WATCHDOG_S`): when every stop packet is lost, the watchdog's stop
still confirms (its flag says so). The outcome is a :class:`StopReport`: confirmed, with when and
how, or not, and then the run's exit code is :data:`EXIT_STOP_NOT_CONFIRMED` whatever else
happened.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

from .protocol import SAFE_COMMANDS, WATCHDOG_S

ARM_INTERVAL_S = 0.2
CONNECT_TIMEOUT_S = 3.0
STOP_INTERVAL_S = 0.01
STOP_DEADLINE_S = WATCHDOG_S + 0.3

# the exit codes of deploy and excite --rig (2 is the command line's: bad input, the rig untouched)
EXIT_CLEAN = 0  # the run ended (its steps, --seconds, or a signal) and the stop was confirmed
EXIT_CRASH = 1  # an unexpected error in the loop (a bug; its traceback), the stop confirmed
EXIT_TRIP = 3  # the supervisor tripped; the stop confirmed
EXIT_CONNECT = 4  # the rig never armed (no reading, or only stopped ones); the stop confirmed
EXIT_STOP_NOT_CONFIRMED = 5  # no reading with the stopped flag before the deadline: check the rig
EXIT_MEANING = {
    EXIT_CLEAN: "the run ended and the rig confirmed its stop",
    EXIT_CRASH: "the loop failed (a bug: its traceback above); the rig confirmed its stop",
    EXIT_TRIP: "a safety trip; the rig confirmed its stop",
    EXIT_CONNECT: "the rig did not arm; it confirmed its stop",
    EXIT_STOP_NOT_CONFIRMED: "STOP NOT CONFIRMED: the rig may still be live; check it",
}


class ConnectError(RuntimeError):
    """The rig did not arm: ``readings`` is how many it sent (all of them stopped), 0 if none."""

    def __init__(self, message: str, readings: int, arms: int):
        super().__init__(message)
        self.readings, self.arms = readings, arms


def connect(rig, timeout_s: float = CONNECT_TIMEOUT_S):
    """Arm the rig and wait for its first reading that is not stopped; returns it.
    :class:`ConnectError` if none comes within ``timeout_s``."""
    start = time.perf_counter()
    last_arm = -math.inf
    arms = stopped = 0
    while time.perf_counter() - start < timeout_s:
        if time.perf_counter() - last_arm > ARM_INTERVAL_S:
            rig.arm()
            arms += 1
            last_arm = time.perf_counter()
        r = rig.read()
        if r is not None and not r.stopped:
            return r
        stopped += r is not None
        time.sleep(0.002)
    where = getattr(rig, "address", rig)
    if stopped:
        raise ConnectError(
            f"the rig at {where} answers but stays stopped: it ignored {arms} arm packets in "
            f"{timeout_s:g} s (it sent {stopped} readings with the stopped flag set)",
            stopped,
            arms,
        )
    raise ConnectError(
        f"no reading from the rig at {where} within {timeout_s:g} s ({arms} arm packets sent)", 0, arms
    )


@dataclass(frozen=True)
class StopReport:
    """How a run's stop ended: ``confirmed``, ``after_s`` from the first stop packet to the
    reading that confirmed it (NaN if none), that reading's rig time, whether the rig's watchdog
    had stopped it (not the stop packets), and the stop packets sent."""

    confirmed: bool
    after_s: float
    rig_time: float
    by_watchdog: bool
    packets: int

    def sentence(self) -> str:
        if not self.confirmed:
            return (
                f"STOP NOT CONFIRMED: no reading with the stopped flag within "
                f"{STOP_DEADLINE_S:g} s ({self.packets} stop packets sent); the rig may be live"
            )
        how = ", by the rig's watchdog: the stop packets were not acted on" if self.by_watchdog else ""
        return f"stopped (confirmed at {self.after_s * 1e3:.0f} ms, rig time {self.rig_time:.3f} s{how})"


def stop_and_confirm(rig, deadline_s: float = STOP_DEADLINE_S) -> StopReport:
    """Stop the rig: the safe commands, then a stop packet every :data:`STOP_INTERVAL_S` until a
    reading carries the stopped flag or ``deadline_s`` passes. Never raises for the link: a
    transport error counts as a lost packet."""
    start = time.perf_counter()
    last = -math.inf
    packets = 0
    _quietly(rig.write, *SAFE_COMMANDS)
    while True:
        now = time.perf_counter()
        if now - last >= STOP_INTERVAL_S:
            _quietly(rig.stop)
            packets += 1
            last = now
        r = _quietly(rig.read)
        if r is not None and r.stopped:
            after = time.perf_counter() - start
            return StopReport(True, after, r.time, r.by_watchdog, packets)
        if now - start > deadline_s:
            return StopReport(False, math.nan, math.nan, False, packets)
        time.sleep(0.001)


def _quietly(fn, *args):
    try:
        return fn(*args)
    except OSError:
        return None
