"""The privileged ceilings (docs/benchmark.md, "What the oracle's privileges are worth"): the oracle
without foresight of the load, and the MPC given each plant's true parameters."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import cepam_gym  # noqa: F401
from cepam_gym.bench.harness import run_suite
from cepam_gym.bench.suites import SUITES
from cepam_gym.control import make_controller


def _actions(name: str, env_kwargs: dict, steps: int, seed: int = 3) -> np.ndarray:
    env = gym.make_vec("cepam_gym/CEPAM-v1", num_envs=3, **env_kwargs)
    try:
        ctrl = make_controller(name, env)
        obs, info = env.reset(seed=seed)
        ctrl.reset()
        out = []
        for _ in range(steps):
            a = ctrl.act(obs, info)
            out.append(a)
            obs, _r, _te, _tr, info = env.step(a)
        return np.array(out)
    finally:
        env.close()


def test_the_causal_oracle_is_the_oracle_where_the_load_is_constant():
    kw = {"task_options": {"load_kinds": ["constant"]}}
    np.testing.assert_array_equal(_actions("oracle_causal", kw, 30), _actions("oracle", kw, 30))


def test_the_causal_oracle_plans_with_the_current_load_held():
    env = gym.make_vec("cepam_gym/CEPAM-v1", num_envs=4, task_options={"load_kinds": ["step"]})
    try:
        ctrl = make_controller("oracle_causal", env)
        env.reset(seed=5)
        core = env.unwrapped.core
        for _ in range(120):
            _tl, _tk, load, _w = ctrl.horizon()
            np.testing.assert_array_equal(load, np.repeat(core.load[np.arange(4), core.t_idx][:, None], 5, 1))
            env.step(np.zeros((4, 2), dtype=np.float32))
    finally:
        env.close()


def test_the_known_parameters_mpc_is_the_mpc_on_the_nominal_plant():
    kw = {"task_options": {"load_kinds": ["step"]}}
    np.testing.assert_array_equal(_actions("mpc_known_params", kw, 40), _actions("mpc", kw, 40))


def test_knowing_the_parameters_makes_the_mpc_better_on_randomized_plants():
    # on randomized-v1 (20 episodes) the MPC scores 0.644 and with the true parameters 0.185
    suite = SUITES["randomized-v1"]
    known, _ = run_suite("mpc_known_params", suite, episodes=4)
    nominal, _ = run_suite("mpc", suite, episodes=4)
    assert known["stiffness_rmse_pct"] < 0.5 * nominal["stiffness_rmse_pct"]
    assert known["score"] < 0.6 * nominal["score"]
