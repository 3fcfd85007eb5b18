"""``agent.start_at_base``: the untrained agent is its base controller (the policy's output layer
at zero), for every algorithm; refused where there is no base to start at."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytestmark = pytest.mark.train


def _config(algorithm: str, agent: dict, sde: bool = False):
    from cepam_gym_agents.config.files import TrainConfig

    hp = (
        {"n_steps": 16, "batch_size": 32} if algorithm in ("PPO", "RecurrentPPO") else {"learning_starts": 10}
    )
    if sde:
        hp["use_sde"] = True
    return TrainConfig.from_dict(
        {
            "algorithm": algorithm,
            "learner": "sb3" if sde else "native",  # the native learner refuses gSDE
            "env": {"id": "cepam_gym/CEPAM-v3", "num_envs": 2},
            "agent": agent,
            "hyperparameters": hp,
            "policy_kwargs": {"net_arch": [8, 8]},
        }
    )


@pytest.mark.parametrize("algorithm", ["PPO", "SAC", "TD3", "RecurrentPPO", "SAC-gSDE"])
def test_the_untrained_residual_agent_sends_the_base_controllers_commands(algorithm):
    from cepam_gym_agents.learners.algorithm import training_class
    from cepam_gym_agents.session.trainer import build_train_env, new_model

    sde = algorithm.endswith("gSDE")  # SAC's mean is then Sequential(Linear, Hardtanh)
    algorithm = algorithm.split("-")[0]
    cfg = _config(algorithm, {"residual": True, "residual_scale": 0.3, "start_at_base": True}, sde)
    raw = build_train_env(cfg, 0)
    env, model = new_model(cfg, training_class(cfg.algorithm, cfg.learner), raw)
    obs = env.reset()
    for _ in range(5):  # states other than the first, too
        action, _ = model.predict(obs, deterministic=True)
        np.testing.assert_array_equal(action, 0.0)
        obs, *_ = env.step(np.random.default_rng(0).uniform(-1, 1, action.shape).astype(np.float32))
    if algorithm == "TD3":  # its target actor starts where the actor does
        for a, b in zip(model.actor.parameters(), model.actor_target.parameters()):
            np.testing.assert_array_equal(a.detach().numpy(), b.detach().numpy())
    # without the option the same seed's untrained policy does act
    plain = _config(algorithm, {"residual": True, "residual_scale": 0.3}, sde)
    env2, other = new_model(plain, training_class(plain.algorithm, plain.learner), build_train_env(plain, 0))
    action, _ = other.predict(env2.reset(), deterministic=True)
    assert np.abs(action).max() > 0  # PPO's orthogonal init of the action layer (gain 0.01) acts small, not 0
    env.close()
    env2.close()


def test_start_at_base_needs_a_base():
    from cepam_gym_agents.config.files import ConfigError

    with pytest.raises(ConfigError, match="agent.start_at_base"):
        _config("SAC", {"start_at_base": True})
    assert _config("TD3", {"target_shift": True, "start_at_base": True}).agent.start_at_base
