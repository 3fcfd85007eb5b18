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

from ..session.provenance import git_state, machine, now, write_json

RESULTS_FORMAT = 1
# the model-based controllers beside the agents on the suite's episodes (the MPCs plan through the
# rig's kernel only); on the unseen seed's, those the headline needs. The joint's oracle is left
# out: scoring it took more than ten minutes of the grid's scoring where every other score took
# seconds, so the joint's cells are raw scores beside its baseline.
CONTROLLERS = {"rig": ("baseline", "mpc", "adaptive_mpc", "oracle"), "hinge": ("baseline",)}
UNSEEN_CONTROLLERS = ("baseline", "oracle")


def episode_sets(args) -> dict[str, tuple]:
    """``{set name: (seed, episodes)}``: the suite's own (seed None) and the unseen seed's."""
    return {"suite": (None, args.suite_episodes), "unseen": (args.unseen_seed, args.unseen_episodes)}


def _score(spec: str, suite: str, seed: int | None, episodes: int | None) -> float:
    from cepam_gym.bench.harness import run_suite, seeded

    s = seeded(suite, seed)
    return float(run_suite(spec, s, episodes or s.episodes)[0]["score"])


def stored(spec: str, suite: str, seed: int | None, episodes: int | None) -> float | None:
    """The stored reference score of controller ``spec`` (the zero controller, the baseline or the
    oracle) on these episodes (:mod:`cepam_gym.bench.references`: the suite's own and the unseen
    seed's), else None: those are measured once per release, and the oracle's are most of what
    scoring a grid would cost."""
    from cepam_gym.bench.harness import seeded
    from cepam_gym.bench.references import stored_entry

    if spec not in ("zero", "baseline", "oracle"):
        return None
    s = seeded(suite, seed)
    entry = stored_entry(suite, episodes or s.episodes, s.seed)
    return None if entry is None else float(entry[spec])


class Scores:
    """The cache of scores, keyed ``suite|set|spec`` (spec: a controller or a run directory)."""

    def __init__(self, out: Path, sets: dict):
        self.path, self.sets = out / "reference_scores.json", sets
        self.cache = json.loads(self.path.read_text()) if self.path.is_file() else {}
        # scores over other episode counts never mix: the key holds the counts
        self.tag = ",".join(f"{k}:{s}:{n}" for k, (s, n) in sets.items())
        self.spent = 0.0  # seconds this object spent scoring

    def key(self, spec: str, suite: str, where: str, version: str = "") -> str:
        return f"{self.tag}|{suite}|{where}|{spec}{version}"

    def fill(self, requests: list[tuple], jobs: int) -> None:
        """Score the ``(spec, suite, set, version)`` requests not in the cache, ``jobs`` processes
        at a time (each on its share of the cores: the env's kernel threads and the policy's)."""
        todo = [
            r for r in dict.fromkeys(requests) if self.key(*r) not in self.cache and self._stored(*r) is None
        ]
        if jobs < 2 or len(todo) < 2:
            return
        import multiprocessing
        import os
        from concurrent.futures import ProcessPoolExecutor, as_completed

        from .trials import thread_env

        print(f"reference: scoring {len(todo)} runs and controllers, {jobs} processes at a time", flush=True)
        saved, t = dict(os.environ), time.perf_counter()
        os.environ.update(thread_env((os.cpu_count() or 1) // jobs))  # what the spawned workers start with
        try:
            with ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
                futures = {pool.submit(_score, r[0], r[1], *self.sets[r[2]]): r for r in todo}
                for future in as_completed(futures):  # each score kept as it comes
                    self.cache[self.key(*futures[future])] = future.result()
                    write_json(self.path, self.cache)
        finally:
            os.environ.clear()
            os.environ.update(saved)
        self.spent += time.perf_counter() - t

    def _stored(self, spec: str, suite: str, where: str, version: str = "") -> float | None:
        return stored(spec, suite, *self.sets[where])

    def get(self, spec: str, suite: str, where: str, version: str = "") -> float:
        """``version``: what tells a run retrained in the same directory from the one scored."""
        if (value := self._stored(spec, suite, where, version)) is not None:
            return value
        key = self.key(spec, suite, where, version)
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

    from .cells import LEARNERS, suite_of

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
    from .cells import suite_of

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


def report(grid: list[tuple[str, str]], seeds: list[int], out: Path, docs: Path, args) -> int:
    """Score every finished run of ``grid``; write ``docs/reference.md`` (the page) and, in
    ``docs/reference/``, ``reference.json`` and the figures; 1 (said why) when no run of the grid
    has finished."""
    from cepam_gym.progress import runs as bar

    from .cells import SKIPPED, run_dir
    from .page import page, plot

    scores = Scores(out, episode_sets(args))
    done = [(a, i, s) for a, i in grid for s in seeds if (run_dir(out, a, i, s) / "summary.json").is_file()]
    if not done:
        print(f"no finished run of the grid under {out}", file=sys.stderr)
        return 1
    ids = list(dict.fromkeys(i for _, i, _ in done))
    scores.fill(_requests(done, ids, scores, out), max(1, args.jobs))
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


def _requests(done: list[tuple], ids: list[str], scores: Scores, out: Path) -> list[tuple]:
    """Every score the report reads: each finished run's and each controller's, on each set."""
    from .cells import run_dir, suite_of

    out_ = []
    for a, i, s in done:
        run = run_dir(out, a, i, s)
        summary = json.loads((run / "summary.json").read_text())
        version = f"|{summary['steps']}|{summary['wall_s']}"
        out_ += [(str(run), suite_of(i), w, version) for w in scores.sets]
    for i in ids:
        out_ += [(c, suite_of(i), w, "") for w in scores.sets for c in controllers_of(i, w)]
    return out_


def _meta(out: Path, args, scoring_s: float) -> dict:
    """The grid's command, its measured times (``out/grid_time.json``: the trainings' wall time,
    written by the call that trained, and the scoring's, summed over the calls that scored) and
    the machine."""
    from .cells import shown_command

    path = out / "grid_time.json"
    seconds = json.loads(path.read_text()) if path.is_file() else {"train": 0.0, "score": 0.0}
    seconds["score"] += scoring_s
    write_json(path, seconds)
    return {
        "command": seconds.get("command") or shown_command(args.argv),
        "jobs": (seconds.get("how") or "how the trainings ran not recorded") + ",",
        "seconds": {k: seconds.get(k, 0.0) for k in ("train", "score")},
        "unseen_seed": args.unseen_seed,
        "unseen_episodes": args.unseen_episodes,
        "machine": f"{platform.platform()}, {_cpus()} cores",
        "machine_details": {"platform": platform.platform(), "cpus": _cpus(), **machine()},
    }


def _cpus() -> int:
    import os

    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
