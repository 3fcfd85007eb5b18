"""The plant model an env declares to its controllers (:mod:`cepam_gym.envs.model`): what it
exposes, that it is found through wrappers and vector adapters, that it is read-only and live,
and that controllers read the env through it only."""

from __future__ import annotations

import copy
import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym import plant as pl
from cepam_gym.control import make_controller
from cepam_gym.control.baseline import UnsupportedEnvError
from cepam_gym.envs import EnvModel, NoModelError, model_of
from cepam_gym.envs import step_kernel as tk
from cepam_gym.plant.params import PlantParams

SRC = Path(__file__).resolve().parents[2] / "src" / "cepam_gym"


def test_fixed_facts_follow_the_env_kwargs():
    env = gym.make("cepam_gym/CEPAM-v1", action_mode="pressure", control_dt=0.025, episode_seconds=5.0)
    m = model_of(env)
    assert m is env.unwrapped.env_model and isinstance(m, EnvModel)
    assert (m.num_envs, m.mech, m.action_mode) == (1, pl.RIG, "pressure")
    assert m.mode != model_of(gym.make("cepam_gym/CEPAM-v1")).mode  # the kernel's code of the mode
    assert (m.control_dt, m.n_steps) == (0.025, 200)
    assert m.n_sub * m.sub_dt == pytest.approx(m.control_dt)
    assert m.obs_dim == env.observation_space.shape[0] == m.obs_layout.size
    assert m.preview_steps == 10 and m.track_stiffness
    assert isinstance(m.nominal, PlantParams) and m.setpoint_max == m.nominal.pressure_cap
    assert m.task_spec.name == "cepam_v1"
    with pytest.raises(AttributeError):  # frozen
        m.control_dt = 0.01


def test_task_and_mechanism_are_declared():
    assert not model_of(gym.make("cepam_gym/CEPAMLength-v1")).track_stiffness
    assert model_of(gym.make("cepam_gym/CEPAM-v0")).preview_steps == 0
    joint = model_of(gym.make_vec("cepam_gym/CEPAMJoint-v1", num_envs=2))
    assert joint.mech == pl.HINGE and joint.num_envs == 2
    assert joint.hinge.shape == (1, tk.N_HINGE) and joint.hinge[0, tk.H_R] == pytest.approx(0.025)


def test_privileged_facts_are_live_read_only_views():
    venv = gym.make_vec("cepam_gym/CEPAM-v1", num_envs=3, randomize={"end_mass_g": [15.0, 25.0]})
    m = model_of(venv)
    _obs, info = venv.reset(seed=3)
    assert not np.array_equal(m.params[0], m.params[1])  # each env's true (randomized) row
    assert not np.array_equal(m.params[0], m.nominal.to_array())
    state = m.state
    before = state.copy()
    np.testing.assert_array_equal(m.t_idx, 0)
    _obs, _r, _te, _tr, info = venv.step(np.ones((3, 2), np.float32))
    assert not np.array_equal(state, before)  # a view: it follows the env
    np.testing.assert_array_equal(m.t_idx, 1)
    np.testing.assert_array_equal(m.state[:, pl.S_L], info["length"])
    np.testing.assert_array_equal(m.target_l[:, 0], info["target_length"])  # the step just scored
    np.testing.assert_array_equal(m.current_targets()[0], m.target_l[:, 1])  # the step to come
    for name in ("params", "state", "aux", "target_l", "target_k", "load", "t_idx", "hinge"):
        arr = getattr(m, name)
        with pytest.raises(ValueError, match="read-only"):
            arr[...] = 0


def test_a_copy_of_the_env_has_its_own_model():
    env = gym.make("cepam_gym/CEPAM-v1").unwrapped
    env.reset(seed=0)
    clone = copy.deepcopy(env)
    assert model_of(clone) is not model_of(env)
    clone.step(np.ones(2, np.float32))
    assert model_of(clone).t_idx[0] == 1 and model_of(env).t_idx[0] == 0


def test_found_through_gymnasium_wrappers():
    env = gym.wrappers.RecordEpisodeStatistics(gym.wrappers.ClipAction(gym.make("cepam_gym/CEPAM-v1")))
    assert model_of(env) is env.unwrapped.env_model
    venv = gym.wrappers.vector.RecordEpisodeStatistics(gym.make_vec("cepam_gym/CEPAM-v1", num_envs=2))
    assert model_of(venv).num_envs == 2


def test_found_through_the_sb3_adapter_and_vecenv_wrappers():
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.vec_env import VecNormalize

    from cepam_gym.integrations.sb3 import make_sb3_vec_env

    venv = VecNormalize(make_sb3_vec_env("cepam_gym/CEPAM-v1", num_envs=2))
    m = model_of(venv)
    assert m.num_envs == 2 and m is venv.unwrapped.venv.env_model


def test_an_env_without_the_kernel_has_no_model():
    env = gym.make("Pendulum-v1")
    with pytest.raises(NoModelError, match="'Pendulum-v1' does not run on the batched kernel"):
        model_of(env)
    assert issubclass(NoModelError, TypeError)
    for name in ("mpc", "oracle", "mpc_known_params"):  # the benchmark skips such pairs
        with pytest.raises(UnsupportedEnvError):
            make_controller(name, env)


def test_the_mujoco_joint_has_no_model():
    pytest.importorskip("mujoco")
    env = gym.make("cepam_gym/CEPAMJoint-v0")
    with pytest.raises(NoModelError, match="CEPAMJoint-v0"):
        model_of(env)
    with pytest.raises(UnsupportedEnvError, match="rig envs only"):
        make_controller("mpc", env)
    with pytest.raises(UnsupportedEnvError, match="batched kernel"):
        make_controller("oracle", env)


def test_controllers_read_the_env_through_its_model_only():
    """No module of ``control`` digs the batched core out of an env or reads its attributes."""
    bad = []
    for path in sorted((SRC / "control").glob("*.py")):
        for n, line in enumerate(path.read_text().splitlines(), 1):
            if re.search(r"\bcore\.[a-z_]|find_core|\.core\b", line):
                bad.append(f"{path.name}:{n}: {line.strip()}")
    assert bad == []
