"""Env steps per second of every id, single (gym.make) and batched (gym.make_vec), beside
Gymnasium's Pendulum-v1 measured in the same run. Usage: python benchmarks/throughput.py

Batched runs time whole episodes (all envs of a batch end their 500-step episodes on the same
step and are reset in it), so two figures are printed: the rate with those resets amortised, and
the rate of the steps between them (what the step kernel and the vector env's Python sustain).
Single envs (Pendulum-v1 and every id) take turns in short rounds and the median round is
printed, which keeps the ratio to Pendulum-v1 meaningful on a shared, noisy VM; a single env is
reset whenever its episode ends, inside the timed loop."""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import cepam_gym


class _Single:
    """A single env (``gym.make``, with its wrappers) stepped with random actions in timed rounds;
    an ended episode is reset inside the round."""

    def __init__(self, env_id: str):
        self.env = gym.make(env_id)
        self.env.reset(seed=0)
        rng = np.random.default_rng(0)
        self.acts = rng.uniform(-1, 1, size=(256,) + self.env.action_space.shape).astype(np.float32)
        self.rates: list[float] = []
        self.round(0.0)  # warm-up (compilation, caches)

    def round(self, seconds: float) -> None:
        env, n, t0 = self.env, 0, time.perf_counter()
        while True:
            for a in self.acts:
                _, _, te, tr, _ = env.step(a)
                if te or tr:
                    env.reset()
            n += len(self.acts)
            dt = time.perf_counter() - t0
            if dt >= seconds:
                break
        if seconds > 0:
            self.rates.append(n / dt)

    def rate(self) -> float:
        return float(np.median(self.rates))


def _singles(env_ids, seconds: float, rounds: int = 8) -> dict[str, float]:
    """Median steps/s of each env over ``rounds`` rounds, the envs taking turns within each round
    (so a burst of load from another process on the shared VM hits all of them alike)."""
    envs = {env_id: _Single(env_id) for env_id in env_ids}
    for _ in range(rounds):
        for e in envs.values():
            e.round(seconds / rounds)
    return {env_id: e.rate() for env_id, e in envs.items()}


def _batched(env_id: str, num_envs: int, seconds: float) -> tuple[float, float]:
    """``(env-steps/s with resets amortised, env-steps/s of the steps without a reset)``, over
    at least one whole episode and at least ``seconds``."""
    env = gym.make_vec(env_id, num_envs=num_envs)
    env.reset(seed=0)
    a = np.random.default_rng(0).uniform(-1, 1, size=(num_envs, 2))
    for _ in range(5):
        env.step(a)
    steps, t_all, t_reset, n_reset, done_episode = 0, 0.0, 0.0, 0, False
    while t_all < seconds or not done_episode:
        t0 = time.perf_counter()
        _, _, te, tr, _ = env.step(a)
        dt = time.perf_counter() - t0
        steps += 1
        t_all += dt
        if te.any() or tr.any():
            t_reset += dt
            n_reset += 1
            done_episode = True
    return num_envs * steps / t_all, num_envs * (steps - n_reset) / (t_all - t_reset)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--sizes", type=int, nargs="*", default=[1, 64, 1024, 4096])
    args = ap.parse_args()
    singles = _singles(["Pendulum-v1", *cepam_gym.ENV_IDS], args.seconds)
    ref = singles["Pendulum-v1"]
    print(f"{'env':30s} {'mode':>11s} {'steps/s':>11s} {'x Pendulum-v1':>14s} {'between resets':>15s}")
    print(f"{'Pendulum-v1':30s} {'single':>11s} {ref:11,.0f} {1.0:14.2f}")
    for env_id in cepam_gym.ENV_IDS:
        s = singles[env_id]
        print(f"{env_id:30s} {'single':>11s} {s:11,.0f} {s / ref:14.2f}")
        for n in args.sizes:
            b, steady = _batched(env_id, n, args.seconds)
            print(f"{env_id:30s} {'batch ' + str(n):>11s} {b:11,.0f} {b / ref:14.2f} {steady:15,.0f}")


if __name__ == "__main__":
    main()
