"""``cepam-gym`` command line: ``run`` (the main job), ``demo``, ``validate``, ``rollout``."""

from __future__ import annotations

import argparse
import sys
from datetime import UTC


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
    table, then train an agent on the shipped ``student`` config (the student of a privileged
    teacher, distilled by DAgger: about 5 minutes of training on 2 cores, 7.5 for the whole job; ``--config
    quick``: PPO, about 3.5 minutes of training) and score it
    beside the zero controller, the inverse-model baseline, the MPC and the oracle on the
    ``nominal-v1`` and ``randomized-v1`` suites, with the headline score. Everything
    lands in ``--out-dir`` (default ``runs/main``): ``step_response.png``, ``validate/``,
    ``agent/`` (model, logs, config; ``agent-2/`` ... on later runs), ``agent/eval/``
    (table.txt, results.json, plots) and ``summary.md`` (what ran, versions, where everything is,
    the scores)."""
    from pathlib import Path

    ap = argparse.ArgumentParser(prog="cepam-gym run", description=_run.__doc__)
    ap.add_argument("--out-dir", default="runs/main")
    ap.add_argument(
        "--config",
        default="student",
        help="training config: a shipped one by name (student, quick, cepam_ppo, ...) or a YAML file",
    )
    ap.add_argument("--episodes", type=int, default=20, help="benchmark episodes per suite")
    ap.add_argument(
        "--no-train",
        action="store_true",
        help="skip training: plant, reproduction, and the model-based controllers on the v1 suites",
    )
    args = ap.parse_args(argv)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    from datetime import datetime

    from .run_summary import write_summary

    started, steps = datetime.now(UTC), []
    where = {"run_dir": None, "table": None}
    try:
        return _run_steps(args, out, steps, where)
    finally:
        path = write_summary(out, argv, started, steps, where["run_dir"], where["table"])
        print(f"summary: {path}", flush=True)


def _run_steps(args, out, steps: list, where: dict) -> int:
    """The steps of :func:`_run`, each recorded in ``steps`` for the summary."""

    from . import demo
    from .validation.cli import validate_main

    if not args.no_train:  # a bad --config fails now, not after the steps before training
        try:
            code = _plugin_command("train")(["--config", args.config, "--check"])
        except ImportError:
            code = 0  # reported at step 3, with the extra to install
        if code:
            return code
    steps.append(["plant step response", "failed", None])
    steps[-1][1:] = ["done", demo.step_response(out_dir=out)]
    print(f"[1/3] plant step response: {steps[-1][2]}", flush=True)
    print("[2/3] the paper's reported numbers beside the model's", flush=True)
    steps.append(["the paper's numbers beside the model's", "failed", out / "validate"])
    validate_main(["--out-dir", str(out / "validate")])
    steps[-1][1] = "done"
    if args.no_train:
        from .bench import cli as bench_cli

        steps.append(
            [
                "zero, baseline, mpc and oracle on the nominal-v1 and randomized-v1 suites",
                "failed",
                out / "bench",
            ]
        )
        against = [a for c in REFERENCE_CONTROLLERS for a in ("--controller", c)]
        suites = ["--suite", "nominal-v1", "--suite", "randomized-v1"]
        code = bench_cli.main(
            [*against, *suites, "--episodes", str(args.episodes), "--out-dir", str(out / "bench")]
        )
        steps[-1][1] = "done" if not code else f"exit code {code}"
        where["table"] = out / "bench" / "table.txt"
        return code
    try:
        train, evaluate = _plugin_command("train"), _plugin_command("eval")
    except ImportError as e:
        print(
            f"cepam-gym run: training needs the [train] extra ({e}); `make run` installs it", file=sys.stderr
        )
        return 2
    print(f"[3/3] train {args.config}, then score it beside {', '.join(REFERENCE_CONTROLLERS)}", flush=True)
    run_dir = fresh_dir(out / "agent")
    where["run_dir"] = run_dir
    steps.append([f"train an agent ({args.config})", "failed", run_dir])
    code = train(["--config", args.config, "--out", str(run_dir)])
    steps[-1][1] = "done" if not code else f"exit code {code}"
    if code:
        return code
    steps.append(
        [
            "score the agent beside zero, baseline, mpc and oracle (its version's suites)",
            "failed",
            run_dir / "eval",
        ]
    )
    against = [a for c in REFERENCE_CONTROLLERS for a in ("--against", c)]
    code = evaluate(["--run", str(run_dir), *against, "--episodes", str(args.episodes)])
    steps[-1][1] = "done" if not code else f"exit code {code}"
    where["table"] = run_dir / "eval" / "table.txt"
    return code


# scored beside the trained agent by the main job: the ends of the headline (baseline, oracle) and
# of the normalized score (zero, oracle), and the two model-based controllers an agent must beat
REFERENCE_CONTROLLERS = ("zero", "baseline", "mpc", "oracle")

PLUGIN_GROUP = "cepam_gym.commands"  # commands of other packages: the training package's train, eval


def _plugin_command(name: str):
    """The ``main(argv)`` of the command ``name`` that an installed package declares in the
    entry-point group :data:`PLUGIN_GROUP` (``train`` and ``eval`` come with the training package):
    the command line reaches the training code by name, never by an import."""
    from importlib.metadata import entry_points

    found = entry_points(group=PLUGIN_GROUP, name=name)
    if not found:
        raise ImportError(
            f"no package provides the command {name!r} (entry-point group {PLUGIN_GROUP}); "
            "pip install 'cepam-gym[train]'"
        )
    return next(iter(found)).load()


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
        rows.append(
            {
                "id": env_id,
                "steps": steps,
                "return": round(total, 2),
                **{k: round(v, 2) for k, v in terms.items()},
            }
        )
        print(f"{env_id:32s} random policy: {steps} steps, return {total:9.2f}")
        env.close()
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / "rollouts.json").write_text(json.dumps(rows, indent=2))
    print(f"wrote {out / 'rollouts.json'}")
    return 0


def _version() -> str:
    """The package's version: :data:`cepam_gym.__version__`, the one source pyproject.toml reads."""
    from . import __version__

    return __version__


def main(argv: list[str] | None = None) -> int:
    from ._cli_errors import debug_requested, run_guarded

    debug, argv = debug_requested(list(sys.argv[1:] if argv is None else argv))
    if argv[:1] == ["--version"]:
        print(f"cepam-gym {_version()}")
        return 0
    if argv and argv[0] not in ("-h", "--help"):
        return run_guarded(f"cepam-gym {argv[0]}", _dispatch, argv, debug)
    return _dispatch(argv)


def _dispatch(argv: list[str]) -> int:
    commands = {"run": _run, "rollout": _rollout}
    lazy = {
        "demo": "cepam_gym.demo",
        "validate": "cepam_gym.validation.cli:validate_main",
        "bench": "cepam_gym.bench.cli",
        "dataset": "cepam_gym.offline.cli",
        "video": "cepam_gym.video",
        "calibrate": "cepam_gym.validation.cli:calibrate_main",
        "identify": "cepam_gym.identify.cli:identify_main",
        "excite": "cepam_gym.identify.cli:excite_main",
    }
    plugins = ("train", "eval")
    if not argv or argv[0] in ("-h", "--help"):
        print(
            "usage: cepam-gym [--version] {run,bench,dataset,train,eval,demo,validate,calibrate,identify,"
            "excite,rollout,video} [options] [--debug]\n"
            "  bench     score controllers on the benchmark suites\n"
            "  dataset   record a Minari offline-RL dataset of a controller on a suite ([offline] extra)\n"
            "  train     train an agent from a YAML config (--config quick, or a file)\n"
            "  eval      score a trained agent beside the baseline (--run DIR)\n"
            "  run       the main job on the default config\n"
            "  demo      plant step response plot\n"
            "  validate  the paper's reported numbers beside the model's\n"
            "  calibrate fit unknown plant parameters to measured data (docs/calibration.md)\n"
            "  identify  fit the plant's dynamics and sensors to a rig's logs (docs/identify.md)\n"
            "  excite    an excitation schedule to play on a rig (or a simulated log of it)\n"
            "  rollout   random-action episodes of every registered id\n"
            "  video     MP4/GIF of an episode, MuJoCo view beside the traces (the [mujoco] extra)\n"
            "A user error (bad config, missing or corrupted file) is one line on stderr and exit code 2;\n"
            "--debug (or CEPAM_GYM_DEBUG=1) shows its traceback."
        )
        return 0
    cmd, rest = argv[0], argv[1:]
    if cmd in commands:
        return commands[cmd](rest) or 0
    if cmd in lazy:
        import importlib

        module, _, func = lazy[cmd].partition(":")
        return getattr(importlib.import_module(module), func or "main")(rest) or 0
    if cmd in plugins:
        try:
            command = _plugin_command(cmd)
        except ImportError as e:
            print(f"cepam-gym {cmd}: {e}", file=sys.stderr)
            return 2
        return command(rest) or 0
    print(f"cepam-gym: unknown command {cmd!r}; try --help", file=sys.stderr)
    return 2


if __name__ == "__main__":
    raise SystemExit(main())
