"""Env steps per second of the CE-PAM ids, as ratios against references measured in the same run.

Usage: python benchmarks/throughput.py [--repeats 5] [--all] [--busy-core]

The default prints the speed table of docs/results/speed.md, every row a median of ``--repeats``
runs that take turns
(so a burst of load from another process on a shared machine hits all of them alike):

* ``CEPAM-v1`` batched (1024 envs, zero actions, whole 500-step episodes, the autoreset step
  included) against ``CEPAM-v0`` run the same way;
* ``CEPAM-v1`` between resets (the same runs, the reset steps left out);
* one v1 reset of 1024 envs (``core.reset()``, as an autoreset of all envs pays it), per env and in
  env-steps of the v1 rate between resets;
* single ``CEPAM-v1`` (``gym.make``, its wrappers, reset whenever an episode ends) against
  Gymnasium's ``Pendulum-v1``, the two taking turns in short rounds;
* ``CEPAMJoint-v1`` batched (256 envs, resets included), also against ``CEPAM-v0``.

``--all`` adds every id, single and batched (64, 1024, 4096 envs), against ``Pendulum-v1``.

``--busy-core`` measures the batched kernel's thread choice: env-steps/s between resets at each
``num_threads`` (the default ``None``, which picks the fastest count while it runs, then 1 and
every core), first on the machine as it is, then with one core kept busy by a spinning process (as
in training, where the learner takes a core); prints the busy/quiet ratio of each and what the
default keeps of the best setting's speed with the core busy.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

import gymnasium as gym
import numba
import numpy as np

import cepam_gym

EPISODE = 500  # the registered max_episode_steps


def _load() -> str:
    return "load average {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())


# ----------------------------------------------------------------------------- batched
class _Batch:
    """A batched env stepped with zero actions over whole episodes; one :meth:`run` times
    ``episodes`` episodes (each 500 steps and its autoreset step)."""

    def __init__(self, env_id: str, num_envs: int, **kwargs):
        self.env = gym.make_vec(env_id, num_envs=num_envs, **kwargs)
        self.n = num_envs
        self.env.reset(seed=0)
        self.a = np.zeros((num_envs, 2))
        self.with_resets: list[float] = []
        self.between: list[float] = []
        self.run(1, record=False)  # warm-up: compilation, the thread choice settles

    def run(self, episodes: int, record: bool = True) -> None:
        step, a = self.env.step, self.a
        t_all, t_reset, steps = 0.0, 0.0, 0
        for _ in range(episodes):
            while True:
                t0 = time.perf_counter()
                _, _, te, tr, _ = step(a)
                t_all += time.perf_counter() - t0
                steps += 1
                if te.any() or tr.any():
                    break
            t0 = time.perf_counter()
            step(a)  # next-step autoreset: this call resets every env (its action is ignored)
            dt = time.perf_counter() - t0
            t_all += dt
            t_reset += dt
        if record:  # env-steps: the episodes' transitions (the reset calls count as time only)
            self.with_resets.append(self.n * steps / t_all)
            self.between.append(self.n * steps / (t_all - t_reset))


def _reset_time(batch: _Batch, repeats: int) -> float:
    """Median seconds of ``core.reset()`` on every env of ``batch`` (no reseeding, as an
    autoreset)."""
    core = batch.env.unwrapped.core
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        core.reset()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


# ----------------------------------------------------------------------------- single
class _Single:
    """A single env (``gym.make``, with its wrappers) stepped with fixed random actions in timed
    rounds; an ended episode is reset inside the round."""

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


def _singles(env_ids, seconds: float, rounds: int) -> dict[str, float]:
    """Median steps/s of each env over ``rounds`` rounds, the envs taking turns in each."""
    envs = {env_id: _Single(env_id) for env_id in env_ids}
    for _ in range(rounds):
        for e in envs.values():
            e.round(seconds / rounds)
    return {env_id: e.rate() for env_id, e in envs.items()}


# ----------------------------------------------------------------------------- the table
def _row(what: str, value: str, ratio: str, goal: str) -> None:
    print(f"| {what} | {value} | {ratio} | {goal} |")


def issue_table(repeats: int, single_seconds: float) -> None:
    v0 = _Batch("cepam_gym/CEPAM-v0", 1024)
    v1 = _Batch("cepam_gym/CEPAM-v1", 1024)
    joint = _Batch("cepam_gym/CEPAMJoint-v1", 256)
    for _ in range(repeats):
        for b in (v0, v1, joint):
            b.run(2 if b is joint else 1)
    med = {
        k: (float(np.median(b.with_resets)), float(np.median(b.between)))
        for k, b in (("v0", v0), ("v1", v1), ("joint", joint))
    }
    reset = _reset_time(v1, repeats)
    reset_v0 = _reset_time(v0, repeats)
    singles = _singles(
        ["Pendulum-v1", "cepam_gym/CEPAM-v0", "cepam_gym/CEPAM-v1"], single_seconds, 2 * repeats
    )
    v0_all, v0_between = med["v0"]
    v1_all, v1_between = med["v1"]
    pend = singles["Pendulum-v1"]
    threads = numba.config.NUMBA_NUM_THREADS
    print(f"medians of {repeats} alternating runs; {_load()}; NUMBA_NUM_THREADS={threads}")
    print("| row | measured | ratio (same run) | goal |")
    print("|---|---|---|---|")
    _row("CEPAM-v0 batched 1024, resets included (reference)", f"{v0_all / 1e6:.2f} M/s", "1.00", "")
    _row(
        "CEPAM-v1 batched 1024, resets included",
        f"{v1_all / 1e6:.2f} M/s",
        f"{v1_all / v0_all:.2f} x v0",
        ">= 0.8 x v0",
    )
    _row(
        "CEPAM-v1 between resets",
        f"{v1_between / 1e6:.2f} M/s",
        f"{v1_between / v0_between:.2f} x v0 between",
        "keep",
    )
    _row(
        "one v1 reset (1024 envs)",
        f"{reset / 1024 * 1e6:.1f} us per env",
        f"{reset / 1024 * v1_between:.0f} env-steps (v0's: {reset_v0 / 1024 * v0_between:.0f})",
        "<= 100 env-steps",
    )
    _row("Pendulum-v1 single (reference)", f"{pend / 1e3:.0f} k/s", "1.00", "")
    s0, s1 = singles["cepam_gym/CEPAM-v0"], singles["cepam_gym/CEPAM-v1"]
    _row(
        "CEPAM-v0 single (gym.make, resets included)",
        f"{s0 / 1e3:.0f} k/s",
        f"{s0 / pend:.2f} x Pendulum",
        "",
    )
    _row(
        "CEPAM-v1 single (gym.make, resets included)",
        f"{s1 / 1e3:.0f} k/s",
        f"{s1 / pend:.2f} x Pendulum",
        ">= 1.5 x",
    )
    j_all, j_between = med["joint"]
    _row(
        "CEPAMJoint-v1 batched 256, resets included",
        f"{j_all / 1e3:.0f} k/s (between resets {j_between / 1e3:.0f} k)",
        f"{j_all / v0_all:.2f} x v0 1024",
        ">= 1 M",
    )
    choice = getattr(getattr(v1.env.unwrapped.core, "threads", None), "choice", None)
    if choice is not None:
        ran = f"{choice.current} thread(s) at the end; {choice.trials} trials of other counts"
        print(f"(the v1 batch ran on {ran})")


def every_id(sizes, seconds: float, repeats: int) -> None:
    singles = _singles(["Pendulum-v1", *cepam_gym.ENV_IDS], seconds, 2 * repeats)
    ref = singles["Pendulum-v1"]
    print(f"{'env':30s} {'mode':>11s} {'steps/s':>11s} {'x Pendulum-v1':>14s} {'between resets':>15s}")
    print(f"{'Pendulum-v1':30s} {'single':>11s} {ref:11,.0f} {1.0:14.2f}")
    for env_id in cepam_gym.ENV_IDS:
        s = singles[env_id]
        print(f"{env_id:30s} {'single':>11s} {s:11,.0f} {s / ref:14.2f}")
        for n in sizes:
            b = _Batch(env_id, n)
            for _ in range(repeats):
                b.run(1)
            rate, between = float(np.median(b.with_resets)), float(np.median(b.between))
            print(f"{env_id:30s} {'batch ' + str(n):>11s} {rate:11,.0f} {rate / ref:14.2f} {between:15,.0f}")


# ----------------------------------------------------------------------------- threads
def _steady(env_id: str, num_envs: int, seconds: float, num_threads) -> float:
    """Env-steps/s of the batched env between resets (no episode ends in the timed steps), after
    100 steps of warm-up (compilation; the default's first trials of each thread count, whose
    first parallel call also starts the thread pool: about 20 ms once beside a busy core)."""
    env = gym.make_vec(env_id, num_envs=num_envs, num_threads=num_threads, max_episode_steps=None)
    env.reset(seed=0)
    a = np.zeros((num_envs, 2))
    for _ in range(100):
        env.step(a)
    steps, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        env.step(a)
        steps += 1
    return num_envs * steps / (time.perf_counter() - t0)


def busy_core_study(sizes, seconds: float, repeats: int) -> None:
    top = numba.config.NUMBA_NUM_THREADS
    choices = [None, *sorted({1, top})]
    env_id = "cepam_gym/CEPAM-v1"
    print(f"batched {env_id}, steps between resets, median of {repeats}; NUMBA_NUM_THREADS={top}; {_load()}")
    print("| envs | num_threads | quiet steps/s | one core busy | busy / quiet |")
    print("|---|---|---|---|---|")
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
        q = {c: float(np.median(quiet[c])) for c in choices}
        b = {c: float(np.median(busy[c])) for c in choices}
        for c in choices:
            name = "None (default)" if c is None else str(c)
            print(f"| {n} | {name} | {q[c]:,.0f} | {b[c]:,.0f} | {b[c] / q[c]:.2f} |")
        best_busy = max(b[c] for c in choices if c is not None)
        best_quiet = max(q[c] for c in choices if c is not None)
        print(
            f"| {n} | default / best | {q[None] / best_quiet:.2f} | {b[None] / best_busy:.2f} | "
            "(goal: >= 0.90 with the core busy) |"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument(
        "--seconds", type=float, default=2.0, help="single envs: total time each; --busy-core: per run"
    )
    ap.add_argument("--all", action="store_true", help="also every id, single and batched")
    ap.add_argument("--sizes", type=int, nargs="*", default=None)
    ap.add_argument("--busy-core", action="store_true", help="the num_threads study, quiet vs one core busy")
    args = ap.parse_args()
    if args.busy_core:
        busy_core_study(args.sizes or [256, 1024], args.seconds, args.repeats)
        return
    issue_table(args.repeats, args.seconds)
    if args.all:
        every_id(args.sizes or [64, 1024, 4096], args.seconds, args.repeats)


if __name__ == "__main__":
    main()
