"""A trained model is loaded with the observation normalisation it was trained with, whatever
layout it comes in (a run of cepam-gym train, RL Zoo3's, a bare SB3 .zip with SB3's file
names), or refused in one line: never scored on raw observations without a word."""

from __future__ import annotations

import shutil
import warnings
from collections import OrderedDict

import gymnasium as gym
import numpy as np
import pytest
import yaml

pytest.importorskip("stable_baselines3")

import cepam_gym  # noqa: E402, F401
from cepam_gym.errors import InputError  # noqa: E402

ID = "cepam_gym/CEPAM-v2"


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    """An (untrained) PPO model and VecNormalize statistics far from the identity."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    root = tmp_path_factory.mktemp("models")
    model = PPO("MlpPolicy", gym.make(ID), n_steps=8, batch_size=8, policy_kwargs={"net_arch": [8]}, seed=0)
    model.save(str(root / "agent.zip"))
    vn = VecNormalize(DummyVecEnv([lambda: gym.make(ID)]), norm_reward=False)
    rng = np.random.default_rng(0)
    vn.obs_rms.mean = rng.uniform(-1, 1, vn.obs_rms.mean.shape)
    vn.obs_rms.var = rng.uniform(0.05, 0.2, vn.obs_rms.var.shape)
    vn.save(str(root / "stats.pkl"))
    return root, model, vn


def _venv_obs():
    venv = gym.make_vec(ID, num_envs=3)
    obs, _ = venv.reset(seed=1)
    return venv, obs


def _layout(tmp_path, saved, model_name: str, stats_name: str | None):
    root, _, _ = saved
    (tmp_path / model_name).parent.mkdir(parents=True, exist_ok=True)
    shutil.copy(root / "agent.zip", tmp_path / model_name)
    if stats_name is not None:
        (tmp_path / stats_name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(root / "stats.pkl", tmp_path / stats_name)
    return tmp_path / model_name


@pytest.mark.parametrize(
    "model_name, stats_name",
    [
        ("agent.zip", "vec_normalize.pkl"),  # SB3's documentation
        ("rl_model_100_steps.zip", "rl_model_vecnormalize_100_steps.pkl"),  # SB3's CheckpointCallback
        ("model.zip", "vecnormalize.pkl"),  # cepam-gym train
    ],
)
def test_a_bare_model_acts_through_the_statistics_beside_it(tmp_path, saved, model_name, stats_name):
    from cepam_gym_agents.policy import load_policy

    _, model, vn = saved
    path = _layout(tmp_path, saved, model_name, stats_name)
    venv, obs = _venv_obs()
    pol = load_policy(path, venv)
    want, _ = model.predict(vn.normalize_obs(obs.astype(np.float32)), deterministic=True)
    raw, _ = model.predict(obs, deterministic=True)
    np.testing.assert_allclose(pol.act(obs), want, atol=1e-6)
    assert not np.allclose(want, raw, atol=1e-3)  # the statistics change the actions


def test_a_run_directory_that_normalised_is_refused_without_its_statistics(tmp_path, saved):
    from cepam_gym_agents.policy import load_policy

    cfg = {"algorithm": "PPO", "env": {"id": ID}, "normalize": {"obs": True}}
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(cfg))
    _layout(tmp_path, saved, "model.zip", "vec_normalize.pkl")  # SB3's name in our run directory
    venv, obs = _venv_obs()
    assert load_policy(tmp_path, venv).normalizer is not None
    (tmp_path / "vec_normalize.pkl").unlink()
    with pytest.raises(InputError, match=r"normalize\.obs in .*config\.yaml.*refusing") as e:
        load_policy(tmp_path, venv)
    assert "\n" not in str(e.value)


def _zoo_run(tmp_path, saved, normalize):
    """RL Zoo3's layout: <env name>.zip beside <env name>/{args,config}.yml (OrderedDict dumps)."""
    name = "cepam_gym-CEPAM-v2"
    _layout(tmp_path, saved, f"{name}.zip", f"{name}/vecnormalize.pkl")
    (tmp_path / name / "args.yml").write_text(yaml.dump(OrderedDict([("algo", "ppo"), ("env", ID)])))
    config = OrderedDict([("normalize", normalize), ("policy", "MlpPolicy")])
    (tmp_path / name / "config.yml").write_text(yaml.dump(config))
    return tmp_path / name


def test_an_rl_zoo_run_loads_with_its_statistics_and_names_its_env(tmp_path, saved):
    from cepam_gym_agents.evaluate import trained_env_id
    from cepam_gym_agents.policy import load_policy, locate

    params = _zoo_run(tmp_path, saved, "{'norm_obs': True, 'norm_reward': True}")
    venv, obs = _venv_obs()
    for spec in (tmp_path, tmp_path / "cepam_gym-CEPAM-v2.zip"):
        assert load_policy(spec, venv).normalizer is not None
    files = locate(tmp_path)
    assert files.env_id() == ID and trained_env_id(files, None) == ID
    with pytest.raises(InputError, match="was trained on cepam_gym/CEPAM-v2"):
        trained_env_id(files, "cepam_gym/CEPAM-v1")
    (params / "vecnormalize.pkl").unlink()
    with pytest.raises(InputError, match=r"normalize in .*config\.yml.*refusing"):
        load_policy(tmp_path, venv)


def test_a_bare_model_without_statistics_says_so_and_needs_its_env_id(tmp_path, saved):
    from cepam_gym_agents.evaluate import trained_env_id
    from cepam_gym_agents.policy import load_policy, locate

    path = _layout(tmp_path, saved, "agent.zip", None)
    venv, obs = _venv_obs()
    with pytest.warns(UserWarning, match="raw observations"):
        pol = load_policy(path, venv)
    assert pol.normalizer is None
    with pytest.raises(InputError, match="--env-id is needed"):
        trained_env_id(locate(path), None)
    assert trained_env_id(locate(path), ID) == ID
    # a record that says the model was trained without: no note
    _zoo_run(tmp_path / "zoo", saved, False)
    (tmp_path / "zoo" / "cepam_gym-CEPAM-v2" / "vecnormalize.pkl").unlink()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert load_policy(tmp_path / "zoo", venv).normalizer is None


def test_the_algorithm_of_a_bare_model_is_read_from_its_zip(tmp_path, saved):
    from stable_baselines3 import SAC

    from cepam_gym_agents.session.model_files import algorithm_of

    root, _, _ = saved
    assert algorithm_of(root / "agent.zip") == "PPO"
    SAC("MlpPolicy", gym.make(ID), buffer_size=10, policy_kwargs={"net_arch": [8]}).save(str(tmp_path / "s"))
    assert algorithm_of(tmp_path / "s.zip") == "SAC"
    (tmp_path / "junk.zip").write_bytes(b"not a zip")
    with pytest.raises(InputError, match="cannot load the SB3 model"):
        algorithm_of(tmp_path / "junk.zip")
