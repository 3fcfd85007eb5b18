"""Fit the unknown plant parameters to measured static data (``cepam-gym calibrate``).

Input: a CSV with one measurement per row (format in docs/calibration.md; the paper's own numbers
ship as ``cepam_gym/data/paper_cepam.csv``, generated from ``data/reported.yaml``). Each row is
simulated exactly as :mod:`cepam_gym.validation` simulates the paper's experiments (pressures
held, the free end hanging; stiffness by hanging weights or at a held length; force at a held
length), with the plant's own force model and form (``balloon``: enhanced, virtual work).

Fit: bounded least squares (``scipy.optimize.least_squares``, trust-region reflective) on the
relative residuals ``(model - measured) / measured`` over the chosen parameters, each scaled to
``[0, 1]`` inside its physical bounds (:data:`FIT_PARAMS`). Uncertainty from the Jacobian at the
optimum: ``cov = s^2 (J^T J)^-1`` with ``s^2 = sum(r^2) / (m - p)`` (pseudo-inverse when ``J``
is rank deficient; such directions are reported as not identifiable). The result is written as a
YAML that :meth:`PlantParams.from_yaml` loads: ``preset: <base>`` plus the fitted keys in edge
units (``PlantParams.to_dict`` names).

Parameters that only enter through a combination cannot be told apart: the bladder and sleeve
thicknesses enter only as ``t_a = t_s + t_b`` (Eq. 35), so the default set fits ``wall_thickness``
(``t_a``, keeping the base ratio ``t_b : t_s``); ``kr_scale`` scales both ``K_r`` of Eq. 27.
"""

from __future__ import annotations

import argparse
import csv
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from .params import PlantParams, preset
from .validation import Experiment, load_experiments, simulate

DATA_DIR = Path(__file__).parent / "data"
PAPER_CSV = DATA_DIR / "paper_cepam.csv"  # the CE-PAM's numbers (sections V, XII)
PAPER_SINGLE_CSV = DATA_DIR / "paper_single_muscles.csv"  # its balloon CPAM and EPAM alone (II, III)

# ------------------------------------------------------------------ the parameters that can be fitted
KR_HIGH_PAPER = 2.0e6  # Pa/m, Eq. 27
KR_LOW_PAPER = 5.0e5


@dataclass(frozen=True)
class FitParam:
    """A fittable quantity in edge units, its physical bounds and how it maps onto PlantParams."""

    name: str
    unit: str
    lo: float
    hi: float
    why: str
    get: Callable[[PlantParams], float]
    set: Callable[[PlantParams, float], dict]
    fields: tuple[str, ...]  # PlantParams fields it writes


def _split_wall(p: PlantParams, ta_mm: float) -> dict:
    ta = ta_mm * 1e-3
    total = p.bladder_thickness + p.sleeve_thickness
    frac = p.bladder_thickness / total if total > 0 else 0.5
    return {"bladder_thickness": ta * frac, "sleeve_thickness": ta * (1.0 - frac)}


FIT_PARAMS: dict[str, FitParam] = {fp.name: fp for fp in (
    FitParam("cpam_rest_angle", "deg", 5.0, 50.0,
             "braid angle of the CPAM at rest: a contractor's braid is below 54.7 deg; commercial "
             "sleeves are woven at about 15-45 deg",
             lambda p: math.degrees(p.cpam_rest_angle),
             lambda p, v: {"cpam_rest_angle": math.radians(v)}, ("cpam_rest_angle",)),
    FitParam("epam_sleeve_free_angle", "deg", 5.0, 50.0,
             "braid angle of the EPAM sleeve before it is compressed (the same kind of sleeve)",
             lambda p: math.degrees(p.epam_sleeve_free_angle),
             lambda p, v: {"epam_sleeve_free_angle": math.radians(v)}, ("epam_sleeve_free_angle",)),
    FitParam("wall_thickness", "mm", 0.1, 1.5,
             "t_a = t_s + t_b (Eq. 35): a balloon wall of a few tenths of a mm (< 1 mm, sections "
             "I-II) plus a braid of nylon threads; a wall cannot be thinner than 0.1 mm; the base "
             "ratio t_b : t_s is kept",
             lambda p: 1e3 * (p.bladder_thickness + p.sleeve_thickness), _split_wall,
             ("bladder_thickness", "sleeve_thickness")),
    FitParam("bladder_thickness", "mm", 0.0, 1.0, "t_b (Eq. 35): the balloon is thinner than the 1 mm tube",
             lambda p: 1e3 * p.bladder_thickness,
             lambda p, v: {"bladder_thickness": v * 1e-3}, ("bladder_thickness",)),
    FitParam("sleeve_thickness", "mm", 0.0, 1.0, "t_s (Eq. 35): a braid of nylon threads",
             lambda p: 1e3 * p.sleeve_thickness,
             lambda p, v: {"sleeve_thickness": v * 1e-3}, ("sleeve_thickness",)),
    FitParam("kr_scale", "", 0.0, 4.0,
             "factor on both K_r of Eq. 27 (2000 and 500 kPa/m, measured by Tsagarakis and "
             "Caldwell on another muscle); 4 lets a balloon lose up to 80 kPa to inflation",
             lambda p: p.kr_high / KR_HIGH_PAPER,
             lambda p, v: {"kr_high": v * KR_HIGH_PAPER, "kr_low": v * KR_LOW_PAPER}, ("kr_high", "kr_low")),
    FitParam("elastic_stiffness", "n_per_m", 0.0, 400.0,
             "axial stiffness of the two bladders (not in the paper): latex E of 1-2 MPa, wall "
             "<= 1 mm, 5 and 10 mm diameter, 15-20 cm long gives at most a few hundred N/m",
             lambda p: p.elastic_stiffness,
             lambda p, v: {"elastic_stiffness": v}, ("elastic_stiffness",)),
    FitParam("elastic_rest_length", "cm", 15.0, 19.5,
             "rest length of that elasticity: between the EPAM bladder (15 cm) and the CPAM (19.5 cm)",
             lambda p: 100.0 * p.elastic_rest_length,
             lambda p, v: {"elastic_rest_length": v * 1e-2}, ("elastic_rest_length",)),
    FitParam("end_mass", "g", 5.0, 100.0, "the hanging end cap (3D printed)",
             lambda p: 1e3 * p.end_mass, lambda p, v: {"end_mass": v * 1e-3}, ("end_mass",)),
)}
DEFAULT_FIT = ("cpam_rest_angle", "epam_sleeve_free_angle", "wall_thickness", "kr_scale", "elastic_stiffness")


def apply(base: PlantParams, names: tuple[str, ...], values: np.ndarray) -> PlantParams:
    """``base`` with the fit parameters ``names`` set to ``values`` (edge units); validated."""
    p = base
    for name, v in zip(names, values):
        p = p.replace(**FIT_PARAMS[name].set(p, float(v)))
    return p


# ------------------------------------------------------------------ the CSV
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
        raise ValueError(f"{where}, column {column!r}: {cell!r} is not a number") from None
    if not math.isfinite(x):
        raise ValueError(f"{where}, column {column!r}: {cell!r} is not a finite number")
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
                raise ValueError(f"{path}, line {line} (header): duplicate column(s) {sorted(dup)}")
            unknown = [c for c in header if c not in REQUIRED_COLUMNS + OPTIONAL_COLUMNS]
            if unknown:
                raise ValueError(f"{path}, line {line} (header): unknown column(s) {unknown}; "
                                 f"known: {list(REQUIRED_COLUMNS + OPTIONAL_COLUMNS)}")
            missing = [c for c in REQUIRED_COLUMNS if c not in header]
            if missing:
                raise ValueError(f"{path}, line {line} (header): missing column(s) {missing}; "
                                 f"required: {list(REQUIRED_COLUMNS)}")
            continue
        where = f"{path}, line {line}"
        if len(cells) != len(header):
            raise ValueError(f"{where}: {len(cells)} cells, but the header has {len(header)} columns")
        row = dict(zip(header, cells))
        out.append(_parse_row(row, where, line, f"{path.name}:{line}"))
    if header is None:
        raise ValueError(f"{path}: empty file (no header)")
    if not out:
        raise ValueError(f"{path}: no measurement rows after the header")
    return out


def _parse_row(row: dict[str, str], where: str, line: int, ident: str) -> Measurement:
    kind = row["kind"].lower()
    if kind not in KINDS:
        raise ValueError(f"{where}, column 'kind': unknown kind {row['kind']!r}; one of {list(KINDS)}")
    muscle = (row.get("muscle") or "cepam").lower()
    if muscle not in MUSCLES:
        raise ValueError(f"{where}, column 'muscle': unknown muscle {row['muscle']!r}; one of {list(MUSCLES)}")

    def num(column: str, required: bool, default: float | None = None) -> float | None:
        cell = row[column]
        if cell == "":
            if required:
                raise ValueError(f"{where}, column {column!r}: empty, but a {kind} of the {muscle} needs it")
            return default
        return _number(cell, where, column)

    pc = num("pc_kpa", required=muscle in ("cepam", "cpam"), default=0.0)
    pe = num("pe_kpa", required=muscle in ("cepam", "epam"), default=0.0)
    for column, v in (("pc_kpa", pc), ("pe_kpa", pe)):
        if v < 0:
            raise ValueError(f"{where}, column {column!r}: negative gauge pressure {v:g} kPa "
                             "(suction is not modelled)")
    if muscle == "cpam" and pe != 0:
        raise ValueError(f"{where}, column 'pe_kpa': a single CPAM has no EPAM chamber; leave it empty or 0")
    if muscle == "epam" and pc != 0:
        raise ValueError(f"{where}, column 'pc_kpa': a single EPAM has no CPAM chamber; leave it empty or 0")

    length = num("length_cm", required=kind == "force")
    loads: tuple[float, ...] = ()
    if row["load_g"] != "":
        parts = [s.strip() for s in row["load_g"].split(";")]
        loads = tuple(_number(s, where, "load_g") for s in parts)
        if any(m < 0 for m in loads):
            raise ValueError(f"{where}, column 'load_g': negative load {row['load_g']!r}")
    if kind == "equilibrium_length":
        if length is not None:
            raise ValueError(f"{where}, column 'length_cm': an equilibrium_length is measured, not held; "
                             "leave length_cm empty (the measured length goes in 'value')")
        if len(loads) > 1:
            raise ValueError(f"{where}, column 'load_g': one hanging load per equilibrium_length row")
    elif kind == "stiffness":
        if (length is None) == (not loads):
            raise ValueError(f"{where}, columns 'length_cm'/'load_g': a stiffness needs exactly one of "
                             "length_cm (held length: local -dF/dL) or load_g (the weights hung, "
                             "';'-separated: K = mean(m g / displacement))")
        if loads and min(loads) <= 0:
            raise ValueError(f"{where}, column 'load_g': stiffness weights must be > 0")
    else:  # force
        if loads and any(m != 0 for m in loads):
            raise ValueError(f"{where}, column 'load_g': a force is measured at a held length; leave load_g empty")
    if length is not None and length <= 0:
        raise ValueError(f"{where}, column 'length_cm': length must be > 0, got {length:g}")

    value = _number(row["value"], where, "value") if row["value"] != "" else None
    if value is None:
        raise ValueError(f"{where}, column 'value': empty")
    unit = row["unit"]
    factors = UNITS[kind]
    if unit.lower() not in factors:
        raise ValueError(f"{where}, column 'unit': {unit!r} is not a unit of a {kind}; one of {sorted(factors)}")
    v = value * factors[unit.lower()]
    if kind in ("equilibrium_length", "stiffness") and v <= 0:
        raise ValueError(f"{where}, column 'value': a {kind} must be > 0, got {value:g}")
    if v == 0:
        raise ValueError(f"{where}, column 'value': 0 cannot carry a relative residual")
    name = row.get("name") or f"line {line}: {kind} {muscle} Pc={pc:g} Pe={pe:g}"
    exp = Experiment(
        id=ident, name=name, measured=_MEASURED[kind], unit=_CANON_UNIT[kind], value=v,
        device=muscle, pc_kpa=pc, pe_kpa=pe,
        load_g=loads[0] if (kind == "equilibrium_length" and loads) else 0.0,
        loads_g=loads if kind == "stiffness" else (),
        held_length_cm=length, note=row.get("note", ""))
    return Measurement(exp, line, kind, value, unit)


def paper_csv_text(devices: tuple[str, ...] = ("cepam",), experiments: list[Experiment] | None = None) -> str:
    """The paper's balloon numbers (``data/reported.yaml``) as a calibration CSV: every computable,
    non-derived length and stiffness of the given devices (``cepam``; ``cpam``, ``epam``: the
    balloon muscles alone, built from the same braids and bladders, section V)."""
    experiments = experiments if experiments is not None else load_experiments()
    what = "CE-PAM" if devices == ("cepam",) else "/".join(d.upper() for d in devices) + " (single balloon muscles)"
    lines = [f"# The CE-PAM paper's reported numbers of the {what}, generated from",
             "# cepam_gym/data/reported.yaml by `python -m cepam_gym.calibration --write-paper-csv DIR`.",
             "# Stiffness: the weights of reported.yaml defaults.loads_g (the paper does not list them).",
             "kind,muscle,pc_kpa,pe_kpa,length_cm,load_g,value,unit,name"]
    for e in experiments:
        if (not e.computable or e.derived_from or e.bladder != "balloon" or e.device not in devices
                or e.measured not in ("length", "stiffness")):
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


# ------------------------------------------------------------------ the fit
@dataclass
class FitResult:
    names: tuple[str, ...]
    start: np.ndarray  # edge units
    values: np.ndarray
    std: np.ndarray  # nan where not identifiable / undefined
    cov: np.ndarray
    at_bound: np.ndarray  # bool
    identifiable: np.ndarray  # bool
    params: PlantParams
    residuals: np.ndarray  # relative, at the optimum
    residuals_start: np.ndarray
    model: np.ndarray
    model_start: np.ndarray
    cost: float
    success: bool
    message: str
    starts_tried: int = 1
    notes: list[str] = field(default_factory=list)


def model_values(experiments: list[Experiment], params: PlantParams) -> np.ndarray:
    return np.array([simulate(e, params).value for e in experiments])


def _relative(model: np.ndarray, experiments: list[Experiment]) -> np.ndarray:
    meas = np.array([e.value for e in experiments])
    r = (model - meas) / np.abs(meas)
    return np.where(np.isfinite(r), r, 1.0)  # a model that gives no value is 100 % off


def fit(experiments: list[Experiment], base: PlantParams, names: tuple[str, ...] = DEFAULT_FIT,
        starts: int = 1, seed: int = 0, bounds: dict[str, tuple[float, float]] | None = None) -> FitResult:
    """Bounded least squares of the relative residuals over ``names`` (see the module docstring).

    ``starts > 1`` adds ``starts - 1`` random starting points inside the bounds (seeded); the
    lowest cost wins. ``bounds`` overrides :data:`FIT_PARAMS` bounds (edge units).
    """
    from scipy.optimize import least_squares

    names = tuple(names)
    for n in names:
        if n not in FIT_PARAMS:
            raise ValueError(f"unknown fit parameter {n!r}; one of {sorted(FIT_PARAMS)}")
    written = [f for n in names for f in FIT_PARAMS[n].fields]
    if len(set(written)) != len(written):
        raise ValueError(f"fit parameters {list(names)} write the same field twice (e.g. wall_thickness "
                         "and bladder_thickness); choose one")
    lo = np.array([(bounds or {}).get(n, (FIT_PARAMS[n].lo, FIT_PARAMS[n].hi))[0] for n in names])
    hi = np.array([(bounds or {}).get(n, (FIT_PARAMS[n].lo, FIT_PARAMS[n].hi))[1] for n in names])
    span = hi - lo
    x_start = np.array([FIT_PARAMS[n].get(base) for n in names])
    model_start = model_values(experiments, base)

    def to_edge(z: np.ndarray) -> np.ndarray:
        return lo + z * span

    def residuals(z: np.ndarray) -> np.ndarray:
        try:
            p = apply(base, names, to_edge(z))
        except ValueError:
            return np.full(len(experiments), 1.0)  # impossible geometry: 100 % off everywhere
        return _relative(model_values(experiments, p), experiments)

    rng = np.random.default_rng(seed)
    z0s = [np.clip((x_start - lo) / span, 0.0, 1.0)] + [rng.uniform(0.05, 0.95, len(names)) for _ in range(starts - 1)]
    best = None
    for z0 in z0s:
        try:
            sol = least_squares(residuals, z0, bounds=(0.0, 1.0), method="trf", diff_step=1e-4,
                                x_scale=1.0, xtol=1e-10, ftol=1e-10, gtol=1e-10, max_nfev=200 * len(names))
        except ValueError:
            continue
        if best is None or sol.cost < best.cost:
            best = sol
    if best is None:
        raise RuntimeError("no start gave a valid parameter set")
    values = to_edge(best.x)
    params = apply(base, names, values)
    model = model_values(experiments, params)
    r = _relative(model, experiments)
    m, k = len(experiments), len(names)
    Jz = _jacobian(residuals, best.x, r)  # d r / d z, own finite differences (see _jacobian)
    J = Jz / span  # d r / d (edge value)
    notes: list[str] = []
    identifiable = np.ones(k, bool)
    if m > k:
        s2 = float(r @ r) / (m - k)
        JtJ = J.T @ J
        cov = s2 * np.linalg.pinv(JtJ, rcond=1e-10)
        # a parameter is not identifiable if the data do not move it: its column is (near) zero or it
        # lies in the null space of J
        _, s, vt = np.linalg.svd(Jz, full_matrices=False)
        tiny = s < 1e-8 * max(s.max(), 1e-300)
        for j in range(k):
            if np.any(tiny & (np.abs(vt[:, j]) > 1e-3)):
                identifiable[j] = False
        std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        std[~identifiable] = np.nan
    else:
        cov = np.full((k, k), np.nan)
        std = np.full(k, np.nan)
        notes.append(f"{m} measurements for {k} parameters: no residual degrees of freedom, no uncertainty")
    at_bound = best.active_mask != 0
    if np.any(at_bound):
        notes.append("at a bound (the uncertainty of a bounded parameter is not a confidence interval): "
                     + ", ".join(n for n, b in zip(names, at_bound) if b))
    if np.any(~identifiable):
        notes.append("not identifiable from these data (the Jacobian has no component along them): "
                     + ", ".join(n for n, i in zip(names, identifiable) if not i))
    return FitResult(names, x_start, values, std, cov, at_bound, identifiable, params, r,
                     _relative(model_start, experiments), model, model_start, float(best.cost),
                     bool(best.success), str(best.message), len(z0s), notes)


def _jacobian(fun: Callable[[np.ndarray], np.ndarray], z: np.ndarray, r0: np.ndarray,
              h: float = 1e-4) -> np.ndarray:
    """Finite-difference Jacobian of the residuals in the scaled variables ``z`` in [0, 1]:
    central differences inside, one-sided at a bound (so a parameter that sits on its bound still
    shows how the data pull on it)."""
    J = np.empty((r0.size, z.size))
    for j in range(z.size):
        up, dn = z.copy(), z.copy()
        up[j], dn[j] = min(z[j] + h, 1.0), max(z[j] - h, 0.0)
        fu = fun(up) if up[j] != z[j] else r0
        fd = fun(dn) if dn[j] != z[j] else r0
        J[:, j] = (fu - fd) / (up[j] - dn[j])
    return J


def minimax(experiments: list[Experiment], base: PlantParams, names: tuple[str, ...] = DEFAULT_FIT,
            bounds: dict[str, tuple[float, float]] | None = None, seed: int = 0,
            maxiter: int = 200) -> tuple[float, np.ndarray]:
    """The smallest largest relative error the parameters ``names`` can reach inside their bounds
    (``scipy.optimize.differential_evolution`` on ``max |r|``): a check of whether a goal such as
    "every number within 5 %" is reachable at all, not a fit. Returns ``(max |r|, values)``."""
    from scipy.optimize import differential_evolution

    names = tuple(names)
    lims = [(bounds or {}).get(n, (FIT_PARAMS[n].lo, FIT_PARAMS[n].hi)) for n in names]

    def worst(x: np.ndarray) -> float:
        try:
            p = apply(base, names, x)
        except ValueError:
            return 10.0
        return float(np.max(np.abs(_relative(model_values(experiments, p), experiments))))

    res = differential_evolution(worst, lims, seed=seed, maxiter=maxiter, popsize=15, tol=1e-9, polish=True)
    return float(res.fun), np.asarray(res.x)


# ------------------------------------------------------------------ reporting
def format_report(res: FitResult, experiments: list[Experiment]) -> str:
    lines = ["parameters (edge units):",
             f"  {'name':<24} {'start':>10} {'fitted':>10} {'+/- 1 sd':>10} {'unit':>8}  bounds"]
    for j, n in enumerate(res.names):
        fp = FIT_PARAMS[n]
        sd = "n/a" if not math.isfinite(res.std[j]) else f"{res.std[j]:.3g}"
        flag = " (at bound)" if res.at_bound[j] else ""
        lines.append(f"  {n:<24} {res.start[j]:>10.4g} {res.values[j]:>10.4g} {sd:>10} {fp.unit:>8}  "
                     f"[{fp.lo:g}, {fp.hi:g}]{flag}")
    lines.append("")
    lines.append("residuals per measurement (relative, model vs measured):")
    w = max(len(e.name) for e in experiments)
    lines.append(f"  {'measurement':<{w}} {'measured':>10} {'unit':>4} {'before':>10} {'err':>7} {'after':>10} {'err':>7}")
    for i, e in enumerate(experiments):
        lines.append(f"  {e.name:<{w}} {e.value:>10.5g} {e.unit:>4} {res.model_start[i]:>10.5g} "
                     f"{100 * res.residuals_start[i]:>+6.1f}% {res.model[i]:>10.5g} {100 * res.residuals[i]:>+6.1f}%")
    rs, r = np.abs(res.residuals_start), np.abs(res.residuals)
    lines.append(f"  mean |error| {100 * rs.mean():.2f}% -> {100 * r.mean():.2f}%, max {100 * rs.max():.1f}% -> "
                 f"{100 * r.max():.1f}%, within 5%: {int((rs <= 0.05).sum())} -> {int((r <= 0.05).sum())} of {len(r)}")
    lines.append(f"  optimizer: {res.message} (success={res.success}, cost={res.cost:.4g}, starts={res.starts_tried})")
    for n in res.notes:
        lines.append(f"  note: {n}")
    for (a, b), rho in correlations(res).items():
        lines.append(f"  note: {a} and {b} are strongly correlated (rho = {rho:+.2f}): the data fix a "
                     "combination of them better than either")
    return "\n".join(lines)


def correlations(res: FitResult, threshold: float = 0.9) -> dict[tuple[str, str], float]:
    """Pairs of fitted parameters whose estimates correlate beyond ``threshold`` (from ``cov``)."""
    out = {}
    sd = np.sqrt(np.clip(np.diag(res.cov), 0.0, None)) if np.all(np.isfinite(res.cov)) else None
    if sd is None:
        return out
    for i in range(len(res.names)):
        for j in range(i + 1, len(res.names)):
            if sd[i] > 0 and sd[j] > 0 and not (res.at_bound[i] or res.at_bound[j]):
                rho = res.cov[i, j] / (sd[i] * sd[j])
                if abs(rho) > threshold:
                    out[(res.names[i], res.names[j])] = float(rho)
    return out


def fitted_yaml(res: FitResult, base_preset: str, header: str = "") -> str:
    """``preset: <base>`` plus the fitted fields, unit-named (the keys of ``PlantParams.to_dict``)."""
    edge = res.params.to_dict()
    keys = PlantParams.edge_keys()
    fields = [f for n in res.names for f in FIT_PARAMS[n].fields]
    lines = [f"# {ln}" if ln else "#" for ln in header.splitlines()]
    lines.append(f"preset: {base_preset}")
    for key, name in keys.items():
        if name in fields:
            lines.append(f"{key}: {edge[key]:.6g}")
    return "\n".join(lines) + "\n"


def plot_fit(res: FitResult, experiments: list[Experiment], path: str | Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    n = len(experiments)
    fig, ax = plt.subplots(figsize=(max(7.0, 0.45 * n + 3), 5))
    x = np.arange(n)
    ax.bar(x - 0.2, 100 * res.residuals_start, 0.4, label="start", color="0.7")
    ax.bar(x + 0.2, 100 * res.residuals, 0.4, label="fitted", color="C0")
    ax.axhspan(-5, 5, color="C2", alpha=0.15, label="+/- 5 %")
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(x, [e.name for e in experiments], rotation=75, ha="right", fontsize=7)
    ax.set_ylabel("relative error [%]")
    pars = ", ".join(f"{nm}={v:.3g}" for nm, v in zip(res.names, res.values))
    ax.set_title(f"calibration residuals\n{pars}", fontsize=8)
    lim = max(10.0, min(150.0, 100 * max(np.abs(res.residuals_start).max(), np.abs(res.residuals).max()) * 1.1))
    ax.set_ylim(-lim, lim)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="cepam-gym calibrate",
        description="fit unknown plant parameters to measured static data (format: docs/calibration.md)")
    ap.add_argument("--data", action="append",
                    help="measurement CSV; repeat to fit several files jointly (the paper's numbers: "
                         "cepam_gym/data/paper_cepam.csv and paper_single_muscles.csv)")
    ap.add_argument("--out", help="fitted parameter YAML to write (loadable by PlantParams.from_yaml)")
    ap.add_argument("--preset", default="balloon", help="base preset: the start and every unfitted value")
    ap.add_argument("--fit", default=",".join(DEFAULT_FIT),
                    help=f"comma-separated parameters to fit; one of {sorted(FIT_PARAMS)}")
    ap.add_argument("--bounds", default="", help="override bounds: name=lo:hi,... (edge units)")
    ap.add_argument("--starts", type=int, default=1, help="starting points (1 = the preset; more: seeded random)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--plot", default=None, help="residual plot (default: next to --out, .png)")
    ap.add_argument("--minimax", action="store_true",
                    help="also search (differential evolution, about a minute) for the smallest "
                         "largest error the fit parameters can reach inside their bounds")
    ap.add_argument("--write-paper-csv", metavar="DIR", default=None,
                    help="write the paper's numbers (data/reported.yaml) as paper_cepam.csv and "
                         "paper_single_muscles.csv into DIR and exit")
    args = ap.parse_args(argv)
    if args.write_paper_csv:
        for path in write_paper_csvs(args.write_paper_csv):
            print(f"wrote {path}")
        return 0
    if not args.data or not args.out:
        ap.error("--data and --out are required")
    names = tuple(s.strip() for s in args.fit.split(",") if s.strip())
    bounds = {}
    for item in filter(None, (s.strip() for s in args.bounds.split(","))):
        try:
            k, rng = item.split("=")
            a, b = rng.split(":")
            bounds[k.strip()] = (float(a), float(b))
        except ValueError:
            ap.error(f"--bounds: cannot read {item!r}; expected name=lo:hi")
    base = preset(args.preset)
    experiments = [m.experiment for path in args.data for m in read_csv(path)]
    res = fit(experiments, base, names, starts=args.starts, seed=args.seed, bounds=bounds)
    report = format_report(res, experiments)
    print(f"calibration of preset {args.preset!r} ({base.force_model}/{base.force_form}) to {', '.join(args.data)}: "
          f"{len(experiments)} measurements, {len(names)} parameters")
    print(report)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    data = " ".join(f"--data {d}" for d in args.data)
    header = (f"fitted by `cepam-gym calibrate {data} --preset {args.preset} --fit {','.join(names)}`\n"
              f"mean |relative error| {100 * np.abs(res.residuals).mean():.2f}% over {len(experiments)} "
              f"measurements; the full report is printed by the command")
    out.write_text(fitted_yaml(res, args.preset, header))
    PlantParams.from_yaml(out)  # round trip: the file loads
    plot = plot_fit(res, experiments, args.plot or out.with_suffix(".png"))
    print(f"wrote {out} and {plot}")
    if args.minimax:
        worst, x = minimax(experiments, base, names, bounds=bounds, seed=args.seed)
        pars = ", ".join(f"{n} = {v:.4g}" for n, v in zip(names, x))
        print(f"minimax check: the smallest largest |error| inside the bounds is {100 * worst:.2f}% ({pars})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
