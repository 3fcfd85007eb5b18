"""``cepam-gym train``: train an agent (an algorithm of ``ALGORITHMS``) on a CE-PAM env from a YAML config.

    cepam-gym train --config configs/quick.yaml [--total-timesteps N] [--seed S] [--out DIR] [--resume]

The run directory (default ``runs/<config name>-s<seed>``) receives:

| file | what |
|---|---|
| ``config.yaml`` | the resolved config (overrides applied; ``--config DIR/config.yaml`` reruns it) |
| ``run.json`` | seed, command line, package versions, git commit, and one entry per training session |
| ``model.zip``, ``vecnormalize.pkl`` | the model at the end of training (and its observation statistics) |
| ``best_model.zip``, ``best_vecnormalize.pkl`` | the model with the best periodic evaluation score |
| ``checkpoints/`` | periodic checkpoints; ``latest.json`` names the newest (``--resume`` starts there) |
| ``evaluations.json`` | every periodic evaluation (benchmark metrics) |
| ``tb/``, ``logs/`` | TensorBoard events and CSV: losses, returns, reward terms, errors, evaluations |

Ctrl-C (SIGINT) or SIGTERM (what batch schedulers send) saves a checkpoint of the current model
(and the replay buffer) before exiting with 130 or 143; ``--resume`` continues from the newest
checkpoint with the step count it had. The first checkpoint comes early (after 10 % of the session's
steps or 2 minutes, whichever first), then every ``checkpoint.every_steps``. After a SIGKILL or a
crash, ``--resume`` continues from the newest loadable model (checkpoint, final or best); a
directory that never saved a model (killed during start-up) starts afresh, with or without
``--resume``. A run directory is locked while a session trains in it (``.train.lock``, an OS lock
released when the process dies, so a lock left by a killed run never blocks): a second session on
it is refused, naming the first one's pid. A stop by ``time_limit_minutes`` is reported loudly and
recorded in ``run.json`` (status ``stopped_by_time_limit``, not ``finished``); a
``--total-timesteps`` that the algorithm rounds up (PPO collects ``n_steps x num_envs`` at a time)
is reported with the number it will train.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from cepam_gym.cli_errors import CommandParser, debug_on, report, user_error_types

from .config.files import load_config

# the session's parts, importable from here as before the split into modules
from .learners.algorithm import ALGORITHMS, steps_per_collection
from .session.callbacks import FIRST_CHECKPOINT_FRACTION, FIRST_CHECKPOINT_MINUTES
from .session.envs import make_train_env
from .session.lock import LOCK_NAME, RunLock
from .session.provenance import git_state, package_versions
from .session.signals import EXIT_INTERRUPTED
from .session.trainer import Trainer, train

__all__ = [
    "EXIT_INTERRUPTED",
    "FIRST_CHECKPOINT_FRACTION",
    "FIRST_CHECKPOINT_MINUTES",
    "LOCK_NAME",
    "RunLock",
    "Trainer",
    "git_state",
    "main",
    "make_train_env",
    "package_versions",
    "steps_per_collection",
    "train",
]


# --------------------------------------------------------------------------- command line
def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    ap = CommandParser(
        prog="cepam-gym train",
        description=f"train an agent ({', '.join(ALGORITHMS)}) on a CE-PAM env from a YAML config",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--config", help="training config (YAML), e.g. configs/quick.yaml")
    ap.add_argument("--total-timesteps", type=int, help="override the config's total_timesteps")
    ap.add_argument("--seed", type=int, help="override the config's seed")
    ap.add_argument("--out", help="run directory (default runs/<config name>-s<seed>)")
    ap.add_argument(
        "--resume",
        action="store_true",
        help="continue the run in --out (or the default directory) from its newest checkpoint",
    )
    ap.add_argument("--quiet", action="store_true", help="no progress bar or messages")
    ap.add_argument(
        "--check",
        action="store_true",
        help="run every check a training session makes (the config, its env and plant, the model and its "
        "hyperparameters, the evaluation env), build each once, then exit without writing anything",
    )
    args = ap.parse_args(argv)
    if args.total_timesteps is not None and args.total_timesteps < 1:
        ap.error("--total-timesteps must be >= 1")
    if args.seed is not None and args.seed < 0:
        ap.error("--seed must be >= 0")
    try:
        if args.resume:
            from .policy import load_run_config

            if args.out is None and args.config is None:
                ap.error("--resume needs --out DIR (or --config to find the default directory)")
            if args.out is not None:
                run = Path(args.out)
            else:
                seed = args.seed if args.seed is not None else load_config(args.config).seed
                run = Path("runs") / f"{Path(args.config).stem}-s{seed}"
            if not (run / "config.yaml").is_file():
                ap.error(f"--resume: {run} is not a run directory (no config.yaml)")
            cfg = load_run_config(run)
            if args.seed is not None and args.seed != cfg.seed:
                ap.error(f"--resume: the run was seeded with {cfg.seed}, not {args.seed}")
        else:
            if args.config is None:
                ap.error("--config is required (e.g. configs/quick.yaml)")
            cfg = load_config(args.config)
            if args.seed is not None:
                cfg = cfg.replace(seed=args.seed)
            run = Path(args.out) if args.out else Path("runs") / f"{Path(args.config).stem}-s{cfg.seed}"
        if args.total_timesteps is not None:
            cfg = cfg.replace(total_timesteps=args.total_timesteps)
        if args.check:
            from .session.trainer import check

            check(cfg)
            print(f"cepam-gym train: {args.config or run} checks: the config, its env and its model build")
            return 0
        return train(cfg, run, resume=args.resume, quiet=args.quiet, argv=["train", *argv])
    except KeyboardInterrupt:  # during start-up (learn() handles its own): nothing to save yet
        print(
            "cepam-gym train: interrupted before training started; nothing saved (the same command "
            "starts the run afresh)",
            file=sys.stderr,
        )
        return EXIT_INTERRUPTED
    except user_error_types() as e:  # bad config, env kwargs, hyperparameters, missing or corrupted files
        if debug_on():
            raise
        return report("cepam-gym train", e)


if __name__ == "__main__":
    raise SystemExit(main())
