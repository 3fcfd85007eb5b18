"""Reference results of the recommended version: every learner on every recommended id, several
training seeds, in the manner of RL Zoo3's benchmark and Open RL Benchmark (Huang et al. 2024).

    python -m cepam_gym_agents.reference                   # train the grid, score it, write the results
    python -m cepam_gym_agents.reference --report-only     # score and report the runs already trained
    python -m cepam_gym_agents.reference --ray auto        # the same trials as Ray tasks on a cluster

A cell is a learner (a shipped config, :data:`LEARNERS`) on one id of the recommended version,
trained and scored on that id's first headline suite: the config with the env id, the suite, the
seed and the wall-time budget set here: the same for every learner (``--minutes``, 2 by default;
a student's round stops there too), or each config's own (``--minutes 0``). Every trial is one
``cepam-gym train`` command (:mod:`agents.grid.trials`): ``--jobs`` at a time on this machine, sharing its
cores, or as Ray tasks. A cell a learner cannot run is left out and said so (:data:`SKIPPED`).

Each run's final model is scored on the suite's own episodes and on ``--unseen-episodes`` of an
unseen seed, beside the baseline, the MPC and the oracle on the same episodes
(:mod:`agents.grid.report`); the baseline's and the oracle's scores are the stored references where
those were measured on the same episodes (the defaults: ``cepam-gym bench --update-references
[--unseen]``), so a grid does not re-run the oracle. Written to ``--docs``: the page
``reference.md`` (per cell the interquartile mean over seeds with its 95 % stratified-bootstrap
interval, Agarwal et al. 2021, and the grid's measured time) and, in ``reference/``,
``reference.json`` (every run: its config, seed, budget, wall time, env-steps, scores and evaluation
curve, with the package version, the commit and the machine) and one figure per id (the best score
so far against wall time and against env-steps). Trained runs are kept in ``--out``: a second call
trains only what is missing.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from cepam_gym import versions
from cepam_gym.bench.references import UNSEEN_EPISODES, UNSEEN_SEED
from cepam_gym.cli_errors import CommandParser

from .config.files import ConfigError, dump_config
from .grid.cells import LEARNERS, cell_config, cells, recommended_ids, run_dir, shown_command
from .grid.trials import RAY_HELP, run_trials


def trials(grid: list[tuple[str, str]], seeds: list[int], out: Path, minutes: float | None) -> list:
    """One :class:`agents.grid.trials.Trial` per cell and seed not yet trained (no ``summary.json``; what
    an interrupted run left is removed: a run trains its whole budget in one go); each cell's
    config is written to ``out/configs/``. ``ConfigError`` for a finished run of another budget
    (its cell would mix budgets)."""
    import shutil

    import yaml

    from .grid.trials import Trial

    configs = {cell: cell_config(*cell, minutes) for cell in grid}
    for (learner, env_id), cfg in configs.items():  # every finished run checked before any file is written
        for seed in seeds:
            run = run_dir(out, learner, env_id, seed)
            if (run / "summary.json").is_file():
                budget = yaml.safe_load((run / "config.yaml").read_text()).get("time_limit_minutes")
                if budget != cfg.time_limit_minutes:
                    raise ConfigError(
                        f"{run} was trained for {budget} min, this grid's {learner} runs for "
                        f"{cfg.time_limit_minutes} min: pass another --out (or the same --minutes)"
                    )
    (out / "configs").mkdir(parents=True, exist_ok=True)
    todo = []
    for (learner, env_id), cfg in configs.items():
        path = out / "configs" / f"{learner}-{versions.short_name(env_id)}.yaml"
        dump_config(cfg, path)
        for seed in seeds:
            run = run_dir(out, learner, env_id, seed)
            if (run / "summary.json").is_file():
                continue
            if run.exists():
                shutil.rmtree(run)
            run.parent.mkdir(parents=True, exist_ok=True)
            todo.append(Trial(str(path), seed, run))
    return todo


def record_training(out: Path, seconds: float, argv: list[str], how: str) -> None:
    """Add a training call's wall time to ``out/grid_time.json`` (a grid trained in several calls
    sums them) with its command and ``how`` its trainings ran."""
    import json

    from .session.provenance import write_json

    path = out / "grid_time.json"
    times = json.loads(path.read_text()) if path.is_file() else {"train": 0.0, "score": 0.0}
    times["train"] += seconds
    times["command"] = shown_command(argv)
    times["how"] = how
    write_json(path, times)


def _parser() -> CommandParser:
    ap = CommandParser(prog="python -m cepam_gym_agents.reference", description=__doc__.split("\n\n")[0])
    ap.add_argument("--learners", nargs="+", default=list(LEARNERS), choices=list(LEARNERS))
    ap.add_argument("--ids", nargs="+", default=None, help="ids of the recommended version (default: all)")
    ap.add_argument("--seeds", type=int, default=5, help="training seeds 0..N-1 (at least 5 for the IQM)")
    ap.add_argument(
        "--minutes",
        type=float,
        default=2.0,
        help="wall-time budget of every run [min] (0: each config's own)",
    )
    ap.add_argument("--jobs", type=int, default=2, help="trainings at a time (per machine with --ray)")
    ap.add_argument(
        "--ray",
        metavar="ADDRESS",
        help=RAY_HELP,
    )
    ap.add_argument("--unseen-seed", type=int, default=UNSEEN_SEED, help="the episodes no suite uses")
    ap.add_argument(
        "--unseen-episodes", type=int, default=UNSEEN_EPISODES, help="episodes of the unseen seed"
    )
    ap.add_argument(
        "--suite-episodes", type=int, default=None, help="episodes of the suite (default: its own)"
    )
    ap.add_argument("--out", default="runs/reference", help="run directories")
    ap.add_argument("--docs", default="docs/results", help="where the page (reference.md) and its files go")
    ap.add_argument("--report-only", action="store_true", help="score and report the runs already trained")
    return ap


def main(argv: list[str] | None = None) -> int:
    ap = _parser()
    args = ap.parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)
    if args.seeds < 1 or args.jobs < 1 or args.unseen_episodes < 1 or args.minutes < 0:
        ap.error("--seeds, --jobs and --unseen-episodes must be >= 1 and --minutes >= 0")
    if args.suite_episodes is not None and args.suite_episodes < 1:
        ap.error("--suite-episodes must be >= 1")
    known = {**{versions.short_name(i): i for i in recommended_ids()}, **{i: i for i in recommended_ids()}}
    for i in args.ids or ():
        if i not in known:
            ap.error(f"{i!r} is not an id of the recommended version; one of {', '.join(recommended_ids())}")
    ids = [known[i] for i in args.ids] if args.ids else recommended_ids()
    if args.ray is not None:
        import importlib.util

        from .grid.trials import NO_RAY

        if importlib.util.find_spec("ray") is None:
            ap.error(NO_RAY)
    os.environ.setdefault("MPLBACKEND", "Agg")
    out, seeds, grid = Path(args.out), list(range(args.seeds)), cells(args.learners, ids)
    if not args.report_only:
        try:
            todo = trials(grid, seeds, out, args.minutes or None)
        except ConfigError as e:
            ap.error(str(e))
        t = time.perf_counter()
        try:
            run_trials(todo, args.jobs, args.ray)
        except RuntimeError as e:  # a trial failed: its log says why
            ap.error(str(e))
        how = "as Ray tasks" if args.ray else f"{args.jobs} training{'s' * (args.jobs > 1)} at a time"
        record_training(out, time.perf_counter() - t, args.argv, how)
    from .grid.report import report

    return report(grid, seeds, out, Path(args.docs), args)


if __name__ == "__main__":
    raise SystemExit(main())
