"""What the native learners share (``learner: native``): the vector env beneath the SB3 wrappers,
stepped as arrays, with ``VecNormalize``'s statistics and ``VecMonitor``'s episode log kept by the
same formulas in the same order, on whole arrays (:mod:`agents.learners.native_ppo`,
:mod:`agents.learners.native_offpolicy`). With an ``agent`` section, the agent's features
(:class:`cepam_gym.policies.Features`: set-point gaps, history, a residual...) are the agent wrapper's
own object, applied in the wrapper's order: the policy's action mapped to the env's, the step,
the finished envs' last observations featurised before their state is forgotten, then the new
observation."""

from __future__ import annotations

import time

import numpy as np

from cepam_gym.envs.vector import CEPAMVectorEnv


def _unwrap(env):
    """(the CE-PAM vector env beneath the SB3 wrappers, the ``VecNormalize`` among them or None, the
    agent's features wrapper (:func:`agents.session.envs.make_agent_vec_env`) or None)."""
    from stable_baselines3.common.vec_env import VecNormalize

    norm = agent = None
    while not isinstance(env, CEPAMVectorEnv):
        if isinstance(env, VecNormalize):
            norm = env
        if agent is None and hasattr(env, "features"):
            agent = env
        inner = getattr(env, "venv", None)
        if inner is None:
            raise TypeError(
                "learner: native steps the native vector env (cepam_gym ids); "
                f"{type(env).__name__} has none beneath it"
            )
        env = inner
    return env, norm, agent


def last_step_infos(infos: dict, dones: np.ndarray) -> dict:
    """The vector env's step info with each finished env's entries replaced by its last step's
    (``final_info``): what SB3's callbacks are given for a finished env."""
    if not dones.any() or "final_info" not in infos:
        return infos
    final = infos["final_info"]
    out = {}
    for k, v in infos.items():
        if k.startswith("_") or k in ("final_info", "final_obs") or k not in final:
            continue
        v = np.array(v, copy=True)
        v[dones] = final[k][dones]
        out[k] = v
        present = infos.get("_" + k, np.ones(len(dones), bool)).copy()
        present[dones] = final.get("_" + k, np.ones(len(dones), bool))[dones]
        out["_" + k] = present
    return out


class NativeCollection:
    """Mixed into an SB3 algorithm: the session's handles on the native vector env beneath the
    SB3 wrappers, ``VecNormalize``'s statistics updated as its ``step_wait`` does, and the episode
    log kept as ``VecMonitor`` keeps it, all on whole arrays."""

    # the session's handles on the env and its episode counters are not part of the model
    _SESSION = ("_venv", "_norm", "_agent", "_ep_return", "_ep_length", "_t_start")

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), *self._SESSION]

    def _setup_learn(self, *args, **kwargs):
        before = self._last_obs
        out = super()._setup_learn(*args, **kwargs)
        self._venv, self._norm, self._agent = _unwrap(self.env)
        if self._last_obs is not before or not hasattr(self, "_ep_return"):  # the envs were reset
            self._on_reset()
        return out

    def _on_reset(self) -> None:
        """The session's counters after the envs were reset (a learner adds its own)."""
        n = self._venv.num_envs
        self._ep_return = np.zeros(n)
        self._ep_length = np.zeros(n, dtype=np.int64)
        self._t_start = time.time()

    def _normalize_obs(self, obs: np.ndarray) -> np.ndarray:
        if self._norm is None:
            return obs.astype(np.float32)
        return self._norm.normalize_obs(obs)

    def _step(self, actions: np.ndarray):
        """One step of the vector env, normalised by ``VecNormalize``'s own methods in the order
        of its ``step_wait``, with the episode log kept as ``VecMonitor`` keeps it."""
        agent = self._agent
        if agent is not None:
            actions = agent.features.action(actions.reshape(len(actions), -1), agent._base)
        obs, rewards, terminated, truncated, infos = self._venv.step(actions)
        rewards = rewards.astype(np.float32)  # as the SB3 adapter hands them to VecNormalize
        dones = terminated | truncated
        if agent is not None:
            obs, infos = self._featurise(agent, obs, dones, infos)
        self._ep_return += rewards
        self._ep_length += 1
        # the log keeps the last maxlen episodes: the ones older than that are not written
        for i in np.flatnonzero(dones)[-self.ep_info_buffer.maxlen :]:
            self.ep_info_buffer.append(
                {
                    "r": float(self._ep_return[i]),
                    "l": int(self._ep_length[i]),
                    "t": time.time() - self._t_start,
                }
            )
        self._ep_return[dones] = 0.0
        self._ep_length[dones] = 0
        norm = self._norm
        if norm is not None:
            norm.old_obs, norm.old_reward = obs, rewards
            if norm.training and norm.norm_obs:
                norm.obs_rms.update(obs)
            if norm.training:
                norm._update_reward(rewards)
            rewards = norm.normalize_reward(rewards)
            norm.returns[dones] = 0
        return self._normalize_obs(obs), rewards, terminated, truncated, dones, infos

    @staticmethod
    def _featurise(agent, obs: np.ndarray, dones: np.ndarray, infos: dict):
        """The agent's features of a step's observations and of the finished envs' last ones
        (``final_obs``), by the wrapper's own :meth:`cepam_gym.policies.Features.after_step`."""
        done = np.flatnonzero(dones)
        out, agent._base, term = agent.features.after_step(
            obs, done, infos["final_obs"][done] if done.size else None
        )
        if done.size:
            final = np.zeros_like(out)
            final[done] = term
            infos = {**infos, "final_obs": final}
        return out, infos
