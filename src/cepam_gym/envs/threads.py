"""How many threads the batched kernel uses when the user leaves ``num_threads=None``: the count
that steps fastest on this machine now, found while the env runs.

All cores are fastest on a quiet machine. Beside a process that keeps a core busy (a learner, a
second training run) a parallel step waits for its slowest thread, and a thread that shares its
core is descheduled for whole time slices: measured on a 2-core VM, 2 threads fell to a third of
1 thread's speed at 1024 envs and to a seventeenth at 256 envs. No setting is right for both, and
a machine changes between them while a run goes on. So :class:`ThreadChoice` times the kernel
calls: it runs the count it believes fastest, tries the other now and then for a few steps
(stopping at once if the first is slow) and keeps whichever is faster, trying less often while
its choice keeps winning. The steps' results do not depend on the count (every env is computed
alone, in its own block), only their speed does.
"""

from __future__ import annotations

import time
from contextlib import contextmanager

import numba
import numpy as np

_PROBE_STEPS = 3  # calls of the other count per trial
_FIRST_TRIAL, _MAX_INTERVAL = 4, 4000  # calls between trials (after a lost trial at least doubled)
_COST_SPAN = 40  # a lost trial costing r - 1 calls is followed by 40 r calls (at most 4000): < 2.5 %
_SWITCH = 0.95  # the other count must take at most this fraction of the time
_DRIFT = 1.3  # the current count's time changed by this factor since the last trial: try again
_HISTORY = 9  # recent calls whose median is the current count's time
_CLOSE = 2.0  # a drift is tried on a count that was at most this many times slower (times the drift)


class ThreadChoice:
    """Picks one of ``counts`` (ascending; the first is the serial kernel) per kernel call."""

    def __init__(self, counts: tuple[int, ...]):
        self.counts = tuple(counts)
        # serial first: at worst it is as many times slower as there are cores for a few calls,
        # while a parallel step beside a busy core can be ten times slower still
        self.current = self.counts[0]
        self.trials = 0  # how many trials were run (benchmarks report it)
        self._recent: list[float] = []  # the current count's calls since its time was last taken
        self._mine = np.inf  # the current count's time: the median of its last _HISTORY calls
        self._calls, self._last_trial = 0, 0
        self._next_trial, self._interval = _FIRST_TRIAL, _FIRST_TRIAL
        self._trial: list[float] | None = None  # the other count's times while it is tried
        self._trial_count = self.current
        self._ref = np.inf  # the current count's time after the last trial
        self._ratio: dict[int, float] = {}  # each tried count's time over the current's, last trial
        self._seen: set[int] = set()  # counts that ran once: a first call (compilation, the thread
        # pool's start) says nothing about the next ones and is not counted
        self._up = False

    def pick(self) -> int:
        """The count for the next call."""
        if self._trial is None and self._calls >= self._next_trial and len(self.counts) > 1:
            self._up = not self._up
            self._start(self._neighbour(self._up))
        return self._trial_count if self._trial is not None else self.current

    def record(self, count: int, seconds: float) -> None:
        """The duration of a call made with ``count`` threads."""
        self._calls += 1
        if count not in self._seen:
            self._seen.add(count)
            return
        if self._trial is not None:
            self._trial.append(seconds)
            mine = self._time()
            if len(self._trial) >= _PROBE_STEPS or seconds > 2.0 * mine:  # a slow one: stop at once
                self._end(float(np.median(self._trial)), mine)
            return
        self._recent.append(seconds)
        if len(self._recent) < _HISTORY:
            return
        self._mine = sorted(self._recent)[_HISTORY // 2]  # a median every _HISTORY calls: cheap
        self._recent = []
        if self._calls < self._last_trial + max(_HISTORY, self._interval // 4):
            return  # (not before a quarter of the wait a lost trial earned: noise is not a change)
        # the machine changed: busier (fewer threads may win) or quieter (more may)
        # (a count that lost by far is left to the scheduled trials: a drift of the current count's
        # time on a noisy machine would try it again and again)
        mine = self._time()
        if mine > _DRIFT * self._ref and self.current > self.counts[0]:
            # slower by f: a count that was up to f times slower may be faster now
            self._drift_trial(self._neighbour(up=False), _CLOSE * mine / self._ref)
        elif mine * _DRIFT < self._ref and self.current < self.counts[-1]:
            self._drift_trial(self._neighbour(up=True), _CLOSE)

    def _drift_trial(self, count: int, within: float) -> None:
        if self._ratio.get(count, 1.0) <= within:
            self._start(count)
        else:
            self._ref = self._time()  # noted: the next drift is measured from here

    def timed(self, run) -> None:
        """``run(count)`` with the picked count, its duration recorded."""
        count = self.pick()
        t0 = time.perf_counter()
        run(count)
        self.record(count, time.perf_counter() - t0)

    def _neighbour(self, up: bool) -> int:
        i = self.counts.index(self.current)
        if (up and i < len(self.counts) - 1) or i == 0:
            return self.counts[i + 1]
        return self.counts[i - 1]

    def _time(self) -> float:
        if self._mine == np.inf and self._recent:
            return sorted(self._recent)[len(self._recent) // 2]
        return self._mine

    def _start(self, count: int) -> None:
        self._trial, self._trial_count = [], count
        self.trials += 1

    def _end(self, theirs: float, mine: float) -> None:
        self._trial = None
        self._ratio[self._trial_count] = theirs / mine
        if theirs < _SWITCH * mine:
            self._ratio[self.current] = mine / theirs
            self.current, self._recent, self._mine = self._trial_count, [], theirs
            self._interval = 4 * _FIRST_TRIAL
            self._ref = theirs
        else:
            self._interval = min(_MAX_INTERVAL, max(2 * self._interval, int(_COST_SPAN * theirs / mine)))
            self._ref = mine
        self._last_trial = self._calls
        self._next_trial = self._calls + self._interval


@contextmanager
def numba_threads(count: int):
    """numba's thread count of the calling thread set to ``count`` for the block (its own setting
    restored afterwards: other parallel code of the caller keeps its count)."""
    prev = numba.get_num_threads()
    if prev != count:
        numba.set_num_threads(count)
    try:
        yield
    finally:
        if prev != count:
            numba.set_num_threads(prev)


class KernelThreads:
    """The thread count of one batch's step kernel: ``num_threads`` fixed, or (``None``, on a
    batch large enough for the parallel kernel) a :class:`ThreadChoice`."""

    def __init__(self, num_threads: int | None, num_envs: int, parallel_min: int):
        top = numba.config.NUMBA_NUM_THREADS
        self.fixed = 1 if num_envs < parallel_min else (num_threads or top)
        self.choice = (
            ThreadChoice(thread_counts(top)) if num_threads is None and num_envs >= parallel_min else None
        )

    def now(self) -> int:
        """The count the batch runs on now (what the reset's planner uses too)."""
        return self.choice.current if self.choice is not None else self.fixed

    def run(self, serial, parallel, args) -> None:
        """One call of the step kernel: ``serial(*args)`` (no parallel region at all) or
        ``parallel(*args)`` on the count of :meth:`now`, timed when the count is chosen."""

        def call(count: int) -> None:
            if count == 1:
                serial(*args)
            else:
                with numba_threads(count):
                    parallel(*args)

        if self.choice is not None:
            self.choice.timed(call)
        else:
            call(self.fixed)


def thread_counts(top: int) -> tuple[int, ...]:
    """The counts tried on a machine of ``top`` threads: serial, all but one (a learner's core),
    all."""
    return tuple(sorted({1, max(1, top - 1), top}))
