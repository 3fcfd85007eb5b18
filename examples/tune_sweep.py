"""Small Ray Tune sweep over hyperparameters of our own SB3 trainer (agents/session/trainer.py).

    .venv/bin/python examples/tune_sweep.py --config quick --total-timesteps 100000 \
        --grid learning_rate=1e-4,3e-4 --grid gamma=0.97,0.98

Every trial trains ``cepam-gym train``'s config with the overridden ``hyperparameters`` keys (each
--grid value list is crossed with the others), in its own Tune trial directory, and reports the
trainer's final evaluation score (the benchmark score: lower is better). Needs the ``train`` and
``distributed`` extras. Add ``--address auto`` to spread the trials over a Ray cluster.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path


def parse_grid(items: list[str]) -> dict[str, list]:
    import yaml

    from cepam_gym_agents.config.files import parse_number  # YAML 1.1 reads "3e-4" as a string

    grid: dict[str, list] = {}
    for item in items:
        key, sep, values = item.partition("=")
        if not sep or not key or not values:
            raise SystemExit(
                f"--grid {item!r}: expected KEY=V1,V2,... (a key of the config's hyperparameters)"
            )
        try:
            grid[key] = [parse_number(yaml.safe_load(v)) for v in values.split(",")]
        except yaml.YAMLError:
            raise SystemExit(f"--grid {item!r}: values must be comma-separated scalars") from None
    return grid


def trainable(config: dict) -> None:
    """One trial: the base config with this trial's hyperparameters, trained and evaluated."""
    import json

    from ray import tune

    from cepam_gym_agents.config.files import TrainConfig, load_config
    from cepam_gym_agents.train import train

    base = load_config(config["base_config"]).to_dict()
    base["hyperparameters"] = {**base["hyperparameters"], **config["hyperparameters"]}
    base["total_timesteps"] = config["total_timesteps"]
    base["seed"] = config["seed"]
    base["time_limit_minutes"] = None  # the budget is total_timesteps, the same for every trial
    base["eval"] = {
        **base["eval"],
        "episodes": config["eval_episodes"],
        "every_steps": config["total_timesteps"],
    }
    cfg = TrainConfig.from_dict(base)  # ConfigError names a bad key or value
    run = Path(tune.get_context().get_trial_dir()) / "run"
    train(cfg, run, quiet=True)
    summary = json.loads((run / "summary.json").read_text())
    tune.report(
        {"score": summary["final_score"], "best_score": summary["best_score"], "steps": summary["steps"]}
    )


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument("--config", default="quick", help="base training config (name in configs/ or a path)")
    p.add_argument(
        "--grid",
        action="append",
        default=None,
        help="KEY=V1,V2 (scalars) over the config's hyperparameters (repeatable); "
        "default learning_rate=1e-4,3e-4",
    )
    p.add_argument("--total-timesteps", type=int, default=100_000, help="training steps per trial")
    p.add_argument("--eval-episodes", type=int, default=8)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--max-concurrent", type=int, default=None, help="default: one trial per CPU")
    p.add_argument(
        "--address", default=None, help="existing Ray cluster ('auto'); default: $RAY_ADDRESS or local"
    )
    p.add_argument("--out", default="runs/tune", help="Tune's storage directory")
    p.add_argument("--name", default="sweep")
    args = p.parse_args(argv)
    if args.total_timesteps < 1 or args.eval_episodes < 1:
        p.error("--total-timesteps and --eval-episodes must be >= 1")
    try:
        import ray
        from ray import tune
    except ImportError:
        raise SystemExit('Ray Tune is not installed: pip install "cepam-gym[distributed]"') from None

    from cepam_gym_agents.config.files import (  # installed with cepam-gym
        ConfigError,
        TrainConfig,
        load_config,
    )

    grid = parse_grid(args.grid or ["learning_rate=1e-4,3e-4"])
    try:  # fail before starting Ray if a key or value is bad
        base = load_config(args.config)
        for key, values in grid.items():
            for v in values:
                TrainConfig.from_dict({**base.to_dict(), "hyperparameters": {**base.hyperparameters, key: v}})
    except ConfigError as e:
        raise SystemExit(f"tune_sweep: {e}") from None

    address = args.address or os.environ.get("RAY_ADDRESS")
    # the trials import cepam_gym_agents and cepam_gym: on a cluster, install cepam-gym on every node
    if address:
        ray.init(address=address)
    else:
        ray.init(include_dashboard=False, log_to_driver=False)

    param_space = {
        "base_config": str(Path(args.config).resolve()) if Path(args.config).is_file() else args.config,
        "hyperparameters": {k: tune.grid_search(v) for k, v in grid.items()},
        "total_timesteps": args.total_timesteps,
        "seed": args.seed,
        "eval_episodes": args.eval_episodes,
    }
    tuner = tune.Tuner(
        tune.with_resources(trainable, {"cpu": 1}),
        param_space=param_space,
        tune_config=tune.TuneConfig(metric="score", mode="min", max_concurrent_trials=args.max_concurrent),
        run_config=tune.RunConfig(storage_path=str(Path(args.out).resolve()), name=args.name, verbose=0),
    )
    results = tuner.fit()
    rows = []
    for r in results:
        if r.error:
            print(f"trial {r.path}: FAILED: {r.error}")
            continue
        rows.append((r.metrics["score"], r.config["hyperparameters"]))
    for score, hp in sorted(rows, key=lambda t: t[0]):
        print(f"score {score:8.4f}  {hp}")
    best = results.get_best_result()
    print(f"best: score {best.metrics['score']:.4f} with {best.config['hyperparameters']} ({best.path})")
    ray.shutdown()
    return 0 if rows and len(rows) == len(results) else 1


if __name__ == "__main__":
    sys.exit(main())
