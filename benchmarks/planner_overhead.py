"""What a planner step costs beyond simulating its candidate plans.

The cross-entropy planner (:class:`cepam_gym.control.planner.CEMPlanner`, the oracle's and the
MPCs' search) spends each control step on ``iterations`` calls of the compiled rollout
(:func:`cepam_gym.control.rollout.rollout_cost`: ``population`` plans per env through the plant
kernel) and on the rest: drawing the noise, building the samples, ranking and refitting. This
times, in the same run and interleaved in rounds, one ``plan`` call and the same number of bare
rollout calls on the same shapes, for batches of N envs of a suite (default ``nominal-v2`` under
the oracle's shipped settings), and prints the medians and their ratio: 1.0 would be a planner
that costs only its simulations. The load average is printed: another busy process moves both.

Run: ``.venv/bin/python benchmarks/planner_overhead.py`` (options: ``--suite``, ``--sizes``,
``--rounds``, ``--threads``).
"""

from __future__ import annotations

import argparse
import os
import time

import gymnasium as gym
import numba
import numpy as np

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym.bench.suites import SUITES
from cepam_gym.control.oracle import OracleController


def measure(suite: str, n: int, rounds: int) -> tuple[float, float]:
    """Median seconds of one ``plan`` call and of its rollouts alone, for ``n`` envs."""
    s = SUITES[suite]
    venv = gym.make_vec(s.env_id, num_envs=n, **s.env_kwargs)
    venv.reset(seed=s.seed)
    oracle = OracleController(venv)
    planner, m, cfg = oracle.planner, oracle.model, oracle.cfg
    tl, tk, load, w = oracle.horizon()
    state, params = m.state.copy(), m.params.copy()
    p = cfg.population
    rep = lambda a: np.repeat(a, p, axis=0)  # noqa: E731
    rows = params if params.shape[0] == 1 else rep(params)
    rollout = planner._rollout(rep(state), rows, rep(tl), rep(tk), rep(load), rep(w))
    actions = np.clip(np.random.default_rng(0).normal(0, 0.3, (n * p, cfg.horizon_steps, 2)), -1, 1)
    planner.plan(state, params, tl, tk, load, w)  # compile and warm up
    rollout(actions)
    plan_t, roll_t = [], []
    for _ in range(rounds):
        planner.reset()
        t0 = time.perf_counter()
        planner.plan(state, params, tl, tk, load, w)
        plan_t.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        for _ in range(cfg.iterations):
            rollout(actions)
        roll_t.append(time.perf_counter() - t0)
    venv.close()
    return float(np.median(plan_t)), float(np.median(roll_t))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--suite", default="nominal-v2")
    ap.add_argument("--sizes", type=int, nargs="+", default=[1, 2, 8, 20])
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--threads", type=int, default=None, help="numba threads (default: all)")
    args = ap.parse_args()
    if args.threads:
        numba.set_num_threads(args.threads)
    print(
        f"cepam-gym {cepam_gym.__version__}; suite {args.suite}; numba threads "
        f"{numba.get_num_threads()}; load average {os.getloadavg()[0]:.2f}"
    )
    print("| envs | plan [ms] | its rollouts alone [ms] | plan / rollouts |")
    print("|---|---|---|---|")
    for n in args.sizes:
        plan, roll = measure(args.suite, n, args.rounds)
        print(f"| {n} | {plan * 1e3:.1f} | {roll * 1e3:.1f} | {plan / roll:.2f} |", flush=True)
    print(f"load average at the end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
