"""Env-steps per second of PPO training: SB3's learner against the native one, beside the bare env.

For each batch size N, in the same process and interleaved in rounds: the bare vector env stepped
with random actions, SB3's PPO (``learner: sb3``: the SB3 ``VecEnv`` adapter, ``VecMonitor``,
``VecNormalize``) and the native learner (``learner: native``, :mod:`agents.learners.native_ppo`) on the same
hyperparameters and the network of ``configs/fast_ppo.yaml``, each timed over whole
collect-and-train iterations after one warm-up iteration.
Printed: medians over the rounds and the native/SB3 ratio. The share of a training iteration
spent in the gradient steps grows with ``--epochs``: at the default 1 epoch the collection's cost
shows; the load average is printed (another busy process slows all three).

Run: ``.venv/bin/python benchmarks/learner_throughput.py`` (options: ``--algorithm`` (``PPO``,
``RecurrentPPO``: a 32-unit LSTM before the same network), ``--id``, ``--sizes``,
``--n-steps``, ``--epochs``, ``--minibatches``, ``--rounds``, ``--threads``).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the agents package from a checkout


def make_model(
    learner: str, env_id: str, n: int, n_steps: int, epochs: int, minibatches: int, algorithm="PPO"
):
    from cepam_gym_agents.config.files import TrainConfig, load_config
    from cepam_gym_agents.learners.algorithm import hyperparameters, policy, training_class
    from cepam_gym_agents.session.envs import make_train_env, normalize

    pk = dict(load_config("fast_ppo").policy_kwargs)  # the fast config's network
    if algorithm == "RecurrentPPO":
        pk["lstm_hidden_size"] = 32  # one small LSTM layer before it
    cfg = TrainConfig.from_dict(
        {
            "algorithm": algorithm,
            "learner": learner,
            "env": {"id": env_id, "num_envs": n},
            "normalize": {"obs": True, "reward": True},
            "hyperparameters": {
                "n_steps": n_steps,
                "batch_size": n * n_steps // minibatches,
                "n_epochs": epochs,
                "gamma": 0.98,
            },
            "policy_kwargs": pk,
        }
    )
    cls = training_class(algorithm, learner)
    env = normalize(make_train_env(cfg, 0), cfg)
    name, pk = policy(algorithm, cfg.policy_kwargs, False, env)
    return cls(name, env, seed=0, device="cpu", policy_kwargs=pk, **hyperparameters(cfg.hyperparameters))


def learner_rate(model, iterations: int) -> float:
    chunk = model.n_steps * model.n_envs
    t = time.perf_counter()
    model.learn(iterations * chunk, reset_num_timesteps=False)
    return iterations * chunk / (time.perf_counter() - t)


def env_rate(env_id: str, n: int, steps: int) -> float:
    import gymnasium as gym

    venv = gym.make_vec(
        env_id, num_envs=n, vectorization_mode="vector_entry_point", autoreset_mode="same_step"
    )
    venv.reset(seed=0)
    a = np.random.default_rng(0).uniform(-1, 1, (n, *venv.single_action_space.shape))
    for _ in range(5):
        venv.step(a)
    t = time.perf_counter()
    for _ in range(steps):
        venv.step(a)
    return steps * n / (time.perf_counter() - t)


def main(argv=None) -> None:
    import torch

    import cepam_gym  # noqa: F401

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--id", default="cepam_gym/CEPAM-v2")
    p.add_argument("--sizes", type=int, nargs="+", default=[64, 256, 1024, 2048])
    p.add_argument("--n-steps", type=int, default=32)
    p.add_argument("--epochs", type=int, default=1)
    p.add_argument("--minibatches", type=int, default=4)
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--threads", type=int, default=2, help="torch threads")
    p.add_argument("--algorithm", default="PPO", choices=["PPO", "RecurrentPPO"])
    a = p.parse_args(argv)
    torch.set_num_threads(a.threads)
    print(
        f"load average at start: {os.getloadavg()[0]:.2f}; {a.algorithm} on {a.id}, n_steps {a.n_steps}, "
        f"{a.epochs} epoch(s), "
        f"{a.minibatches} minibatches, torch threads {a.threads}"
    )
    print("| envs | bare env steps/s | SB3 learner steps/s | native learner steps/s | native / SB3 |")
    print("|---|---|---|---|---|")
    for n in a.sizes:
        models = {
            k: make_model(k, a.id, n, a.n_steps, a.epochs, a.minibatches, a.algorithm)
            for k in ("sb3", "native")
        }
        iterations = max(1, 65536 // (n * a.n_steps))
        for m in models.values():
            m.learn(m.n_steps * m.n_envs)  # warm-up: the first iteration compiles and allocates
        rates: dict[str, list[float]] = {"env": [], "sb3": [], "native": []}
        for _ in range(a.rounds):
            rates["env"].append(env_rate(a.id, n, max(20, 16384 // n)))
            for k, m in models.items():
                rates[k].append(learner_rate(m, iterations))
        med = {k: float(np.median(v)) for k, v in rates.items()}
        print(
            f"| {n} | {med['env'] / 1e3:.0f} k | {med['sb3'] / 1e3:.1f} k | {med['native'] / 1e3:.1f} k | "
            f"{med['native'] / med['sb3']:.2f} |",
            flush=True,
        )
    print(f"load average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
