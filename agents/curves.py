"""Reference learning curves for RL researchers, in the manner of RL Zoo3's benchmark: each
algorithm from scratch (the policy drives the valves, no baseline in the loop) on each v1 id,
several seeds, a wall-time budget per run.

    python -m cepam_gym_agents.curves --minutes 3 --jobs 2        # train every run, then report
    python -m cepam_gym_agents.curves --report-only                # re-read the runs, report

Each run is the shipped config ``v1_<algorithm>`` (``configs/``) with the env id, the suite whose
plant, loads and references it trains on (``env.suite``, also ``eval.suite``) and the seed set
here; it trains with ``cepam-gym train`` in its own process, on one core (``--jobs 2`` runs two at
a time, each pinned to a core with ``taskset`` where it exists). Written to ``--docs``:

* ``curves.csv``: every periodic evaluation (16 episodes, seed 12345, never the suite's own
  episodes): algorithm, env id, seed, env steps, wall seconds, score, normalized score;
* ``<id>.png``: normalized score against env steps and against wall time, mean over seeds with
  the min-max band (the raw score for the joint, which has no oracle and so no normalized score);
* ``table.md``: the best model of each run scored on the suite itself (its seeds, 20 episodes),
  mean and standard deviation over seeds, raw and normalized (0 = zero controller, 100 = oracle,
  the suite's stored reference scores), beside the baseline's and the MPC's on the same suite.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from cepam_gym import versions
from cepam_gym.cli_errors import CommandParser

from .config.files import ConfigError, dump_config, load_config

# the version the study's configs (v1_*) were tuned and its curves measured on
STUDY_VERSION = 1
# each id of that version and the suite it is trained and scored on: its first headline suite
SUITE_OF = {env_id: versions.get(env_id).suites[0] for env_id in versions.ids(version=STUDY_VERSION)}
CONFIG_OF = {"PPO": "v1_ppo", "SAC": "v1_sac", "TD3": "v1_td3", "RecurrentPPO": "v1_recurrentppo"}
# scored beside the agents in table.md (the MPC plans through the rig's kernel only)
MODEL_CONTROLLERS = {"joint-v1": ("baseline",)}
RIG_CONTROLLERS = ("baseline", "mpc")


def run_config(algorithm: str, env_id: str, seed: int, minutes: float):
    """The config of one run: ``v1_<algorithm>`` on ``env_id`` and its suite, this seed and budget."""
    from .config.files import EnvConfig, EvalConfig

    if algorithm not in CONFIG_OF:
        raise ConfigError(f"unknown algorithm {algorithm!r}; choose from {list(CONFIG_OF)}")
    if env_id not in SUITE_OF:
        raise ConfigError(f"unknown env id {env_id!r}; choose from {list(SUITE_OF)}")
    import yaml

    from .config.files import resolve_config_path

    cfg = load_config(CONFIG_OF[algorithm])
    suite = SUITE_OF[env_id]
    # the config's own env kwargs (its resolved ones also hold its default suite's), over this suite's
    raw = yaml.safe_load(resolve_config_path(CONFIG_OF[algorithm]).read_text())
    own = (raw.get("env") or {}).get("kwargs") or {}
    env = EnvConfig.parse({"id": env_id, "num_envs": cfg.env.num_envs, "suite": suite, "kwargs": own})
    ev = EvalConfig(cfg.eval.every_steps, cfg.eval.episodes, suite, cfg.eval.seed)
    return cfg.replace(env=env, eval=ev, seed=int(seed), time_limit_minutes=float(minutes))


def run_dir(out: Path, algorithm: str, env_id: str, seed: int) -> Path:
    return out / algorithm / versions.short_name(env_id) / f"seed{seed}"


def train_all(runs: list[tuple], out: Path, minutes: float, jobs: int) -> None:
    """Train ``runs`` [(algorithm, env id, seed)], ``jobs`` at a time, one core each."""
    pending = list(runs)
    active: list[tuple[subprocess.Popen, int, Path]] = []
    cores = list(range(max(1, jobs)))
    taskset = shutil.which("taskset")
    while pending or active:
        while pending and len(active) < jobs:
            algo, env_id, seed = pending.pop(0)
            d = run_dir(out, algo, env_id, seed)
            if (d / "summary.json").is_file():
                print(f"skip {d} (done)", flush=True)
                continue
            if d.exists():
                shutil.rmtree(d)
            d.parent.mkdir(parents=True, exist_ok=True)
            cfg_path = d.parent / f"seed{seed}.yaml"
            dump_config(run_config(algo, env_id, seed, minutes), cfg_path)
            core = [c for c in cores if c not in {a[1] for a in active}][0]
            cmd = [sys.executable, "-m", "cepam_gym_agents.train", "--config", str(cfg_path)]
            cmd += ["--out", str(d), "--quiet"]
            if taskset:
                cmd = [taskset, "-c", str(core), *cmd]
            log = open(d.parent / f"seed{seed}.log", "w")
            print(f"train {algo} {env_id} seed {seed} on core {core} -> {d}", flush=True)
            active.append((subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT), core, d))
        time.sleep(2.0)
        for job in list(active):
            code = job[0].poll()
            if code is not None:
                active.remove(job)
                print(f"{'done' if code == 0 else f'FAILED (exit {code})'}: {job[2]}", flush=True)


# --------------------------------------------------------------------------- the report
def eval_references(out: Path, suite: str, episodes: int, seed: int) -> tuple[float, float]:
    """The zero controller's and the oracle's scores on the periodic evaluation's own episodes
    (``episodes`` from ``seed`` on the suite's env): the ends its scores are normalized between.
    The suite's stored references are measured on other episodes (its own seed and count), so
    they cannot normalize these. Measured once, cached in ``out/eval_references.json``."""
    import dataclasses

    from cepam_gym.bench.harness import run_suite
    from cepam_gym.bench.suites import SUITES

    path = out / "eval_references.json"
    cache = json.loads(path.read_text()) if path.is_file() else {}
    key = f"{suite}|{episodes}|{seed}"
    if key not in cache:
        s = dataclasses.replace(SUITES[suite], seed=seed)
        cache[key] = [float(run_suite(name, s, episodes)[0]["score"]) for name in ("zero", "oracle")]
        path.write_text(json.dumps(cache, indent=1))
    return tuple(cache[key])


def read_curves(out: Path) -> list[dict]:
    """Every periodic evaluation of every run under ``out``, normalized between the zero
    controller and the oracle on the same episodes (:func:`eval_references`; None for a suite
    without an oracle: the MuJoCo joint)."""
    import yaml

    from cepam_gym.bench.metrics import normalized_score
    from cepam_gym.bench.suites import REFERENCE_SCORES

    rows = []
    for algo in CONFIG_OF:
        for env_id, suite in SUITE_OF.items():
            for d in sorted((out / algo / versions.short_name(env_id)).glob("seed*")):
                ev = d / "evaluations.json"
                if not d.is_dir() or not ev.is_file():
                    continue
                ends = None
                if suite in REFERENCE_SCORES:
                    cfg = yaml.safe_load((d / "config.yaml").read_text())["eval"]
                    ends = eval_references(out, suite, int(cfg["episodes"]), int(cfg["seed"]))
                for e in json.loads(ev.read_text()):
                    rows.append(
                        {
                            "algorithm": algo,
                            "env_id": env_id,
                            "seed": int(d.name[4:]),
                            "steps": int(e["step"]),
                            "wall_s": float(e["wall_s"]),
                            "score": float(e["score"]),
                            "normalized": None if ends is None else normalized_score(e["score"], *ends),
                        }
                    )
    return rows


def write_csv(rows: list[dict], path: Path) -> None:
    cols = ["algorithm", "env_id", "seed", "steps", "wall_s", "score", "normalized"]
    lines = [",".join(cols)]
    for r in rows:
        lines.append(
            ",".join(
                f"{r[c]:.4f}" if isinstance(r[c], float) else ("" if r[c] is None else str(r[c]))
                for c in cols
            )
        )
    path.write_text("\n".join(lines) + "\n")


def _band(xs: list[np.ndarray], ys: list[np.ndarray], grid: np.ndarray):
    """Mean, min and max over seeds of curves interpolated on ``grid``, from the latest first
    evaluation to the shortest run's end (no extrapolation)."""
    start, end = max(x[0] for x in xs), min(x[-1] for x in xs)
    g = grid[(grid >= start) & (grid <= end)]
    if len(g) == 0:
        return g, g, g, g
    vals = np.array([np.interp(g, x, y) for x, y in zip(xs, ys)])
    return g, vals.mean(0), vals.min(0), vals.max(0)


def plot_curves(rows: list[dict], docs: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    for env_id in SUITE_OF:
        mine = [r for r in rows if r["env_id"] == env_id]
        if not mine:
            continue
        key_y = "normalized" if mine[0]["normalized"] is not None else "score"
        fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
        for algo in CONFIG_OF:
            runs = {}
            for r in mine:
                if r["algorithm"] == algo:
                    runs.setdefault(r["seed"], []).append(r)
            if not runs:
                continue
            for ax, key, scale in ((axes[0], "steps", 1e-6), (axes[1], "wall_s", 1 / 60)):
                xs = [np.array([r[key] for r in v]) * scale for v in runs.values()]
                ys = [np.array([r[key_y] for r in v]) for v in runs.values()]
                grid = np.linspace(0.0, max(x[-1] for x in xs), 400)
                g, mean, lo, hi = _band(xs, ys, grid)
                (line,) = ax.plot(g, mean, label=f"{algo} ({len(runs)} seeds)")
                ax.fill_between(g, lo, hi, color=line.get_color(), alpha=0.2)
        axes[0].set_xscale("log")  # off-policy runs take 20-50 times fewer steps in the same time
        axes[0].set_xlabel("env steps [millions, log scale]")
        axes[1].set_xlabel("wall time [min] (one core per run)")
        if key_y == "normalized":
            axes[0].set_ylabel("normalized score (0 zero controller, 100 oracle)")
        else:
            axes[0].set_ylabel("score (lower is better; no oracle yet)")
        for ax in axes:
            ax.grid(alpha=0.3)
            if key_y == "normalized":
                ax.set_ylim(-50, 110)
            else:
                ax.set_yscale("log")
        axes[0].legend(loc="lower right")
        fig.suptitle(f"{env_id} (trained and scored on {SUITE_OF[env_id]}): mean and min-max over seeds")
        fig.tight_layout()
        p = docs / f"{versions.short_name(env_id)}.png"
        fig.savefig(p, dpi=110)
        plt.close(fig)
        paths.append(p)
    return paths


def final_scores(out: Path, episodes: int | None) -> list[dict]:
    """The best model of every finished run, scored on its suite (the suite's seeds)."""
    from cepam_gym.bench.harness import run_suite

    rows = []
    for algo in CONFIG_OF:
        for env_id, suite in SUITE_OF.items():
            for d in sorted((out / algo / versions.short_name(env_id)).glob("seed*")):
                if not (d / "summary.json").is_file():
                    continue
                summary = json.loads((d / "summary.json").read_text())
                m, _ = run_suite(str(d), suite, episodes=episodes)
                rows.append(
                    {
                        "algorithm": algo,
                        "env_id": env_id,
                        "suite": suite,
                        "seed": int(d.name[4:]),
                        "score": m["score"],
                        "steps": summary["steps"],
                        "wall_s": summary["wall_s"],
                    }
                )
    return rows


def table_markdown(finals: list[dict], episodes: int | None) -> str:
    from cepam_gym.bench.harness import run_suite
    from cepam_gym.bench.metrics import normalized_score
    from cepam_gym.bench.suites import REFERENCE_SCORES, SUITES

    lines = [
        "| algo | env id (suite) | seeds | normalized (mean +- sd) | score (mean +- sd) | n_timesteps "
        "| wall min | eval episodes |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for env_id, suite in SUITE_OF.items():
        ends = REFERENCE_SCORES.get(suite)

        def norm(v, ends=ends):
            return float("nan") if ends is None else normalized_score(v, *ends)

        n_eval = episodes or SUITES[suite].episodes
        for algo in CONFIG_OF:
            mine = [r for r in finals if r["env_id"] == env_id and r["algorithm"] == algo]
            if not mine:
                continue
            s = np.array([r["score"] for r in mine])
            n = np.array([norm(v) for v in s])
            steps = np.mean([r["steps"] for r in mine])
            wall = np.mean([r["wall_s"] for r in mine]) / 60
            lines.append(
                f"| {algo} | {versions.short_name(env_id)} ({suite}) | {len(mine)} | "
                f"{'-' if ends is None else f'**{n.mean():.1f}** +- {n.std():.1f}'} | "
                f"{s.mean():.3f} +- {s.std():.3f} | "
                f"{steps / 1e6:.2f} M | {wall:.1f} | {n_eval} |"
            )
        if any(r["env_id"] == env_id for r in finals):
            for c in MODEL_CONTROLLERS.get(suite, RIG_CONTROLLERS):
                m, _ = run_suite(c, suite, episodes=episodes)
                nc = "-" if ends is None else f"{norm(m['score']):.1f}"
                lines.append(
                    f"| *{c}* | {versions.short_name(env_id)} ({suite}) | - | {nc} | {m['score']:.3f} "
                    f"| - | - | {n_eval} |"
                )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = CommandParser(prog="python -m cepam_gym_agents.curves", description=__doc__.split("\n\n")[0])
    ap.add_argument("--algos", nargs="+", default=list(CONFIG_OF), choices=list(CONFIG_OF))
    ap.add_argument("--ids", nargs="+", default=list(SUITE_OF), choices=list(SUITE_OF))
    ap.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    ap.add_argument("--minutes", type=float, default=3.0, help="wall-time budget per run [min]")
    ap.add_argument("--jobs", type=int, default=2, help="runs at a time (one core each)")
    ap.add_argument("--out", default="runs/curves", help="run directories")
    ap.add_argument("--docs", default="docs/learning_curves", help="where the CSV, PNGs and table go")
    ap.add_argument("--episodes", type=int, default=None, help="episodes of the final scoring")
    ap.add_argument("--report-only", action="store_true", help="do not train; report the runs in --out")
    args = ap.parse_args(argv)
    if args.minutes <= 0 or args.jobs < 1 or any(s < 0 for s in args.seeds):
        ap.error("--minutes must be > 0, --jobs >= 1 and the seeds >= 0")
    out, docs = Path(args.out), Path(args.docs)
    os.environ.setdefault("MPLBACKEND", "Agg")
    if not args.report_only:
        runs = [(a, i, s) for i in args.ids for a in args.algos for s in args.seeds]
        train_all(runs, out, args.minutes, args.jobs)
    docs.mkdir(parents=True, exist_ok=True)
    rows = read_curves(out)
    if not rows:
        print(f"no evaluations under {out}", file=sys.stderr)
        return 1
    write_csv(rows, docs / "curves.csv")
    for p in plot_curves(rows, docs):
        print(f"wrote {p}")
    table = table_markdown(final_scores(out, args.episodes), args.episodes)
    (docs / "table.md").write_text(table)
    print(table)
    print(f"wrote {docs}/curves.csv and table.md")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
