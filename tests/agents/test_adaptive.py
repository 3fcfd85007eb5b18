"""The adaptive agent (``agent.plant_features``): trained on the true plant's parameter columns,
deployed on the fit of its episode's identification window (the one ``identify_mpc`` runs)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

import cepam_gym  # noqa: E402, F401  (registers the ids)
from cepam_gym.bench.suites import RANDOMIZE_V2  # noqa: E402
from cepam_gym.control import make_controller  # noqa: E402
from cepam_gym.control.baseline import UnsupportedEnvError, rig_model_of  # noqa: E402
from cepam_gym.identify.window_identifier import plant_columns, plant_dim  # noqa: E402
from cepam_gym.physics import layout as ix  # noqa: E402
from cepam_gym.policies import Features, FeatureSpec  # noqa: E402
from cepam_gym_agents.config.agent import feature_spec  # noqa: E402
from cepam_gym_agents.config.files import AgentConfig, TrainConfig  # noqa: E402

CFG = AgentConfig(history=2, setpoint_gaps_in_obs=True, plant_features=True)


def _window_env(n: int, seconds: float):
    return gym.make_vec(
        "cepam_gym/CEPAM-v2", num_envs=n, task_options={"id_window_s": seconds}, randomize=RANDOMIZE_V2
    )


def test_plant_columns_are_zero_on_the_nominal_plant_and_never_tell_the_load():
    venv = gym.make_vec("cepam_gym/CEPAM-v2", num_envs=4, randomize=RANDOMIZE_V2)
    venv.reset(seed=3)
    model = rig_model_of(venv)
    nominal = model.nominal
    assert not plant_columns(nominal.to_array()[None], nominal).any()
    cols = plant_columns(model.params, nominal)
    assert cols.shape == (4, plant_dim(nominal)) and cols.dtype == np.float32
    assert (np.abs(cols) > 1e-3).sum(axis=1).min() >= 10  # every randomized plant differs in many
    # the guide's Coulomb friction (nominal 0, randomized) is told too: in units of its tolerance
    np.testing.assert_allclose(cols[:, -1], np.clip(model.params[:, ix.F_COUL] / 0.5, -2, 2), rtol=1e-6)
    heavier = np.array(model.params)
    heavier[:, ix.M_END] *= 3.0  # a load rides on the end mass: the columns must not carry it
    np.testing.assert_array_equal(plant_columns(heavier, nominal), cols)
    venv.close()


def test_training_features_tell_the_true_plant():
    venv = gym.make_vec("cepam_gym/CEPAM-v2", num_envs=3, randomize=RANDOMIZE_V2)
    obs, _ = venv.reset(seed=2)
    model = rig_model_of(venv)
    f = Features(venv, feature_spec(CFG), obs.shape[1])
    f.use_true_plant()
    x, _ = f(obs)
    k = plant_dim(model.nominal)
    assert f.actor_dim == f.frame_dim * 2 + k == x.shape[1]
    np.testing.assert_array_equal(x[:, -k:], plant_columns(model.params, model.nominal))
    assert f.window is None  # training: no identification, the env's actions are the policy's
    venv.close()


@pytest.mark.parametrize(
    "changes, words",
    [
        (
            {"eval": {"suite": "randomized-v2"}},
            "eval.suite must start its episodes with an identification window",
        ),
        ({"eval": {}}, "got None"),
        ({"student": {"suites": {"randomized-id-v2": 4}}}, "student.suites.randomized-id-v2 start episodes"),
        ({"env": {"id": "cepam_gym/CEPAM-v2", "suite": "randomized-id-v2"}}, "env start episodes"),
        ({"algorithm": "RecurrentPPO", "student": None}, "recurrent policy"),
    ],
)
def test_a_config_told_the_plant_trains_without_a_window_and_evaluates_behind_one(changes, words):
    from cepam_gym_agents.config.files import ConfigError

    base = {
        "algorithm": "PPO",
        "env": {"id": "cepam_gym/CEPAM-v2", "suite": "randomized-v2"},
        "normalize": {"obs": True},
        "agent": {"plant_features": True},
        "student": {"suites": {"randomized-v2": 4}},
        "eval": {"suite": "randomized-id-v2"},
    }
    TrainConfig.from_dict(base)  # the shipped recipe's shape passes
    bad = {k: v for k, v in {**base, **changes}.items() if v is not None}
    with pytest.raises(ConfigError, match=words):
        TrainConfig.from_dict(bad)


def test_deployed_it_needs_an_identification_window():
    venv = gym.make_vec("cepam_gym/CEPAM-v2", num_envs=1)
    obs, _ = venv.reset(seed=0)
    f = Features(venv, feature_spec(CFG), obs.shape[1])
    with pytest.raises(UnsupportedEnvError, match="plant_features.*id_window_s"):
        f(obs)
    venv.close()


def _agent(tmp_path, venv):
    """A saved student with random weights on ``venv``'s features (the format a run loads)."""
    import torch

    from cepam_gym_agents.config.files import dump_config
    from cepam_gym_agents.learners.student import _Actor, as_ppo
    from cepam_gym_agents.policy import load_policy
    from cepam_gym_agents.session.checkpoints import save_model

    cfg = TrainConfig.from_dict(
        {
            "algorithm": "PPO",
            "env": {"id": "cepam_gym/CEPAM-v2", "num_envs": 2, "suite": "randomized-v2"},
            "normalize": {"obs": True},
            "agent": {"history": 2, "setpoint_gaps_in_obs": True, "plant_features": True},
            "student": {"suites": {"randomized-v2": 2}, "net_arch": [16, 16]},
            "eval": {"suite": "randomized-id-v2"},
        }
    )
    obs_dim = venv.observation_space.shape[1]
    dim = Features(venv, feature_spec(cfg.agent), obs_dim).actor_dim
    rng = np.random.default_rng(0)
    actor = _Actor(dim, [16, 16], seed=0)
    with torch.no_grad():
        for p in actor.params:
            p.add_(torch.as_tensor(rng.normal(0, 0.3, tuple(p.shape)), dtype=torch.float32))
    model, vecnorm = as_ppo(cfg, actor, np.zeros(dim), np.ones(dim), np.array([0.05, 0.05]), seed=0)
    save_model(tmp_path, "final", model, vecnorm)
    dump_config(cfg, tmp_path / "config.yaml")
    return load_policy(tmp_path, venv, "final")


def test_deployed_it_plays_identify_mpcs_window_and_is_told_its_fit(tmp_path):
    """In the window the agent sends identify_mpc's excitation (command for command, on the same
    episodes); at the tracking's start it is told the same fit, its frames begin afresh, and it
    drives the valves itself."""
    ours, theirs = _window_env(2, 1.5), _window_env(2, 1.5)
    policy = _agent(tmp_path, ours)
    ident = make_controller("identify_mpc", theirs)
    obs, _ = ours.reset(seed=4)
    obs2, _ = theirs.reset(seed=4)
    policy.reset()
    window = ident.window
    for _ in range(window):
        a, b = policy.act(obs), ident.act(obs2)
        np.testing.assert_array_equal(a, b)
        obs, *_ = ours.step(a)
        obs2, *_ = theirs.step(b)
    a, b = policy.act(obs), ident.act(obs2)  # the first tracking step: both fit their windows
    features = policy.features
    nominal = rig_model_of(ours).nominal
    fitted = plant_columns(ident.identifier.rows, nominal)
    np.testing.assert_allclose(plant_columns(features.identifier.rows, nominal), fitted, rtol=0, atol=1e-6)
    assert np.abs(fitted).max() > 1e-3  # the fit moved off the nominal plant
    assert not features.window[0].any() and not np.allclose(a, b)  # the agent acts, not the MPC
    # the history restarted at the tracking's start: two copies of its first frame
    np.testing.assert_array_equal(features._hist[:, 0], features._hist[:, 1])
    ours.close()
    theirs.close()


def test_export_refuses_it_by_name(tmp_path):
    from cepam_gym.errors import InputError
    from cepam_gym_agents.export import export

    venv = _window_env(1, 1.5)
    _agent(tmp_path, venv)
    venv.close()
    with pytest.raises(InputError, match="plant_features"):
        export(tmp_path, tmp_path / "p.onnx")


def test_the_told_plants_setpoint_gaps_are_the_nominal_ones_on_the_nominal_plant_only():
    """With ``setpoint_gaps_in_obs`` each frame holds the nominal model's set-point gaps, then the
    told plant's: on the nominal plant the two agree, on a randomized one they differ."""
    cfg = FeatureSpec(history=1, setpoint_gaps_in_obs=True, plant_features=True)
    for randomize, same in ((None, True), (RANDOMIZE_V2, False)):
        venv = gym.make_vec("cepam_gym/CEPAM-v2", num_envs=3, randomize=randomize)
        obs, _ = venv.reset(seed=5)
        f = Features(venv, cfg, obs.shape[1])
        f.use_true_plant()
        for _ in range(3):
            x, _ = f(obs)
            obs, *_ = venv.step(np.full((3, 2), 0.2, dtype=np.float32))
        raw = obs.shape[1]
        nominal_gaps, plant_gaps = x[:, raw : raw + 2], x[:, raw + 2 : raw + 4]
        assert np.isfinite(plant_gaps).all()
        if same:
            np.testing.assert_allclose(plant_gaps, nominal_gaps, atol=1e-5)
        else:
            assert np.abs(plant_gaps - nominal_gaps).max() > 0.02  # 2 kPa: the plants differ
        venv.close()


@pytest.mark.slow
def test_the_adaptive_student_learns_and_runs_behind_the_window(tmp_path):
    """Learning works end to end: two DAgger rounds (a cheap search, 8 randomized v2 plants) told
    the true plant give an agent that, deployed on randomized-id-v2's first 2 episodes (the
    benchmark's own, never trained on), plays the window, is told its fit and tracks better than
    the baseline."""
    from cepam_gym.bench.harness import run_suite
    from cepam_gym_agents.config.files import dump_config
    from cepam_gym_agents.learners.student import train_student

    cfg = TrainConfig.from_dict(
        {
            "algorithm": "PPO",
            "env": {"id": "cepam_gym/CEPAM-v2", "num_envs": 2, "suite": "randomized-v2"},
            "normalize": {"obs": True},
            "agent": {"history": 4, "setpoint_gaps_in_obs": True, "plant_features": True},
            "student": {
                "teacher": "mpc_known_params",
                "teacher_options": {"population": 16, "iterations": 2, "elites": 4},
                "suites": {"randomized-v2": 8},
                "iterations": 2,
            },
            "eval": {"episodes": 1, "suite": "randomized-id-v2", "seed": 5},
        }
    )
    dump_config(cfg, tmp_path / "config.yaml")
    assert train_student(cfg, tmp_path, quiet=True) == 0
    agent, _ = run_suite(str(tmp_path), "randomized-id-v2", episodes=2, max_steps=250)
    baseline, _ = run_suite("baseline", "randomized-id-v2", episodes=2, max_steps=250)
    assert agent["failure_rate"] == 0.0
    assert agent["score"] < baseline["score"], (agent["score"], baseline["score"])


def test_in_training_a_terminal_observation_is_told_the_finished_episodes_plant():
    """At an autoreset the env already holds the next plant: the finished episode's last features
    (SB3's ``terminal_observation``) keep the plant it ran on, the next episode's its own."""
    from cepam_gym.integrations.sb3 import make_sb3_vec_env
    from cepam_gym_agents.session.envs import make_agent_vec_env

    raw = make_sb3_vec_env(
        "cepam_gym/CEPAM-v2", num_envs=2, seed=0, max_episode_steps=3, randomize=RANDOMIZE_V2
    )
    env = make_agent_vec_env(raw, CFG)
    model = rig_model_of(raw)
    k = plant_dim(model.nominal)
    env.reset()
    before = plant_columns(model.params, model.nominal)
    for _ in range(5):
        obs, _, done, infos = env.step(np.zeros((2, 2), dtype=np.float32))
        if done.any():
            break
    else:
        pytest.fail("episodes of 3 steps did not end")
    after = plant_columns(model.params, model.nominal)
    i = int(np.flatnonzero(done)[0])
    assert np.abs(after[i] - before[i]).max() > 1e-3  # a new plant was drawn
    np.testing.assert_array_equal(infos[i]["terminal_observation"][-k:], before[i])
    np.testing.assert_array_equal(obs[i, -k:], after[i])
    env.close()


def test_deployed_one_envs_new_episode_restarts_its_window_alone(tmp_path):
    venv = _window_env(2, 1.5)
    policy = _agent(tmp_path, venv)
    obs, _ = venv.reset(seed=2)
    policy.reset()
    window = policy.features._rig.window_steps
    for _ in range(window + 2):
        obs, *_ = venv.step(policy.act(obs))
    assert not policy.features.window[0].any()  # both tracking
    policy.reset([0])  # env 0's episode ended
    a = policy.act(obs)
    in_window, excitation = policy.features.window
    assert in_window.tolist() == [True, False]
    np.testing.assert_array_equal(a[0], excitation[0])
    assert policy.features.identifier.k.tolist() == [1, window + 3]
    venv.close()


def test_the_feature_spec_is_the_agent_section_but_the_trainers_own_key():
    """The library's FeatureSpec and the config's agent section name the same fields with the same
    defaults (the config adds ``start_at_base``, which only the trainer reads), so a feature added
    to one and not the other fails here."""
    import dataclasses

    from cepam_gym_agents.config.agent import AgentConfig

    spec = {f.name: f for f in dataclasses.fields(FeatureSpec)}
    agent = {f.name: f for f in dataclasses.fields(AgentConfig)}
    assert set(agent) - set(spec) == {"start_at_base"} and set(spec) <= set(agent)
    defaults = feature_spec(AgentConfig())
    assert defaults == FeatureSpec()
    on = feature_spec(AgentConfig(residual=True, obs_filters_s=[0.5, 2.0], history=3))
    assert on == FeatureSpec(residual=True, obs_filters_s=(0.5, 2.0), history=3) and on.uses_baseline
