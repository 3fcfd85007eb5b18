"""PPO that collects its rollouts from the native batched env as whole arrays (``learner: native``).

Stable-baselines3's PPO (Schulman et al. 2017) steps a ``VecEnv``: every step turns the batch's
info into one Python dict per env, ``VecMonitor`` and ``VecNormalize`` loop over the finished envs,
and the time-limit bootstrap asks the critic once per truncated env. At a few envs that is noise;
at the thousand envs that keep two cores busy it costs more than the env. :class:`NativePPO`
keeps everything else of SB3's PPO (its policy, loss, optimiser, ``train``, saving and loading:
a run of this learner is an SB3 PPO model and a ``VecNormalize`` file like any other) and replaces
only ``collect_rollouts`` with one that works on the vector env's arrays:

* the env is stepped through Gymnasium's vector API (``autoreset_mode="same_step"``), under the
  SB3 wrappers the trainer built, which are kept only for their state;
* the observation and reward normalisation is ``VecNormalize``'s own statistics, updated with the
  same formulas in the same order (the saved file is the one ``eval`` and ``export`` load);
* episode returns and lengths are counted as arrays and pushed to SB3's episode log, as
  ``VecMonitor`` would;
* the truncated envs' last observations are valued in one call (SB3's bootstrap at the time
  limit: ``r += gamma * V(s_T)``).

The callbacks see ``infos`` as one dict of arrays (a finished env's entries are its last step's),
not a list of dicts; :mod:`agents.callbacks` reads both."""

from __future__ import annotations

import time

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3 import PPO

from cepam_gym.envs.vector import CEPAMVectorEnv


def _unwrap(env):
    """(the CE-PAM vector env beneath the SB3 wrappers, the ``VecNormalize`` among them or None)."""
    from stable_baselines3.common.vec_env import VecNormalize

    norm = None
    while not isinstance(env, CEPAMVectorEnv):
        if isinstance(env, VecNormalize):
            norm = env
        inner = getattr(env, "venv", None)
        if inner is None:
            raise TypeError(
                "learner: native steps the native vector env (cepam_gym ids); "
                f"{type(env).__name__} has none beneath it"
            )
        env = inner
    return env, norm


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


class NativePPO(PPO):
    """SB3's PPO whose rollouts come from the native vector env as arrays (module docstring)."""

    # the session's handles on the env and its episode counters are not part of the model
    _SESSION = ("_venv", "_norm", "_ep_return", "_ep_length", "_t_start")

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), *self._SESSION]

    def _setup_learn(self, *args, **kwargs):
        before = self._last_obs
        out = super()._setup_learn(*args, **kwargs)
        self._venv, self._norm = _unwrap(self.env)
        if self._last_obs is not before or not hasattr(self, "_ep_return"):  # the envs were reset
            n = self._venv.num_envs
            self._ep_return = np.zeros(n)
            self._ep_length = np.zeros(n, dtype=np.int64)
            self._t_start = time.time()
        return out

    def _normalize_obs(self, obs: np.ndarray) -> np.ndarray:
        if self._norm is None:
            return obs.astype(np.float32)
        return self._norm.normalize_obs(obs)

    def _step(self, actions: np.ndarray):
        """One step of the vector env, normalised by ``VecNormalize``'s own methods in the order
        of its ``step_wait``, with the episode log kept as ``VecMonitor`` keeps it."""
        obs, rewards, terminated, truncated, infos = self._venv.step(actions)
        rewards = rewards.astype(np.float32)  # as the SB3 adapter hands them to VecNormalize
        dones = terminated | truncated
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

    def collect_rollouts(self, env, callback, rollout_buffer, n_rollout_steps: int) -> bool:
        assert self._last_obs is not None, "No previous observation was provided"
        self.policy.set_training_mode(False)
        rollout_buffer.reset()
        callback.on_rollout_start()
        box = self.action_space
        assert isinstance(box, spaces.Box)
        new_obs = dones = None
        for _ in range(n_rollout_steps):
            with th.no_grad():
                actions, values, log_probs = self.policy(th.as_tensor(self._last_obs, device=self.device))
            actions = actions.cpu().numpy()
            clipped = np.clip(actions, box.low, box.high)
            new_obs, rewards, terminated, truncated, dones, step_infos = self._step(clipped)
            self.num_timesteps += len(dones)
            infos = last_step_infos(step_infos, dones)
            callback.update_locals(locals())
            if not callback.on_step():
                return False
            # a time limit is not a failure: bootstrap with the critic's value of the last observation
            cut = np.flatnonzero(truncated & ~terminated)
            if cut.size:
                last = self._normalize_obs(step_infos["final_obs"][cut])
                with th.no_grad():
                    v = self.policy.predict_values(th.as_tensor(last, device=self.device)).cpu().numpy()[:, 0]
                rewards[cut] += self.gamma * v
            rollout_buffer.add(self._last_obs, actions, rewards, self._last_episode_starts, values, log_probs)
            self._last_obs = new_obs
            self._last_episode_starts = dones
        with th.no_grad():
            values = self.policy.predict_values(th.as_tensor(new_obs, device=self.device))
        rollout_buffer.compute_returns_and_advantage(last_values=values, dones=dones)
        callback.update_locals(locals())
        callback.on_rollout_end()
        return True
