"""What a cheaper teacher costs: the student's teacher at several search settings.

The student (``configs/student.yaml``) is distilled from ``mpc_known_params``, a cross-entropy
planner whose cost per label is ``population x iterations x horizon_steps`` simulated control
steps. For each setting (``student.teacher_options`` in a config) this prints the teacher's own
score on the suites the student trains on (their 20 episodes) and the wall time it took to drive
them, beside the plant sub-steps it simulates per label (``plan_substeps`` sets how many make a
control step of its own simulation; the env's by default): the screen that picks which settings
are worth training students on. Whether a student of that teacher is as good is a 5-seed
measurement (``python -m cepam_gym_agents.compare``); the results are in docs/results/agents.md,
"A cheaper teacher". A better teacher is not always a better student: see there.

Wall times include creating the envs and the controller; the load average is printed, since a
busy machine slows every setting.

Run: ``.venv/bin/python benchmarks/teacher_trade.py`` (``--settings`` a JSON list of
``teacher_options`` dicts; ``--suites``).
"""

from __future__ import annotations

import argparse
import json
import os
import time

SETTINGS = (
    {},  # the planner's defaults: population 48, 6 iterations, a 10-step horizon
    {"population": 48, "iterations": 3},
    {"population": 24, "iterations": 3, "elites": 4},
    {"population": 24, "iterations": 2, "elites": 4},
    {"population": 16, "iterations": 2, "elites": 4},
    {"population": 24, "iterations": 1, "elites": 4},
    # the same searches through a coarser integration of the planner's own plant (20 sub-steps
    # of 1 ms per control step instead of the env's 40 of 0.5 ms)
    {"plan_substeps": 20},
    {"population": 24, "iterations": 3, "elites": 4, "plan_substeps": 20},
    {"population": 16, "iterations": 2, "elites": 4, "plan_substeps": 20},
)
SUITES = ("nominal-v1", "randomized-v1")


def teacher_score(opts: dict, suite_name: str) -> tuple[float, float]:
    """(score, wall seconds) of ``mpc_known_params`` with ``opts`` on a suite's own episodes."""
    from cepam_gym.bench.harness import run_suite

    t0 = time.perf_counter()
    metrics, _ = run_suite("mpc_known_params", suite_name, **opts)
    return float(metrics["score"]), time.perf_counter() - t0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--settings", type=json.loads, default=list(SETTINGS), help="JSON list of option dicts")
    ap.add_argument("--suites", nargs="+", default=list(SUITES))
    args = ap.parse_args(argv)
    import warnings

    import cepam_gym  # noqa: F401  (registers the ids; then its deprecation notice is silenced)

    warnings.filterwarnings("ignore", message=".*out of date.*")
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    teacher_score({"population": 2, "iterations": 1, "elites": 1}, args.suites[0])  # compile, cache
    import gymnasium as gym

    from cepam_gym.bench.suites import SUITES as ALL
    from cepam_gym.envs.model import model_of

    first = ALL[args.suites[0]]
    venv = gym.make_vec(first.env_id, num_envs=1, **first.env_kwargs)
    env_substeps = model_of(venv).n_sub
    venv.close()
    head = " | ".join(f"{s} score | {s} s" for s in args.suites)
    print(f"| teacher_options | sims per label | sub-steps per label | {head} |")
    print("|---|---|---|" + "---|---|" * len(args.suites))
    for opts in args.settings:
        from cepam_gym.control.planner import CEMConfig

        c = CEMConfig(**opts)
        cells = []
        for s in args.suites:
            score, wall = teacher_score(opts, s)
            cells += [f"{score:.4f}", f"{wall:.1f}"]
        sims = c.population * c.iterations * c.horizon_steps
        sub = sims * (c.plan_substeps or env_substeps)
        print(f"| {json.dumps(opts)} | {sims} | {sub} | " + " | ".join(cells) + " |", flush=True)
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
