"""``cepam-gym run``: the main job, declared by the training package (the entry point ``run`` of
the group ``cepam_gym.commands``); ``cepam_gym``'s command line only dispatches to it.

The job and its default config (:data:`MAIN_CONFIG`) live here, its ``summary.md`` in
:mod:`.main_summary`.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path

from .evaluate import main as evaluate_main
from .main_summary import write_summary
from .train import main as train_main

# the main job's agent: the shipped config ``configs/student_baseline_residual_v3.yaml`` (the two-minute
# student on the recommended id, a residual on the baseline; ``--config student_fast`` trains the
# student on CEPAM-v1)
MAIN_CONFIG = "student_baseline_residual_v3"

# run beside the trained agent by the main job: the two model-based controllers an agent must beat.
# The other ends of the scores (the zero controller, the oracle) are the stored reference scores of
# the same episodes (cepam_gym/data/reference_scores.json, re-checked by the test suite): the
# oracle alone would take longer than the whole job.
REFERENCE_CONTROLLERS = ("baseline", "mpc")

# what training imports (the [train] extra); the rest of the job runs without it (--no-train)
TRAINING_MODULES = ("stable_baselines3", "torch")


def fresh_dir(path) -> Path:
    """``path`` if it does not exist yet, else ``path-2``, ``path-3``...: the main job never
    overwrites (or refuses to run over) an earlier run."""
    path = Path(path)
    candidate, k = path, 2
    while candidate.exists():
        candidate = path.with_name(f"{path.name}-{k}")
        k += 1
    return candidate


def main(argv: list[str] | None = None) -> int:
    """The main job on the default config: the recommended plant's step response and its reproduction of
    the paper's numbers, then train an agent on the shipped ``student_baseline_residual_v3`` config
    (the student of a privileged teacher on the recommended id ``CEPAM-v3``, a residual on the
    baseline, in about three minutes) and score it beside
    the inverse-model baseline and the MPC on its id's headline suites, with the headline score (the zero
    controller's and the oracle's ends: the stored reference scores of the same episodes); ``--no-train``
    scores the baseline and the MPC on the recommended id's suites. Everything lands in ``--out-dir``
    (default ``runs/main``): ``step_response.png``, ``validate/``, ``agent/`` (model, logs, config;
    ``agent-2/`` ... on later runs), ``agent/eval/`` (table.txt, results.json, plots) and ``summary.md``
    (what ran, versions, where everything is, the scores)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    ap = argparse.ArgumentParser(prog="cepam-gym run", description=main.__doc__)
    ap.add_argument("--out-dir", default="runs/main")
    ap.add_argument(
        "--config",
        default=MAIN_CONFIG,
        help="training config: a shipped one by name (student, quick, cepam_ppo, ...) or a YAML file",
    )
    ap.add_argument("--episodes", type=int, default=20, help="benchmark episodes per suite")
    ap.add_argument(
        "--no-train",
        action="store_true",
        help="skip training: plant, reproduction, and the model-based controllers on the headline suites",
    )
    args = ap.parse_args(argv)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    started, steps = datetime.now(UTC), []
    where = {"run_dir": None, "table": None}
    try:
        return _run_steps(args, out, steps, where)
    finally:
        path = write_summary(out, argv, started, steps, where["run_dir"], where["table"])
        print(f"summary: {path}", flush=True)


def missing_training_modules() -> list[str]:
    return [m for m in TRAINING_MODULES if importlib.util.find_spec(m) is None]


@contextmanager
def _step(steps: list, k: int, n: int, what: str, path: Path | None):
    """One step of the job: ``[k/n] what`` when it starts, its elapsed time when it ends, and its
    row of the summary (what, status, output, seconds), "failed" unless the body sets it."""
    print(f"[{k}/{n}] {what}", flush=True)
    entry = [what, "failed", path, None]
    steps.append(entry)
    t0 = time.perf_counter()
    try:
        yield entry
    finally:
        entry[3] = time.perf_counter() - t0
        print(f"[{k}/{n}] {entry[1]} in {entry[3]:.0f} s: {what}", flush=True)


def _run_steps(args, out: Path, steps: list, where: dict) -> int:
    """The steps of :func:`main`, each recorded in ``steps`` for the summary."""
    from cepam_gym import demo, versions
    from cepam_gym.validation.cli import validate_main

    if not args.no_train:  # a missing extra or a bad --config fails now, not after the steps before training
        missing = missing_training_modules()
        if missing:
            print(
                f"cepam-gym run: training needs the [train] extra ({', '.join(missing)} not installed): "
                "pip install 'cepam-gym[train]' (`make run` installs it), or pass --no-train",
                file=sys.stderr,
            )
            return 2
        code = train_main(["--config", args.config, "--check"])
        if code:
            return code
    from cepam_gym.plant.params import preset

    # the plant of the recommended id: its step response and its calibration against the paper
    plant = versions.get(versions.RECOMMENDED_ID).plant_preset
    n = 3 if args.no_train else 4
    with _step(steps, 1, n, f"plant step response (preset {plant})", None) as step:
        step[2] = demo.step_response(preset(plant), out_dir=out)
        step[1] = "done"
    with _step(steps, 2, n, f"the paper's numbers beside plant {plant}'s", out / "validate") as step:
        validate_main(["--preset", plant, "--out-dir", str(out / "validate")])
        step[1] = "done"
    if args.no_train:
        from cepam_gym.bench import cli as bench_cli

        headline = versions.get(versions.RECOMMENDED_ID).suites
        what = f"{' and '.join(REFERENCE_CONTROLLERS)} on {' and '.join(headline)}"
        with _step(steps, 3, n, what, out / "bench") as step:
            against = [a for c in REFERENCE_CONTROLLERS for a in ("--controller", c)]
            suites = [a for s in headline for a in ("--suite", s)]
            code = bench_cli.main(
                [*against, *suites, "--episodes", str(args.episodes), "--out-dir", str(out / "bench")]
            )
            step[1] = "done" if not code else f"exit code {code}"
        where["table"] = out / "bench" / "table.txt"
        return code
    run_dir = fresh_dir(out / "agent")
    where["run_dir"] = run_dir
    with _step(steps, 3, n, f"train an agent ({args.config})", run_dir) as step:
        code = train_main(["--config", args.config, "--out", str(run_dir)])
        step[1] = "done" if not code else f"exit code {code}"
    if code:
        return code
    what = f"score the agent beside {' and '.join(REFERENCE_CONTROLLERS)} (its version's headline suites)"
    with _step(steps, 4, n, what, run_dir / "eval") as step:
        against = [a for c in REFERENCE_CONTROLLERS for a in ("--against", c)]
        code = evaluate_main(["--run", str(run_dir), *against, "--episodes", str(args.episodes)])
        step[1] = "done" if not code else f"exit code {code}"
    where["table"] = run_dir / "eval" / "table.txt"
    return code


if __name__ == "__main__":
    raise SystemExit(main())
