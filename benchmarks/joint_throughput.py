"""Env-steps per second of ``gym.make_vec("cepam_gym/CEPAMJoint-v1", num_envs=N)`` (the hinge on
the batched kernel) against the v0 joint (MuJoCo hinge), whose ``make_vec`` is Gymnasium's
generic sync vector env, measured in the same run, and their ratio.

Usage: python benchmarks/joint_throughput.py [--num-envs 64 256] [--seconds 3]

Each figure is the median of ``--repeats`` alternating timed runs of random actions between
resets (episodes are 500 steps; a run is much shorter, so no reset is timed). The v0 and v1
envs take turns, so a burst of load from another process hits both alike."""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import cepam_gym  # noqa: F401  (registers the ids)


def _run(env, acts: np.ndarray, seconds: float) -> float:
    """Env-steps/s of ``env`` stepped with the rows of ``acts`` for about ``seconds``."""
    n, t0 = 0, time.perf_counter()
    while True:
        for a in acts:
            env.step(a)
            n += 1
        dt = time.perf_counter() - t0
        if dt >= seconds:
            return n * env.num_envs / dt


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--num-envs", type=int, nargs="+", default=[64, 256])
    ap.add_argument("--seconds", type=float, default=3.0, help="length of one timed run")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    print(f"{'N':>5} {'v0 sync (MuJoCo)':>18} {'v1 batched':>12} {'ratio':>8}   env-steps/s")
    for n in args.num_envs:
        envs = {
            "v0": gym.make_vec("cepam_gym/CEPAMJoint-v0", num_envs=n, vectorization_mode="sync"),
            "v1": gym.make_vec("cepam_gym/CEPAMJoint-v1", num_envs=n),
        }
        rng = np.random.default_rng(0)
        acts = rng.uniform(-1, 1, (8, n, 2)).astype(np.float32)
        rates: dict[str, list[float]] = {k: [] for k in envs}
        for env in envs.values():
            env.reset(seed=0)
            _run(env, acts[:2], 0.0)  # warm-up (compilation, caches)
        for _ in range(args.repeats):
            for k, env in envs.items():
                rates[k].append(_run(env, acts, args.seconds))
        v0, v1 = (float(np.median(rates[k])) for k in ("v0", "v1"))
        print(f"{n:>5} {v0:>18,.0f} {v1:>12,.0f} {v1 / v0:>7.0f}x")
        for env in envs.values():
            env.close()


if __name__ == "__main__":
    main()
