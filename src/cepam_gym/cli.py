"""``cepam-gym`` command line: ``run`` (the main job), ``demo``, ``validate``, ``rollout``."""

from __future__ import annotations

import argparse
import sys


def _run(argv: list[str]) -> int:
    """The main job. Today: the plant step response, the reproduction table, and a rollout of
    each registered env with random actions, written into ``runs/main``."""
    from pathlib import Path

    from . import demo, validation

    ap = argparse.ArgumentParser(prog="cepam-gym run", description=_run.__doc__)
    ap.add_argument("--out-dir", default="runs/main")
    args = ap.parse_args(argv)
    out = Path(args.out_dir)
    png = demo.step_response(out_dir=out)
    print(f"step response plot: {png}")
    validation.main([])
    return _rollout(["--out-dir", str(out)])


def _rollout(argv: list[str]) -> int:
    import json
    from pathlib import Path

    import gymnasium as gym
    import numpy as np

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
    lazy = {"demo": "cepam_gym.demo", "validate": "cepam_gym.validation", "bench": "cepam_gym.bench.cli",
            "train": "agents.train", "eval": "agents.evaluate"}
    if not argv or argv[0] in ("-h", "--help"):
        print("usage: cepam-gym {run,bench,train,eval,demo,validate,rollout} [options]\n"
              "  bench     score controllers on the benchmark suites\n"
              "  train     train an agent from a YAML config (configs/quick.yaml)\n"
              "  eval      score a trained agent beside the baseline (--run DIR)\n"
              "  run       the main job on the default config\n"
              "  demo      plant step response plot\n"
              "  validate  the paper's reported numbers beside the model's\n"
              "  rollout   random-action episodes of every registered id")
        return 0
    cmd, rest = argv[0], argv[1:]
    if cmd in commands:
        return commands[cmd](rest) or 0
    if cmd in lazy:
        import importlib

        return importlib.import_module(lazy[cmd]).main(rest) or 0
    print(f"cepam-gym: unknown command {cmd!r}; try --help", file=sys.stderr)
    return 2


if __name__ == "__main__":
    raise SystemExit(main())
