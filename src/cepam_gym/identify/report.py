"""What an identification reports: the text, the fitted YAML and its header, the JSON summary and
the figures (measured against predicted, and the residuals, per recording)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..validation import fitcore
from .dynamic_params import ALL_PARAMS, SENSOR_PARAMS
from .run import Identification
from .simulate import CHANNELS

_EDGE = {"pressure_c": ("kPa", 1e-3), "pressure_e": ("kPa", 1e-3), "length": ("cm", 1e2)}


def _score_line(scores: dict) -> str:
    return ", ".join(f"{c} {100 * scores[c]['nrmse']:.2f} % (R2 {scores[c]['r2']:.4f})" for c in CHANNELS)


def score_lines(ident: Identification) -> list[str]:
    lines = []
    for r in ident.records:
        lines.append(f"  {r.role:<8} {r.name}")
        lines.append(f"    fit:    {_score_line(r.fit)}")
        lines.append(f"    preset: {_score_line(r.base)}")
    return lines


def format_report(ident: Identification) -> str:
    flags = [
        "identifiable" if i else ("" if j >= ident.k else "NOT identifiable")
        for j, i in enumerate(ident.identifiable)
    ]
    lines = [
        f"identification of preset {ident.preset!r} ({ident.mode} mode) on {', '.join(ident.data)}; "
        f"held out: {', '.join(ident.holdout)}",
        "parameters (edge units; sd: approximate, from the Jacobian; identifiable: 2 sd within "
        f"{100 * 0.1:.0f} % of the value):",
    ]
    lines += fitcore.parameter_lines(
        ident.names, ident.units, ident.start, ident.values, ident.std, ident.bounds, ident.at_bound, flags
    )
    lines.append("")
    lines.append("NRMSE per channel (RMS error / std of the measured), after the unscored warm-up:")
    lines += score_lines(ident)
    lines.append(
        f"  optimizer: {ident.message} (cost {ident.cost:.4g}, {ident.starts} start(s)); "
        f"{ident.seconds:.1f} s; interval widening for correlated residuals x{math.sqrt(ident.inflation):.2g}"
    )
    weak = [n for n, i in zip(ident.names[: ident.k], ident.identifiable) if not i]
    if weak:
        lines.append(
            "  the data do not pin down: "
            + ", ".join(weak)
            + " (their values are the fit's, but another value would predict these logs as well; "
            "excite more, or freeze them with the preset's value)"
        )
    for n in ident.notes:
        lines.append(f"  note: {n}")
    return "\n".join(lines)


def yaml_header(ident: Identification, command: str) -> str:
    """The header of the fitted YAML: what was fitted to what, how well, and the sensors."""
    lines = [
        f"fitted by `{command}`" if command else "fitted by cepam-gym identify",
        f"data: {', '.join(ident.data)}; held out: {', '.join(ident.holdout)}",
        f"mode {ident.mode}, {ident.starts} start(s), {ident.seconds:.0f} s",
    ]
    for role in ("fitted", "held out"):
        worst = ident.worst(role)
        if worst:
            lines.append(
                f"worst NRMSE on {role} data: " + ", ".join(f"{c} {100 * v:.2f} %" for c, v in worst.items())
            )
    lines.append("parameter = value +/- 1 sd (approximate), identifiable or not:")
    for j, n in enumerate(ident.names):
        sd = "n/a" if not math.isfinite(ident.std[j]) else f"{ident.std[j]:.3g}"
        tag = "" if j >= ident.k else ("identifiable" if ident.identifiable[j] else "NOT identifiable")
        lines.append(f"  {n} = {ident.values[j]:.5g} +/- {sd} {ident.units[j]} {tag}".rstrip())
    lines.append("the sensor lines describe the rig's instruments, not the plant: they are not parameters")
    return "\n".join(lines)


def fitted_yaml(ident: Identification, command: str = "") -> str:
    return fitcore.fitted_yaml(ident.params, ident.fields(), ident.preset, yaml_header(ident, command))


def summary(ident: Identification) -> dict:
    """The JSON summary."""

    def num(x):
        return None if not math.isfinite(float(x)) else float(x)

    return {
        "preset": ident.preset,
        "mode": ident.mode,
        "data": ident.data,
        "holdout": ident.holdout,
        "seconds": ident.seconds,
        "cost": ident.cost,
        "parameters": [
            {
                "name": n,
                "kind": "plant" if j < ident.k else "sensor",
                "unit": ident.units[j],
                "start": num(ident.start[j]),
                "value": num(ident.values[j]),
                "sd": num(ident.std[j]),
                "ci95": [num(ident.values[j] - 2 * ident.std[j]), num(ident.values[j] + 2 * ident.std[j])],
                "bounds": list(ident.bounds[n]),
                "at_bound": bool(ident.at_bound[j]),
                "identifiable": bool(ident.identifiable[j]),
                "why": (ALL_PARAMS.get(n) or SENSOR_PARAMS[n]).why,
            }
            for j, n in enumerate(ident.names)
        ],
        "recordings": [
            {
                "name": r.name,
                "role": r.role,
                "fit": r.fit,
                "preset": r.base,
                "scored_from_s": float(r.time[r.scored_from]),
            }
            for r in ident.records
        ],
        "notes": ident.notes,
    }


def write_report(ident: Identification, out_dir: str | Path) -> list[Path]:
    """``summary.json`` and one PNG per recording into ``out_dir``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "summary.json"]
    paths[0].write_text(json.dumps(summary(ident), indent=1))
    for i, r in enumerate(ident.records):
        fig, axes = plt.subplots(6, 1, figsize=(12, 13), sharex=True, height_ratios=[3, 1] * 3)
        for c, ch in enumerate(CHANNELS):
            unit, k = _EDGE[ch]
            ax, res = axes[2 * c], axes[2 * c + 1]
            ax.plot(r.time, r.measured[:, c] * k, "k", lw=0.8, label="measured")
            ax.plot(
                r.time, r.predicted[:, c] * k, "C0", lw=0.8, label=f"fit ({100 * r.fit[ch]['nrmse']:.2f} %)"
            )
            ax.plot(
                r.time,
                r.preset[:, c] * k,
                "C1",
                lw=0.6,
                alpha=0.7,
                label=f"preset ({100 * r.base[ch]['nrmse']:.1f} %)",
            )
            ax.axvspan(r.time[0], r.time[r.scored_from], color="0.9", label="warm-up (not scored)")
            ax.set_ylabel(f"{ch} [{unit}]")
            ax.legend(fontsize=7, loc="upper right", ncol=4)
            res.plot(r.time, (r.predicted[:, c] - r.measured[:, c]) * k, "C0", lw=0.6)
            res.axhline(0.0, color="k", lw=0.5)
            res.set_ylabel(f"residual [{unit}]")
        axes[-1].set_xlabel("time [s]")
        axes[0].set_title(f"{r.role}: {r.name}")
        fig.tight_layout()
        paths.append(out / f"recording_{i + 1}_{r.role.replace(' ', '_')}.png")
        fig.savefig(paths[-1], dpi=90)
        plt.close(fig)
    return paths


def recovery_lines(ident: Identification, truth: dict[str, float]) -> list[str]:
    """The recovered plant parameters beside the truth (the self-check)."""
    lines = [f"  {'name':<28} {'truth':>10} {'fitted':>10} {'error':>8}  identifiable"]
    for j, n in enumerate(ident.names[: ident.k]):
        t = truth[n]
        err = (ident.values[j] - t) / abs(t) if t else float("nan")
        ok = "yes" if ident.identifiable[j] else "no"
        lines.append(f"  {n:<28} {t:>10.4g} {ident.values[j]:>10.4g} {100 * err:>+7.2f}%  {ok}")
    return lines


def recovery_errors(ident: Identification, truth: dict[str, float]) -> np.ndarray:
    return np.array(
        [(ident.values[j] - truth[n]) / abs(truth[n]) for j, n in enumerate(ident.names[: ident.k])]
    )
