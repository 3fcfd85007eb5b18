"""``cepam-gym`` command line: the library's commands (``demo``, ``validate``, ``bench``, ``rollout``...)
and the hook of the training package's (``run``, the main job; ``train``; ``eval``; ``export``)."""

from __future__ import annotations

import sys

from .cli_errors import CommandParser

# commands of other packages, found by name: the training package's run (the main job, with its
# default config and summary), train, eval and export (a trained agent as an ONNX file)
PLUGIN_GROUP = "cepam_gym.commands"
PLUGIN_COMMANDS = ("run", "train", "eval", "export")
PLUGIN_EXTRA = "pip install 'cepam-gym[train]'"  # what installs them and what they need


def _plugin_command(name: str):
    """The ``main(argv)`` of the command ``name`` that an installed package declares in the
    entry-point group :data:`PLUGIN_GROUP` (``run``, ``train`` and ``eval`` come with the training
    package): the command line reaches the training code by name, never by an import. An
    ``ImportError`` names the extra to install."""
    from importlib.metadata import entry_points

    found = entry_points(group=PLUGIN_GROUP, name=name)
    if not found:
        raise ImportError(
            f"no package provides the command {name!r} (entry-point group {PLUGIN_GROUP}); {PLUGIN_EXTRA}"
        )
    try:
        return next(iter(found)).load()
    except ImportError as e:
        raise ImportError(f"the command {name!r} cannot be loaded ({e}); {PLUGIN_EXTRA}") from e


def _rollout(argv: list[str]) -> int:
    import json
    from pathlib import Path

    import gymnasium as gym

    from . import ENV_IDS

    ap = CommandParser(prog="cepam-gym rollout", description="random-action episodes of every id")
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
    from .cli_errors import debug_requested, run_guarded

    debug, argv = debug_requested(list(sys.argv[1:] if argv is None else argv))
    if argv[:1] == ["--version"]:
        print(f"cepam-gym {_version()}")
        return 0
    if argv and argv[0] not in ("-h", "--help"):
        return run_guarded(f"cepam-gym {argv[0]}", _dispatch, argv, debug)
    return _dispatch(argv)


def _dispatch(argv: list[str]) -> int:
    commands = {"rollout": _rollout}
    lazy = {
        "demo": "cepam_gym.demo",
        "validate": "cepam_gym.validation.cli:validate_main",
        "bench": "cepam_gym.bench.cli",
        "dataset": "cepam_gym.offline.cli",
        "video": "cepam_gym.video",
        "calibrate": "cepam_gym.validation.cli:calibrate_main",
        "identify": "cepam_gym.identify.cli:identify_main",
        "excite": "cepam_gym.rig.cli:excite_main",
        "deploy": "cepam_gym.rig.cli:deploy_main",
        "rig-emulator": "cepam_gym.rig.cli:emulator_main",
    }
    if not argv or argv[0] in ("-h", "--help"):
        print(
            "usage: cepam-gym [--version] {run,bench,dataset,train,eval,export,deploy,rig-emulator,demo,"
            "validate,calibrate,identify,excite,rollout,video} [options] [--debug]\n"
            "  bench     score controllers on the benchmark suites\n"
            "  dataset   record a Minari offline-RL dataset of a controller on a suite ([offline] extra)\n"
            "  train     train an agent from a YAML config (--config quick, or a file)\n"
            "  eval      score a trained agent beside the baseline (--run DIR)\n"
            "  export    a trained agent as one ONNX file (--run DIR --out policy.onnx)\n"
            "  deploy    run an ONNX policy or a controller on a rig, under the safety supervisor\n"
            "  rig-emulator  a simulated rig behind the rig protocol (UDP), with faults to inject\n"
            "  run       the main job on its default config (declared by the training package)\n"
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
    if cmd in PLUGIN_COMMANDS:
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
