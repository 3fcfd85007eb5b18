"""Gymnasium environments of the CE-PAM (single and batched) over :class:`CEPAMBatch`."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded
from gymnasium.utils import EzPickle

from ..errors import InputError
from ..viewer import FrameWindow
from .core import CEPAMBatch
from .shared import (
    ENV_KWARGS,
    RIG_SPEC_SHEET,
    TERMINATION_NAMES,
    check_kwargs,
    check_renderer,
    episode_of,
    expose,
    mujoco_frames,
    restore_episode,
    seed_core,
)
from .single_slabs import NONFINITE_ACTION

_REFUSED = NONFINITE_ACTION  # bound once: the hot path's


class CEPAMEnv(gym.Env, EzPickle):
    __doc__ = "CE-PAM length and stiffness regulation under changing loads (single env)." + RIG_SPEC_SHEET
    metadata = {
        "render_modes": ["rgb_array", "human"],
        "render_fps": 50,
        "termination_reasons": TERMINATION_NAMES,
    }

    default_task = "cepam"

    def __init__(
        self,
        task: str | None = None,
        render_mode: str | None = None,
        renderer: str | None = None,
        **kwargs: Any,
    ):
        EzPickle.__init__(self, task=task, render_mode=render_mode, renderer=renderer, **kwargs)
        check_kwargs(kwargs, ENV_KWARGS, type(self).__name__)
        self.core = CEPAMBatch(1, task=self.default_task if task is None else task, **kwargs)
        self.renderer = check_renderer(self.core, renderer)
        if self.renderer == "mujoco":
            from ..mujoco._mj import require_mujoco

            require_mujoco()  # fail now, with the install hint, rather than at the first render()
        expose(self, self.core)
        # the hot path's handles: the single step's arrays, its info keys (None: the task builds
        # its info itself), the episode's redraws as a Python int
        self._obs_row, self._info_row = self.core.obs[0], self.core.info_row
        self._one_call = self.core.fast_single
        self._slabs = self.core.slabs if self._one_call else None
        self._step_single = self.core.step_module.env_step_single  # the task's reward compiled in
        self._step_keys = self.core.task.step_keys if self.core.fast_single else None
        self._redraws = 0
        self.metadata = {
            **self.metadata,
            "render_fps": round(1.0 / self.core.control_dt),
            "termination_reasons": self.core.task.termination_names,  # the task's (tasks.termination)
        }
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        clip = self.core.obs_layout.clip  # the kernel clips every column to it
        self.observation_space = spaces.Box(-clip, clip, (self.core.obs_dim,), np.float32)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise InputError(
                f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}"
            )
        self.render_mode = render_mode
        self._renderer = None
        self._mujoco = None

    def _info(self, scored: bool) -> dict[str, Any]:
        info = self.core.task.info_single(self.core.s, scored)
        if self.core.n_window:
            info.update((k, bool(v[0])) for k, v in self.core.window_info(scored).items())
        if self.core.planned:
            info.update((k, float(v[0])) for k, v in self.core.schedule_info(scored).items())
        return info

    def __getstate__(self) -> dict[str, Any]:
        """Pickles and deep copies carry the episode: the constructor's arguments (EzPickle), then
        the core's episode and the env's own random stream."""
        return {**EzPickle.__getstate__(self), **episode_of(self)}

    def __setstate__(self, st: dict[str, Any]) -> None:
        EzPickle.__setstate__(self, st)
        restore_episode(self, st)
        self._redraws = int(self.core.redraws[0])

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        seed_core(self, seed)
        self.core.reset()
        self.core.apply_options(options)
        self._redraws = int(self.core.redraws[0])
        info = self._info(scored=False)
        if self.render_mode == "human":
            self.render()
        return self.core.obs[0].copy(), info

    def step(self, action):
        core = self.core
        if core.needs_reset:
            raise ResetNeeded("call reset() before step(): the env has no episode yet")
        if (
            self._one_call
            and type(action) is np.ndarray
            and action.shape == (2,)
            and action.dtype.char in "fd"
        ):
            # the hot path, kept lean (a single env's step is mostly Python overhead): one compiled
            # call that also checks the action and writes the info values
            if core.has_noise:
                core._draw_noise()
            reward, reason = self._step_single(*self._slabs, *action.tolist())
            if reason == _REFUSED:
                raise InputError(f"action contains NaN or inf: {action.tolist()}; actions must be finite")
            keys = self._step_keys
            if keys is not None:
                info = dict(zip(keys, self._info_row.tolist()))
                info["redraws"] = self._redraws
            else:
                info = self._info(scored=True)
        else:
            core.step(core.check_actions(action, single=True))
            reward, reason = float(core.rewards[0]), int(core.reasons[0])
            info = self._info(scored=True)
        info["termination_reason"] = reason
        if self.render_mode == "human":
            self.render()
        return self._obs_row.copy(), reward, reason != 0, False, info

    def _frame(self):
        """The current frame of env 0 (RGB array)."""
        if self.renderer == "mujoco":
            if self._mujoco is None:
                self._mujoco = mujoco_frames(self.core)
            return self._mujoco.render_core(self.core, 0)
        from .render import draw

        return draw(self.core, 0)

    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array'")
            return None
        frame = self._frame()
        if self.render_mode == "rgb_array":
            return frame
        if self._renderer is None:
            self._renderer = FrameWindow(frame.shape)
        self._renderer.show(frame)
        return None

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        if self._mujoco is not None:
            self._mujoco.close()
            self._mujoco = None


# the native vector env lives in envs/vector.py; its old import path is kept
from .vector import CEPAMVectorEnv  # noqa: E402

__all__ = ["TERMINATION_NAMES", "CEPAMEnv", "CEPAMVectorEnv"]
