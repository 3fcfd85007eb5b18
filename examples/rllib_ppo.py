"""PPO with Ray RLlib on a CE-PAM env: several env runners on local Ray or on an existing cluster.

    .venv/bin/python examples/rllib_ppo.py --iterations 20                  # local Ray, 2 env runners
    .venv/bin/python examples/rllib_ppo.py --suite randomized --iterations 50
    .venv/bin/python examples/rllib_ppo.py --address auto --num-env-runners 16  # after `ray start --head`

Each iteration samples --train-batch env steps (split over the runners), runs --epochs of SGD on
minibatches of --minibatch, and prints the mean return of the episodes finished in it. The final
checkpoint and summary.json go to --out/<timestamp>/. The env creator is
:func:`cepam_gym.integrations.rllib.make_env` (distinct seed per runner and sub-env; unknown env
kwargs rejected).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument("--env-id", default="cepam_gym/CEPAM-v0")
    p.add_argument(
        "--suite",
        default=None,
        help="start the env kwargs from a benchmark suite (cepam_gym.bench.suites), e.g. randomized",
    )
    p.add_argument(
        "--env-config",
        default="{}",
        type=json.loads,
        help='extra env kwargs as JSON, e.g. \'{"sensor_noise": {"length_mm": 0.2}}\'',
    )
    p.add_argument(
        "--max-episode-steps", type=int, default=None, help="default: the registration's 500 (10 s)"
    )
    p.add_argument("--num-env-runners", type=int, default=2)
    p.add_argument("--envs-per-runner", type=int, default=1)
    p.add_argument("--iterations", type=int, default=10)
    p.add_argument("--train-batch", type=int, default=4000, help="env steps per iteration (all runners)")
    p.add_argument("--minibatch", type=int, default=500)
    p.add_argument("--epochs", type=int, default=10)
    p.add_argument("--lr", type=float, default=3e-4)
    p.add_argument("--gamma", type=float, default=0.98)
    p.add_argument("--hidden", type=int, nargs="+", default=[64, 64], help="MLP layer sizes")
    p.add_argument("--seed", type=int, default=0, help="base seed of the envs (and of RLlib)")
    p.add_argument(
        "--stop-reward", type=float, default=None, help="stop once the mean episode return reaches this"
    )
    p.add_argument(
        "--address",
        default=None,
        help="existing Ray cluster ('auto', 'ray://head:10001'); default: $RAY_ADDRESS, else a new local Ray",
    )
    p.add_argument(
        "--ship-package",
        action="store_true",
        help="upload this checkout's cepam_gym to the cluster (runtime_env py_modules); its "
        "dependencies must already be installed on the nodes",
    )
    p.add_argument("--out", default="runs/rllib", help="checkpoint and summary directory")
    args = p.parse_args(argv)
    for name in ("num_env_runners", "envs_per_runner", "iterations", "train_batch", "minibatch", "epochs"):
        if getattr(args, name) < (0 if name == "num_env_runners" else 1):
            p.error(f"--{name.replace('_', '-')} must be {'>= 0' if name == 'num_env_runners' else '>= 1'}")
    if args.minibatch > args.train_batch:
        p.error(f"--minibatch ({args.minibatch}) must not exceed --train-batch ({args.train_batch})")
    if not isinstance(args.env_config, dict):
        p.error("--env-config must be a JSON object")
    return args


def env_config(args: argparse.Namespace) -> dict:
    cfg: dict = {}
    if args.suite is not None:
        from cepam_gym.bench.suites import SUITES

        if args.suite not in SUITES:
            raise SystemExit(f"--suite: unknown suite {args.suite!r}; available: {sorted(SUITES)}")
        cfg.update(SUITES[args.suite].env_kwargs)
    cfg.update(args.env_config)
    cfg.update({"id": args.env_id, "seed": args.seed})
    if args.max_episode_steps is not None:
        cfg["max_episode_steps"] = args.max_episode_steps
    return cfg


def runner_seeds(algo) -> dict[int, list[int]]:
    """Seed of every sub-env, per env runner (worker_index 0: the driver's local runner)."""

    def seeds(runner):
        if getattr(runner, "env", None) is None:
            return runner.worker_index, []
        return runner.worker_index, [
            int(e.get_wrapper_attr("runner_seed")) for e in runner.env.unwrapped.envs
        ]

    return dict(algo.env_runner_group.foreach_env_runner(seeds, local_env_runner=True))


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        import ray
        from ray.rllib.algorithms.ppo import PPOConfig
        from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig
    except ImportError:
        raise SystemExit('Ray RLlib is not installed: pip install "cepam-gym[distributed]"') from None
    from cepam_gym.integrations.rllib import check_env_config, register_env

    cfg = env_config(args)
    check_env_config(cfg)  # bad kwargs fail here, not inside a remote env runner

    address = args.address or os.environ.get("RAY_ADDRESS")
    runtime_env = {}
    if args.ship_package:
        import cepam_gym

        runtime_env["py_modules"] = [os.path.dirname(cepam_gym.__file__)]
    if address:
        ray.init(address=address, runtime_env=runtime_env or None)
    else:
        # one logical CPU per runner even on a small machine (they mostly wait on each other)
        ray.init(
            num_cpus=max(os.cpu_count() or 1, args.num_env_runners),
            include_dashboard=False,
            runtime_env=runtime_env or None,
            log_to_driver=False,
        )

    name = register_env()
    config = (
        PPOConfig()
        .environment(name, env_config=cfg)
        .env_runners(
            num_env_runners=args.num_env_runners,
            num_envs_per_env_runner=args.envs_per_runner,
            rollout_fragment_length="auto",
        )
        .training(
            train_batch_size_per_learner=args.train_batch,
            minibatch_size=args.minibatch,
            num_epochs=args.epochs,
            lr=args.lr,
            gamma=args.gamma,
            lambda_=0.95,
        )
        .rl_module(model_config=DefaultModelConfig(fcnet_hiddens=list(args.hidden), vf_share_layers=False))
        .debugging(seed=args.seed)
    )
    algo = config.build_algo()
    seeds = runner_seeds(algo)
    print(f"env runner seeds (worker_index: sub-env seeds): {seeds}", flush=True)

    history = []
    for it in range(1, args.iterations + 1):
        t0 = time.perf_counter()
        result = algo.train()
        dt = time.perf_counter() - t0
        runners = result.get("env_runners", {})
        ret = float(runners.get("episode_return_mean", math.nan))
        steps = int(
            runners.get("num_env_steps_sampled_lifetime", result.get("num_env_steps_sampled_lifetime", 0))
        )
        history.append(
            {
                "iteration": it,
                "env_steps": steps,
                "episode_return_mean": ret,
                "episode_len_mean": float(runners.get("episode_len_mean", math.nan)),
                "seconds": dt,
            }
        )
        print(f"iter {it:3d}  env steps {steps:8d}  episode return {ret:9.2f}  ({dt:.1f} s)", flush=True)
        if args.stop_reward is not None and ret >= args.stop_reward:
            print(f"reached --stop-reward {args.stop_reward}", flush=True)
            break

    run_dir = Path(args.out).resolve() / time.strftime("%Y%m%d-%H%M%S")
    checkpoint = algo.save_to_path(run_dir / "checkpoint")
    summary = {
        "args": vars(args),
        "env_config": cfg,
        "runner_seeds": {str(k): v for k, v in seeds.items()},
        "iterations": history,
        "checkpoint": str(checkpoint),
    }
    (run_dir / "summary.json").write_text(json.dumps(summary, indent=2, default=str, allow_nan=True))
    print(f"checkpoint: {checkpoint}", flush=True)
    print(f"summary: {run_dir / 'summary.json'}", flush=True)
    algo.stop()
    ray.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
