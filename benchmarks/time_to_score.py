"""How long PPO on the native learner takes to beat the inverse-model baseline and to reach the MPC.

For each recommended-version id and its headline suite, trains ``configs/fast_ppo.yaml`` (the
native learner, ``learner: native``) on that id and suite for each seed, under a wall-time budget,
evaluating on the suite's own episodes (its seed and count: the score ``cepam-gym bench`` gives) at a
fixed step interval; a run stops at the budget or once it scores below the MPC. Printed per id: the
baseline's and the MPC's score on the suite (the MPC measured
here, the baseline's stored reference re-measured), then the median and range over seeds of the
training time (evaluations excluded) at the first evaluation that beat each, the best score reached,
and the learner's env-steps per second beside the bare env's, stepped with random actions at the
same batch size in the same process right after training; then, per minute of training, the best
score reached so far (interquartile mean over the seeds: what PPO reaches per minute on 2 cores).
A seed that never beats a yardstick within the budget counts as the budget (shown as ``>budget``).

The load average is printed: another busy process slows both the learner and the env.

Run: ``.venv/bin/python benchmarks/time_to_score.py`` (options: ``--ids``, ``--seeds``, ``--config``
(another shipped config than ``fast_ppo``),
``--budget-s``, ``--eval-every``, ``--out`` for the run directories, ``--json`` to keep every
evaluation, ``--report`` to re-read kept files, ``--plot`` for the curves, ``--ray ADDRESS`` to
train the seeds as Ray tasks on a cluster, each asking for a whole node).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the agents package when run from a checkout

IDS = ("CEPAM-v2", "CEPAMLength-v2", "CEPAMStiffness-v2", "CEPAMJoint-v2")
# the wall-time budget per run: the goals are 30 s and 10 s on the nominal and length suites,
# 3 minutes on the stiffness and joint suites
BUDGET_S = {"CEPAM-v2": 60.0, "CEPAMLength-v2": 60.0, "CEPAMStiffness-v2": 180.0, "CEPAMJoint-v2": 180.0}


def suite_of(env_id: str):
    from cepam_gym.bench.suites import SUITES
    from cepam_gym.versions import VERSIONS

    return SUITES[VERSIONS[f"cepam_gym/{env_id}"].suites[0]]


def yardsticks(suite) -> dict[str, float]:
    """The baseline's and the MPC's scores on the suite's own episodes (a hinge id has no MPC: it
    plans through the rig's kernel only)."""
    from cepam_gym.bench.harness import run_suite
    from cepam_gym.versions import VERSIONS

    out = {}
    hinge = VERSIONS[suite.env_id].mechanism == "hinge"
    for name in ("baseline",) if hinge else ("baseline", "mpc"):
        t = time.perf_counter()
        out[name] = float(run_suite(name, suite)[0]["score"])
        print(f"  {name:8s} {out[name]:.4f}  ({time.perf_counter() - t:.0f} s)", flush=True)
    return out


def train_one(
    env_id: str,
    suite,
    seed: int,
    budget_s: float,
    every: int,
    out: Path,
    stop_below: float,
    config: str = "fast_ppo",
) -> list[dict]:
    """One run of the shipped ``config`` on ``env_id``, stopped at the budget or at the first
    evaluation scoring below ``stop_below`` (nothing is left to measure); its evaluations."""

    from stable_baselines3.common.callbacks import BaseCallback

    from cepam_gym_agents.train import train

    cfg = run_config(env_id, suite, seed, budget_s, every, config)
    run = out / env_id / f"seed{seed}"
    if run.exists():
        shutil.rmtree(run)
    log = run / "evaluations.json"

    class StopAtTarget(BaseCallback):
        """Ends the session once an evaluation scored below the target (read from the run's log)."""

        seen = 0.0

        def _on_step(self) -> bool:
            if not log.is_file() or log.stat().st_mtime == self.seen:
                return True
            self.seen = log.stat().st_mtime
            return min(e["score"] for e in json.loads(log.read_text())) >= stop_below

    train(cfg, run, callbacks=[StopAtTarget()], quiet=True)
    return json.loads(log.read_text())


def run_config(env_id: str, suite, seed: int, budget_s: float, every: int, config: str):
    """The shipped ``config`` on ``env_id`` and its suite, evaluated every ``every`` steps on the
    suite's own episodes, this seed and budget."""
    from cepam_gym_agents.config.files import EnvConfig, EvalConfig, load_config

    cfg = load_config(config)
    env = EnvConfig.parse({"id": f"cepam_gym/{env_id}", "num_envs": cfg.env.num_envs, "suite": suite.name})
    return cfg.replace(
        env=env,
        eval=EvalConfig(every, suite.episodes, suite.name, suite.seed),
        seed=seed,
        time_limit_minutes=budget_s / 60.0,
    )


def train_on_ray(
    env_id: str, suite, seeds: int, budget_s: float, every: int, out: Path, config: str, address
):
    """Every seed's run as a Ray task asking for a whole node's cores (a run's speed is what is
    measured: two on one node would halve it), on the Ray instance at ``address`` (None: a new one
    here); the runs' evaluations. A Ray run goes to its budget (no stop at the MPC)."""
    from cepam_gym_agents.config.files import dump_config
    from cepam_gym_agents.grid.trials import Trial, run_ray

    path = out / "configs" / f"{env_id}.yaml"
    path.parent.mkdir(parents=True, exist_ok=True)
    dump_config(run_config(env_id, suite, 0, budget_s, every, config), path)
    trials = [Trial(str(path), seed, out / env_id / f"seed{seed}") for seed in range(seeds)]
    for t in trials:  # a fresh run each time, as train_one's
        if t.run.exists():
            shutil.rmtree(t.run)
        t.run.parent.mkdir(parents=True, exist_ok=True)
    run_ray(trials, address, None)
    return [json.loads((t.run / "evaluations.json").read_text()) for t in trials]


def training_times(evals: list[dict]) -> list[tuple[float, float, int]]:
    """(training seconds, score, step) per evaluation: the wall time less every evaluation's own."""
    spent, rows = 0.0, []
    for e in evals:
        spent += e["eval_s"]
        rows.append((e["wall_s"] - spent, e["score"], e["step"]))
    return rows


def first_below(rows, target: float) -> float | None:
    return next((t for t, s, _ in rows if s < target), None)


def env_rate(env_id: str, num_envs: int, seconds: float = 3.0) -> float:
    """Env-steps per second of the bare vector env (random actions) at this batch size."""
    import gymnasium as gym

    venv = gym.make_vec(
        f"cepam_gym/{env_id}",
        num_envs=num_envs,
        vectorization_mode="vector_entry_point",
        autoreset_mode="same_step",
    )
    venv.reset(seed=0)
    rng = np.random.default_rng(0)
    a = rng.uniform(-1, 1, (num_envs, *venv.single_action_space.shape))
    for _ in range(20):
        venv.step(a)
    rates = []
    for _ in range(5):
        n, t = 0, time.perf_counter()
        while time.perf_counter() - t < seconds / 5:
            venv.step(a)
            n += num_envs
        rates.append(n / (time.perf_counter() - t))
    return float(np.median(rates))


def fmt(ts: list[float | None], budget: float) -> str:
    vals = [budget if t is None else t for t in ts]
    missed = sum(t is None for t in ts)
    med = np.median(vals)
    text = f">{budget:.0f}" if med >= budget and missed else f"{med:.0f}"
    return f"{text} s ({min(vals):.0f}-{max(vals):.0f}{', ' + str(missed) + ' missed' if missed else ''})"


def report(results: dict) -> str:
    """The markdown table of ``results`` (``{env id: {"suite", "budget_s", "yardsticks",
    "env_steps_per_s", "runs": [evaluations of each seed]}}``)."""
    lines = [
        "| id | suite | budget | baseline | MPC | time to beat the baseline | time to reach the MPC | "
        "best score, IQM (median, range) | learner steps/s | env steps/s |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for env_id, r in results.items():
        ys, budget = r["yardsticks"], r["budget_s"]
        rows = [training_times(evals) for evals in r["runs"]]
        beat = [first_below(x, ys["baseline"]) for x in rows]
        reach = [first_below(x, ys["mpc"]) if "mpc" in ys else None for x in rows]
        best = [min(sc for _, sc, _ in x) for x in rows]
        rates = [x[-1][2] / x[-1][0] for x in rows]
        iqm = "-"
        mpc_cell = f"{ys['mpc']:.4f}" if "mpc" in ys else "-"
        if len(best) >= 5:
            from cepam_gym.bench.stats import iqm_interval

            iqm = f"{iqm_interval({env_id: best})[env_id][0]:.4f}"
        lines.append(
            f"| {env_id} | {r['suite']} | {budget:.0f} s | {ys['baseline']:.4f} | {mpc_cell} | "
            f"{fmt(beat, budget)} | "
            f"{fmt(reach, budget) if 'mpc' in ys else '-'} | "
            f"{iqm} ({np.median(best):.4f}, {min(best):.4f}-{max(best):.4f}) | "
            f"{np.median(rates) / 1e3:.0f} k | {r['env_steps_per_s'] / 1e3:.0f} k |"
        )
    return "\n".join(lines)


def best_by(rows, seconds: float) -> float | None:
    """The best score a run had reached after ``seconds`` of training (None: not evaluated yet);
    a run stopped earlier (at the MPC) keeps its best."""
    seen = [sc for t, sc, _ in rows if t <= seconds]
    return min(seen) if seen else None


def per_minute(results: dict) -> str:
    """What PPO reaches per minute of training: per id, each full minute up to the budget, the
    best score so far over the seeds (interquartile mean with its 95 % stratified-bootstrap
    interval, Agarwal et al. 2021) beside the baseline's and the MPC's."""
    from cepam_gym.bench.stats import MIN_SEEDS, iqm_interval

    lines = [
        "| id | suite | after | best score so far, IQM (95 % CI) | seeds evaluated | baseline | MPC |",
        "|---|---|---|---|---|---|---|",
    ]
    for env_id, r in results.items():
        ys, rows = r["yardsticks"], [training_times(evals) for evals in r["runs"]]
        for minute in range(1, int(r["budget_s"] // 60) + 1):
            best = [b for b in (best_by(x, 60.0 * minute) for x in rows) if b is not None]
            if len(best) >= MIN_SEEDS:
                iqm, lo, hi = iqm_interval({env_id: best})[env_id]
                cell = f"{iqm:.4f} ({lo:.4f}-{hi:.4f})"
            else:
                cell = "-"
            mpc_cell = f"{ys['mpc']:.4f}" if "mpc" in ys else "-"
            lines.append(
                f"| {env_id} | {r['suite']} | {minute} min | {cell} | {len(best)} of {len(rows)} | "
                f"{ys['baseline']:.4f} | {mpc_cell} |"
            )
    return "\n".join(lines)


def plot(results: dict, path: Path) -> None:
    """Score against training seconds, each seed a line, the baseline and the MPC dashed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=(4.2 * len(results), 3.4), squeeze=False)
    for ax, (env_id, r) in zip(axes[0], results.items()):
        for evals in r["runs"]:
            rows = training_times(evals)
            ax.plot([t for t, _, _ in rows], [sc for _, sc, _ in rows], color="C0", alpha=0.6, lw=1)
        for name, style in (("baseline", "--"), ("mpc", ":")):
            if name in r["yardsticks"]:
                ax.axhline(r["yardsticks"][name], color="k", ls=style, lw=1, label=name)
        ax.set_yscale("log")
        ax.set_title(f"{env_id} ({r['suite']})", fontsize=9)
        ax.set_xlabel("training time [s] (evaluations excluded)")
        ax.legend(fontsize=8)
    axes[0][0].set_ylabel("score (lower is better)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None) -> None:
    import cepam_gym  # noqa: F401
    from cepam_gym_agents.config.files import load_config

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--ids", nargs="+", default=list(IDS))
    p.add_argument("--seeds", type=int, default=5)
    p.add_argument("--config", default="fast_ppo", help="the shipped training config (default fast_ppo)")
    p.add_argument("--budget-s", type=float, default=None, help="seconds per run (default: per id)")
    p.add_argument("--eval-every", type=int, default=200_000, help="env steps between evaluations")
    p.add_argument("--out", type=Path, default=None, help="run directories (default: a temporary one)")
    p.add_argument("--json", type=Path, default=None, help="write the results (every evaluation) here")
    p.add_argument("--report", type=Path, nargs="+", default=None, help="re-read --json files, train nothing")
    p.add_argument("--plot", type=Path, default=None, help="draw the curves into this image")
    p.add_argument(
        "--ray",
        metavar="ADDRESS",
        help="train the seeds as Ray tasks, one per node at a time: 'local' (a Ray instance here), "
        "'auto' (the running cluster) or the head's address; on a cluster --out must be on a "
        "filesystem every node sees",
    )
    a = p.parse_args(argv)
    if a.report:
        results = {}
        for f in a.report:
            results.update(json.loads(f.read_text()))
    else:
        results = measure(a, load_config(a.config).env.num_envs)
    print(f"\nevaluation every {a.eval_every} steps on the suite's episodes\n" if not a.report else "")
    print(report(results))
    print("\nthe best score by each minute of training:\n")
    print(per_minute(results))
    if a.plot:
        plot(results, a.plot)


def measure(a, num_envs: int) -> dict:
    out = a.out or Path(tempfile.mkdtemp(prefix="time_to_score_"))
    print(f"load average at start: {os.getloadavg()[0]:.2f}; runs in {out}", flush=True)
    results = {}
    for env_id in a.ids:
        suite = suite_of(env_id)
        print(f"{env_id} on {suite.name}:", flush=True)
        ys = yardsticks(suite)
        budget = a.budget_s or BUDGET_S[env_id]
        if a.ray:
            address = None if a.ray == "local" else a.ray
            runs = train_on_ray(env_id, suite, a.seeds, budget, a.eval_every, out, a.config, address)
        else:
            stop = ys.get("mpc", ys["baseline"])
            runs = [
                train_one(env_id, suite, s, budget, a.eval_every, out, stop, a.config) for s in range(a.seeds)
            ]
        for seed in range(a.seeds):
            rows = training_times(runs[seed])
            print(
                f"  seed {seed}: beats the baseline at {first_below(rows, ys['baseline'])} s, "
                f"best {min(sc for _, sc, _ in rows):.4f}, {rows[-1][2] / rows[-1][0] / 1e3:.0f} k steps/s",
                flush=True,
            )
        results[env_id] = {
            "config": a.config,
            "suite": suite.name,
            "budget_s": budget,
            "yardsticks": ys,
            "env_steps_per_s": env_rate(env_id, num_envs),
            "runs": runs,
        }
        if a.json:
            a.json.write_text(json.dumps(results, indent=1))
    print(f"load average at end: {os.getloadavg()[0]:.2f}")
    return results


if __name__ == "__main__":
    main()
