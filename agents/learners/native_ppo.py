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
not a list of dicts; :mod:`agents.session.callbacks` reads both."""

from __future__ import annotations

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3 import PPO

from .native_collection import NativeCollection, last_step_infos


class NativePPO(NativeCollection, PPO):
    """SB3's PPO whose rollouts come from the native vector env as arrays (module docstring)."""

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
