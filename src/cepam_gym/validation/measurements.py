"""Calibration data: the measurement CSV (format in docs/calibration.md section 2), read into
:class:`~cepam_gym.validation.experiments.Experiment` rows, and the paper's own numbers written in
that format (``cepam_gym/data/paper_cepam.csv``, ``paper_single_muscles.csv``)."""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError
from .experiments import Experiment, load_experiments

DATA_DIR = Path(__file__).resolve().parent.parent / "data"
PAPER_CSV = DATA_DIR / "paper_cepam.csv"  # the CE-PAM's numbers (sections V, XII)
PAPER_SINGLE_CSV = DATA_DIR / "paper_single_muscles.csv"  # its balloon CPAM and EPAM alone (II, III)

REQUIRED_COLUMNS = ("kind", "pc_kpa", "pe_kpa", "length_cm", "load_g", "value", "unit")
OPTIONAL_COLUMNS = ("muscle", "name", "note")
KINDS = ("equilibrium_length", "stiffness", "force")
MUSCLES = ("cepam", "cpam", "epam")
UNITS = {  # accepted unit spellings per kind -> factor to the Experiment's unit (cm, N/m, N)
    "equilibrium_length": {"cm": 1.0, "mm": 0.1, "m": 100.0},
    "stiffness": {"n/m": 1.0, "n_per_m": 1.0, "n/mm": 1000.0, "kn/m": 1000.0},
    "force": {"n": 1.0},
}
_MEASURED = {"equilibrium_length": "length", "stiffness": "stiffness", "force": "force"}
_CANON_UNIT = {"equilibrium_length": "cm", "stiffness": "N/m", "force": "N"}


@dataclass
class Measurement:
    """One CSV row as the experiment it describes (``experiment``) and where it came from."""

    experiment: Experiment
    line: int
    kind: str
    value_raw: float
    unit_raw: str


def _number(cell: str, where: str, column: str) -> float:
    try:
        x = float(cell)
    except ValueError:
        raise InputError(f"{where}, column {column!r}: {cell!r} is not a number") from None
    if not math.isfinite(x):
        raise InputError(f"{where}, column {column!r}: {cell!r} is not a finite number")
    return x


def read_csv(path: str | Path) -> list[Measurement]:
    """Parse a calibration CSV (docs/calibration.md). Lines whose first cell starts with ``#`` and
    empty lines are skipped. Every problem raises ``ValueError`` naming the file, the line (the
    header is line 1) and the column."""
    path = Path(path)
    text = path.read_text()
    reader = csv.reader(text.splitlines())
    header: list[str] | None = None
    out: list[Measurement] = []
    for cells in reader:
        line = reader.line_num
        if not cells or all(not c.strip() for c in cells) or cells[0].lstrip().startswith("#"):
            continue
        cells = [c.strip() for c in cells]
        if header is None:
            header = [c.lower() for c in cells]
            dup = {c for c in header if header.count(c) > 1}
            if dup:
                raise InputError(f"{path}, line {line} (header): duplicate column(s) {sorted(dup)}")
            unknown = [c for c in header if c not in REQUIRED_COLUMNS + OPTIONAL_COLUMNS]
            if unknown:
                raise InputError(
                    f"{path}, line {line} (header): unknown column(s) {unknown}; "
                    f"known: {list(REQUIRED_COLUMNS + OPTIONAL_COLUMNS)}"
                )
            missing = [c for c in REQUIRED_COLUMNS if c not in header]
            if missing:
                raise InputError(
                    f"{path}, line {line} (header): missing column(s) {missing}; "
                    f"required: {list(REQUIRED_COLUMNS)}"
                )
            continue
        where = f"{path}, line {line}"
        if len(cells) != len(header):
            raise InputError(f"{where}: {len(cells)} cells, but the header has {len(header)} columns")
        row = dict(zip(header, cells))
        out.append(_parse_row(row, where, line, f"{path.name}:{line}"))
    if header is None:
        raise InputError(f"{path}: empty file (no header)")
    if not out:
        raise InputError(f"{path}: no measurement rows after the header")
    return out


def _loads(row: dict[str, str], where: str, kind: str, length: float | None) -> tuple[float, ...]:
    """The row's hung loads [g] (``load_g``, ``;``-separated), checked against its kind and its
    held length (``length_cm``)."""
    loads: tuple[float, ...] = ()
    if row["load_g"] != "":
        parts = [s.strip() for s in row["load_g"].split(";")]
        loads = tuple(_number(s, where, "load_g") for s in parts)
        if any(m < 0 for m in loads):
            raise InputError(f"{where}, column 'load_g': negative load {row['load_g']!r}")
    if kind == "equilibrium_length":
        if length is not None:
            raise InputError(
                f"{where}, column 'length_cm': an equilibrium_length is measured, not held; "
                "leave length_cm empty (the measured length goes in 'value')"
            )
        if len(loads) > 1:
            raise InputError(f"{where}, column 'load_g': one hanging load per equilibrium_length row")
    elif kind == "stiffness":
        if (length is None) == (not loads):
            raise InputError(
                f"{where}, columns 'length_cm'/'load_g': a stiffness needs exactly one of "
                "length_cm (held length: local -dF/dL) or load_g (the weights hung, "
                "';'-separated: K = mean(m g / displacement))"
            )
        if loads and min(loads) <= 0:
            raise InputError(f"{where}, column 'load_g': stiffness weights must be > 0")
    else:  # force
        if loads and any(m != 0 for m in loads):
            raise InputError(
                f"{where}, column 'load_g': a force is measured at a held length; leave load_g empty"
            )
    if length is not None and length <= 0:
        raise InputError(f"{where}, column 'length_cm': length must be > 0, got {length:g}")

    return loads


def _parse_row(row: dict[str, str], where: str, line: int, ident: str) -> Measurement:
    kind = row["kind"].lower()
    if kind not in KINDS:
        raise InputError(f"{where}, column 'kind': unknown kind {row['kind']!r}; one of {list(KINDS)}")
    muscle = (row.get("muscle") or "cepam").lower()
    if muscle not in MUSCLES:
        raise InputError(
            f"{where}, column 'muscle': unknown muscle {row['muscle']!r}; one of {list(MUSCLES)}"
        )

    def num(column: str, required: bool, default: float | None = None) -> float | None:
        cell = row[column]
        if cell == "":
            if required:
                raise InputError(f"{where}, column {column!r}: empty, but a {kind} of the {muscle} needs it")
            return default
        return _number(cell, where, column)

    pc = num("pc_kpa", required=muscle in ("cepam", "cpam"), default=0.0)
    pe = num("pe_kpa", required=muscle in ("cepam", "epam"), default=0.0)
    for column, v in (("pc_kpa", pc), ("pe_kpa", pe)):
        if v < 0:
            raise InputError(
                f"{where}, column {column!r}: negative gauge pressure {v:g} kPa (suction is not modelled)"
            )
    if muscle == "cpam" and pe != 0:
        raise InputError(f"{where}, column 'pe_kpa': a single CPAM has no EPAM chamber; leave it empty or 0")
    if muscle == "epam" and pc != 0:
        raise InputError(f"{where}, column 'pc_kpa': a single EPAM has no CPAM chamber; leave it empty or 0")

    length = num("length_cm", required=kind == "force")
    loads = _loads(row, where, kind, length)
    value = _number(row["value"], where, "value") if row["value"] != "" else None
    if value is None:
        raise InputError(f"{where}, column 'value': empty")
    unit = row["unit"]
    factors = UNITS[kind]
    if unit.lower() not in factors:
        raise InputError(
            f"{where}, column 'unit': {unit!r} is not a unit of a {kind}; one of {sorted(factors)}"
        )
    v = value * factors[unit.lower()]
    if kind in ("equilibrium_length", "stiffness") and v <= 0:
        raise InputError(f"{where}, column 'value': a {kind} must be > 0, got {value:g}")
    if v == 0:
        raise InputError(f"{where}, column 'value': 0 cannot carry a relative residual")
    name = row.get("name") or f"line {line}: {kind} {muscle} Pc={pc:g} Pe={pe:g}"
    exp = Experiment(
        id=ident,
        name=name,
        measured=_MEASURED[kind],
        unit=_CANON_UNIT[kind],
        value=v,
        device=muscle,
        pc_kpa=pc,
        pe_kpa=pe,
        load_g=loads[0] if (kind == "equilibrium_length" and loads) else 0.0,
        loads_g=loads if kind == "stiffness" else (),
        held_length_cm=length,
        note=row.get("note", ""),
    )
    return Measurement(exp, line, kind, value, unit)


def paper_csv_text(devices: tuple[str, ...] = ("cepam",), experiments: list[Experiment] | None = None) -> str:
    """The paper's balloon numbers (``data/reported.yaml``) as a calibration CSV: every computable,
    non-derived length and stiffness of the given devices (``cepam``; ``cpam``, ``epam``: the
    balloon muscles alone, built from the same braids and bladders, section V)."""
    experiments = experiments if experiments is not None else load_experiments()
    what = (
        "CE-PAM"
        if devices == ("cepam",)
        else "/".join(d.upper() for d in devices) + " (single balloon muscles)"
    )
    lines = [
        f"# The CE-PAM paper's reported numbers of the {what}, generated from",
        "# cepam_gym/data/reported.yaml by `cepam-gym calibrate --write-paper-csv DIR`.",
        "# Stiffness: the weights of reported.yaml defaults.loads_g (the paper does not list them).",
        "kind,muscle,pc_kpa,pe_kpa,length_cm,load_g,value,unit,name",
    ]
    for e in experiments:
        if (
            not e.computable
            or e.derived_from
            or e.bladder != "balloon"
            or e.device not in devices
            or e.measured not in ("length", "stiffness")
        ):
            continue
        kind = "equilibrium_length" if e.measured == "length" else "stiffness"
        pc = f"{e.pc_kpa:g}" if e.device != "epam" else ""
        pe = f"{e.pe_kpa:g}" if e.device != "cpam" else ""
        load = ";".join(f"{m:g}" for m in e.loads_g) if kind == "stiffness" else "0"
        lines.append(f"{kind},{e.device},{pc},{pe},,{load},{e.value:.10g},{e.unit},{e.id}")
    return "\n".join(lines) + "\n"


def write_paper_csvs(directory: str | Path = DATA_DIR) -> list[Path]:
    """Write ``paper_cepam.csv`` and ``paper_single_muscles.csv`` into ``directory``."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    out = []
    for name, devices in (("paper_cepam.csv", ("cepam",)), ("paper_single_muscles.csv", ("cpam", "epam"))):
        (directory / name).write_text(paper_csv_text(devices))
        out.append(directory / name)
    return out
