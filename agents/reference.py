"""Reference results of the recommended version: every learner on every recommended id, several
training seeds, in the manner of RL Zoo3's benchmark and Open RL Benchmark (Huang et al. 2024).

    python -m cepam_gym_agents.reference                   # train the grid, score it, write the results
    python -m cepam_gym_agents.reference --report-only     # score and report the runs already trained
    python -m cepam_gym_agents.reference --ray auto        # the same trials as Ray tasks on a cluster

A cell is a learner (a shipped config, :data:`LEARNERS`) on one id of the recommended version,
trained and scored on that id's first headline suite: the config with the env id, the suite, the
seed and the wall-time budget (the config's own, or ``--minutes``) set here. Every trial is one
``cepam-gym train`` command (:mod:`agents.grid`): ``--jobs`` at a time on this machine, sharing its
cores, or as Ray tasks. A cell a learner cannot run is left out and said so (:data:`SKIPPED`).

Each run's final model is scored on the suite's own episodes and on ``--unseen-episodes`` of an
unseen seed, beside the baseline, the MPC and the oracle on the same episodes
(:mod:`agents.reference_report`). Written to ``--docs``: ``reference.json`` (every run: its config,
seed, budget, wall time, env-steps, scores and evaluation curve, with the package version, the
commit and the machine), ``reference.md`` (per cell the interquartile mean over seeds with its 95 %
stratified-bootstrap interval, Agarwal et al. 2021) and one figure per id (the best score so far
against wall time and against env-steps). Trained runs are kept in ``--out``: a second call trains
only what is missing.
"""

from __future__ import annotations

import os
from pathlib import Path

from cepam_gym import versions
from cepam_gym.cli_errors import CommandParser

from .config import ConfigError, dump_config, load_config

# learner -> the shipped config it runs (configs/), all on the recommended id CEPAM-v3
LEARNERS = {
    "PPO": "fast_ppo_v3",
    "SAC": "fast_sac_v3",
    "TD3": "fast_td3_v3",
    "RecurrentPPO": "fast_recurrent_v3",
    "student": "student_mpc_v3",
}
# (learner, mechanism) -> why that cell is not run
SKIPPED = {
    ("student", "hinge"): "its teacher, the adaptive MPC, plans through the rig's kernel only",
}


def recommended_ids() -> list[str]:
    """The ids of the recommended version that have a benchmark suite."""
    version = versions.get(versions.RECOMMENDED_ID).version
    return [i for i in versions.ids(version=version) if versions.get(i).suites]


def suite_of(env_id: str) -> str:
    """The suite a cell trains and is scored on: the id's first headline suite."""
    return versions.get(env_id).suites[0]


def skipped(learner: str, env_id: str) -> str | None:
    return SKIPPED.get((learner, versions.get(env_id).mechanism))


def cell_config(learner: str, env_id: str, minutes: float | None):
    """The config of one cell: ``LEARNERS[learner]`` on ``env_id`` and its suite (the env, the
    periodic evaluation and a student's DAgger suites), its budget ``minutes`` (None: the config's)."""
    import dataclasses

    from .config_schema import EnvConfig, EvalConfig

    cfg = load_config(LEARNERS[learner])
    suite = suite_of(env_id)
    env = EnvConfig.parse({"id": env_id, "num_envs": cfg.env.num_envs, "suite": suite})
    ev = EvalConfig(cfg.eval.every_steps, cfg.eval.episodes, suite, cfg.eval.seed)
    changes = {"env": env, "eval": ev}
    if cfg.student is not None:  # the same number of DAgger envs per round, on this suite
        changes["student"] = dataclasses.replace(cfg.student, suites={suite: sum(cfg.student.suites.values())})
    if minutes is not None:
        changes["time_limit_minutes"] = float(minutes)
    return cfg.replace(**changes)


def cells(learners: list[str], ids: list[str]) -> list[tuple[str, str]]:
    """The (learner, id) pairs of the grid, without the skipped ones."""
    return [(a, i) for i in ids for a in learners if skipped(a, i) is None]


def run_dir(out: Path, learner: str, env_id: str, seed: int) -> Path:
    return out / learner / versions.short_name(env_id) / f"seed{seed}"


def trials(grid: list[tuple[str, str]], seeds: list[int], out: Path, minutes: float | None) -> list:
    """One :class:`agents.grid.Trial` per cell and seed not yet trained (no ``summary.json``); each
    cell's config is written once to ``out/configs/``."""
    from .grid import Trial

    (out / "configs").mkdir(parents=True, exist_ok=True)
    todo = []
    for learner, env_id in grid:
        path = out / "configs" / f"{learner}-{versions.short_name(env_id)}.yaml"
        dump_config(cell_config(learner, env_id, minutes), path)
        for seed in seeds:
            run = run_dir(out, learner, env_id, seed)
            if not (run / "summary.json").is_file():
                run.parent.mkdir(parents=True, exist_ok=True)
                todo.append(Trial(str(path), seed, run))
    return todo


def train_grid(todo: list, jobs: int, ray: str | None) -> None:
    from .grid import run_local, run_ray

    if ray is None:
        run_local(todo, jobs)
    else:
        run_ray(todo, None if ray == "local" else ray, max(1, (os.cpu_count() or 1) // max(jobs, 1)))


def _parser() -> CommandParser:
    ap = CommandParser(prog="python -m cepam_gym_agents.reference", description=__doc__.split("\n\n")[0])
    ap.add_argument("--learners", nargs="+", default=list(LEARNERS), choices=list(LEARNERS))
    ap.add_argument("--ids", nargs="+", default=None, help="ids of the recommended version (default: all)")
    ap.add_argument("--seeds", type=int, default=5, help="training seeds 0..N-1 (at least 5 for the IQM)")
    ap.add_argument("--minutes", type=float, default=None, help="wall-time budget per run (default: the config's)")
    ap.add_argument("--jobs", type=int, default=2, help="trainings at a time (per machine with --ray)")
    ap.add_argument(
        "--ray",
        metavar="ADDRESS",
        help="train as Ray tasks: 'local' (a Ray instance on this machine), 'auto' (the running cluster) "
        "or the head's address; on a cluster --out must be on a filesystem every node sees",
    )
    ap.add_argument("--unseen-seed", type=int, default=99000, help="the episodes no suite uses")
    ap.add_argument("--unseen-episodes", type=int, default=100, help="episodes of the unseen seed")
    ap.add_argument("--suite-episodes", type=int, default=None, help="episodes of the suite (default: its own)")
    ap.add_argument("--out", default="runs/reference", help="run directories")
    ap.add_argument("--docs", default="docs/results/reference", help="where the results go")
    ap.add_argument("--report-only", action="store_true", help="score and report the runs already trained")
    return ap


def main(argv: list[str] | None = None) -> int:
    ap = _parser()
    args = ap.parse_args(argv)
    if args.seeds < 1 or args.jobs < 1 or args.unseen_episodes < 1 or (args.minutes or 1) <= 0:
        ap.error("--seeds, --jobs and --unseen-episodes must be >= 1 and --minutes > 0")
    known = {**{versions.short_name(i): i for i in recommended_ids()}, **{i: i for i in recommended_ids()}}
    for i in args.ids or ():
        if i not in known:
            ap.error(f"{i!r} is not an id of the recommended version; one of {', '.join(recommended_ids())}")
    ids = [known[i] for i in args.ids] if args.ids else recommended_ids()
    if args.ray is not None:
        import importlib.util

        from .grid import NO_RAY

        if importlib.util.find_spec("ray") is None:
            ap.error(NO_RAY)
    os.environ.setdefault("MPLBACKEND", "Agg")
    out, seeds, grid = Path(args.out), list(range(args.seeds)), cells(args.learners, ids)
    try:
        todo = trials(grid, seeds, out, args.minutes)
    except ConfigError as e:
        ap.error(str(e))
    if not args.report_only:
        train_grid(todo, args.jobs, args.ray)
    from .reference_report import report

    return report(grid, seeds, out, Path(args.docs), args)


if __name__ == "__main__":
    raise SystemExit(main())
