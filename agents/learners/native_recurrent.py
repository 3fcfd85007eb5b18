"""Recurrent PPO that collects its rollouts from the native batched env as arrays
(``learner: native`` with ``algorithm: RecurrentPPO``).

sb3-contrib's ``RecurrentPPO`` (an LSTM actor and critic; Schulman et al. 2017, Hochreiter and
Schmidhuber 1997) steps a ``VecEnv`` with the per-env costs :mod:`agents.learners.native_ppo` describes, and
values each env cut by the time limit in a call of its own. :class:`NativeRecurrentPPO` keeps the
rest of it (policy, LSTM states, loss, saving: a run of it is an sb3-contrib ``RecurrentPPO``
model) and collects from the vector env's arrays; the truncated envs' last observations are
valued in one call, each with its own LSTM state.
"""

from __future__ import annotations

from copy import deepcopy

import numpy as np
import torch as th
from gymnasium import spaces
from sb3_contrib import RecurrentPPO

from .native_collection import NativeCollection, last_step_infos


class NativeRecurrentPPO(NativeCollection, RecurrentPPO):
    """sb3-contrib's RecurrentPPO whose rollouts come from the native vector env as arrays."""

    def collect_rollouts(self, env, callback, rollout_buffer, n_rollout_steps: int) -> bool:
        assert self._last_obs is not None, "No previous observation was provided"
        self.policy.set_training_mode(False)
        rollout_buffer.reset()
        callback.on_rollout_start()
        box = self.action_space
        assert isinstance(box, spaces.Box)
        lstm_states = deepcopy(self._last_lstm_states)
        new_obs = dones = None
        for _ in range(n_rollout_steps):
            with th.no_grad():
                obs = th.as_tensor(self._last_obs, device=self.device)
                starts = th.as_tensor(self._last_episode_starts, dtype=th.float32, device=self.device)
                actions, values, log_probs, lstm_states = self.policy(obs, lstm_states, starts)
            actions = actions.cpu().numpy()
            new_obs, rewards, terminated, truncated, dones, step_infos = self._step(
                np.clip(actions, box.low, box.high)
            )
            self.num_timesteps += len(dones)
            infos = last_step_infos(step_infos, dones)
            callback.update_locals(locals())
            if not callback.on_step():
                return False
            cut = np.flatnonzero(truncated & ~terminated)
            if cut.size:  # the time limit: bootstrap with the critic, each env on its own LSTM state
                last = th.as_tensor(self._normalize_obs(step_infos["final_obs"][cut]), device=self.device)
                idx = th.as_tensor(cut, device=self.device)
                state = (lstm_states.vf[0][:, idx, :].contiguous(), lstm_states.vf[1][:, idx, :].contiguous())
                with th.no_grad():
                    v = self.policy.predict_values(last, state, th.zeros(cut.size, device=self.device))
                rewards[cut] += self.gamma * v.cpu().numpy()[:, 0]
            rollout_buffer.add(
                self._last_obs,
                actions,
                rewards,
                self._last_episode_starts,
                values,
                log_probs,
                lstm_states=self._last_lstm_states,
            )
            self._last_obs = new_obs
            self._last_episode_starts = dones
            self._last_lstm_states = lstm_states
        with th.no_grad():
            starts = th.as_tensor(dones, dtype=th.float32, device=self.device)
            values = self.policy.predict_values(
                th.as_tensor(new_obs, device=self.device), lstm_states.vf, starts
            )
        rollout_buffer.compute_returns_and_advantage(last_values=values, dones=dones)
        callback.update_locals(locals())
        callback.on_rollout_end()
        return True
