"""``cepam-gym`` command line: ``run`` (the main job), ``demo``, ``validate``, ``rollout``."""

from __future__ import annotations

import argparse
import sys


def fresh_dir(path):
    """``path`` if it does not exist yet, else ``path-2``, ``path-3``...: the main job never
    overwrites (or refuses to run over) an earlier run."""
    from pathlib import Path

    path = Path(path)
    candidate, k = path, 2
    while candidate.exists():
        candidate = path.with_name(f"{path.name}-{k}")
        k += 1
    return candidate


def _run(argv: list[str]) -> int:
    """The main job on the default config: the plant's step response, the paper reproduction
    table, then train an agent on ``configs/quick.yaml`` (a few minutes on 2 cores) and score it
    beside the inverse-model baseline on the ``nominal`` and ``randomized`` suites. Everything
    lands in ``--out-dir`` (default ``runs/main``): ``step_response.png``, ``validate/``,
    ``agent/`` (model, logs, config; ``agent-2/`` ... on later runs) and ``agent/eval/``
    (table.txt, results.json, plots)."""
    from pathlib import Path

    from . import demo
    from .validation.cli import validate_main

    ap = argparse.ArgumentParser(prog="cepam-gym run", description=_run.__doc__)
    ap.add_argument("--out-dir", default="runs/main")
    ap.add_argument("--config", default="configs/quick.yaml", help="training config (YAML)")
    ap.add_argument("--episodes", type=int, default=20, help="benchmark episodes per suite")
    ap.add_argument("--no-train", action="store_true", help="skip training: plant, reproduction, baseline only")
    args = ap.parse_args(argv)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    print(f"[1/3] plant step response: {demo.step_response(out_dir=out)}", flush=True)
    print("[2/3] the paper's reported numbers beside the model's", flush=True)
    validate_main(["--out-dir", str(out / "validate")])
    if args.no_train:
        from .bench import cli as bench_cli

        return bench_cli.main(["--controller", "baseline", "--suite", "nominal", "--suite", "randomized",
                               "--episodes", str(args.episodes), "--out-dir", str(out / "bench")])
    if not Path(args.config).exists():
        print(f"cepam-gym run: training config {args.config} not found (run from the repository "
              "root, or pass --config)", file=sys.stderr)
        return 2
    try:
        from agents import evaluate, train
    except ImportError as e:
        print(f"cepam-gym run: training needs the [train] extra ({e}); `make run` installs it",
              file=sys.stderr)
        return 2
    print(f"[3/3] train {args.config}, then score the agent beside the baseline", flush=True)
    run_dir = fresh_dir(out / "agent")
    code = train.main(["--config", args.config, "--out", str(run_dir)])
    if code:
        return code
    return evaluate.main(["--run", str(run_dir), "--suite", "nominal", "--suite", "randomized",
                          "--episodes", str(args.episodes)])


def _rollout(argv: list[str]) -> int:
    import json
    from pathlib import Path

    import gymnasium as gym

    from . import ENV_IDS

    ap = argparse.ArgumentParser(prog="cepam-gym rollout", description="random-action episodes of every id")
    ap.add_argument("--out-dir", default="runs/rollout")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    rows = []
    for env_id in ENV_IDS:
        env = gym.make(env_id)
        env.reset(seed=args.seed)
        total, steps, done = 0.0, 0, False
        terms: dict[str, float] = {}
        while not done:
            _, r, term, trunc, info = env.step(env.action_space.sample())
            total += r
            steps += 1
            done = term or trunc
            for k, v in info.items():
                if k.startswith("reward_"):
                    terms[k] = terms.get(k, 0.0) + v
        rows.append({"id": env_id, "steps": steps, "return": round(total, 2),
                     **{k: round(v, 2) for k, v in terms.items()}})
        print(f"{env_id:32s} random policy: {steps} steps, return {total:9.2f}")
        env.close()
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / "rollouts.json").write_text(json.dumps(rows, indent=2))
    print(f"wrote {out / 'rollouts.json'}")
    return 0


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    commands = {"run": _run, "rollout": _rollout}
    lazy = {"demo": "cepam_gym.demo", "validate": "cepam_gym.validation.cli:validate_main", "bench": "cepam_gym.bench.cli",
            "train": "agents.train", "eval": "agents.evaluate", "video": "cepam_gym.mujoco.video",
            "calibrate": "cepam_gym.validation.cli:calibrate_main"}
    if not argv or argv[0] in ("-h", "--help"):
        print("usage: cepam-gym {run,bench,train,eval,demo,validate,calibrate,rollout,video} [options]\n"
              "  bench     score controllers on the benchmark suites\n"
              "  train     train an agent from a YAML config (configs/quick.yaml)\n"
              "  eval      score a trained agent beside the baseline (--run DIR)\n"
              "  run       the main job on the default config\n"
              "  demo      plant step response plot\n"
              "  validate  the paper's reported numbers beside the model's\n"
              "  calibrate fit unknown plant parameters to measured data (docs/calibration.md)\n"
              "  rollout   random-action episodes of every registered id\n"
              "  video     MP4/GIF of an episode, MuJoCo view beside the traces (the [mujoco] extra)")
        return 0
    cmd, rest = argv[0], argv[1:]
    if cmd in commands:
        return commands[cmd](rest) or 0
    if cmd in lazy:
        import importlib

        module, _, func = lazy[cmd].partition(":")
        return getattr(importlib.import_module(module), func or "main")(rest) or 0
    print(f"cepam-gym: unknown command {cmd!r}; try --help", file=sys.stderr)
    return 2


if __name__ == "__main__":
    raise SystemExit(main())
