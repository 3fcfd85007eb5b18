"""Scoring and reporting the reference grid (:mod:`agents.reference`): every run's model on the
suite's episodes and on the unseen seed's, the controllers beside them on the same episodes, and
the results file, table and figures.

Scores are cached in ``<out>/reference_scores.json`` (a run or a controller on an episode set is
scored once); a run is scored as ``cepam-gym bench`` scores a run directory.
"""

from __future__ import annotations

import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

from cepam_gym import versions

from .provenance import git_state, machine, now, write_json

RESULTS_FORMAT = 1
# the model-based controllers beside the agents on the suite's episodes (the MPCs plan through the
# rig's kernel only); on the unseen seed's, those the headline needs
CONTROLLERS = {"rig": ("baseline", "mpc", "adaptive_mpc", "oracle"), "hinge": ("baseline", "oracle")}
UNSEEN_CONTROLLERS = ("baseline", "oracle")


def episode_sets(args) -> dict[str, tuple]:
    """``{set name: (seed, episodes)}``: the suite's own (seed None) and the unseen seed's."""
    return {"suite": (None, args.suite_episodes), "unseen": (args.unseen_seed, args.unseen_episodes)}


def _score(spec: str, suite: str, seed: int | None, episodes: int | None) -> float:
    import dataclasses

    from cepam_gym.bench.harness import run_suite
    from cepam_gym.bench.suites import SUITES

    s = SUITES[suite] if seed is None else dataclasses.replace(SUITES[suite], seed=seed)
    return float(run_suite(spec, s, episodes or s.episodes)[0]["score"])


class Scores:
    """The cache of scores, keyed ``suite|set|spec`` (spec: a controller or a run directory)."""

    def __init__(self, out: Path, sets: dict):
        self.path, self.sets = out / "reference_scores.json", sets
        self.cache = json.loads(self.path.read_text()) if self.path.is_file() else {}
        # scores over other episode counts never mix: the key holds the counts
        self.tag = ",".join(f"{k}:{s}:{n}" for k, (s, n) in sets.items())
        self.spent = 0.0  # seconds this object spent scoring

    def get(self, spec: str, suite: str, where: str, version: str = "") -> float:
        """``version``: what tells a run retrained in the same directory from the one scored."""
        key = f"{self.tag}|{suite}|{where}|{spec}{version}"
        if key not in self.cache:
            seed, episodes = self.sets[where]
            t = time.perf_counter()
            self.cache[key] = _score(spec, suite, seed, episodes)
            self.spent += time.perf_counter() - t
            write_json(self.path, self.cache)
        return self.cache[key]


def controllers_of(env_id: str, where: str) -> tuple:
    own = CONTROLLERS[versions.get(env_id).mechanism]
    return own if where == "suite" else tuple(c for c in own if c in UNSEEN_CONTROLLERS)


def curve(run: Path) -> list[list[float]]:
    """``[[wall_s, env_steps, score], ...]``: the run's periodic evaluations (a student's one,
    at its end)."""
    ev = json.loads((run / "evaluations.json").read_text()) if (run / "evaluations.json").is_file() else []
    end = json.loads((run / "summary.json").read_text())
    return [
        [float(e.get("wall_s", end["wall_s"])), int(e["step"]), float(e["score"])]
        for e in ev
        if e.get("score") is not None
    ]


def run_row(learner: str, env_id: str, seed: int, run: Path, scores: Scores) -> dict:
    """One run of the results file: what it ran, where, for how long, and its scores."""
    import yaml

    from .reference_grid import LEARNERS, suite_of

    summary = json.loads((run / "summary.json").read_text())
    record = json.loads((run / "run.json").read_text())
    cfg = yaml.safe_load((run / "config.yaml").read_text())
    suite = suite_of(env_id)
    return {
        "learner": learner,
        "config": LEARNERS[learner],
        "env_id": env_id,
        "suite": suite,
        "seed": seed,
        "budget_minutes": cfg.get("time_limit_minutes"),
        "wall_s": float(summary["wall_s"]),
        "env_steps": int(summary["steps"]),
        "scores": {
            where: scores.get(str(run), suite, where, f"|{summary['steps']}|{summary['wall_s']}")
            for where in scores.sets
        },
        "curve": curve(run),
        "cepam_gym": record["versions"].get("cepam-gym"),
        "commit": record["git"].get("commit"),
        "dirty": record["git"].get("dirty"),
        "machine": {k: record["versions"].get(k) for k in ("platform", "cpu_llvm", "torch_cpu_capability")},
        "resolved_config": cfg,
    }


def yardsticks(ids: list[str], scores: Scores) -> dict:
    """``{suite: {set: {controller: score}}}`` for the suite of every id in the grid."""
    from .reference_grid import suite_of

    return {
        suite_of(i): {
            w: {c: scores.get(c, suite_of(i), w) for c in controllers_of(i, w)} for w in scores.sets
        }
        for i in ids
    }


def headline(value: float, marks: dict) -> float | None:
    """The share of the baseline-to-oracle gap closed (None without an oracle)."""
    from cepam_gym.bench.headline import headline_score

    return headline_score(value, marks["baseline"], marks["oracle"]) if "oracle" in marks else None


def _cell(values: list[float]) -> tuple[float, str]:
    from cepam_gym.bench.stats import MIN_SEEDS, iqm_interval

    if len(values) >= MIN_SEEDS:
        iqm, lo, hi = iqm_interval({"x": values})["x"]
        return iqm, f"**{iqm:.4f}** ({lo:.4f}-{hi:.4f})"
    mean = float(np.mean(values))
    return mean, f"**{mean:.4f}** (mean, range {min(values):.4f}-{max(values):.4f}; under {MIN_SEEDS} seeds)"


def table(rows: list[dict], marks: dict, sets: dict) -> str:
    """Per id and learner: the score on each episode set (IQM over seeds, 95 % CI) and its headline,
    the median wall time and env-steps; the controllers' scores on the same episodes below."""
    lines = [
        "| id (suite) | learner | seeds | "
        + " | ".join(f"{w}: score (headline)" for w in sets)
        + " | wall s (median) | env-steps (median) |",
        "|---|---|---|" + "---|" * len(sets) + "---|---|",
    ]
    for env_id in dict.fromkeys(r["env_id"] for r in rows):
        mine = [r for r in rows if r["env_id"] == env_id]
        suite = mine[0]["suite"]
        name = f"{versions.short_name(env_id)} ({suite})"
        for learner in dict.fromkeys(r["learner"] for r in mine):
            runs = [r for r in mine if r["learner"] == learner]
            cells = []
            for w in sets:
                value, text = _cell([r["scores"][w] for r in runs])
                h = headline(value, marks[suite][w])
                cells.append(text + ("" if h is None else f" ({h:.1f})"))
            wall = np.median([r["wall_s"] for r in runs])
            steps = np.median([r["env_steps"] for r in runs])
            lines.append(
                f"| {name} | {learner} | {len(runs)} | "
                + " | ".join(cells)
                + f" | {wall:.0f} | {steps:.3g} |"
            )
        for c in marks[suite][next(iter(sets))]:
            cells = []
            for w in sets:
                v = marks[suite][w].get(c)
                h = None if v is None else headline(v, marks[suite][w])
                cells.append("-" if v is None else f"{v:.4f}" + ("" if h is None else f" ({h:.1f})"))
            lines.append(f"| {name} | *{c}* | - | " + " | ".join(cells) + " | - | - |")
    return "\n".join(lines) + "\n"


def best_so_far(runs: list[dict], column: int, grid: np.ndarray) -> np.ndarray:
    """The IQM over runs of the best evaluation score reached by each x of ``grid`` (wall seconds,
    column 0, or env-steps, column 1); NaN where a run had no evaluation yet."""
    from scipy.stats import trim_mean

    out = []
    for x in grid:
        vals = []
        for r in runs:
            seen = [p[2] for p in r["curve"] if p[column] <= x]
            vals.append(min(seen) if seen else np.nan)
        vals = np.array(vals)
        out.append(np.nan if np.isnan(vals).any() else float(trim_mean(vals, 0.25)))
    return np.array(out)


def plot(rows: list[dict], marks: dict, docs: Path) -> list[Path]:
    """One figure per id: the best score so far against wall time and against env-steps (IQM over
    seeds, the periodic evaluations' episodes), the baseline's and the MPC's suite scores as lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    for env_id in dict.fromkeys(r["env_id"] for r in rows):
        mine = [r for r in rows if r["env_id"] == env_id]
        fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
        for learner in dict.fromkeys(r["learner"] for r in mine):
            runs = [r for r in mine if r["learner"] == learner and r["curve"]]
            if not runs:
                continue
            for ax, column, scale in ((axes[0], 0, 1.0), (axes[1], 1, 1e-6)):
                end = max(p[column] for r in runs for p in r["curve"])
                grid = np.linspace(0.0, end, 200)
                ax.plot(grid * scale, best_so_far(runs, column, grid), label=f"{learner} ({len(runs)} seeds)")
        for c, style in (("baseline", "--"), ("mpc", ":")):
            if c in marks[mine[0]["suite"]]["suite"]:
                for ax in axes:
                    ax.axhline(marks[mine[0]["suite"]]["suite"][c], color="k", ls=style, lw=1, label=c)
        axes[0].set_xlabel("wall time [s]")
        axes[1].set_xlabel("env-steps [millions]")
        axes[1].set_xscale("symlog", linthresh=0.1)
        axes[0].set_ylabel("best score so far, IQM over seeds (lower is better)")
        for ax in axes:
            ax.set_yscale("log")
            ax.grid(alpha=0.3)
        axes[0].legend(fontsize=8)
        fig.suptitle(f"{versions.short_name(env_id)} ({mine[0]['suite']}): periodic evaluations")
        fig.tight_layout()
        path = docs / f"{versions.short_name(env_id)}.png"
        fig.savefig(path, dpi=100)
        plt.close(fig)
        paths.append(path)
    return paths


PAGE = """# Reference results

Every learner on every id of the recommended version, {seeds} training seeds each, a wall-time
budget of {budgets} per run (a student stops at the first DAgger round past it), {jobs}
regenerated by one command ({grid_time}):

```text
{command}
```

Each run is scored on its suite's episodes and on {unseen} episodes of an unseen seed (seed
{unseen_seed}); a learner's cell is the interquartile mean over its seeds with a 95 %
stratified-bootstrap interval (Agarwal et al. 2021), its headline in brackets (the share of the
baseline-to-oracle gap closed on the same episodes). The controllers' rows are their scores on
the same episodes; the MPCs run on the suite's episodes only. Lower scores are better. A
student's env-steps are its teacher's labels. What every run did (its
config, seed, budget, env-steps, scores, evaluation curve, package version, commit and machine):
[`reference/reference.json`](reference/reference.json). Measured with cepam-gym {version} at
commit {commit} on {machine}.

{table}
The best score so far (the periodic evaluations' episodes; interquartile mean over seeds) against
wall time and against env-steps, the baseline's and the MPC's suite scores as lines:

{figures}
"""


def page(rows: list[dict], table_md: str, figures: list[Path], meta: dict) -> str:
    """The results page (``reference.md``) around the table and the figures."""
    from .reference_grid import SKIPPED

    commits = sorted({(r["commit"] or "unknown")[:7] + ("+dirty" if r["dirty"] else "") for r in rows})
    t = meta["seconds"]
    skipped = "; ".join(f"{a} is not run on the {m} ({why})" for (a, m), why in SKIPPED.items())
    return PAGE.format(
        seeds=max(len({r["seed"] for r in rows if r["learner"] == a}) for a in {r["learner"] for r in rows}),
        grid_time=f"the trainings took {t['train'] / 60:.0f} minutes, the scoring {t['score'] / 60:.0f}"
        if t["train"]
        else "the trainings' time not recorded",
        command=meta["command"],
        budgets=" or ".join(sorted({_minutes(r["budget_minutes"]) for r in rows})),
        jobs=meta["jobs"],
        unseen=meta["unseen_episodes"],
        unseen_seed=meta["unseen_seed"],
        version=rows[0]["cepam_gym"],
        commit=", ".join(commits),
        machine=meta["machine"],
        table=table_md + f"\n{skipped}.\n",
        figures="\n".join(f"![{p.stem}](reference/{p.name})" for p in figures),
    )


def report(grid: list[tuple[str, str]], seeds: list[int], out: Path, docs: Path, args) -> int:
    """Score every finished run of ``grid``; write ``docs/reference.md`` (the page) and, in
    ``docs/reference/``, ``reference.json`` and the figures; 1 (said why) when no run of the grid
    has finished."""
    from cepam_gym.progress import runs as bar

    from .reference_grid import SKIPPED, run_dir

    scores = Scores(out, episode_sets(args))
    done = [(a, i, s) for a, i in grid for s in seeds if (run_dir(out, a, i, s) / "summary.json").is_file()]
    if not done:
        print(f"no finished run of the grid under {out}", file=sys.stderr)
        return 1
    ids = list(dict.fromkeys(i for _, i, _ in done))
    with bar(len(done) * len(scores.sets), "reference: scoring"):
        rows = [run_row(a, i, s, run_dir(out, a, i, s), scores) for a, i, s in done]
        marks = yardsticks(ids, scores)
    meta = _meta(out, args, scores.spent)
    files = docs / "reference"
    files.mkdir(parents=True, exist_ok=True)
    write_json(
        files / "reference.json",
        {
            "format": RESULTS_FORMAT,
            "written": now(),
            "git": git_state(),
            **meta,
            "episode_sets": {w: {"seed": s, "episodes": n} for w, (s, n) in scores.sets.items()},
            "skipped": [{"learner": a, "mechanism": m, "why": why} for (a, m), why in SKIPPED.items()],
            "controllers": marks,
            "runs": rows,
        },
    )
    md = table(rows, marks, scores.sets)
    figures = plot(rows, marks, files)
    (docs / "reference.md").write_text(page(rows, md, figures, meta))
    print(md)
    print(f"wrote {docs}/reference.md, {files}/reference.json and {len(figures)} figures")
    return 0


def _meta(out: Path, args, scoring_s: float) -> dict:
    """The grid's command, its measured times (``out/grid_time.json``: the trainings' wall time,
    written by the call that trained, and the scoring's, summed over the calls that scored) and
    the machine."""
    from .reference_grid import shown_command

    path = out / "grid_time.json"
    seconds = json.loads(path.read_text()) if path.is_file() else {"train": 0.0, "score": 0.0}
    seconds["score"] += scoring_s
    write_json(path, seconds)
    jobs = args.jobs if args.ray is None else None
    return {
        "command": seconds.get("command") or shown_command(args.argv),
        "jobs": "as Ray tasks," if jobs is None else f"{jobs} training{'s' if jobs > 1 else ''} at a time,",
        "seconds": {k: v for k, v in seconds.items() if k != "command"},
        "unseen_seed": args.unseen_seed,
        "unseen_episodes": args.unseen_episodes,
        "machine": f"{platform.platform()}, {_cpus()} cores",
        "machine_details": {"platform": platform.platform(), "cpus": _cpus(), **machine()},
    }


def _minutes(value) -> str:
    return "its config's own" if value is None else f"{float(value):g} min"


def _cpus() -> int:
    import os

    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
