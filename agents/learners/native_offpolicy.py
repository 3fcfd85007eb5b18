"""SAC and TD3 that collect from the native batched env as whole arrays (``learner: native``).

Stable-baselines3's off-policy algorithms (Haarnoja et al. 2018, SAC; Fujimoto et al. 2018, TD3)
step a ``VecEnv`` one vector step at a time and, per env, build an info dict, draw a warm-up
action, check for a terminal observation and read the time-limit flag into the replay buffer.
At the hundreds of envs that keep the cores busy that per-env Python costs more than the env.
:class:`NativeOffPolicy` keeps the rest of SB3's algorithm (its policy, losses, optimisers,
``train``, target networks, saving and loading: a run of it is an SB3 SAC or TD3 model like any
other) and replaces the collection with one that works on the vector env's arrays:

* warm-up actions drawn for the whole batch at once, exploration noise drawn per env (SB3's
  ``NormalActionNoise`` on a vector env adds the *same* draw to every env);
* the replay buffer written as SB3's ``add`` writes it (the observation before normalisation,
  the next one, the terminal observation for a finished env, the reward before normalisation,
  ``done`` and the time-limit flag), whole rows at a time;
* ``VecNormalize``'s statistics and ``VecMonitor``'s episode log kept as arrays
  (:class:`~.native_collection.NativeCollection`).

What a vector step costs the learner is the env's one kernel call, one policy forward pass for
all envs and ``gradient_steps`` gradient steps: ``train_freq`` counts vector steps, so the
update-to-data ratio is ``gradient_steps / num_envs`` per env-step.
"""

from __future__ import annotations

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3 import SAC, TD3
from stable_baselines3.common.noise import NormalActionNoise
from stable_baselines3.common.type_aliases import RolloutReturn, TrainFrequencyUnit

from .native_collection import NativeCollection, last_step_infos
from .offpolicy_updates import sac_updates, td3_updates


class NativeOffPolicy(NativeCollection):
    """Mixed into SB3's SAC or TD3: rollouts from the native vector env as arrays (module
    docstring)."""

    _SESSION = (*NativeCollection._SESSION, "_raw_obs", "_noise_rng")

    def _on_reset(self) -> None:
        super()._on_reset()
        # SB3 holds the normalised observation; the replay buffer wants the raw one
        norm = self._norm
        self._raw_obs = norm.get_original_obs() if norm is not None else np.asarray(self._last_obs)
        self._noise_rng = np.random.default_rng(self.seed)

    def _exploration(self, learning_starts: int, action_noise) -> np.ndarray:
        """The batch's actions in [-1, 1] (SB3's ``_sample_action`` for a [-1, 1] box, per env)."""
        n = self._venv.num_envs
        box = self.action_space
        if self.num_timesteps < learning_starts:
            return self._noise_rng.uniform(box.low, box.high, (n, *box.shape)).astype(np.float32)
        with th.no_grad():
            obs = th.as_tensor(self._last_obs, device=self.device)
            scaled = self.actor(obs) if isinstance(self, TD3) else self.actor(obs, deterministic=False)
        scaled = scaled.cpu().numpy()
        if isinstance(action_noise, NormalActionNoise):  # one draw per env, not one for all
            draw = self._noise_rng.normal(0.0, 1.0, scaled.shape) * action_noise._sigma
            scaled = np.clip(scaled + action_noise._mu + draw, -1, 1)
        elif action_noise is not None:
            scaled = np.clip(scaled + action_noise(), -1, 1)
        return scaled.astype(np.float32)

    def collect_rollouts(
        self, env, callback, train_freq, replay_buffer, action_noise=None, learning_starts=0, log_interval=0
    ) -> RolloutReturn:
        self.policy.set_training_mode(False)
        box = self.action_space
        assert isinstance(box, spaces.Box) and np.all(box.low == -1) and np.all(box.high == 1), (
            "the native off-policy learner drives a [-1, 1] action box"
        )
        assert train_freq.unit == TrainFrequencyUnit.STEP, "train_freq counts vector steps"
        n = self._venv.num_envs
        steps = episodes = 0
        callback.on_rollout_start()
        while steps < train_freq.frequency:
            actions = self._exploration(learning_starts, action_noise)
            new_obs, rewards, terminated, truncated, dones, step_infos = self._step(actions)
            raw_rewards = self._norm.get_original_reward() if self._norm is not None else rewards
            raw_obs = self._norm.get_original_obs() if self._norm is not None else new_obs
            self.num_timesteps += n
            steps += 1
            infos = last_step_infos(step_infos, dones)
            callback.update_locals(locals())
            if not callback.on_step():
                return RolloutReturn(steps * n, episodes, continue_training=False)
            next_obs = raw_obs
            if dones.any():
                next_obs = np.array(raw_obs, copy=True)
                next_obs[dones] = step_infos["final_obs"][dones]
            self._add(replay_buffer, next_obs, actions, raw_rewards, dones, truncated & ~terminated)
            self._raw_obs = raw_obs
            self._last_obs = new_obs
            self._update_current_progress_remaining(self.num_timesteps, self._total_timesteps)
            self._on_step()
            finished = int(dones.sum())
            episodes += finished
            self._episode_num += finished
        callback.on_rollout_end()
        return RolloutReturn(steps * n, episodes, True)

    def _add(self, buf, next_obs, actions, rewards, dones, timeouts) -> None:
        """One row of the replay buffer, as SB3's ``ReplayBuffer.add`` writes it."""
        p = buf.pos
        buf.observations[p] = self._raw_obs
        if buf.optimize_memory_usage:
            buf.observations[(p + 1) % buf.buffer_size] = next_obs
        else:
            buf.next_observations[p] = next_obs
        buf.actions[p] = actions.reshape(buf.n_envs, buf.action_dim)
        buf.rewards[p] = rewards
        buf.dones[p] = dones
        if buf.handle_timeout_termination:
            buf.timeouts[p] = timeouts
        buf.pos = (p + 1) % buf.buffer_size
        buf.full = buf.full or buf.pos == 0


class NativeSAC(NativeOffPolicy, SAC):
    """SB3's SAC whose rollouts come from the native vector env as arrays, and whose gradient
    steps are SB3's in fewer Python calls (:func:`~.offpolicy_updates.sac_updates`)."""

    def train(self, gradient_steps: int, batch_size: int = 64) -> None:
        sac_updates(self, gradient_steps, batch_size)


class NativeTD3(NativeOffPolicy, TD3):
    """SB3's TD3 whose rollouts come from the native vector env as arrays, and whose gradient
    steps are SB3's in fewer Python calls (:func:`~.offpolicy_updates.td3_updates`)."""

    def train(self, gradient_steps: int, batch_size: int = 100) -> None:
        td3_updates(self, gradient_steps, batch_size)
