"""The fast learner beside a second busy process: how much of its quiet speed it keeps, beside the
bare env's.

A 2-core machine with one core taken by another job (a second training run, a compile) is where
new users train. The env's step kernel picks its thread count while it runs
(:mod:`cepam_gym.envs.threads`); this script measures what is left to the learner's torch threads.
For each torch thread setting of ``--threads`` (an integer, or ``auto``: the trainer's default,
chosen while it runs), in the same process and interleaved in rounds: the native PPO learner of
``--config`` (its env, batch and network) timed over whole collect-and-train iterations, and the
bare vector env stepped with random actions, each once on the quiet machine and once beside a
process that keeps one core busy (pure Python arithmetic, started and stopped by this script).

Printed: medians over the rounds; "kept" is the loaded figure over the quiet one. The goal:
the learner keeps at least the bare env's fraction.

Run: ``.venv/bin/python benchmarks/learner_under_load.py`` (options: ``--config``, ``--threads``,
``--rounds``, ``--iterations``).
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the agents package from a checkout


def _spin(stop) -> None:  # the second busy process: one core of pure Python
    x = 0
    while not stop.is_set():
        for i in range(100_000):
            x = (x + i * i) % 1_000_003


class Busy:
    """A process keeping one core busy inside the ``with`` block."""

    def __enter__(self):
        self.stop = mp.Event()
        self.proc = mp.Process(target=_spin, args=(self.stop,), daemon=True)
        self.proc.start()
        time.sleep(0.5)
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.proc.join(5)
        if self.proc.is_alive():
            self.proc.kill()


def make_model(config: str, threads: str):
    from cepam_gym_agents.config.files import load_config
    from cepam_gym_agents.learners.algorithm import training_class
    from cepam_gym_agents.session.torch_threads import TorchThreads
    from cepam_gym_agents.session.trainer import build_train_env, new_model

    cfg = load_config(config)
    _, model = new_model(cfg, training_class(cfg.algorithm, cfg.learner), build_train_env(cfg, 0))
    model.torch_threads = TorchThreads(threads if threads == "auto" else int(threads))  # as the trainer
    return cfg, model


def learner_rate(model, iterations: int) -> float:
    chunk = model.n_steps * model.n_envs
    t = time.perf_counter()
    model.learn(iterations * chunk, reset_num_timesteps=False)
    return iterations * chunk / (time.perf_counter() - t)


def env_rate(env_id: str, n: int, seconds: float = 2.0) -> float:
    import gymnasium as gym

    venv = gym.make_vec(
        env_id, num_envs=n, vectorization_mode="vector_entry_point", autoreset_mode="same_step"
    )
    venv.reset(seed=0)
    a = np.random.default_rng(0).uniform(-1, 1, (n, *venv.single_action_space.shape))
    for _ in range(50):  # warm-up, and the thread choice settles
        venv.step(a)
    steps, t = 0, time.perf_counter()
    while time.perf_counter() - t < seconds:
        venv.step(a)
        steps += 1
    return steps * n / (time.perf_counter() - t)


def main(argv=None) -> None:
    import cepam_gym  # noqa: F401

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--config", default="fast_ppo_v3")
    p.add_argument("--threads", nargs="+", default=["1", "2", "auto"], help="torch threads: integers or auto")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--iterations", type=int, default=8, help="collect-and-train iterations per timing")
    a = p.parse_args(argv)
    print(
        f"load average at start: {os.getloadavg()[0]:.2f}; {a.config}; {os.cpu_count()} cores; "
        f"medians of {a.rounds} rounds"
    )
    models = {}
    for t in a.threads:
        cfg, m = make_model(a.config, t)
        m.learn(m.n_steps * m.n_envs)  # warm-up: compilation and allocation
        models[t] = m
    env_id, n = cfg.env.id, cfg.env.num_envs
    rates: dict[tuple[str, bool], list[float]] = {}
    for _ in range(a.rounds):
        for loaded in (False, True):
            ctx = Busy() if loaded else None
            if ctx:
                ctx.__enter__()
            try:
                rates.setdefault(("env", loaded), []).append(env_rate(env_id, n))
                for t, m in models.items():
                    m.torch_threads.apply(m.torch_threads.now())  # torch's count is per process
                    rates.setdefault((t, loaded), []).append(learner_rate(m, a.iterations))
            finally:
                if ctx:
                    ctx.__exit__(None, None, None)
    print("| | quiet steps/s | beside a busy process | kept |")
    print("|---|---|---|---|")
    for key in ["env", *a.threads]:
        q, b = float(np.median(rates[(key, False)])), float(np.median(rates[(key, True)]))
        name = f"bare env, {n} envs" if key == "env" else f"learner, torch threads {key}"
        print(f"| {name} | {q / 1e3:.1f} k | {b / 1e3:.1f} k | {b / q:.2f} |", flush=True)
    print(f"load average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
