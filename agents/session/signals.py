"""How a training session is stopped from outside: SIGTERM (what batch schedulers send) is turned
into the KeyboardInterrupt that Ctrl-C raises, so both take the same path (save a checkpoint, then
exit with 128 + the signal's number)."""

from __future__ import annotations

import signal
import threading

EXIT_INTERRUPTED = 130  # 128 + SIGINT; a SIGTERM exits with 128 + 15


class StopSignal(KeyboardInterrupt):
    """SIGTERM turned into the KeyboardInterrupt path (save, then exit 128 + signum)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


def _on_sigterm(signum, frame):
    raise StopSignal(signum)


def exit_code(stop: KeyboardInterrupt) -> int:
    """The process's exit code after ``stop``: 128 + the signal's number."""
    return 128 + stop.signum if isinstance(stop, StopSignal) else EXIT_INTERRUPTED


def describe(stop: KeyboardInterrupt) -> str:
    """What stopped the session, as run.json and the message name it."""
    return "SIGTERM" if isinstance(stop, StopSignal) else "interrupted (SIGINT)"


class SigtermAsInterrupt:
    """``with SigtermAsInterrupt() as s:``: inside, SIGTERM raises :class:`StopSignal`;
    ``s.ignore()`` (while saving) lets a second SIGTERM not cut the save; on exit the previous
    handler is back. Signal handlers can only be set from the main thread: a session run inside a
    worker thread (Ray Tune's function trainables) leaves SIGTERM to its host."""

    def __enter__(self) -> SigtermAsInterrupt:
        self.main_thread = threading.current_thread() is threading.main_thread()
        self.previous = signal.signal(signal.SIGTERM, _on_sigterm) if self.main_thread else None
        return self

    def ignore(self) -> None:
        if self.main_thread:
            signal.signal(signal.SIGTERM, signal.SIG_IGN)

    def __exit__(self, *exc) -> None:
        if self.main_thread:
            signal.signal(signal.SIGTERM, self.previous if self.previous is not None else signal.SIG_DFL)
