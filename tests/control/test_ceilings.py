"""The ladder of docs/benchmark.md, "What the oracle's privileges are worth": the MPC that tracks its
friction elements, the oracle without foresight of the load, and the MPC given each plant's true
parameters."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401
from cepam_gym.bench.harness import run_suite
from cepam_gym.bench.suites import SUITES
from cepam_gym.control import make_controller


def _actions(name: str, env_kwargs: dict, steps: int, seed: int = 3, env_id="cepam_gym/CEPAM-v1"):
    env = gym.make_vec(env_id, num_envs=3, **env_kwargs)
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


@pytest.mark.slow
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


@pytest.mark.slow
def test_the_known_parameters_mpc_is_the_mpc_on_the_nominal_plant():
    kw = {"task_options": {"load_kinds": ["step"]}}
    np.testing.assert_array_equal(_actions("mpc_known_params", kw, 40), _actions("mpc", kw, 40))


@pytest.mark.slow
def test_the_friction_mpc_is_the_mpc_on_a_plant_without_friction():
    # plant v0 has no friction elements: the balance and the plan are the plain MPC's, bit for bit
    got = _actions("mpc_friction", {}, 40, env_id="cepam_gym/CEPAM-v0")
    np.testing.assert_array_equal(got, _actions("mpc", {}, 40, env_id="cepam_gym/CEPAM-v0"))


@pytest.mark.slow
def test_the_friction_mpc_given_the_true_parameters_is_the_friction_mpc_on_the_nominal_plant():
    kw = {"task_options": {"load_kinds": ["step"]}}
    np.testing.assert_array_equal(
        _actions("mpc_friction_known_params", kw, 40), _actions("mpc_friction", kw, 40)
    )


def test_the_friction_baseline_is_the_baseline_without_friction_and_differs_with_it():
    v0 = {"env_id": "cepam_gym/CEPAM-v0"}
    np.testing.assert_array_equal(
        _actions("baseline_friction", {}, 60, **v0), _actions("baseline", {}, 60, **v0)
    )
    assert not np.array_equal(_actions("baseline_friction", {}, 60), _actions("baseline", {}, 60))


@pytest.mark.slow
def test_the_friction_mpc_tracks_the_plants_friction_deflections():
    from cepam_gym import plant as pl

    env = gym.make_vec("cepam_gym/CEPAM-v1", num_envs=4, task_options={"load_kinds": ["step"]})
    try:
        ctrl = make_controller("mpc_friction", env)
        obs, info = env.reset(seed=11)
        ctrl.reset()
        core, errs, sizes = env.unwrapped.core, [], []
        for _ in range(150):
            a = ctrl.act(obs, info)
            z_true = core.state[:, [pl.S_Z1, pl.S_Z2, pl.S_Z3]]
            errs.append(np.abs(ctrl.friction.z - z_true).max())
            sizes.append(np.abs(z_true).max())
            obs, _r, _te, _tr, info = env.step(a)
    finally:
        env.close()
    # the play operator of the control-step motion against the plant's sub-step motion: the
    # deflections agree to a small share of the largest one (they differ only where the end turns
    # within a control period)
    assert max(sizes) > 1e-5
    assert np.median(errs) < 0.05 * max(sizes)


@pytest.mark.slow
def test_balancing_the_friction_makes_the_mpc_better_on_the_nominal_plant():
    # nominal-v1, 20 episodes: the MPC 0.0783, with its friction tracked 0.0428
    suite = SUITES["nominal-v1"]
    friction, _ = run_suite("mpc_friction", suite, episodes=4)
    plain, _ = run_suite("mpc", suite, episodes=4)
    assert friction["score"] < 0.8 * plain["score"]


@pytest.mark.slow
def test_knowing_the_parameters_makes_the_mpc_better_on_randomized_plants():
    # on randomized-v1 (20 episodes) the MPC scores 0.644, given the true parameters far less
    suite = SUITES["randomized-v1"]
    known, _ = run_suite("mpc_known_params", suite, episodes=4)
    nominal, _ = run_suite("mpc", suite, episodes=4)
    assert known["stiffness_rmse_pct"] < 0.5 * nominal["stiffness_rmse_pct"]
    assert known["score"] < 0.6 * nominal["score"]


@pytest.mark.slow
def test_the_known_parameters_adaptive_mpc_is_the_adaptive_mpc_on_the_nominal_plant():
    kw = {"env_id": "cepam_gym/CEPAM-v3"}
    np.testing.assert_array_equal(
        _actions("adaptive_mpc_known_params", {}, 30, **kw), _actions("adaptive_mpc", {}, 30, **kw)
    )


def test_the_known_parameters_adaptive_mpc_filters_and_plans_with_each_plants_true_row():
    from cepam_gym.bench.suites import SUITES
    from cepam_gym.errors import InputError

    s = SUITES["randomized-v3"]
    env = gym.make_vec(s.env_id, num_envs=3, **s.env_kwargs)
    try:
        with pytest.raises(InputError, match="keys must be empty"):
            make_controller("adaptive_mpc_known_params", env, keys=["bladder_thickness_mm"])
        ctrl = make_controller("adaptive_mpc_known_params", env, population=8, iterations=1)
        obs, info = env.reset(seed=2)
        ctrl.reset()
        ctrl.act(obs, info)
        true_rows = env.unwrapped.core.params
        assert np.abs(true_rows - ctrl.params[None]).max() > 0  # the plants are randomized
        np.testing.assert_array_equal(ctrl._rows, true_rows)
    finally:
        env.close()


@pytest.mark.slow
def test_knowing_the_parameters_makes_the_adaptive_mpc_better_on_randomized_plants():
    suite = SUITES["randomized-v3"]
    known, _ = run_suite("adaptive_mpc_known_params", suite, episodes=2, max_steps=200)
    nominal, _ = run_suite("adaptive_mpc", suite, episodes=2, max_steps=200)
    assert known["score"] < 0.6 * nominal["score"], (known["score"], nominal["score"])
