"""A run's log that survives the run: the CSV streamed one row per step and flushed, the JSON summary
written when the run starts (``"stopped_by": "running"``) and again on every way out.

The CSV is ``identify``'s format (:mod:`cepam_gym.identify.logs`, edge units): each step's host
time since the start, the command sent, the newest measurement, the hanging load and the supply;
so a deployment log feeds the next identification. Each row is flushed to the operating system as
it is written: a process killed (SIGKILL) loses at most the step it was in; the summary is
replaced atomically (written beside, then renamed), so it is never half written.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

from ..identify.logs import OPTIONAL, REQUIRED

_FMT = {"time_s": "{:.6f}", "command_c": "{:.5f}", "command_e": "{:.5f}", "length_cm": "{:.5f}"}
COLUMNS = REQUIRED + OPTIONAL


class StepLog:
    """The CSV at ``path`` (and its summary ``path.with_suffix('.json')``); ``None`` logs nothing."""

    def __init__(self, path: str | Path | None, load_kg: float):
        self.path = None if path is None else Path(path)
        self.load_g = load_kg * 1e3
        self.rows = 0
        self.nonfinite_rows = 0  # rows with a measured value that is not finite (logged as such)
        self._sq_error = 0.0  # the length's squared tracking error over the finite rows [m^2]
        self._fh = None
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._fh = self.path.open("w", newline="")
            self._fh.write(",".join(COLUMNS) + "\n")
            self._fh.flush()

    def step(self, t: float, command, reading, target_length: float) -> None:
        """One step's row: host time [s] since the start, the command sent, the newest reading
        (SI), the reference length [m]."""
        measured = (reading.pressure_c, reading.pressure_e, reading.length, reading.supply)
        if all(math.isfinite(v) for v in measured):
            self._sq_error += (reading.length - target_length) ** 2
        else:
            self.nonfinite_rows += 1
        self.rows += 1
        if self._fh is None:
            return
        values = {
            "time_s": t,
            "command_c": command[0],
            "command_e": command[1],
            "pressure_c_kpa": reading.pressure_c / 1e3,
            "pressure_e_kpa": reading.pressure_e / 1e3,
            "length_cm": reading.length * 1e2,
            "load_g": self.load_g,
            "supply_kpa": reading.supply / 1e3,
        }
        self._fh.write(",".join(_FMT.get(n, "{:.4f}").format(values[n]) for n in COLUMNS) + "\n")
        self._fh.flush()

    @property
    def length_rmse_m(self) -> float:
        """The length's RMSE against the reference over the rows whose readings are finite."""
        finite = self.rows - self.nonfinite_rows
        return math.sqrt(self._sq_error / finite) if finite else math.nan

    def summary(self, data: dict) -> None:
        """Write (replace) the JSON summary."""
        if self.path is None:
            return
        target = self.path.with_suffix(".json")
        tmp = target.with_name(target.name + ".tmp")
        tmp.write_text(json.dumps(data, indent=2, default=_jsonable))
        os.replace(tmp, target)

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None


def _jsonable(value):
    return str(value)
