"""The native off-policy learners (``learner: native`` with SAC or TD3, agents/learners/native_offpolicy.py):
SB3's SAC and TD3 whose replay buffer is filled from the vector env as arrays. Its transitions are
SB3's own, step for step; its runs are ordinary run directories; its config is refused where it
cannot run."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytestmark = pytest.mark.train

from cepam_gym_agents.config.files import ConfigError, TrainConfig  # noqa: E402

BASE = {
    "algorithm": "SAC",
    "learner": "native",
    "total_timesteps": 1024,
    "seed": 5,
    "env": {"id": "cepam_gym/CEPAMLength-v2", "num_envs": 8, "kwargs": {"max_episode_steps": 20}},
    "normalize": {"obs": True, "reward": True},
    "hyperparameters": {"learning_starts": 0, "batch_size": 64, "buffer_size": 4096, "gradient_steps": 1},
    "policy_kwargs": {"net_arch": [16, 16]},
    "eval": {"every_steps": 512, "episodes": 2},
    "checkpoint": {"every_steps": 100000},
    "log_every_steps": 256,
}


def _cfg(**changes) -> TrainConfig:
    d = json.loads(json.dumps(BASE))
    d.update(changes)
    return TrainConfig.from_dict(d)


@pytest.mark.parametrize(
    "changes, match",
    [
        ({"hyperparameters": {"use_sde": True}}, "does not take hyperparameters.use_sde"),
        ({"hyperparameters": {"train_freq": [1, "episode"]}}, "train_freq in episodes"),
    ],
)
def test_native_off_policy_refuses_what_it_cannot_run(changes, match):
    with pytest.raises(ConfigError, match=match):
        _cfg(**changes)


def _model(cls, cfg):
    from cepam_gym_agents.learners.algorithm import hyperparameters
    from cepam_gym_agents.session.envs import make_train_env, normalize

    env = normalize(make_train_env(cfg, cfg.seed), cfg)
    return cls(
        "MlpPolicy",
        env,
        seed=cfg.seed,
        device="cpu",
        policy_kwargs=dict(cfg.policy_kwargs),
        **hyperparameters(cfg.hyperparameters),
    )


@pytest.mark.parametrize("algorithm", ["SAC", "TD3"])
def test_native_transitions_are_sb3s_transitions(algorithm):
    """Same seed, same env, no warm-up and no exploration noise (the two places where the native
    learner draws its own random numbers): the replay buffer holds SB3's transitions
    (observations before normalisation, the terminal observation of a finished episode, actions,
    rewards before normalisation, done and time-limit flags), and the gradient steps between them
    agree, so the networks do too. 48 vector steps of 20-step episodes cross two time limits."""
    from stable_baselines3 import SAC, TD3

    from cepam_gym_agents.learners.native_offpolicy import NativeSAC, NativeTD3

    cfg = _cfg(algorithm=algorithm)
    sb3, native = {"SAC": (SAC, NativeSAC), "TD3": (TD3, NativeTD3)}[algorithm]
    steps = 48 * cfg.env.num_envs
    ref = _model(sb3, cfg)
    ref.learn(steps)
    nat = _model(native, cfg)
    nat.learn(steps)
    a, b = ref.replay_buffer, nat.replay_buffer
    assert a.pos == b.pos == 48
    for key in ("observations", "next_observations", "actions", "rewards", "dones", "timeouts"):
        np.testing.assert_allclose(getattr(b, key), getattr(a, key), rtol=2e-4, atol=2e-5, err_msg=key)
    assert a.timeouts.sum() > 0  # the comparison crossed time limits
    for pa, pb in zip(ref.policy.parameters(), nat.policy.parameters(), strict=True):
        np.testing.assert_allclose(pb.detach().numpy(), pa.detach().numpy(), rtol=1e-3, atol=1e-5)
    na, nb = ref.get_env(), nat.get_env()
    np.testing.assert_allclose(nb.obs_rms.mean, na.obs_rms.mean, rtol=1e-6, atol=1e-8)
    np.testing.assert_allclose(nb.ret_rms.var, na.ret_rms.var, rtol=1e-6, atol=1e-8)
    ra = [(e["r"], e["l"]) for e in ref.ep_info_buffer]
    rb = [(e["r"], e["l"]) for e in nat.ep_info_buffer]
    assert len(ra) == len(rb) > 0
    np.testing.assert_allclose(np.array(rb), np.array(ra), rtol=1e-5)


def test_warm_up_and_noise_are_drawn_per_env():
    """Warm-up actions are uniform over the box for each env; TD3's Gaussian exploration noise is
    a separate draw per env (SB3's ``NormalActionNoise`` on a vector env adds one draw to all)."""
    from cepam_gym_agents.learners.native_offpolicy import NativeTD3

    cfg = _cfg(
        algorithm="TD3",
        hyperparameters={
            "learning_starts": 80,
            "batch_size": 64,
            "buffer_size": 4096,
            "action_noise": {"type": "normal", "sigma": 0.3},
        },
    )
    model = _model(NativeTD3, cfg)
    model.learn(20 * cfg.env.num_envs)
    acts = model.replay_buffer.actions[:20]  # (steps, envs, 2)
    warm = acts[:10].reshape(-1, 2)
    assert np.all(np.abs(warm) <= 1) and warm.std(0).min() > 0.45  # uniform on [-1, 1]: std 0.58
    noisy = acts[10:20]
    spread = noisy.std(axis=1).mean()  # across envs at one step: per-env draws differ
    assert spread > 0.05


@pytest.mark.slow  # trains
def test_native_off_policy_run_is_an_ordinary_run_directory(tmp_path):
    import gymnasium as gym

    from cepam_gym_agents.policy import load_policy
    from cepam_gym_agents.train import train

    run = tmp_path / "sac"
    assert train(_cfg(), run, quiet=True) == 0
    for name in ("model.zip", "vecnormalize.pkl", "best_model.zip", "evaluations.json", "summary.json"):
        assert (run / name).is_file(), name
    import zipfile

    with zipfile.ZipFile(run / "model.zip") as z:
        saved = json.loads(z.read("data"))
    assert not {"_venv", "_norm", "_raw_obs", "_noise_rng", "torch_threads"} & set(saved)
    venv = gym.make_vec("cepam_gym/CEPAMLength-v2", num_envs=2)
    obs, _ = venv.reset(seed=0)
    pol = load_policy(run, venv)
    pol.reset()
    act = pol.act(obs)
    assert act.shape == (2, 2) and np.all(np.abs(act) <= 1)
