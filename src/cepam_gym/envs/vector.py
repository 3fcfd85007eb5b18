"""The native vector env of the CE-PAM: N envs of one task stepped by one compiled kernel
(:class:`~cepam_gym.envs.core.CEPAMBatch`), with Gymnasium's vector conventions (both autoreset
modes, info masks, ``final_obs``/``final_info``, the sub-env API of ``call``/``get_attr``)."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded
from gymnasium.utils import EzPickle
from gymnasium.vector import AutoresetMode, VectorEnv

from ..errors import InputError
from . import step_kernel as tk
from .core import CEPAMBatch
from .shared import (
    ENV_KWARGS,
    RIG_SPEC_SHEET,
    TERMINATION_NAMES,
    VECTOR_KWARGS,
    check_kwargs,
    check_renderer,
    episode_of,
    expose,
    mujoco_frames,
    restore_episode,
    seed_core,
)

_AUTORESET_MODES = {"next_step": AutoresetMode.NEXT_STEP, "same_step": AutoresetMode.SAME_STEP}


def _autoreset_mode(mode) -> AutoresetMode:
    if isinstance(mode, AutoresetMode) and mode in _AUTORESET_MODES.values():
        return mode
    if isinstance(mode, str) and mode.lower() in _AUTORESET_MODES:
        return _AUTORESET_MODES[mode.lower()]
    if isinstance(mode, str) and mode in [m.value for m in _AUTORESET_MODES.values()]:
        return AutoresetMode(mode)  # "NextStep", "SameStep"
    raise InputError(
        f"autoreset_mode must be one of {list(_AUTORESET_MODES)} (or gymnasium's "
        f"AutoresetMode.NEXT_STEP / SAME_STEP), got {mode!r}"
    )


def _with_masks(info: dict[str, Any], present: np.ndarray, absent_keys=()) -> dict[str, Any]:
    """Gymnasium's vector-info convention: each array ``k`` gets a boolean mask ``_k`` of the envs
    whose info holds it (``absent_keys``: only the envs of ``present``; the others: all). The
    masks are rows of one array (one allocation per step; each row its own memory)."""
    masks = np.ones((len(info), len(present)), dtype=bool)
    out = {}
    for j, (k, v) in enumerate(info.items()):
        out[k] = v
        if k in absent_keys:
            masks[j] = present
        out["_" + k] = masks[j]
    return out


class CEPAMVectorEnv(VectorEnv, EzPickle):
    __doc__ = (
        "N CE-PAM envs stepped by one compiled kernel (``gym.make_vec(id, num_envs=N)``). "
        "Same spaces, rewards and kwargs as the single env; env i of a vector env seeded "
        "``s`` follows exactly the single env made with ``stream=i`` and seeded ``s`` "
        "(a vector env's ``stream`` kwarg offsets its envs' streams)."
        + """

    ## Vector conventions (Gymnasium 1.x)

    * ``autoreset_mode`` (kwarg, attribute and ``metadata["autoreset_mode"]``):
      ``"next_step"`` (default, as Gymnasium's): the step that ends an episode returns its last
      observation; the next ``step`` resets that env (its action is ignored) and returns the new
      episode's first observation, reward 0, ``terminated = truncated = False`` and the reset
      info. ``"same_step"``: the step that ends an episode returns the new episode's first
      observation and reset info; the last observation is in ``infos["final_obs"]`` and the last
      step's info in ``infos["final_info"]`` (masks ``_final_obs``, ``_final_info``).
    * Every info array ``k`` has a boolean mask ``infos["_k"]``; reward terms and
      ``termination_reason`` are absent (mask False) for an env whose entry is a reset info.
    * ``infos["termination_reason"]`` is an integer code, named by
      ``metadata["termination_reasons"]`` (0 ``"none"``, 1 ``"burst"``, 2 ``"non_finite_state"``).
    * ``call``, ``get_attr`` and ``set_attr``: the N envs share one Python object, so these act on
      it and return its value once per env.
    """
        + RIG_SPEC_SHEET
    )
    metadata = {
        "render_modes": ["rgb_array"],
        "autoreset_mode": AutoresetMode.NEXT_STEP,
        "render_fps": 50,
        "termination_reasons": TERMINATION_NAMES,
    }

    def __init__(
        self,
        num_envs: int = 1,
        task: str | None = None,
        max_episode_steps: int | None = 500,
        render_mode: str | None = None,
        renderer: str | None = None,
        autoreset_mode: str | AutoresetMode = "next_step",
        **kwargs: Any,
    ):
        EzPickle.__init__(
            self,
            num_envs=num_envs,
            task=task,
            max_episode_steps=max_episode_steps,
            render_mode=render_mode,
            renderer=renderer,
            autoreset_mode=autoreset_mode,
            **kwargs,
        )
        self.autoreset_mode = _autoreset_mode(autoreset_mode)
        self.metadata = {**self.metadata, "autoreset_mode": self.autoreset_mode}
        self._mujoco = None
        check_kwargs(kwargs, ENV_KWARGS + VECTOR_KWARGS, type(self).__name__)
        self.core = CEPAMBatch(num_envs, task=self.default_task if task is None else task, **kwargs)
        self.metadata = {**self.metadata, "termination_reasons": self.core.task.termination_names}
        self.renderer = check_renderer(self.core, renderer)
        if self.renderer == "mujoco":
            from ..mujoco._mj import require_mujoco

            require_mujoco()
        expose(self, self.core)
        self._term_keys = self.core.task.term_keys
        self.num_envs = self.core.num_envs
        if max_episode_steps is not None and (
            int(max_episode_steps) != max_episode_steps or max_episode_steps < 1
        ):
            raise InputError(
                f"max_episode_steps must be a positive integer or None, got {max_episode_steps!r}"
            )
        self.max_episode_steps = max_episode_steps
        self.single_action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        clip = self.core.obs_layout.clip
        self.single_observation_space = spaces.Box(-clip, clip, (self.core.obs_dim,), np.float32)
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, self.num_envs)
        self.observation_space = gym.vector.utils.batch_space(self.single_observation_space, self.num_envs)
        if render_mode is not None and render_mode != "rgb_array":
            raise InputError(f"the vector env renders only 'rgb_array', got {render_mode!r}")
        self.render_mode = render_mode
        self._elapsed = np.zeros(self.num_envs, dtype=np.int64)
        self._autoreset = np.zeros(self.num_envs, dtype=bool)  # envs to reset at the next step

    default_task = "cepam"

    def _infos(self, scored: bool) -> dict[str, np.ndarray]:
        info = self.core.task.info_arrays(self.core.s, scored)
        if self.core.n_window:  # (no second dict per step without a window)
            info.update(self.core.window_info(scored))
        if self.core.planned:
            info.update(self.core.schedule_info(scored))
        return info

    def __getstate__(self) -> dict[str, Any]:
        """As the single env's: the episode (and the autoreset bookkeeping) travels along."""
        st = {**EzPickle.__getstate__(self), **episode_of(self)}
        st["elapsed"], st["autoreset"] = self._elapsed.copy(), self._autoreset.copy()
        return st

    def __setstate__(self, st: dict[str, Any]) -> None:
        EzPickle.__setstate__(self, st)
        restore_episode(self, st)
        self._elapsed[:], self._autoreset[:] = st["elapsed"], st["autoreset"]

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        seed_core(self, seed)
        self.core.reset()
        self.core.apply_options(options)
        self._elapsed[:] = 0
        self._autoreset[:] = False
        everyone = np.ones(self.num_envs, dtype=bool)
        return self.core.obs.copy(), _with_masks(self._infos(scored=False), everyone)

    def step(self, actions):
        core = self.core
        if core.needs_reset:
            raise ResetNeeded("call reset() before step(): the vector env has no episode yet")
        a = core.check_actions(actions)
        next_step = self.autoreset_mode == AutoresetMode.NEXT_STEP
        pending = np.flatnonzero(self._autoreset) if next_step else np.empty(0, dtype=np.int64)
        if pending.size:
            core.step(a, active=np.flatnonzero(~self._autoreset))
            core.reset(pending)
            core.rewards[pending] = 0.0
            core.reasons[pending] = tk.TERMINATION_NONE
            self._elapsed[pending] = 0
            self._elapsed[~self._autoreset] += 1
        else:
            core.step(a)
            self._elapsed += 1
        terminated = core.reasons != 0
        if self.max_episode_steps:
            # the identification window (envs.id_window) does not count towards the episode's length
            truncated = (self._elapsed >= self.max_episode_steps + core.n_window) & ~terminated
        else:
            truncated = np.zeros(self.num_envs, dtype=bool)
        done = terminated | truncated
        stepped = ~self._autoreset if pending.size else np.ones(self.num_envs, dtype=bool)
        infos = self._infos(scored=True)
        infos["termination_reason"] = core.reasons.copy()
        rewards = core.rewards.copy()
        obs = core.obs.copy()
        if next_step:
            self._autoreset = done
            for k in self._term_keys:
                infos[k][~stepped] = 0.0
            scored_keys = (*self._term_keys, "termination_reason")
            return obs, rewards, terminated, truncated, _with_masks(infos, stepped, scored_keys)
        if done.any():
            idx = np.flatnonzero(done)
            final = _with_masks(infos, done, infos.keys())
            core.reset(idx)
            self._elapsed[idx] = 0
            infos = self._infos(scored=True)  # the new episode's info for the reset envs
            infos["termination_reason"] = core.reasons.copy()
            infos["termination_reason"][idx] = tk.TERMINATION_NONE
            for k in self._term_keys:
                infos[k][idx] = 0.0
            infos = _with_masks(infos, ~done, (*self._term_keys, "termination_reason"))
            infos["final_obs"] = np.where(done[:, None], obs, 0.0).astype(np.float32)
            infos["_final_obs"] = done
            infos["final_info"] = final
            infos["_final_info"] = done.copy()
            obs = core.obs.copy()
            return obs, rewards, terminated, truncated, infos
        return obs, rewards, terminated, truncated, _with_masks(infos, stepped)

    # ------------------------------------------------- the sub-env API of Gymnasium's vector envs
    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Call method ``name`` (or read attribute ``name``) of the shared env object; the result
        once per env, as :meth:`gymnasium.vector.SyncVectorEnv.call` returns one per sub-env."""
        attr = getattr(self, name)
        value = attr(*args, **kwargs) if callable(attr) else attr
        return tuple(value for _ in range(self.num_envs))

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """Attribute ``name`` of the shared env object, once per env."""
        return tuple(getattr(self, name) for _ in range(self.num_envs))

    def set_attr(self, name: str, values: Any) -> None:
        """Set attribute ``name`` of the shared env object. A list or tuple must have one value
        per env, all equal (the envs share the object)."""
        if isinstance(values, (list, tuple)):
            if len(values) != self.num_envs:
                raise InputError(f"set_attr: {len(values)} values for {self.num_envs} envs")
            if any(v is not values[0] and v != values[0] for v in values[1:]):
                raise InputError(
                    f"set_attr({name!r}): the envs of a native vector env share one "
                    "object, so per-env values must be equal"
                )
            values = values[0]
        setattr(self, name, values)

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        if self.renderer == "mujoco":
            if self._mujoco is None:
                self._mujoco = mujoco_frames(self.core)
            return tuple(self._mujoco.render_core(self.core, i) for i in range(self.num_envs))
        from .render import draw

        return tuple(draw(self.core, i) for i in range(self.num_envs))

    def close_extras(self, **kwargs):
        if self._mujoco is not None:
            self._mujoco.close()
            self._mujoco = None
