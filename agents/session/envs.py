"""The envs a training session builds from its config: the training VecEnv (native batched env ->
agent features -> optional VecNormalize), the periodic evaluation's env, and the per-step info keys
the session logs."""

from __future__ import annotations

from pathlib import Path

from ..config.files import TrainConfig


def make_train_env(cfg: TrainConfig, seed: int):
    """SB3 VecEnv: native batched env (one process) -> agent features -> VecNormalize (optional)."""
    from cepam_gym.integrations.sb3 import make_sb3_vec_env

    env = make_sb3_vec_env(cfg.env.id, num_envs=cfg.env.num_envs, seed=seed, **cfg.env.kwargs)
    return make_agent_vec_env(env, cfg.agent)


def normalize(env, cfg: TrainConfig, load_from: Path | None = None):
    """``env`` wrapped in the config's VecNormalize (new, or the statistics saved at ``load_from``,
    training on); ``env`` itself if the config does not normalize."""
    from stable_baselines3.common.vec_env import VecNormalize

    if not cfg.normalize.enabled:
        return env
    if load_from is not None:
        vn = VecNormalize.load(str(load_from), env)
        vn.training = True
        return vn
    gamma = cfg.hyperparameters.get("gamma", 0.99)
    return VecNormalize(
        env,
        norm_obs=cfg.normalize.obs,
        norm_reward=cfg.normalize.reward,
        clip_obs=cfg.normalize.clip_obs,
        clip_reward=cfg.normalize.clip_reward,
        gamma=gamma,
    )


def eval_env_spec(cfg: TrainConfig) -> tuple[str, dict, object]:
    """(env id, kwargs, trace spec) of the periodic evaluation: the eval suite's, else the
    training env scored as the benchmark scores its version (v1 ids: the settling allowance)."""
    from cepam_gym.bench.suites import SUITES, trace_spec_for

    if cfg.eval.suite is None:
        return cfg.env.id, dict(cfg.env.kwargs), trace_spec_for(cfg.env.id)
    s = SUITES[cfg.eval.suite]
    return s.env_id, dict(s.env_kwargs), s.traces


def info_keys(contract) -> list[str]:
    """The per-env info entries the session averages into its log, by the training task's
    contract (:mod:`cepam_gym.tasks.contract`): its tracked position, stiffness and their targets
    (the columns the benchmark scores: the rig's length, the joint's angle and joint stiffness),
    then its reward terms."""
    cols = ("length", "target_length", "stiffness", "target_stiffness")
    return [contract.score_keys[c] for c in cols] + list(contract.term_keys)


def make_agent_vec_env(venv, cfg):
    """Wrap an SB3 VecEnv of the CE-PAM env so that it shows and takes the agent's features
    (:class:`cepam_gym.policies.Features` of the config's ``agent`` section ``cfg``; identity when
    it is trivial). Imports stable-baselines3."""
    import numpy as np
    from gymnasium import spaces
    from stable_baselines3.common.vec_env import VecEnvWrapper

    from cepam_gym.policies import Features

    from ..config.agent import feature_spec

    class AgentVecEnv(VecEnvWrapper):
        def __init__(self, venv, features: Features):
            space = spaces.Box(-10.0, 10.0, (features.dim,), np.float32)
            act = spaces.Box(-1.0, 1.0, (features.n_actions,), np.float32)
            super().__init__(venv, observation_space=space, action_space=act)
            self.features = features
            self._base = None

        def reset(self):
            obs = self.venv.reset()
            self.features.reset()
            f, self._base = self.features(obs)
            return f

        def step_async(self, actions) -> None:
            a = np.asarray(actions, dtype=np.float32).reshape(self.num_envs, self.features.n_actions)
            self.venv.step_async(self.features.action(a, self._base))

        def step_wait(self):
            obs, rewards, dones, infos = self.venv.step_wait()
            done = np.flatnonzero(dones)
            last = np.array([infos[i]["terminal_observation"] for i in done]) if done.size else None
            f, self._base, term = self.features.after_step(obs, done, last)
            for j, i in enumerate(done):
                infos[i]["terminal_observation"] = term[j]
            return f, rewards, dones, infos

    features = Features(venv, feature_spec(cfg), venv.observation_space.shape[0])
    if features.trivial:
        return venv
    if features.priv_dim:  # training: the privileged columns come from this env
        features.privileged = features._view
    if features.plant_dim:  # training: the actor is told this env's true plant
        features.use_true_plant()
    return AgentVecEnv(venv, features)
