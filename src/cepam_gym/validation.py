"""The model beside each number the paper reports (model-notes section 3), with relative errors.

The reported numbers and the conditions of their experiments are package data
(``cepam_gym/data/reported.yaml``); the model column is computed every time from a
:class:`~cepam_gym.params.PlantParams` (default: the ``balloon`` preset) at each force-model level
(``basic`` Eq. 20-25, ``radial`` Eq. 26-33, ``enhanced`` Eq. 34-45) and each force form (``paper``:
Eq. 22 and 15 literally; ``virtual_work``: energy-consistent), switched with
``PlantParams.replace``. Nothing model-related is stored.

How each experiment is simulated (static model, chamber pressures held constant as by the paper's
regulators; the rig hangs vertically, so the end cap and any weight pull towards extension):

* ``length``: the unloaded free end (only its cap, ``end_mass``) settles from its starting length
  (CE-PAM and EPAM: the 15 cm bladder length; CPAM: its 19.5 cm rest length) to the first stable
  equilibrium ``F(L) + W = 0`` in the direction the net force moves it (grid scan, then
  ``brentq``). The CE-PAM has end stops at 15 and 19.5 cm; a single muscle is limited only by its
  braid (positive air diameter, Eq. 34).
* ``contraction`` / ``extension``: that length against 19.5 cm (CPAM) or 15 cm (EPAM, CE-PAM).
* ``stiffness``: as in the paper (sections II, III, XII; Fig. 5, 24): from the unloaded
  equilibrium ``L0`` the weights ``m`` are hung one at a time, each loaded equilibrium ``L_m`` is
  found the same way, and ``K = mean(m g / (L_m - L0))``. A weight that pulls the end onto a stop
  measures the stop and is left out (named in the note). If ``L0`` itself is on a stop there is no
  displacement to measure; the local ``-dF/dL`` at ``L0`` is reported instead and the note says so.
  With a *held* length (calibration data, ``held_length_cm``) the local ``-dF/dL`` there.
* ``force`` (calibration data): the push force at a held length.
* ``mean_force_error``: the paper's own model error against force curves that are only plotted
  (Fig. 18, 20, 23); listed, not computable.

Single muscles: the CPAM alone is the CE-PAM force with ``Pe = 0`` and the EPAM alone the one with
``Pc = 0`` and no CPAM term, each with its own air volume (Eq. 14 with ``P_a`` of Eq. 26-32 and
``V_air`` of Eq. 34-43); both are evaluated by the plant's kernels on a parameter row whose
coupling factors (kappa, lambda) and CE-PAM elasticity ``k_el`` are zeroed. Tube rows use the
plant's parameters with the tube's bladder thickness.

``cepam-gym validate`` prints the table and writes plots into ``--out-dir``; ``--json`` prints the
rows as a JSON list of objects with the keys ``name, unit, reported, model, rel_error,
model_level`` (plus ``id, source, force_model, force_form, method, note``).
"""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
from scipy.optimize import brentq

from ._jit import jit
from .params import FORCE_FORMS, FORCE_MODELS, PlantParams, preset
from .physics import api, muscle
from .physics import layout as ix

KPA = 1e3
CM = 1e-2
GRAM = 1e-3
_GRID = 4001  # scan points per settle search (about 0.01 mm over the CE-PAM range)
REPORTED_PATH = Path(__file__).parent / "data" / "reported.yaml"

MEASURED_UNITS = {
    "length": "cm",
    "contraction": "%",
    "extension": "%",
    "stiffness": "N/m",
    "force": "N",
    "mean_force_error": "%",
}
DEVICES = ("cepam", "cpam", "epam")
BLADDERS = ("balloon", "tube")
LEVELS = tuple(f"{fm}/{ff}" for fm in FORCE_MODELS for ff in FORCE_FORMS)


# ------------------------------------------------------------------ experiments
@dataclass(frozen=True)
class Experiment:
    """One measurement: what is measured, on which device, under which conditions.

    Pressures in kPa gauge, lengths in cm, weights in g (edge units; converted where used).
    """

    id: str
    name: str
    measured: str
    unit: str
    value: float
    device: str = "cepam"
    bladder: str = "balloon"
    pc_kpa: float = 0.0
    pe_kpa: float = 0.0
    load_g: float = 0.0  # hanging weight during a length measurement
    loads_g: tuple[float, ...] = ()  # weights of a stiffness measurement
    held_length_cm: float | None = None  # force / local stiffness at this length
    at_length_cm: float | None = None  # the length the paper reports (information only)
    bladder_thickness_mm: float | None = None
    section: str = ""
    figure: str = ""
    derived_from: str | None = None
    computable: bool = True
    model_level: str | None = None  # for the paper's own error numbers
    quote: str = ""
    note: str = ""

    @property
    def source(self) -> str:
        return f"sec. {self.section}" + (f", {self.figure}" if self.figure else "")


_YAML_KEYS = {
    "id", "name", "measured", "unit", "value", "section", "figure", "device", "bladder",
    "bladder_thickness_mm", "pc_kpa", "pe_kpa", "at_length_cm", "loads_g", "derived_from",
    "computable", "model_level", "quote", "note",
}


def load_experiments(path: str | Path | None = None) -> list[Experiment]:
    """Read the reported numbers (``data/reported.yaml`` by default); errors name the entry."""
    import yaml

    path = Path(path) if path is not None else REPORTED_PATH
    with path.open() as fh:
        doc = yaml.safe_load(fh)
    if not isinstance(doc, dict) or not isinstance(doc.get("experiments"), list):
        raise ValueError(f"{path}: expected a mapping with a list 'experiments'")
    default_loads = tuple(float(x) for x in (doc.get("defaults") or {}).get("loads_g", ()))
    out: list[Experiment] = []
    seen: set[str] = set()
    for i, e in enumerate(doc["experiments"]):
        where = f"{path}: experiment {i + 1}" + (f" ({e.get('id')})" if isinstance(e, dict) else "")
        if not isinstance(e, dict):
            raise ValueError(f"{where}: expected a mapping")
        unknown = set(e) - _YAML_KEYS
        if unknown:
            raise ValueError(f"{where}: unknown key(s) {sorted(unknown)}")
        for key in ("id", "name", "measured", "unit", "value", "section", "device", "bladder"):
            if key not in e:
                raise ValueError(f"{where}: missing key {key!r}")
        if e["id"] in seen:
            raise ValueError(f"{where}: duplicate id {e['id']!r}")
        seen.add(e["id"])
        measured, device, bladder = e["measured"], e["device"], e["bladder"]
        if measured not in MEASURED_UNITS:
            raise ValueError(f"{where}: measured must be one of {sorted(MEASURED_UNITS)}, got {measured!r}")
        if e["unit"] != MEASURED_UNITS[measured]:
            raise ValueError(f"{where}: unit of a {measured} must be {MEASURED_UNITS[measured]!r}, got {e['unit']!r}")
        if device not in DEVICES:
            raise ValueError(f"{where}: device must be one of {DEVICES}, got {device!r}")
        if bladder not in BLADDERS:
            raise ValueError(f"{where}: bladder must be one of {BLADDERS}, got {bladder!r}")
        if bladder == "tube" and "bladder_thickness_mm" not in e:
            raise ValueError(f"{where}: a tube row needs bladder_thickness_mm")
        if measured == "contraction" and device != "cpam":
            raise ValueError(f"{where}: contraction is defined for the cpam only")
        if measured == "extension" and device == "cpam":
            raise ValueError(f"{where}: extension is defined for the epam and the cepam")
        value = float(e["value"])
        if not math.isfinite(value) or value <= 0:
            raise ValueError(f"{where}: value must be a positive number, got {e['value']!r}")
        loads = tuple(float(x) for x in e.get("loads_g", default_loads)) if measured == "stiffness" else ()
        if measured == "stiffness" and (not loads or min(loads) <= 0):
            raise ValueError(f"{where}: a stiffness needs positive loads_g")
        out.append(Experiment(
            id=str(e["id"]), name=str(e["name"]), measured=measured, unit=e["unit"], value=value,
            device=device, bladder=bladder, pc_kpa=float(e.get("pc_kpa", 0.0)),
            pe_kpa=float(e.get("pe_kpa", 0.0)), loads_g=loads,
            at_length_cm=float(e["at_length_cm"]) if "at_length_cm" in e else None,
            bladder_thickness_mm=float(e["bladder_thickness_mm"]) if "bladder_thickness_mm" in e else None,
            section=str(e["section"]), figure=str(e.get("figure", "")),
            derived_from=e.get("derived_from"), computable=bool(e.get("computable", True)),
            model_level=e.get("model_level"), quote=str(e.get("quote", "")), note=str(e.get("note", "")),
        ))
    ids = {x.id for x in out}
    for x in out:
        if x.derived_from is not None and x.derived_from not in ids:
            raise ValueError(f"{path}: experiment {x.id}: derived_from {x.derived_from!r} is not an id")
    return out


# ------------------------------------------------------------------ equilibrium search
@jit
def _force_grid(lengths, pc, pe, row, weight):
    """``F(L) + weight`` on an array of lengths (the plant's kernel, Eq. 25 / 41-45)."""
    out = np.empty(lengths.shape[0])
    for i in range(lengths.shape[0]):
        out[i] = muscle.cepam_force(lengths[i], pc, pe, row)[0] + weight
    return out


class NetForce:
    """Net extension force on the free end, ``F(L) + weight`` [N], callable on a float or an
    array of lengths [m] (pressures held, kernel parameter row ``row``)."""

    def __init__(self, pc: float, pe: float, row: np.ndarray, weight: float):
        self.pc, self.pe, self.row, self.weight = float(pc), float(pe), row, float(weight)

    def __call__(self, L):
        if np.ndim(L) == 0:
            return muscle.cepam_force(float(L), self.pc, self.pe, self.row)[0] + self.weight
        return _force_grid(np.ascontiguousarray(L, dtype=float), self.pc, self.pe, self.row, self.weight)


def settle(g: Callable, start: float, lo: float, hi: float) -> tuple[float, str]:
    """Length where the end comes to rest when released at ``start`` under the net extension
    force ``g(L)`` (positive = extending; ``g`` takes a float or an array of lengths), with stops
    at ``lo`` and ``hi``.

    Returns ``(L, where)`` with ``where`` in ``{"free", "lower stop", "upper stop"}``; a free
    equilibrium is the first sign change of ``g`` in the direction of motion (found on a grid,
    refined by ``brentq``).
    """
    def g1(L: float) -> float:
        return float(g(L))

    g0 = g1(start)
    if g0 == 0.0:
        return start, "free"
    up = g0 > 0.0
    end = hi if up else lo
    if end == start:
        return start, "upper stop" if up else "lower stop"
    grid = np.linspace(start, end, _GRID)
    vals = g(grid)
    crossed = np.nonzero(vals <= 0.0 if up else vals >= 0.0)[0]
    if crossed.size == 0:
        return end, "upper stop" if up else "lower stop"
    i = int(crossed[0])
    if vals[i] == 0.0:
        return float(grid[i]), "free"
    a, b = sorted((float(grid[i - 1]), float(grid[i])))
    return float(brentq(g1, a, b, xtol=1e-13, rtol=1e-12)), "free"


# ------------------------------------------------------------------ the devices
def experiment_params(exp: Experiment, params: PlantParams) -> PlantParams:
    """The plant parameters of the device the experiment used: tube rows get the tube's wall."""
    if exp.bladder == "tube" and exp.bladder_thickness_mm is not None:
        return params.replace(bladder_thickness=exp.bladder_thickness_mm * 1e-3)
    return params


def _row(params: PlantParams, device: str) -> np.ndarray:
    """Kernel parameter row. A single muscle: no CPAM-in-EPAM coupling (kappa = lambda = 0) and no
    CE-PAM elasticity, so ``cepam_force`` reduces to ``P_ac dV_ac/dL`` (Pe = 0) or
    ``P_ae dV_ae/dL`` (Pc = 0), Eq. 14 of one muscle."""
    row = params.to_array()
    if device != "cepam":
        row[ix.KAPPA] = 0.0
        row[ix.LAMBDA] = 0.0
        row[ix.K_EL] = 0.0
    return row


def _pressures(exp: Experiment) -> tuple[float, float]:
    if exp.device == "cpam":
        return exp.pc_kpa * KPA, 0.0
    if exp.device == "epam":
        return 0.0, exp.pe_kpa * KPA
    return exp.pc_kpa * KPA, exp.pe_kpa * KPA


def braid_limit(params: PlantParams, device: str) -> float:
    """Longest length at which the braid keeps a positive air diameter ``D - 2 t_a`` (Eq. 34)."""
    b, n = params.cpam_braid() if device == "cpam" else params.epam_braid()
    s_min = min(2.0 * params.wall_thickness() * n * math.pi / b + 1e-6, 0.999)
    return b * math.sqrt(1.0 - s_min * s_min) * (1.0 - 1e-9)


def device_range(params: PlantParams, device: str) -> tuple[float, float, float]:
    """``(start, lo, hi)``: where a measurement starts and the stops the end meets [m]."""
    if device == "cepam":
        return params.min_length, params.min_length, params.max_length
    if device == "cpam":
        b, _ = params.cpam_braid()
        return params.cpam_rest_length, 0.05 * b, braid_limit(params, "cpam")
    # the EPAM bladder (15 cm = the CE-PAM's nominal length) is its shortest length
    return params.min_length, params.min_length, braid_limit(params, "epam")


@dataclass
class Outcome:
    value: float
    method: str
    note: str = ""


def simulate(exp: Experiment, params: PlantParams) -> Outcome:
    """The model's value of one experiment, in the experiment's unit (see the module docstring).

    ``params`` is the plant under test (force model and form included); tube rows replace the
    bladder thickness. Returns ``value = nan`` (with the reason in ``note``) if the device's
    parameter set is invalid or the quantity is not computable.
    """
    if not exp.computable:
        return Outcome(math.nan, "not computable", exp.note)
    try:
        p = experiment_params(exp, params)
    except ValueError as err:
        return Outcome(math.nan, "invalid parameters", str(err))
    row = _row(p, exp.device)
    pc, pe = _pressures(exp)
    start, lo, hi = device_range(p, exp.device)
    w_end = p.end_mass * p.gravity
    notes: list[str] = []

    def net(weight: float) -> NetForce:
        return NetForce(pc, pe, row, weight)

    if exp.measured == "force":
        L = exp.held_length_cm * CM
        return Outcome(float(api.force(L, pc, pe, row)), "force at held length")
    if exp.measured == "stiffness" and exp.held_length_cm is not None:
        L = exp.held_length_cm * CM
        return Outcome(float(api.stiffness(L, pc, pe, row)), "local -dF/dL at held length")

    load = exp.load_g * GRAM * p.gravity if exp.measured == "length" else 0.0
    L0, where = settle(net(w_end + load), start, lo, hi)
    if where != "free":
        notes.append(f"rests on the {where} ({L0 / CM:.2f} cm)")
    if exp.measured == "length":
        return Outcome(L0 / CM, "free length", "; ".join(notes))
    if exp.measured == "contraction":
        return Outcome(100.0 * (p.cpam_rest_length - L0) / p.cpam_rest_length, "free length", "; ".join(notes))
    if exp.measured == "extension":
        return Outcome(100.0 * (L0 - p.min_length) / p.min_length, "free length", "; ".join(notes))
    if exp.measured != "stiffness":
        raise ValueError(f"experiment {exp.id}: cannot simulate a {exp.measured!r}")

    # stiffness by hanging weights (sections II, III, XII)
    if where != "free":
        k = float(api.stiffness(L0, pc, pe, row))
        notes.append(f"no displacement to measure: local -dF/dL there reported")
        return Outcome(k, "local -dF/dL (on stop)", "; ".join(notes))
    ks, stopped = [], []
    for m in exp.loads_g:
        w = m * GRAM * p.gravity
        Lm, wm = settle(net(w_end + w), L0, lo, hi)
        if wm != "free" or Lm <= L0:
            stopped.append(f"{m:g}")
            continue
        ks.append(w / (Lm - L0))
    notes.append(f"unloaded at {L0 / CM:.2f} cm" + (f" (paper {exp.at_length_cm:g} cm)" if exp.at_length_cm else ""))
    if stopped:
        notes.append(f"loads {', '.join(stopped)} g reach a stop and are left out")
    if not ks:
        k = float(api.stiffness(L0, pc, pe, row))
        notes.append("every load reaches a stop: local -dF/dL at the unloaded length reported")
        return Outcome(k, "local -dF/dL (loads on stop)", "; ".join(notes))
    return Outcome(float(np.mean(ks)), "hanging weights", "; ".join(notes))


# ------------------------------------------------------------------ the table
def base_params(preset_name: str | None = None, params_file: str | Path | None = None) -> PlantParams:
    if params_file is not None:
        return PlantParams.from_yaml(params_file)
    return preset(preset_name) if preset_name else PlantParams()


def _finite(x: float) -> float | None:
    return float(x) if x is not None and math.isfinite(x) else None


def validation_rows(params: PlantParams | None = None, levels: tuple[str, ...] = LEVELS,
                    experiments: list[Experiment] | None = None) -> list[dict]:
    """One row per computable experiment and force-model level (``force_model/force_form``), one
    row per non-computable experiment (``model_level = "n/a"``, ``model = rel_error = None``).

    Keys: ``name, unit, reported, model, rel_error, model_level`` and ``id, source, force_model,
    force_form, method, note, derived_from``.
    """
    params = params if params is not None else PlantParams()
    experiments = experiments if experiments is not None else load_experiments()
    rows = []
    for exp in experiments:
        if not exp.computable:
            rows.append({"name": exp.name, "unit": exp.unit, "reported": exp.value, "model": None,
                         "rel_error": None, "model_level": "n/a", "id": exp.id, "source": exp.source,
                         "force_model": exp.model_level, "force_form": None, "method": "not computable",
                         "note": "the measured force curves are only plotted in the paper",
                         "derived_from": exp.derived_from})
            continue
        for level in levels:
            fm, ff = level.split("/")
            out = simulate(exp, params.replace(force_model=fm, force_form=ff))
            model = _finite(out.value)
            rows.append({
                "name": exp.name, "unit": exp.unit, "reported": exp.value, "model": model,
                "rel_error": None if model is None else (model - exp.value) / exp.value,
                "model_level": level, "id": exp.id, "source": exp.source, "force_model": fm,
                "force_form": ff, "method": out.method, "note": out.note,
                "derived_from": exp.derived_from,
            })
    return rows


def summary(rows: list[dict]) -> dict[str, dict]:
    """Per level: mean |rel error|, count within 5 %, count of rows (derived ratios excluded)."""
    out = {}
    for level in dict.fromkeys(r["model_level"] for r in rows if r["model_level"] != "n/a"):
        errs = [abs(r["rel_error"]) if r["rel_error"] is not None else math.inf
                for r in rows if r["model_level"] == level and not r["derived_from"]]
        finite = [e for e in errs if math.isfinite(e)]
        out[level] = {"mean_abs_rel_error": float(np.mean(finite)) if finite else math.nan,
                      "within_5pct": sum(e <= 0.05 for e in errs), "rows": len(errs)}
    return out


_SHORT = {"basic": "bas", "radial": "rad", "enhanced": "enh", "paper": "pap", "virtual_work": "vw"}


def _short(level: str) -> str:
    fm, ff = level.split("/")
    return f"{_SHORT[fm]}/{_SHORT[ff]}"


def format_table(rows: list[dict], title: str = "") -> str:
    """Text table: one line per reported number, model value (relative error) per level; then the
    non-computable numbers, a summary and the notes."""
    levels = list(dict.fromkeys(r["model_level"] for r in rows if r["model_level"] != "n/a"))
    by = {(r["id"], r["model_level"]): r for r in rows}
    ids = list(dict.fromkeys(r["id"] for r in rows if r["model_level"] != "n/a"))
    names = {r["id"]: r["name"] for r in rows}
    w_name = max([len(names[i]) for i in ids] + [20])
    head = f"{'reported number':<{w_name}} {'unit':>4} {'reported':>9}" + "".join(f" {_short(lv):>17}" for lv in levels)
    lines = [title] if title else []
    lines += [head, "-" * len(head)]
    for i in ids:
        r0 = by[(i, levels[0])]
        line = f"{names[i]:<{w_name}} {r0['unit']:>4} {r0['reported']:>9.5g}"
        for lv in levels:
            r = by[(i, lv)]
            mark = "*" if r["method"].startswith("local") and "held" not in r["method"] else " "
            if r["model"] is None:
                line += f" {'n/a':>17}"
            else:
                line += f" {r['model']:>8.4g}{mark}({100 * r['rel_error']:+5.0f}%)"
        lines.append(line)
    lines.append("")
    lines.append("columns: model value (relative error) per force_model/force_form: bas = basic (Eq. 20-25), "
                 "rad = +P_r (Eq. 26-33), enh = +t_a (Eq. 34-45); pap = paper form (Eq. 22, 15), "
                 "vw = virtual work. * = no free equilibrium to hang weights from: local -dF/dL. "
                 "Single-muscle rows do not depend on the form (no annulus).")
    stats = summary(rows)
    lines.append("mean |error| (derived ratios excluded):" + "".join(
        f"  {_short(lv)} {100 * s['mean_abs_rel_error']:.1f}% ({s['within_5pct']}/{s['rows']} within 5%)"
        for lv, s in stats.items()))
    nc = [r for r in rows if r["model_level"] == "n/a"]
    if nc:
        lines.append("")
        lines.append("reported, not computable (the measured force curves are only plotted):")
        for r in nc:
            lines.append(f"  {r['name']}: {r['reported']:g} {r['unit']} ({r['source']})")
    lines.append("")
    lines.append("notes:")
    for i in ids:
        groups: dict[str, list[str]] = {}
        for lv in levels:
            note = by[(i, lv)]["note"]
            if note:
                groups.setdefault(note, []).append(_short(lv))
        for note, lvs in groups.items():
            lines.append(f"  {names[i]} [{', '.join(lvs)}]: {note}")
    return "\n".join(lines)


# ------------------------------------------------------------------ plots
def write_plots(params: PlantParams, experiments: list[Experiment], rows: list[dict],
                out_dir: str | Path) -> list[Path]:
    """Model curves with the reported points: CE-PAM stiffness and length per pressure pair,
    single-muscle free length vs pressure, CPAM contraction vs tube wall thickness."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    levels = list(dict.fromkeys(r["model_level"] for r in rows if r["model_level"] != "n/a"))
    by = {(r["id"], r["model_level"]): r for r in rows}
    paths = []

    # 1. CE-PAM stiffness and length per pressure pair (section XII)
    stiff = [e for e in experiments if e.device == "cepam" and e.measured == "stiffness"]
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    x = np.arange(len(stiff))
    labels = [f"Pe={e.pe_kpa:g}\nPc={e.pc_kpa:g}\n({e.at_length_cm:g} cm)" for e in stiff]
    axes[0].plot(x, [e.value for e in stiff], "ko", ms=8, label="reported (Fig. 25, 26)")
    for lv in levels:
        axes[0].plot(x, [by[(e.id, lv)]["model"] or np.nan for e in stiff], "-", marker=".", label=lv)
    axes[0].set_xticks(x, labels)
    axes[0].set_ylabel("stiffness [N/m]")
    axes[0].set_title("CE-PAM stiffness, pressures held, weights hung")
    axes[0].legend(fontsize=7)
    lengths = [e for e in experiments if e.device == "cepam" and e.measured == "length"]
    x2 = np.arange(len(lengths))
    axes[1].plot(x2, [e.value for e in lengths], "ko", ms=8, label="reported (sec. V, XII)")
    for lv in levels:
        axes[1].plot(x2, [by[(e.id, lv)]["model"] or np.nan for e in lengths], "-", marker=".", label=lv)
    axes[1].set_xticks(x2, [f"Pe={e.pe_kpa:g}\nPc={e.pc_kpa:g}" for e in lengths], fontsize=7)
    axes[1].set_ylabel("free length [cm]")
    axes[1].set_title("CE-PAM free length (end stops 15, 19.5 cm)")
    fig.tight_layout()
    paths.append(out / "validate_cepam.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)

    # 2. single-muscle free length vs pressure (sections II, III)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    pressures = np.linspace(10.0, 500.0, 50)
    for ax, device in zip(axes, ("cpam", "epam")):
        for bladder, tb, style in (("balloon", None, "-"), ("tube", 1.0, "--")):
            for lv in ("basic/virtual_work", "enhanced/virtual_work"):
                p = params.replace(force_model=lv.split("/")[0])
                curve = []
                for P in pressures:
                    e = Experiment("curve", "curve", "length", "cm", 1.0, device=device, bladder=bladder,
                                   bladder_thickness_mm=tb, pc_kpa=P, pe_kpa=P)
                    curve.append(simulate(e, p).value)
                ax.plot(pressures, curve, style, label=f"model {lv.split('/')[0]}, {bladder}")
        pts = [e for e in experiments if e.device == device and e.measured == "length"]
        for e in pts:
            ax.plot(e.pc_kpa if device == "cpam" else e.pe_kpa, e.value,
                    "ko" if e.bladder == "balloon" else "ks", ms=8)
        ax.plot([], [], "ko", label="reported balloon")
        ax.plot([], [], "ks", label="reported tube")
        ax.set_xlabel(("Pc" if device == "cpam" else "Pe") + " [kPa]")
        ax.set_ylabel("free length [cm]")
        ax.set_title(f"single {device.upper()} free length (Fig. {4 if device == 'cpam' else 10})")
        ax.legend(fontsize=7)
    fig.tight_layout()
    paths.append(out / "validate_single_muscles.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)

    # 3. CPAM contraction vs tube wall at 500 kPa (section X)
    fig, ax = plt.subplots(figsize=(6, 4.5))
    walls = np.linspace(0.2, 2.2, 21)
    for fm in FORCE_MODELS:
        p = params.replace(force_model=fm)
        c = [simulate(Experiment("c", "c", "contraction", "%", 1.0, device="cpam", bladder="tube",
                                 bladder_thickness_mm=t, pc_kpa=500.0), p).value for t in walls]
        ax.plot(walls, c, label=f"model {fm}")
    pts = [e for e in experiments if e.device == "cpam" and e.measured == "contraction" and e.bladder == "tube"]
    ax.plot([e.bladder_thickness_mm for e in pts], [e.value for e in pts], "ko", ms=8, label="reported (Fig. 21)")
    ax.set_xlabel("tube wall t_b [mm]")
    ax.set_ylabel("contraction at 500 kPa [%]")
    ax.set_title("CPAM contraction vs bladder thickness")
    ax.legend(fontsize=7)
    fig.tight_layout()
    paths.append(out / "validate_thickness.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)
    return paths


def _json_rows(rows: list[dict]) -> list[dict]:
    return [{k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in r.items()} for r in rows]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="cepam-gym validate",
                                 description="the paper's reported numbers beside the model's (computed, never stored)")
    ap.add_argument("--json", action="store_true", help="print the rows as a JSON list (no plots)")
    ap.add_argument("--preset", default=None, help="plant preset to validate (default: the dataclass defaults = balloon)")
    ap.add_argument("--params", default=None, help="plant parameter YAML to validate (overrides --preset)")
    ap.add_argument("--out-dir", default="runs/validate", help="where the plots and the table go")
    args = ap.parse_args(argv)
    params = base_params(args.preset, args.params)
    experiments = load_experiments()
    rows = validation_rows(params, experiments=experiments)
    if args.json:
        print(json.dumps(_json_rows(rows), indent=1))
        return 0
    what = (args.params or f"preset {args.preset}") if (args.params or args.preset) else "default plant (balloon)"
    table = format_table(rows, title=f"reproduction table: {what}")
    print(table)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / "validate.txt").write_text(table + "\n")
    (out / "validate.json").write_text(json.dumps(_json_rows(rows), indent=1))
    for path in write_plots(params, experiments, rows, out):
        print(f"plot: {path}")
    print(f"table: {out / 'validate.txt'}, {out / 'validate.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
