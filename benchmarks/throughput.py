"""Env steps per second of every id, single (gym.make) and batched (gym.make_vec), beside
Gymnasium's Pendulum-v1 measured in the same run. Usage: python benchmarks/throughput.py

Batched runs time whole episodes (all envs of a batch end their 500-step episodes on the same
step and are reset in it), so two figures are printed: the rate with those resets amortised, and
the rate of the steps between them (what the step kernel and the vector env's Python sustain).
Single envs (Pendulum-v1 and every id) take turns in short rounds and the median round is
printed, which keeps the ratio to Pendulum-v1 meaningful on a shared, noisy VM; a single env is
reset whenever its episode ends, inside the timed loop.

``--busy-core`` measures the batched kernel's thread choice instead: env-steps/s of the batched
env at each ``num_threads`` (1 and every core), first on the quiet machine, then with one core
kept busy by a spinning process (as in training, where the learner takes a core), and prints the
busy/quiet ratio of each. Medians of ``--repeats`` alternating runs; quiet and busy runs of a
choice are measured in the same run of the script."""

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


def _batched(env_id: str, num_envs: int, seconds: float, **kwargs) -> tuple[float, float]:
    """``(env-steps/s with resets amortised, env-steps/s of the steps without a reset)``, over
    at least one whole episode and at least ``seconds``."""
    env = gym.make_vec(env_id, num_envs=num_envs, **kwargs)
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


def _steady(env_id: str, num_envs: int, seconds: float, num_threads) -> float:
    """Env-steps/s of the batched env between resets (no episode ends in the timed steps)."""
    env = gym.make_vec(env_id, num_envs=num_envs, num_threads=num_threads, max_episode_steps=None)
    env.reset(seed=0)
    a = np.random.default_rng(0).uniform(-1, 1, size=(num_envs, 2))
    for _ in range(3):
        env.step(a)
    steps, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        env.step(a)
        steps += 1
    return num_envs * steps / (time.perf_counter() - t0)


def _busy_core_study(sizes, seconds: float, repeats: int) -> None:
    import subprocess
    import sys

    import numba

    choices = sorted({1, numba.config.NUMBA_NUM_THREADS})
    env_id = "cepam_gym/CEPAM-v0"
    print(
        f"batched {env_id}, steps between resets, median of {repeats}; NUMBA_NUM_THREADS="
        f"{numba.config.NUMBA_NUM_THREADS}, threading layer chosen by numba"
    )
    print(
        f"{'envs':>6s} {'num_threads':>11s} {'quiet steps/s':>14s} {'busy steps/s':>13s} {'busy/quiet':>11s}"
    )
    for n in sizes:
        quiet = {c: [] for c in choices}
        busy = {c: [] for c in choices}
        for _ in range(repeats):
            for c in choices:
                quiet[c].append(_steady(env_id, n, seconds, c))
            spinner = subprocess.Popen([sys.executable, "-c", "while True: pass"])
            try:
                time.sleep(0.2)
                for c in choices:
                    busy[c].append(_steady(env_id, n, seconds, c))
            finally:
                spinner.kill()
                spinner.wait()
        if n == sizes[0]:
            try:
                print(
                    f"(numba threading layer: {numba.threading_layer()}; "
                    "NUMBA_THREADING_LAYER selects another)"
                )
            except ValueError:  # no parallel region ran (every size below the parallel threshold)
                pass
        for c in choices:
            q, b = float(np.median(quiet[c])), float(np.median(busy[c]))
            print(f"{n:6d} {c:11d} {q:14,.0f} {b:13,.0f} {b / q:11.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument(
        "--sizes",
        type=int,
        nargs="*",
        default=None,
        help="batch sizes (default 1 64 1024 4096; with --busy-core 1024 4096)",
    )
    ap.add_argument("--busy-core", action="store_true", help="the num_threads study, quiet vs one core busy")
    ap.add_argument("--repeats", type=int, default=3, help="--busy-core: alternating repeats")
    args = ap.parse_args()
    if args.busy_core:
        _busy_core_study(args.sizes or [1024, 4096], args.seconds, args.repeats)
        return
    args.sizes = args.sizes or [1, 64, 1024, 4096]
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
