"""Tables and plots of benchmark results (matplotlib imported lazily, Agg backend)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

COLUMNS = (("length_rmse_mm", "len RMSE mm"), ("stiffness_rmse_pct", "K RMSE %"),
           ("settling_time_s", "settle s"), ("overshoot_pct", "overshoot %"),
           ("cvar10_return", "CVaR10 ret"), ("failure_rate", "fail"),
           ("air_g_per_episode", "air g/ep"), ("score", "score"))


def table(rows: list[dict]) -> str:
    head = f"{'suite':27s} {'controller':14s}" + "".join(f"{t:>12s}" for _, t in COLUMNS)
    lines = [head, "-" * len(head)]
    for r in rows:
        cells = "".join(f"{'-':>12s}" if r.get(k) is None else f"{r[k]:12.3f}" for k, _ in COLUMNS)
        lines.append(f"{r['suite']:27s} {str(r['controller'])[:14]:14s}{cells}")
    return "\n".join(lines)


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_traces(tr: dict, title: str, path: Path, episode: int = 0) -> Path:
    plt = _plt()
    t = np.arange(tr["length"].shape[0]) * tr["dt"]
    fig, ax = plt.subplots(4, 1, figsize=(8, 8), sharex=True)
    ax[0].plot(t, 100 * tr["length"][:, episode], label="length")
    ax[0].plot(t, 100 * tr["target_length"][:, episode], "--", label="target")
    ax[0].set_ylabel("length [cm]")
    ax[1].plot(t, tr["stiffness"][:, episode], label="stiffness")
    ax[1].plot(t, tr["target_stiffness"][:, episode], "--", label="target")
    ax[1].set_ylabel("stiffness [N/m]")
    ax[2].plot(t, tr["pressure_c"][:, episode] / 1e3, label="Pc (CPAM)")
    ax[2].plot(t, tr["pressure_e"][:, episode] / 1e3, label="Pe (annulus)")
    ax[2].set_ylabel("gauge [kPa]")
    ax[3].plot(t, 1000 * tr["load_mass"][:, episode])
    ax[3].set_ylabel("load [g]")
    ax[3].set_xlabel("time [s]")
    for a in ax[:3]:
        a.legend(loc="upper right", fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def plot_bars(rows: list[dict], path: Path) -> Path:
    plt = _plt()
    suites = sorted({r["suite"] for r in rows}, key=[r["suite"] for r in rows].index)
    ctls = sorted({str(r["controller"]) for r in rows}, key=[str(r["controller"]) for r in rows].index)
    fig, ax = plt.subplots(figsize=(8, 4))
    w = 0.8 / max(len(ctls), 1)
    for j, c in enumerate(ctls):
        vals = [next((r["score"] for r in rows if r["suite"] == s and str(r["controller"]) == c), np.nan) for s in suites]
        ax.bar(np.arange(len(suites)) + j * w, vals, w, label=c)
    ax.set_xticks(np.arange(len(suites)) + 0.4 - w / 2, suites)
    ax.set_ylabel("combined score (lower is better)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path
