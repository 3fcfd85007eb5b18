"""Env steps per second of every id, single (gym.make) and batched (gym.make_vec), beside
Gymnasium's Pendulum-v1 measured in the same run. Usage: python benchmarks/throughput.py"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import cepam_gym


def _single(env_id: str, seconds: float) -> float:
    env = gym.make(env_id)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    acts = rng.uniform(-1, 1, size=(4096,) + env.action_space.shape).astype(np.float32)
    for a in acts[:50]:  # warm-up (compilation, caches)
        _, _, te, tr, _ = env.step(a)
        if te or tr:
            env.reset()
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        for a in acts[:256]:
            _, _, te, tr, _ = env.step(a)
            if te or tr:
                env.reset()
        n += 256
    return n / (time.perf_counter() - t0)


def _batched(env_id: str, num_envs: int, seconds: float) -> float:
    env = gym.make_vec(env_id, num_envs=num_envs)
    env.reset(seed=0)
    a = np.random.default_rng(0).uniform(-1, 1, size=(num_envs, 2))
    for _ in range(5):
        env.step(a)
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        env.step(a)
        n += num_envs
    return n / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--sizes", type=int, nargs="*", default=[1, 64, 1024, 4096])
    args = ap.parse_args()
    ref = _single("Pendulum-v1", args.seconds)
    print(f"{'env':34s} {'mode':>12s} {'steps/s':>12s} {'x Pendulum-v1':>14s}")
    print(f"{'Pendulum-v1':34s} {'single':>12s} {ref:12,.0f} {1.0:14.2f}")
    for env_id in cepam_gym.ENV_IDS:
        s = _single(env_id, args.seconds)
        print(f"{env_id:34s} {'single':>12s} {s:12,.0f} {s / ref:14.2f}")
        for n in args.sizes:
            b = _batched(env_id, n, args.seconds)
            print(f"{env_id:34s} {'batch ' + str(n):>12s} {b:12,.0f} {b / ref:14.2f}")


if __name__ == "__main__":
    main()
