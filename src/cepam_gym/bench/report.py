"""Tables and plots of benchmark results (matplotlib imported lazily, Agg backend)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

COLUMNS = (
    ("length_rmse_mm", "len RMSE mm"),
    ("angle_rmse_deg", "ang RMS deg"),
    ("stiffness_rmse_pct", "K RMSE %"),
    ("settling_time_s", "settle s"),
    ("overshoot_pct", "overshoot %"),
    ("cvar10_return", "CVaR10 ret"),
    ("failure_rate", "fail"),
    ("air_g_per_episode", "air g/ep"),
    ("score", "score"),
    ("headline", "headline"),
    ("normalized", "normalized"),
)
RELATIVE = ("headline", "normalized")  # shown when some row has them


def table(rows: list[dict]) -> str:
    # the tracking-error columns only when some row has them (rig suites: mm, joint suite: deg)
    cols = [
        (k, t)
        for k, t in COLUMNS
        if k not in ("length_rmse_mm", "angle_rmse_deg", *RELATIVE) or any(k in r for r in rows)
    ]
    head = (
        f"{'suite':27s} {'controller':14s}" + "".join(f"{t:>12s}" for _, t in cols) + f"{'score 95% CI':>18s}"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        cells = "".join(f"{'-':>12s}" if r.get(k) is None else f"{r[k]:12.3f}" for k, _ in cols)
        ci = r.get("score_ci95")  # over episodes (bench.metrics.score_interval)
        cells += f"{'-':>18s}" if ci is None else f"{f'{ci[0]:.3f}-{ci[1]:.3f}':>18s}"
        lines.append(f"{r['suite']:27s} {str(r['controller'])[:14]:14s}{cells}")
    if any(k in {c for c, _ in cols} for k in RELATIVE):
        from .headline import LEGEND

        lines.append(LEGEND)
    return "\n".join(lines)


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_traces(tr: dict, title: str, path: Path, episode: int = 0, spec=None) -> Path:
    """Episode ``episode`` of the traces; ``spec`` (a :class:`~cepam_gym.bench.metrics.TraceSpec`,
    default the rig's) names the columns and their units."""
    from .metrics import RIG

    spec = spec or RIG
    plt = _plt()
    t = np.arange(tr["length"].shape[0]) * tr["dt"]
    fig, ax = plt.subplots(4, 1, figsize=(8, 8), sharex=True)
    (qn, qu, qs), (kn, ku, ks), (ln, lu, ls) = spec.plot_quantity, spec.plot_stiffness, spec.plot_load
    ax[0].plot(t, qs * tr["length"][:, episode], label=qn)
    ax[0].plot(t, qs * tr["target_length"][:, episode], "--", label="target")
    ax[0].set_ylabel(f"{qn} [{qu}]")
    ax[1].plot(t, ks * tr["stiffness"][:, episode], label=kn)
    ax[1].plot(t, ks * tr["target_stiffness"][:, episode], "--", label="target")
    ax[1].set_ylabel(f"{kn} [{ku}]")
    ax[2].plot(t, tr["pressure_c"][:, episode] / 1e3, label="Pc (CPAM)")
    ax[2].plot(t, tr["pressure_e"][:, episode] / 1e3, label="Pe (annulus)")
    ax[2].set_ylabel("gauge [kPa]")
    ax[3].plot(t, ls * tr["load_mass"][:, episode])
    ax[3].set_ylabel(f"{ln} [{lu}]")
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
        vals = [
            next((r["score"] for r in rows if r["suite"] == s and str(r["controller"]) == c), np.nan)
            for s in suites
        ]
        ax.bar(np.arange(len(suites)) + j * w, vals, w, label=c)
    ax.set_xticks(np.arange(len(suites)) + 0.4 - w / 2, suites)
    ax.set_ylabel("combined score (lower is better)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path
