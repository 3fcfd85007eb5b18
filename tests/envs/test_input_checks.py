"""Reset options and env kwargs are checked for units and ranges, with messages naming them."""

import warnings

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym


@pytest.mark.parametrize(
    "options, pattern",
    [
        ({"target_length": 17.0}, r"target_length is in metres.*\[0.15, 0.195\] m"),
        ({"target_length": 0.1}, r"target_length is in metres"),
        ({"load_mass": -0.1}, r"load_mass must be >= 0 kg"),
        ({"load_mass": 200.0}, r"load_mass is in kg.*200 g is 0.2"),
        ({"target_stiffness": -500.0}, r"target_stiffness must be > 0 N/m"),
        ({"target_stiffness": 0.0}, r"target_stiffness must be > 0 N/m"),
        ({"target_length": float("nan")}, r"target_length must be finite"),
        ({"load_mass": "heavy"}, r"load_mass must be a number"),
    ],
)
def test_reset_options_checked(options, pattern):
    env = gym.make("cepam_gym/CEPAM-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=pattern):
        env.reset(options=options)
    venv = gym.make_vec("cepam_gym/CEPAM-v0", num_envs=2)
    with pytest.raises(ValueError, match=pattern):
        venv.reset(seed=0, options=options)


def test_negative_stiffness_target_cannot_give_positive_reward():
    """It used to be accepted and then rewarded |K - K*| / K* < 0; now the valid pins score <= 0."""
    env = gym.make("cepam_gym/CEPAM-v0")
    env.reset(seed=0, options={"target_stiffness": 800.0, "target_length": 0.17, "load_mass": 0.1})
    for _ in range(20):
        _, r, *_ = env.step(np.array([0.2, 0.1]))
        assert r <= 0


@pytest.mark.parametrize(
    "kwargs, pattern",
    [
        ({"control_dt": 20}, r"control_dt is in seconds"),
        ({"task_options": {"length_range": [15.5, 19.0]}}, r"length_range is in metres"),
        ({"plant": {"end_mass_g": -20}}, r"end_mass must be > 0"),
        ({"task_options": {"load_range": [-0.1, 0.2]}}, r"load_range"),
        ({"task_options": {"stiffness_range": [-100, 200]}}, r"stiffness_range"),
    ],
)
def test_env_kwargs_checked(kwargs, pattern):
    with pytest.raises(ValueError, match=pattern):
        gym.make("cepam_gym/CEPAM-v0", **kwargs)


def test_supply_above_burst_warns():
    with pytest.warns(UserWarning, match=r"supply_pressure \(400 kPa\) is above burst_pressure \(300 kPa\)"):
        gym.make("cepam_gym/CEPAM-v1", plant={"supply_pressure_kpa": 400})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # the newest id's plant: no warning (an older id warns that a newer version exists)
        gym.make(cepam_gym.RECOMMENDED_ID)


def test_joint_env_zero_stiffness_target_refused():
    pytest.importorskip("mujoco")
    env = gym.make("cepam_gym/CEPAMJoint-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="target_stiffness must be > 0"):
        env.reset(options={"target_stiffness": 0.0})
    with pytest.raises(ValueError, match="target_angle is in radians"):
        env.reset(options={"target_angle": 30.0})
    env.reset(options={"target_stiffness": 0.5})
    _, r, *_ = env.step(np.zeros(2))
    assert np.isfinite(r)
