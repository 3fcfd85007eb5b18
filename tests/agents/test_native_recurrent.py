"""The native recurrent learner (``learner: native`` with RecurrentPPO, agents/learners/native_recurrent.py):
sb3-contrib's RecurrentPPO whose rollouts come from the vector env as arrays. Its rollouts are
sb3-contrib's own, step for step, LSTM states included; its runs are ordinary run directories."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("sb3_contrib")
pytestmark = pytest.mark.train

from cepam_gym_agents.config.files import TrainConfig  # noqa: E402

BASE = {
    "algorithm": "RecurrentPPO",
    "learner": "native",
    "total_timesteps": 1024,
    "seed": 3,
    "env": {"id": "cepam_gym/CEPAMLength-v2", "num_envs": 8, "kwargs": {"max_episode_steps": 40}},
    "normalize": {"obs": True, "reward": True},
    "hyperparameters": {"n_steps": 64, "batch_size": 128, "n_epochs": 2, "gamma": 0.97},
    "policy_kwargs": {"net_arch": [16], "lstm_hidden_size": 16},
    "eval": {"every_steps": 512, "episodes": 2},
    "checkpoint": {"every_steps": 100000},
    "log_every_steps": 256,
}


def _cfg(**changes) -> TrainConfig:
    d = json.loads(json.dumps(BASE))
    d.update(changes)
    return TrainConfig.from_dict(d)


def _model(cls, cfg):
    from cepam_gym_agents.learners.algorithm import hyperparameters
    from cepam_gym_agents.session.envs import make_train_env, normalize

    env = normalize(make_train_env(cfg, cfg.seed), cfg)
    return cls(
        "MlpLstmPolicy",
        env,
        seed=cfg.seed,
        device="cpu",
        policy_kwargs=dict(cfg.policy_kwargs),
        **hyperparameters(cfg.hyperparameters),
    )


def test_native_recurrent_rollouts_are_sb3_contribs_rollouts():
    """Same seed, same env: the buffer holds sb3-contrib's numbers (observations, actions,
    normalised rewards with the time-limit bootstrap on each env's own LSTM state, episode starts,
    values, log-probabilities, returns, advantages, the LSTM states). 64 steps of episodes of 40:
    every env crosses a time limit."""
    from sb3_contrib import RecurrentPPO

    from cepam_gym_agents.learners.native_recurrent import NativeRecurrentPPO

    cfg = _cfg()
    chunk = cfg.hyperparameters["n_steps"] * cfg.env.num_envs
    ref = _model(RecurrentPPO, cfg)
    ref.learn(2 * chunk)
    nat = _model(NativeRecurrentPPO, cfg)
    nat.learn(2 * chunk)
    a, b = ref.rollout_buffer, nat.rollout_buffer
    keys = (
        "observations",
        "actions",
        "rewards",
        "episode_starts",
        "values",
        "log_probs",
        "returns",
        "advantages",
    )
    for key in (*keys, "hidden_states_pi", "cell_states_vf"):
        np.testing.assert_allclose(getattr(b, key), getattr(a, key), rtol=2e-4, atol=2e-5, err_msg=key)
    assert a.episode_starts.sum() > 0
    ra = [(e["r"], e["l"]) for e in ref.ep_info_buffer]
    rb = [(e["r"], e["l"]) for e in nat.ep_info_buffer]
    assert len(ra) == len(rb) > 0
    np.testing.assert_allclose(np.array(rb), np.array(ra), rtol=1e-5)


@pytest.mark.slow  # trains
def test_native_recurrent_run_is_an_ordinary_run_directory(tmp_path):
    import gymnasium as gym

    from cepam_gym_agents.policy import load_policy
    from cepam_gym_agents.train import train

    run = tmp_path / "rppo"
    assert train(_cfg(), run, quiet=True) == 0
    for name in ("model.zip", "vecnormalize.pkl", "best_model.zip", "evaluations.json", "summary.json"):
        assert (run / name).is_file(), name
    venv = gym.make_vec("cepam_gym/CEPAMLength-v2", num_envs=2)
    obs, _ = venv.reset(seed=0)
    pol = load_policy(run, venv)
    pol.reset()
    act = pol.act(obs)
    assert act.shape == (2, 2) and np.all(np.abs(act) <= 1)
