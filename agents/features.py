"""What the agent sees and sends, shared by training (a VecEnv wrapper) and deployment
(:func:`agents.policy.load_policy`), so that both run exactly the same code.

* ``baseline_in_obs``: the inverse-model baseline's action is appended to the env observation.
* ``residual``: the action sent to the env is ``clip(baseline + residual_scale * a, -1, 1)``.
* ``history``: the last ``history`` feature vectors are stacked (oldest first); a new episode
  starts with copies of its first one.

The baseline (:class:`cepam_gym.control.InverseStaticController`) keeps filter and integrator
state per env; :meth:`Features.reset` forgets it for finished episodes. Pure numpy.
"""

from __future__ import annotations

import numpy as np

from .config import AgentConfig


class Features:
    def __init__(self, env, cfg: AgentConfig, raw_dim: int):
        self.cfg = cfg
        self.raw_dim = int(raw_dim)
        self.baseline = None
        if cfg.residual or cfg.baseline_in_obs:
            from cepam_gym.control import InverseStaticController

            self.baseline = InverseStaticController(env)
        self.frame_dim = self.raw_dim + (2 if cfg.baseline_in_obs else 0)
        self.dim = self.frame_dim * cfg.history
        self._hist: np.ndarray | None = None  # (N, history, frame_dim)
        self._fresh: np.ndarray | None = None  # (N,) bool: next frame starts an episode

    @property
    def trivial(self) -> bool:
        """True when features are the raw observation and actions pass through unchanged."""
        return self.baseline is None and self.cfg.history == 1

    def reset(self, indices=None) -> None:
        """Forget the state of all envs, or of ``indices`` (their episodes ended)."""
        if self.baseline is not None:
            if indices is None or self.baseline._weight is None:
                self.baseline.reset()
            else:
                self.baseline.reset(indices)
        if indices is None or self._fresh is None:
            self._hist = self._fresh = None
        else:
            self._fresh[np.asarray(indices)] = True

    def __call__(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Features (N, dim) float32 and the baseline's action (N, 2) (None without a baseline)
        of a batch of env observations (N, raw_dim). Advances the per-env state by one step."""
        obs = np.asarray(obs, dtype=np.float32)
        if obs.ndim != 2 or obs.shape[1] != self.raw_dim:
            raise ValueError(f"observation must have shape (N, {self.raw_dim}), got {obs.shape}")
        base = self.baseline.act(obs) if self.baseline is not None else None
        frame = np.concatenate([obs, base], axis=1) if self.cfg.baseline_in_obs else obs
        if self.cfg.history == 1:
            return frame.astype(np.float32), base
        n = obs.shape[0]
        if self._hist is None or self._hist.shape[0] != n:
            self._hist = np.repeat(frame[:, None], self.cfg.history, axis=1)
            self._fresh = np.zeros(n, dtype=bool)
        else:
            self._hist[self._fresh] = frame[self._fresh, None]
            self._fresh[:] = False
            self._hist = np.concatenate([self._hist[:, 1:], frame[:, None]], axis=1)
        return self._hist.reshape(n, self.dim).astype(np.float32), base

    def peek(self, obs: np.ndarray) -> np.ndarray:
        """Features of ``obs`` without changing any state (terminal observations)."""
        saved = self._save()
        try:
            return self(obs)[0]
        finally:
            self._restore(saved)

    def _save(self):
        b = self.baseline
        copy = (lambda a: None if a is None else a.copy())
        return (copy(self._hist), copy(self._fresh),
                None if b is None else (copy(b._weight), copy(b._integral)))

    def _restore(self, saved) -> None:
        self._hist, self._fresh, b = saved
        if b is not None:
            self.baseline._weight, self.baseline._integral = b

    def action(self, a: np.ndarray, base: np.ndarray | None) -> np.ndarray:
        """The env action for the policy's action ``a`` (N, 2)."""
        a = np.asarray(a, dtype=np.float32)
        if self.cfg.residual:
            return np.clip(base + self.cfg.residual_scale * a, -1.0, 1.0).astype(np.float32)
        return np.clip(a, -1.0, 1.0)


def make_agent_vec_env(venv, cfg: AgentConfig):
    """Wrap an SB3 VecEnv of the CE-PAM env so that it shows and takes the agent's features
    (identity when ``cfg`` is trivial). Imports stable-baselines3."""
    from gymnasium import spaces
    from stable_baselines3.common.vec_env import VecEnvWrapper

    class AgentVecEnv(VecEnvWrapper):
        def __init__(self, venv, features: Features):
            space = spaces.Box(-10.0, 10.0, (features.dim,), np.float32)
            super().__init__(venv, observation_space=space)
            self.features = features
            self._base = None

        def reset(self):
            obs = self.venv.reset()
            self.features.reset()
            f, self._base = self.features(obs)
            return f

        def step_async(self, actions) -> None:
            a = np.asarray(actions, dtype=np.float32).reshape(self.num_envs, 2)
            self.venv.step_async(self.features.action(a, self._base))

        def step_wait(self):
            obs, rewards, dones, infos = self.venv.step_wait()
            done = np.flatnonzero(dones)
            if done.size:
                full = np.array(obs, copy=True)
                for i in done:
                    full[i] = infos[i]["terminal_observation"]
                term = self.features.peek(full)
                for i in done:
                    infos[i]["terminal_observation"] = term[i]
                self.features.reset(done)
            f, self._base = self.features(obs)
            return f, rewards, dones, infos

    features = Features(venv, cfg, venv.observation_space.shape[0])
    if features.trivial:
        return venv
    return AgentVecEnv(venv, features)
