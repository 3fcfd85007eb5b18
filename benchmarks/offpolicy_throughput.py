"""Env-steps and gradient steps per second of SAC and TD3: SB3's learner, the native one, and SBX.

For each algorithm, on the fast config's env, batch and network (``configs/fast_sac_v3.yaml``,
``fast_td3_v3.yaml``), in the same process and interleaved in rounds:

* ``sb3``: stable-baselines3's algorithm through the SB3 ``VecEnv`` adapter (``learner: sb3``);
* ``native``: the native learner (``learner: native``, :mod:`agents.learners.native_offpolicy`): the
  replay buffer filled from the vector env as arrays, SB3's updates in fewer Python calls;
* ``sbx``: SBX (stable-baselines3 in JAX, ``pip install sbx-rl``) through the same adapter as
  ``sb3``, when it is installed (it is not a dependency of the project: run the script in a venv
  that has it);

each timed over ``--steps`` vector steps after a warm-up (compilation, the thread choice), with
``gradient_steps`` updates per vector step and no warm-up phase. The bare vector env is timed in
the same rounds. Printed: medians over the rounds.

Run: ``.venv/bin/python benchmarks/offpolicy_throughput.py`` (options: ``--algorithms``,
``--gradient-steps``, ``--rounds``, ``--steps``).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the agents package from a checkout
sys.path.insert(0, str(Path(__file__).resolve().parent))  # learner_throughput's bare-env timing

from learner_throughput import env_rate  # noqa: E402


def _config(algorithm: str, learner: str, gradient_steps: int):
    from cepam_gym_agents.config.files import TrainConfig, load_config

    base = load_config(f"fast_{algorithm.lower()}_v3").to_dict()
    hp = {**base["hyperparameters"], "learning_starts": 0, "gradient_steps": gradient_steps}
    return TrainConfig.from_dict({**base, "learner": learner, "hyperparameters": hp})


def make_model(algorithm: str, learner: str, gradient_steps: int):
    from cepam_gym_agents.learners.algorithm import hyperparameters, policy, training_class
    from cepam_gym_agents.session.envs import make_train_env, normalize
    from cepam_gym_agents.session.torch_threads import TorchThreads

    cfg = _config(algorithm, "native" if learner == "native" else "sb3", gradient_steps)
    env = normalize(make_train_env(cfg, 0), cfg)
    if learner == "sbx":
        import sbx

        cls = getattr(sbx, algorithm)
        pk = {"net_arch": list(cfg.policy_kwargs["net_arch"])}
        return cls("MlpPolicy", env, seed=0, policy_kwargs=pk, **hyperparameters(cfg.hyperparameters))
    name, pk = policy(algorithm, cfg.policy_kwargs, False, env)
    model = training_class(algorithm, cfg.learner)(
        name, env, seed=0, device="cpu", policy_kwargs=pk, **hyperparameters(cfg.hyperparameters)
    )
    model.torch_threads = TorchThreads(cfg.torch_threads)
    return model


def rate(model, steps: int) -> float:
    n = model.n_envs
    t = time.perf_counter()
    model.learn(steps * n, reset_num_timesteps=False)
    return steps * n / (time.perf_counter() - t)


def main(argv=None) -> None:
    import cepam_gym  # noqa: F401

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--algorithms", nargs="+", default=["SAC", "TD3"])
    p.add_argument("--gradient-steps", type=int, default=2, help="updates per vector step")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--steps", type=int, default=100, help="vector steps per timing")
    a = p.parse_args(argv)
    try:
        import sbx  # noqa: F401

        learners = ("sb3", "native", "sbx")
    except ImportError:
        learners = ("sb3", "native")
    print(
        f"load average at start: {os.getloadavg()[0]:.2f}; {a.gradient_steps} updates per vector step; "
        f"medians of {a.rounds} rounds; learners {', '.join(learners)}"
    )
    print("| algorithm | learner | env-steps/s | gradient steps/s | bare env steps/s |")
    print("|---|---|---|---|---|")
    for algo in a.algorithms:
        models = {k: make_model(algo, k, a.gradient_steps) for k in learners}
        for m in models.values():
            m.learn(10 * m.n_envs)  # warm-up
        cfg = _config(algo, "native", a.gradient_steps)
        rates: dict[str, list[float]] = {k: [] for k in ("env", *learners)}
        for _ in range(a.rounds):
            rates["env"].append(env_rate(cfg.env.id, cfg.env.num_envs, 200))
            for k, m in models.items():
                rates[k].append(rate(m, a.steps))
        env = np.median(rates["env"])
        for k in learners:
            r = float(np.median(rates[k]))
            grad = r / cfg.env.num_envs * a.gradient_steps
            print(f"| {algo} | {k} | {r / 1e3:.1f} k | {grad:.0f} | {env / 1e3:.0f} k |", flush=True)
    print(f"load average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
