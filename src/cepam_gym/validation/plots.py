"""Figures of the reproduction (model curves with the reported points) and of a calibration
(residuals before and after the fit)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..plant.params import FORCE_MODELS, PlantParams
from .equilibrium import simulate
from .experiments import Experiment
from .fit import FitResult


def write_plots(
    params: PlantParams, experiments: list[Experiment], rows: list[dict], out_dir: str | Path
) -> list[Path]:
    """Model curves with the reported points: CE-PAM stiffness and length per pressure pair,
    single-muscle free length vs pressure, CPAM contraction vs tube wall thickness."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, draw in (
        ("validate_cepam.png", lambda: _cepam_figure(plt, experiments, rows)),
        ("validate_single_muscles.png", lambda: _single_muscle_figure(plt, params, experiments)),
        ("validate_thickness.png", lambda: _thickness_figure(plt, params, experiments)),
    ):
        fig = draw()
        fig.tight_layout()
        paths.append(out / name)
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)
    return paths


def _cepam_figure(plt, experiments: list[Experiment], rows: list[dict]):
    """CE-PAM stiffness and length per pressure pair (section XII), each model level's beside the
    reported points."""
    levels = list(dict.fromkeys(r["model_level"] for r in rows if r["model_level"] != "n/a"))
    by = {(r["id"], r["model_level"]): r for r in rows}
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
    return fig


def _free_length_curve(params: PlantParams, device: str, bladder: str, tb, level: str, pressures):
    """The model's free length [cm] of a single ``device`` at each pressure [kPa]."""
    p = params.replace(force_model=level.split("/")[0])
    return [
        simulate(
            Experiment(
                "curve",
                "curve",
                "length",
                "cm",
                1.0,
                device=device,
                bladder=bladder,
                bladder_thickness_mm=tb,
                pc_kpa=P,
                pe_kpa=P,
            ),  # fmt: skip
            p,
        ).value
        for P in pressures
    ]


def _single_muscle_figure(plt, params: PlantParams, experiments: list[Experiment]):
    """Single-muscle free length vs pressure (sections II, III), balloon and tube bladders."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    pressures = np.linspace(10.0, 500.0, 50)
    for ax, device in zip(axes, ("cpam", "epam")):
        for bladder, tb, style in (("balloon", None, "-"), ("tube", 1.0, "--")):
            for lv in ("basic/virtual_work", "enhanced/virtual_work"):
                curve = _free_length_curve(params, device, bladder, tb, lv, pressures)
                ax.plot(pressures, curve, style, label=f"model {lv.split('/')[0]}, {bladder}")
        pts = [e for e in experiments if e.device == device and e.measured == "length"]
        for e in pts:
            ax.plot(
                e.pc_kpa if device == "cpam" else e.pe_kpa,
                e.value,
                "ko" if e.bladder == "balloon" else "ks",
                ms=8,
            )
        ax.plot([], [], "ko", label="reported balloon")
        ax.plot([], [], "ks", label="reported tube")
        ax.set_xlabel(("Pc" if device == "cpam" else "Pe") + " [kPa]")
        ax.set_ylabel("free length [cm]")
        ax.set_title(f"single {device.upper()} free length (Fig. {4 if device == 'cpam' else 10})")
        ax.legend(fontsize=7)
    return fig


def _thickness_figure(plt, params: PlantParams, experiments: list[Experiment]):
    """CPAM contraction vs tube wall at 500 kPa (section X), per force model."""
    fig, ax = plt.subplots(figsize=(6, 4.5))
    walls = np.linspace(0.2, 2.2, 21)
    for fm in FORCE_MODELS:
        p = params.replace(force_model=fm)
        c = [
            simulate(
                Experiment(
                    "c",
                    "c",
                    "contraction",
                    "%",
                    1.0,
                    device="cpam",
                    bladder="tube",
                    bladder_thickness_mm=t,
                    pc_kpa=500.0,
                ),  # fmt: skip
                p,
            ).value
            for t in walls
        ]
        ax.plot(walls, c, label=f"model {fm}")
    pts = [
        e for e in experiments if e.device == "cpam" and e.measured == "contraction" and e.bladder == "tube"
    ]
    ax.plot(
        [e.bladder_thickness_mm for e in pts], [e.value for e in pts], "ko", ms=8, label="reported (Fig. 21)"
    )
    ax.set_xlabel("tube wall t_b [mm]")
    ax.set_ylabel("contraction at 500 kPa [%]")
    ax.set_title("CPAM contraction vs bladder thickness")
    ax.legend(fontsize=7)
    return fig


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
    lim = max(
        10.0, min(150.0, 100 * max(np.abs(res.residuals_start).max(), np.abs(res.residuals).max()) * 1.1)
    )
    ax.set_ylim(-lim, lim)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
