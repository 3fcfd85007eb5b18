"""The native learner (``learner: native``, agents/learners/native_ppo.py): SB3's PPO whose rollouts come from
the vector env as arrays. Its rollouts are SB3's own, step for step; its runs are ordinary run
directories; its config is refused where it cannot run."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytestmark = pytest.mark.train

from cepam_gym_agents.config.files import ConfigError, TrainConfig  # noqa: E402

BASE = {
    "algorithm": "PPO",
    "learner": "native",
    "total_timesteps": 2048,
    "seed": 5,
    "env": {"id": "cepam_gym/CEPAMLength-v2", "num_envs": 8, "kwargs": {"max_episode_steps": 40}},
    "normalize": {"obs": True, "reward": True},
    "hyperparameters": {"n_steps": 64, "batch_size": 256, "n_epochs": 2, "gamma": 0.97},
    "policy_kwargs": {"net_arch": [16, 16]},
    "eval": {"every_steps": 1024, "episodes": 2},
    "checkpoint": {"every_steps": 100000},
    "log_every_steps": 512,
}


def _cfg(**changes) -> TrainConfig:
    d = json.loads(json.dumps(BASE))
    d.update(changes)
    return TrainConfig.from_dict(d)


@pytest.mark.parametrize(
    "changes, match",
    [
        ({"learner": "jax"}, "learner must be one of"),
        ({"agent": {"privileged_critic": True}}, "does not take agent.privileged_critic"),
        ({"hyperparameters": {"use_sde": True}}, "does not take hyperparameters.use_sde"),
    ],
)
def test_native_learner_refuses_what_it_cannot_run(changes, match):
    with pytest.raises(ConfigError, match=match):
        _cfg(**changes)


def test_default_learner_is_sb3():
    d = dict(BASE)
    d.pop("learner")
    assert TrainConfig.from_dict(d).learner == "sb3"


def _model(cls, cfg):
    """A PPO of ``cls`` on the config's env and normalisation, as the trainer builds it."""
    from cepam_gym_agents.learners.algorithm import hyperparameters
    from cepam_gym_agents.session.envs import make_train_env, normalize

    env = normalize(make_train_env(cfg, cfg.seed), cfg)
    pk = dict(cfg.policy_kwargs)
    return cls(
        "MlpPolicy",
        env,
        seed=cfg.seed,
        device="cpu",
        policy_kwargs=pk,
        **hyperparameters(cfg.hyperparameters),
    )


@pytest.mark.parametrize(
    "agent",
    [{}, {"setpoint_gaps_in_obs": True}, {"residual": True, "history": 2, "obs_filters_s": [0.5]}],
    ids=["env", "gaps", "residual-history-filters"],
)
def test_native_rollouts_are_sb3s_rollouts(agent):
    """Same seed, same env: the native collection fills the rollout buffer with SB3's numbers
    (observations, actions, normalised rewards with the time-limit bootstrap, episode starts,
    values, log-probabilities, returns, advantages), keeps VecNormalize's statistics and the
    episode log as the wrappers do; with the agent's features (the baseline's set-point gaps; a
    residual on the baseline with a history and a filter) as the features' wrapper makes them.
    64 steps of episodes of 40: every env crosses a time limit."""
    from stable_baselines3 import PPO

    from cepam_gym_agents.learners.native_ppo import NativePPO

    cfg = _cfg(agent=agent)
    chunk = cfg.hyperparameters["n_steps"] * cfg.env.num_envs
    # one model at a time: the policy samples from torch's global generator, which each
    # constructor seeds
    ref = _model(PPO, cfg)
    ref.learn(2 * chunk)  # collect, train, collect (compared), train
    nat = _model(NativePPO, cfg)
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
    for key in keys:
        np.testing.assert_allclose(getattr(b, key), getattr(a, key), rtol=2e-4, atol=2e-5, err_msg=key)
    assert a.episode_starts.sum() > 0  # the comparison crossed episode ends
    na, nb = ref.get_env(), nat.get_env()
    np.testing.assert_allclose(nb.obs_rms.mean, na.obs_rms.mean, rtol=1e-6)
    np.testing.assert_allclose(nb.obs_rms.var, na.obs_rms.var, rtol=1e-6)
    np.testing.assert_allclose(nb.ret_rms.var, na.ret_rms.var, rtol=1e-6)
    ra = [(e["r"], e["l"]) for e in ref.ep_info_buffer]
    rb = [(e["r"], e["l"]) for e in nat.ep_info_buffer]
    assert len(ra) == len(rb) > 0
    np.testing.assert_allclose(np.array(rb), np.array(ra), rtol=1e-5)
    assert nat.num_timesteps == ref.num_timesteps


@pytest.mark.slow  # trains
def test_native_run_is_an_ordinary_run_directory(tmp_path):
    """A native run writes the files of any PPO run; eval's loader acts with it; the session's
    log holds the env's terms (the callback reads the learner's dict of arrays)."""
    import gymnasium as gym

    from cepam_gym_agents.policy import load_policy
    from cepam_gym_agents.train import train

    run = tmp_path / "native"
    assert train(_cfg(), run, quiet=True) == 0
    for name in ("model.zip", "vecnormalize.pkl", "best_model.zip", "evaluations.json", "summary.json"):
        assert (run / name).is_file(), name
    import zipfile

    with zipfile.ZipFile(run / "model.zip") as z:  # the session's env is not pickled into the model
        saved = json.loads(z.read("data"))
    assert not {"_venv", "_norm", "_ep_return"} & set(saved)
    header = (run / "logs" / "progress_0.csv").read_text().splitlines()[0].split(",")
    assert "env/reward_length" in header and "env/length_error_mm" in header
    rows = (run / "logs" / "progress_0.csv").read_text().splitlines()[1:]
    col = header.index("env/length_error_mm")
    assert any(r.split(",")[col] not in ("", "nan") for r in rows)
    venv = gym.make_vec("cepam_gym/CEPAMLength-v2", num_envs=2)
    obs, _ = venv.reset(seed=0)
    pol = load_policy(run, venv)
    pol.reset()
    act = pol.act(obs)
    assert act.shape == (2, 2) and np.all(np.abs(act) <= 1)


@pytest.mark.slow  # trains for about 10 s
def test_fast_config_beats_the_baseline_on_length_v2(tmp_path):
    """The shipped fast config learns: 300 k steps (about 7 s on 2 quiet cores) of PPO on
    ``CEPAMLength-v2`` score below the inverse-model baseline on the suite's own 20 episodes.
    Measured with 5 seeds, the baseline (0.209) fell after 100-200 k steps and 300 k reached
    0.05-0.08; the bound is the baseline's stored score."""
    from cepam_gym.bench.references import stored_entry
    from cepam_gym.bench.suites import SUITES
    from cepam_gym_agents.config.files import EnvConfig, EvalConfig, load_config
    from cepam_gym_agents.train import train

    suite = SUITES["length-v2"]
    cfg = load_config("fast_ppo")
    cfg = cfg.replace(
        env=EnvConfig.parse({"id": suite.env_id, "num_envs": cfg.env.num_envs, "suite": suite.name}),
        eval=EvalConfig(10**9, suite.episodes, suite.name, suite.seed),  # one evaluation, at the end
        total_timesteps=300_000,
        time_limit_minutes=None,
    )
    run = tmp_path / "fast"
    assert train(cfg, run, quiet=True) == 0
    score = json.loads((run / "summary.json").read_text())["final_score"]
    baseline = stored_entry(suite.name, suite.episodes, suite.seed)["baseline"]
    assert score < baseline, (score, baseline)
