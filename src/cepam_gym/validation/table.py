"""The reproduction table: the model beside each reported number, per force-model level
(``basic`` Eq. 20-25, ``radial`` Eq. 26-33, ``enhanced`` Eq. 34-45) and force form (``paper``:
Eq. 22 and 15 literally; ``virtual_work``: energy-consistent), with relative errors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..plant.params import FORCE_FORMS, FORCE_MODELS, PlantParams, preset
from .equilibrium import Outcome, simulate
from .experiments import Experiment, load_experiments
from .protocols import run

LEVELS = tuple(f"{fm}/{ff}" for fm in FORCE_MODELS for ff in FORCE_FORMS)
# the plant as configured (plant v1: tension-only braids, bladder walls); the paper's levels above
# evaluate its geometry with the paper's force model as written (braids that also push, no wall
# energy: the v0 options), so they are the same for a v0 and a v1 plant of equal geometry
PLANT_LEVEL = "plant"
# the same plant through the paper's protocols on the dynamic plant (validation/protocols.py):
# pressurising order, settle times, weights hung one at a time, friction. The headline uses it.
PROTOCOL_LEVEL = "protocol"
DEFAULT_LEVELS = (PROTOCOL_LEVEL, PLANT_LEVEL) + LEVELS


def base_params(preset_name: str | None = None, params_file: str | Path | None = None) -> PlantParams:
    if params_file is not None:
        return PlantParams.from_yaml(params_file)
    return preset(preset_name) if preset_name else PlantParams()


def _finite(x: float) -> float | None:
    return float(x) if x is not None and math.isfinite(x) else None


def level_params(params: PlantParams, level: str) -> PlantParams:
    """The plant of one table column: ``plant`` as given, else the paper's ``force_model/force_form``
    with the paper's braids and no wall energy (``braid_tension = bidirectional``, ``bladder_model =
    spring``; a v0 plant keeps its spring)."""
    if level in (PLANT_LEVEL, PROTOCOL_LEVEL):
        return params
    fm, ff = level.split("/")
    return params.replace(
        force_model=fm, force_form=ff, braid_tension="bidirectional", bladder_model="spring"
    )


def validation_rows(
    params: PlantParams | None = None,
    levels: tuple[str, ...] = DEFAULT_LEVELS,
    experiments: list[Experiment] | None = None,
) -> list[dict]:
    """One row per computable experiment and force-model level (``force_model/force_form``), one
    row per non-computable experiment (``model_level = "n/a"``, ``model = rel_error = None``).

    Keys: ``name, unit, reported, model, rel_error, model_level`` and ``id, source, force_model,
    force_form, method, note, derived_from``.
    """
    params = params if params is not None else PlantParams()
    experiments = experiments if experiments is not None else load_experiments()
    by_protocol = (
        dict(zip((e.id for e in experiments), run(experiments, params))) if PROTOCOL_LEVEL in levels else {}
    )
    rows = []
    for exp in experiments:
        if not exp.computable:
            rows.append(
                {
                    "name": exp.name,
                    "unit": exp.unit,
                    "reported": exp.value,
                    "model": None,
                    "rel_error": None,
                    "model_level": "n/a",
                    "id": exp.id,
                    "source": exp.source,
                    "force_model": exp.model_level,
                    "force_form": None,
                    "method": "not computable",
                    "note": "the measured force curves are only plotted in the paper",
                    "derived_from": exp.derived_from,
                }
            )
            continue
        for level in levels:
            p = level_params(params, level)
            fm, ff = p.force_model, p.force_form
            if level == PROTOCOL_LEVEL:
                pr = by_protocol[exp.id]
                out = Outcome(pr.value, "protocol on the dynamic plant", pr.note)
            else:
                out = simulate(exp, p)
            model = _finite(out.value)
            rows.append(
                {
                    "name": exp.name,
                    "unit": exp.unit,
                    "reported": exp.value,
                    "model": model,
                    "rel_error": None if model is None else (model - exp.value) / exp.value,
                    "model_level": level,
                    "id": exp.id,
                    "source": exp.source,
                    "force_model": fm,
                    "force_form": ff,
                    "method": out.method,
                    "note": out.note,
                    "derived_from": exp.derived_from,
                }
            )
    return rows


def summary(rows: list[dict]) -> dict[str, dict]:
    """Per level: mean |rel error|, count within 5 %, count of rows (derived ratios excluded)."""
    out = {}
    for level in dict.fromkeys(r["model_level"] for r in rows if r["model_level"] != "n/a"):
        errs = [
            abs(r["rel_error"]) if r["rel_error"] is not None else math.inf
            for r in rows
            if r["model_level"] == level and not r["derived_from"]
        ]
        finite = [e for e in errs if math.isfinite(e)]
        out[level] = {
            "mean_abs_rel_error": float(np.mean(finite)) if finite else math.nan,
            "within_5pct": sum(e <= 0.05 for e in errs),
            "rows": len(errs),
        }
    return out


_SHORT = {"basic": "bas", "radial": "rad", "enhanced": "enh", "paper": "pap", "virtual_work": "vw"}


def _short(level: str) -> str:
    if level in (PLANT_LEVEL, PROTOCOL_LEVEL):
        return level
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
    head = f"{'reported number':<{w_name}} {'unit':>4} {'reported':>9}" + "".join(
        f" {_short(lv):>17}" for lv in levels
    )
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
    lines.append(
        "columns: model value (relative error); protocol = the plant as configured run through the "
        "paper's protocols on the dynamic plant (extensor first, then contractor, weights hung one at a "
        "time, friction; the headline uses it); plant = the same plant solved statically (v1: "
        "tension-only braids, bladder walls); then the paper's model as written per force_model/force_form: "
        "bas = basic (Eq. 20-25), "
        "rad = +P_r (Eq. 26-33), enh = +t_a (Eq. 34-45); pap = paper form (Eq. 22, 15), "
        "vw = virtual work. * = no free equilibrium to hang weights from: local -dF/dL. "
        "Single-muscle rows do not depend on the form (no annulus)."
    )
    stats = summary(rows)
    lines.append(
        "mean |error| (derived ratios excluded):"
        + "".join(
            f"  {_short(lv)} {100 * s['mean_abs_rel_error']:.1f}% ({s['within_5pct']}/{s['rows']} within 5%)"
            for lv, s in stats.items()
        )
    )
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


def device_headline(rows: list[dict], level: str | None = None) -> dict[str, dict]:
    """Per device (CE-PAM, CPAM, EPAM) at one level (default: the first): mean and worst |relative
    error| and how many of its numbers are within 5 % (derived ratios excluded)."""
    from .experiments import DEVICES, load_experiments

    level = level or next(r["model_level"] for r in rows if r["model_level"] != "n/a")
    device = {e.id: e.device for e in load_experiments()}
    out = {}
    for d in DEVICES:
        errs = [
            abs(r["rel_error"]) if r["rel_error"] is not None else math.inf
            for r in rows
            if r["model_level"] == level and not r["derived_from"] and device.get(r["id"]) == d
        ]
        if errs:
            out[d] = {
                "mean": float(np.mean(errs)),
                "worst": float(np.max(errs)),
                "within_5pct": int(sum(e <= 0.05 for e in errs)),
                "rows": len(errs),
            }
    return out


def format_headline(rows: list[dict], level: str | None = None) -> str:
    head = device_headline(rows, level)
    level = level or next(r["model_level"] for r in rows if r["model_level"] != "n/a")
    names = {"cepam": "CE-PAM", "cpam": "CPAM", "epam": "EPAM"}
    return f"headline from the {level!r} column:\n" + "\n".join(
        f"headline {names[d]:<6}: mean {100 * h['mean']:.1f}%, worst {100 * h['worst']:.1f}%, "
        f"{h['within_5pct']}/{h['rows']} within 5%"
        for d, h in head.items()
    )


def geometry_lines(params: PlantParams) -> str:
    """Each muscle's braid diameter and each chamber's air volume over the stroke, beside the
    paper's built dimensions (CPAM 5 mm, EPAM bladder and sleeve 10 mm; sections II, III)."""
    from ..physics import api

    lengths = np.array([params.min_length, 0.5 * (params.min_length + params.max_length), params.max_length])
    bc, nc = params.cpam_braid()
    be, ne = params.epam_braid()
    dc = bc * np.sqrt(1 - (lengths / bc) ** 2) / (np.pi * nc)
    de = be * np.sqrt(1 - (lengths / be) ** 2) / (np.pi * ne)
    vc, ve, _, _ = api.chamber_volumes(lengths, params)
    at = "  ".join(f"{L * 100:.2f} cm" for L in lengths)
    stretch = params.epam_thread_compliance > 0.0 or params.cpam_thread_compliance > 0.0
    tail = ", unpressurised (unstretched threads):" if stretch else ":"
    return "\n".join(
        [
            f"geometry over the stroke ({at}){tail}",
            "  CPAM braid diameter [mm]:   "
            + "  ".join(f"{x * 1e3:7.2f}" for x in dc)
            + f"   (paper: {params.cpam_rest_diameter * 1e3:g} mm at {params.cpam_rest_length * 100:g} cm)",
            "  EPAM braid diameter [mm]:   "
            + "  ".join(f"{x * 1e3:7.2f}" for x in de)
            + f"   (paper: {params.epam_sleeve_free_diameter * 1e3:g} mm sleeve and bladder; "
            f"{de.max() / params.epam_sleeve_free_diameter:.2f}x nominal at most)",
            "  CPAM chamber volume [cm3]:  "
            + "  ".join(f"{x * 1e6:7.2f}" for x in vc)
            + "   (dead volume included)",
            "  annulus volume [cm3]:       "
            + "  ".join(f"{x * 1e6:7.2f}" for x in ve)
            + "   (dead volume included)",
        ]
    )


def json_rows(rows: list[dict]) -> list[dict]:
    return [
        {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in r.items()}
        for r in rows
    ]
