"""A rig's recording: the CSV it comes in, its checks, and its resampling onto the plant's grid.

The CSV (docs/identify.md, "The log format"), one row per sample, a header naming the columns in
any order::

    time_s,command_c,command_e,pressure_c_kpa,pressure_e_kpa,length_cm,load_g[,supply_kpa]

commands in [-1, 1] as the env's action (spool set-points, PWM duties, or pressure set-points
mapped onto [0, pressure cap]); gauge pressures; the hanging load. Any sample rate from 50 Hz to
2 kHz; the samples need not be evenly spaced. A bad file raises one ``ValueError`` naming the
file, the row (the file's line number), the column and what is wrong.

Resampling (:func:`resample`): the plant advances in control steps of ``n_sub`` sub-steps; the
grid's period is the multiple of the sub-step nearest the log's median sample period. The
commands and the load are held from one sample to the next, as a rig's controller holds them
(zero-order hold); the measured channels are interpolated linearly.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..errors import InputError

REQUIRED = ("time_s", "command_c", "command_e", "pressure_c_kpa", "pressure_e_kpa", "length_cm", "load_g")
OPTIONAL = ("supply_kpa",)
MIN_RATE, MAX_RATE = 50.0, 2000.0  # Hz
# plausible ranges per column (edge units): a value outside is a unit or sign mistake
RANGES = {
    "command_c": (-1.0, 1.0),
    "command_e": (-1.0, 1.0),
    "pressure_c_kpa": (-101.3, 1000.0),
    "pressure_e_kpa": (-101.3, 1000.0),
    "length_cm": (1.0, 100.0),
    "load_g": (0.0, 50_000.0),
    "supply_kpa": (1.0, 1000.0),
}
_TOL = 1e-9  # commands exactly at +/-1 written with rounding


@dataclass(frozen=True)
class Recording:
    """One log in SI on its own sample times: ``commands`` (T, 2) in [-1, 1], ``loads`` (T,) [kg],
    ``measured`` (T, 3): pressure_c, pressure_e [Pa gauge], length [m]; ``supply`` [Pa gauge]
    when the log has it (its mean)."""

    name: str
    time: np.ndarray
    commands: np.ndarray
    loads: np.ndarray
    measured: np.ndarray
    supply: float | None = None
    # the supply [Pa gauge] over each sample, where it drifts and was measured (else None: constant)
    supply_trace: np.ndarray | None = None

    @property
    def duration(self) -> float:
        return float(self.time[-1] - self.time[0])

    def split(self, fraction: float) -> tuple[Recording, Recording]:
        """The first ``fraction`` of the samples and the rest (held-out), each its own recording."""
        k = int(round(fraction * len(self.time)))
        parts = []
        for sl, tag in ((slice(0, k), "first"), (slice(k, None), "last")):
            share = fraction if tag == "first" else 1.0 - fraction
            parts.append(
                replace(
                    self,
                    name=f"{self.name} ({tag} {100 * share:.0f} %)",
                    time=self.time[sl] - self.time[sl][0],
                    commands=self.commands[sl],
                    loads=self.loads[sl],
                    measured=self.measured[sl],
                    supply_trace=None if self.supply_trace is None else self.supply_trace[sl],
                )
            )
        return parts[0], parts[1]


def read_log(path: str | Path) -> Recording:
    """Read and check one CSV (see the module docstring); ``ValueError`` naming what is wrong."""
    path = Path(path)
    with path.open(newline="") as fh:
        rows = list(csv.reader(fh))
    if not rows:
        raise InputError(f"{path}: empty file; expected the header {','.join(REQUIRED)}")
    header = [h.strip() for h in rows[0]]
    unknown = [h for h in header if h not in REQUIRED + OPTIONAL]
    if unknown:
        raise InputError(
            f"{path}: row 1: unknown column {unknown[0]!r}; the columns are {', '.join(REQUIRED)} "
            f"and optionally {', '.join(OPTIONAL)}"
        )
    missing = [h for h in REQUIRED if h not in header]
    if missing:
        raise InputError(f"{path}: row 1: missing column {missing[0]!r} (header: {','.join(header)})")
    data = np.empty((len(rows) - 1, len(header)))
    for i, row in enumerate(rows[1:]):
        line = i + 2
        if len(row) != len(header):
            raise InputError(f"{path}: row {line}: {len(row)} values for {len(header)} columns")
        for j, (name, text) in enumerate(zip(header, row)):
            try:
                v = float(text)
            except ValueError:
                raise InputError(
                    f"{path}: row {line}, column {name}: {text.strip()!r} is not a number"
                ) from None
            if not math.isfinite(v):
                raise InputError(f"{path}: row {line}, column {name}: {text.strip()!r} is not finite")
            lo, hi = RANGES.get(name, (-math.inf, math.inf))
            if not lo - _TOL <= v <= hi + _TOL:
                raise InputError(
                    f"{path}: row {line}, column {name}: {v:g} is outside [{lo:g}, {hi:g}] "
                    "(wrong unit or sign?)"
                )
            data[i, j] = v
    col = {name: data[:, j] for j, name in enumerate(header)}
    t = col["time_s"]
    if len(t) < 10:
        raise InputError(f"{path}: {len(t)} samples; a recording needs at least 10")
    back = np.flatnonzero(np.diff(t) <= 0)
    if back.size:
        k = int(back[0]) + 1
        raise InputError(
            f"{path}: row {k + 2}, column time_s: {t[k]:g} s does not increase (previous row {t[k - 1]:g} s)"
        )
    rate = 1.0 / float(np.median(np.diff(t)))
    if not MIN_RATE * 0.99 <= rate <= MAX_RATE * 1.01:
        raise InputError(
            f"{path}: column time_s: sample rate {rate:.4g} Hz is outside {MIN_RATE:g}-{MAX_RATE:g} Hz "
            "(time in seconds?)"
        )
    return Recording(
        name=path.name,
        time=t - t[0],
        commands=np.column_stack([np.clip(col["command_c"], -1, 1), np.clip(col["command_e"], -1, 1)]),
        loads=col["load_g"] * 1e-3,
        measured=np.column_stack(
            [col["pressure_c_kpa"] * 1e3, col["pressure_e_kpa"] * 1e3, col["length_cm"] * 1e-2]
        ),
        supply=float(col["supply_kpa"].mean()) * 1e3 if "supply_kpa" in col else None,
    )


STAMP_JITTER = 0.25  # of a grid step: how late a sample's time stamp may be and still hold at that step


def grid_steps(rec: Recording, sub_dt: float) -> int:
    """Sub-steps per control step of the grid a recording is resampled onto: the multiple of
    ``sub_dt`` nearest its median sample period (at least one)."""
    return max(1, int(round(float(np.median(np.diff(rec.time))) / sub_dt)))


def resample(rec: Recording, h: float) -> Recording:
    """``rec`` on the even grid ``0, h, 2h, ...``: commands and load held (zero-order hold),
    measured channels interpolated. A sample stamped up to :data:`STAMP_JITTER` of ``h`` after a
    grid point counts as at it: a host stamps each control step when it wakes, a little after
    the step's release, and the command it sent belongs to that step, not to the one before."""
    t = np.arange(0.0, rec.time[-1] + 1e-12, h)
    held = np.clip(np.searchsorted(rec.time, t + STAMP_JITTER * h, side="right") - 1, 0, len(rec.time) - 1)
    measured = np.column_stack([np.interp(t, rec.time, rec.measured[:, c]) for c in range(3)])
    trace = None if rec.supply_trace is None else rec.supply_trace[held]
    return replace(
        rec, time=t, commands=rec.commands[held], loads=rec.loads[held], measured=measured, supply_trace=trace
    )


def write_log(path: str | Path, columns: dict[str, np.ndarray]) -> Path:
    """Write a log (or a command schedule: the measured columns left out) in the CSV format."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    names = [n for n in REQUIRED + OPTIONAL if n in columns]
    fmt = {"time_s": "{:.6f}", "command_c": "{:.5f}", "command_e": "{:.5f}", "length_cm": "{:.5f}"}
    with path.open("w", newline="") as fh:
        fh.write(",".join(names) + "\n")
        for i in range(len(columns["time_s"])):
            fh.write(",".join(fmt.get(n, "{:.4f}").format(columns[n][i]) for n in names) + "\n")
    return path
