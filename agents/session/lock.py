"""The run directory's lock: one training session at a time per directory (``.train.lock``, an OS
lock the kernel drops when its holder dies, so a lock left by a killed run never blocks; a second
session is refused, naming the first one's pid)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from .provenance import now

LOCK_NAME = ".train.lock"


class RunLock:
    """An exclusive OS lock on ``run/.train.lock`` (``fcntl.flock``: released by the kernel when
    the holder dies, SIGKILL included, so a stale file never blocks). The file records the
    holder's pid and start time for the refusal message."""

    def __init__(self, run: Path):
        self.path = Path(run) / LOCK_NAME
        self.fh = None

    def acquire(self) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        try:
            import fcntl
        except ImportError:  # not POSIX: an exclusive-create lock file, stale if its pid is gone
            return self._acquire_exclusive_create()
        fh = open(self.path, "a+")
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            fh.seek(0)
            holder = fh.read().strip() or "unknown pid"
            fh.close()
            raise self._refusal(holder) from None
        fh.seek(0)
        stale = fh.read().strip()
        if stale:
            self._say_stale(stale)
        fh.seek(0)
        fh.truncate()
        fh.write(self._holder())
        fh.flush()
        self.fh = fh

    def _acquire_exclusive_create(self) -> None:
        for _ in range(2):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
            except FileExistsError:
                holder = self.path.read_text().strip()
                pid = holder.split()[1] if holder.startswith("pid ") else ""
                if pid.isdigit() and not _pid_alive(int(pid)):
                    self._say_stale(holder)
                    self.path.unlink(missing_ok=True)
                    continue
                raise self._refusal(holder or "unknown pid") from None
            with os.fdopen(fd, "w") as fh:
                fh.write(self._holder())
            self.fh = False  # marks "held, by file"
            return
        raise self._refusal("a session that keeps re-creating the lock")

    def _holder(self) -> str:
        return f"pid {os.getpid()} since {now()}\n"

    def _refusal(self, holder: str) -> FileExistsError:
        return FileExistsError(
            f"run directory {self.path.parent} is in use by another training session "
            f"({holder}); wait for it to end, or pass another --out"
        )

    def _say_stale(self, holder: str) -> None:
        pid = holder.split()[1] if holder.startswith("pid ") else "?"
        if not pid.isdigit() or not _pid_alive(int(pid)):
            print(
                f"cepam-gym train: {self.path.parent}: lock of pid {pid} is stale (process gone): "
                "taking over",
                file=sys.stderr,
            )

    def release(self) -> None:
        if self.fh is False:
            self.path.unlink(missing_ok=True)
        elif self.fh is not None:
            self.fh.seek(0)
            self.fh.truncate()
            self.fh.close()  # closing drops the flock
        self.fh = None


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
