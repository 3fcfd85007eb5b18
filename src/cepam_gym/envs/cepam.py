"""Gymnasium environments of the CE-PAM (single and batched) over :class:`CEPAMBatch`."""

from __future__ import annotations

import inspect
import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded
from gymnasium.utils import EzPickle
from gymnasium.vector import AutoresetMode, VectorEnv

from .. import plant as pl
from ..errors import InputError
from ..tasks import kernel as tk
from ..viewer import FrameWindow
from .core import CEPAMBatch

# names of the integer ``info["termination_reason"]`` codes (index = code; tasks.kernel's order)
TERMINATION_NAMES = ("none", "burst", "non_finite_state")
assert len(TERMINATION_NAMES) == len(tk.TERMINATION_REASONS)


def _check_renderer(core: CEPAMBatch, renderer: str | None) -> str:
    """The renderer of the core's task (``None``: the task's default, its first). The rig's:
    ``"numpy"``, the 2-D drawing of :mod:`cepam_gym.envs.render` (no extra needed), or
    ``"mujoco"``, the 3-D rig of :class:`cepam_gym.mujoco.rig.RigRenderer`; the joint's: MuJoCo
    only (the ``[mujoco]`` extra)."""
    allowed = core.task.renderers
    if renderer is None:
        renderer = allowed[0]
    if renderer not in allowed:
        raise InputError(f"renderer must be one of {allowed} for the {core.task.name} task, got {renderer!r}")
    return renderer


def _mujoco_frames(core: CEPAMBatch):
    """The MuJoCo frame source of the core's task (``render_core(core, i)`` draws env ``i``)."""
    from ..mujoco._mj import require_mujoco

    require_mujoco()  # the install hint, not an import error from deep inside
    if core.mech == pl.HINGE:
        from ..mujoco.joint_view import BatchJointFrames

        return BatchJointFrames(core)
    from ..mujoco.rig import RigRenderer

    return RigRenderer()


_ENV_KWARGS = ("task", "render_mode", "renderer")
_VECTOR_KWARGS = ("num_envs", "max_episode_steps", "autoreset_mode")


def _check_kwargs(kwargs: dict, env_kwargs: tuple[str, ...]) -> None:
    """Unknown kwargs named in one line with the valid ones (not a TypeError of an inner class)."""
    core = set(inspect.signature(CEPAMBatch.__init__).parameters) - {"self", "num_envs", "task"}
    bad = sorted(set(kwargs) - core)
    if bad:
        valid = sorted(core | set(env_kwargs))
        raise InputError(f"unknown env kwarg(s) {bad}; valid: {valid}")


def _episode_of(env) -> dict[str, Any]:
    return {
        "episode": env.core.episode_state(),
        "np_random": getattr(env, "_np_random", None),
        "seeded": getattr(env, "_seeded", False),
    }


def _restore(env, st: dict[str, Any]) -> None:
    env.core.restore(st["episode"])
    if st["np_random"] is not None:
        env._np_random = st["np_random"]
    if st["seeded"]:
        env._seeded = True


def _expose(env, core: CEPAMBatch) -> None:
    """What controllers read of an env (the joint's, as of ``CEPAMJoint-v0``,
    :class:`~cepam_gym.control.joint_baseline.JointInverseStaticController`): the nominal plant,
    the task's spec (and the hinge's geometry), observation layout, action mode and timing."""
    env.obs_layout, env.task = core.obs_layout, core.task.spec
    env.nominal, env.nominal_row = core.nominal, core.nominal.to_array()
    env.setpoint_max, env.action_mode, env.control_dt = (
        core.nominal.pressure_cap,
        core.action_mode,
        core.control_dt,
    )
    if core.mech == pl.HINGE:
        env.geometry, env.angle_max = core.task.geometry, core.task.angle_max


_DOC = """

    ## Description

    A compound extensor pneumatic artificial muscle (CE-PAM: a contractor McKibben muscle inside an
    extensor one; docs/model.md summarises the paper) hangs vertically from a mounting plate with a load on
    its free end. Two valves feed the two chambers (the CPAM, pressure ``Pc``, and the annulus
    between the EPAM bladder and the CPAM, pressure ``Pe``). Because length and stiffness depend
    on both pressures differently, both can be set independently (paper section XII). The plant is
    :mod:`cepam_gym.plant`: enhanced static force model (Eq. 41, 45), ISO 6358 valves, first-law
    chamber air, vertical load with end stops at 15 and 19.5 cm.

    ## Tasks (ids)

    | id | task |
    |---|---|
    | ``cepam_gym/CEPAM-v0`` | hold a target length AND a target stiffness, both changing every 2-4 s, while the hanging load changes (step, ramp, sine, random) |
    | ``cepam_gym/CEPAMLength-v0`` | hold a target length under changing loads; stiffness free |
    | ``cepam_gym/CEPAMStiffness-v0`` | hold 17.5 cm and change stiffness (paper section XII) |

    Targets are sampled only where the inverse static model finds pressures between the bladder
    contact pressure and 85 % of min(supply, burst) for every load of the segment: every episode
    is solvable.

    ## Action space

    ``Box(-1, 1, (2,), float32)``: one command per chamber ``[CPAM, annulus]``. Out-of-range values
    are clipped; NaN, inf or a wrong shape raise ``ValueError``.

    | action_mode | meaning of a command |
    |---|---|
    | ``"valve"`` (default) | proportional valve spool set-point: -1 exhaust, 0 closed, +1 supply |
    | ``"pwm"`` | duty of two on/off solenoid valves (sign: supply or exhaust) at ``pwm_frequency`` |
    | ``"pressure"`` | gauge pressure set-point, -1 -> 0 kPa, +1 -> min(supply, burst), held by an internal regulator |

    ## Observation space

    ``Box(-10, 10, (9,), float32)`` (8 without the stiffness target, ``CEPAMLength-v0``): only what
    a rig measures, scaled to about unit range. The columns are named in ``env.unwrapped.core.obs_layout``
    (:class:`~cepam_gym.tasks.layout.ObsLayout`: ``column(name)``, ``decode(obs)`` in SI units).

    | # | observation | scaling |
    |---|---|---|
    | 0 | length L | (L - 17.25 cm) / 2.25 cm |
    | 1 | dL/dt | / 0.1 m/s |
    | 2 | Pc (gauge) | / supply |
    | 3 | Pe (gauge) | / supply |
    | 4 | supply pressure (gauge) | / nominal supply |
    | 5 | target length | as 0 |
    | 6 | target stiffness (if tracked) | / 1000 N/m |
    | 7-8 | previous action | as is |

    The true stiffness, load, force and every plant quantity are in ``info`` (SI units).

    ## Rewards

    ``reward = sum of terms``, each reported signed in ``info["reward_<term>"]``:

    | term | value | weight kwarg (default) |
    |---|---|---|
    | length | ``-w |L - L*| / 1 cm`` (error clipped at 5 cm) | ``length`` (1.0) |
    | stiffness | ``-w |K - K*| / K*`` (clipped at 2); K at constant pressures | ``stiffness`` (2.5: 20 % weighs like 5 mm, as in the benchmark score) |
    | effort | ``-w mean(a^2)`` | ``effort`` (0.05) |
    | air | ``-w (air drawn from supply this step) / 10 mg`` | ``air`` (0.05) |
    | burst | ``-w`` once when a chamber exceeds the burst pressure | ``burst`` (100) |

    ## Episode

    Starts at rest at a reachable (length, stiffness) different from the first target. Control
    period ``control_dt`` (default 0.02 s, 50 Hz) with plant sub-steps ``sub_dt`` (0.5 ms; must
    divide it). Truncated after ``max_episode_steps`` (500 = 10 s). Terminated only on physical
    failure: ``info["termination_reason"]`` is an integer code (0 while running), named by
    ``env.metadata["termination_reasons"]``: 1 ``"burst"``, 2 ``"non_finite_state"``.

    ## Arguments

    | kwarg | default | meaning |
    |---|---|---|
    | ``plant`` | ``None`` (balloon preset) | PlantParams, preset name, YAML path, or dict of unit-named keys |
    | ``action_mode`` | ``"valve"`` | see above |
    | ``control_dt``, ``sub_dt`` | 0.02, 5e-4 | seconds |
    | ``episode_seconds`` | 10.0 | length of the target and load schedule (beyond it the last targets hold); the episode itself is truncated by ``max_episode_steps`` (500 from the registration: pass both to change the episode length) |
    | ``reward_weights`` | ``{}`` | override any of the weights above |
    | ``randomize`` | ``None`` | ``{plant key: [low, high]}`` in the key's units, sampled per episode; checked when the env is built (each key's ends, corners, a sample: a valid plant, stable integration, reachable targets; the error names the key); a draw that still fails is redrawn, counted in ``info["redraws"]`` |
    | ``sensor_noise`` | ``None`` | ``{"length_mm", "velocity_mm_s", "pressure_kpa"}`` standard deviations |
    | ``action_latency_steps`` | 0 | actions reach the valves this many steps late |
    | ``supply_drift_kpa`` | 0.0 | random-walk intensity of the supply pressure, kPa/sqrt(s), clipped to +-20 % |
    | ``stream`` | 0 | index of the env's random stream (see Seeding) |
    | ``num_threads`` | ``None`` | threads of the batched kernel (vector env, 256 envs or more): ``None`` every core, 1 serial; see ``benchmarks/throughput.py --busy-core`` |
    | ``task_options`` | ``{}`` | override TaskSpec fields: ``length_range`` [m], ``load_range`` [kg], ``load_kinds``, ``segment_duration`` [s], ``stiffness_range`` [N/m], ``pressure_margin`` |
    | ``render_mode`` | ``None`` | ``"rgb_array"`` or ``"human"`` |
    | ``renderer`` | ``"numpy"`` | ``"numpy"`` (2-D drawing) or ``"mujoco"`` (3-D rig, ``pip install 'cepam-gym[mujoco]'``, headless with ``MUJOCO_GL=egl``) |

    ``reset(options={"target_length": m, "target_stiffness": N/m, "load_mass": kg})`` pins any of
    them for the episode (evaluation at chosen operating points; checked: length within the end
    stops, stiffness > 0, 0 <= load <= 20 kg; no reachability check). A supply above the burst
    pressure gives a warning.

    ## Seeding

    ``reset(seed=s)`` seeds per-env streams spawned from ``numpy.random.SeedSequence(s)``: env i
    of a vector env owns the spawned child ``i`` (``SeedSequence(s, spawn_key=(i,))``), which
    feeds its parameter draws, schedules, sensor noise and supply drift. A single env owns child
    ``stream`` (kwarg, default 0). So vector element i seeded ``s`` equals, bit for bit, a single
    env made with ``stream=i`` and seeded ``s``, noise and drift included; different seeds give
    independent streams.

    ## Version history

    * v0: initial release. Later v0 changes: per-env seed streams spawned from a SeedSequence
      (``stream`` kwarg); ``info["termination_reason"]`` an integer code (was a string);
      ``info["redraws"]``; the vector env's ``autoreset_mode`` (default ``"next_step"``, was
      same-step only) and info masks.
"""


class CEPAMEnv(gym.Env, EzPickle):
    __doc__ = "CE-PAM length and stiffness regulation under changing loads (single env)." + _DOC
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
        _check_kwargs(kwargs, _ENV_KWARGS)
        self.core = CEPAMBatch(1, task=self.default_task if task is None else task, **kwargs)
        self.renderer = _check_renderer(self.core, renderer)
        if self.renderer == "mujoco":
            from ..mujoco._mj import require_mujoco

            require_mujoco()  # fail now, with the install hint, rather than at the first render()
        _expose(self, self.core)
        self._obs_row = self.core.obs[0]
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self.core.control_dt)}
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
        return self.core.task.info_single(self.core, scored)

    def _fast_info(self) -> dict[str, Any]:
        """The info of a step taken by the one-call single step (``core.info_row``)."""
        return self.core.task.info_fast(self.core)

    def __getstate__(self) -> dict[str, Any]:
        """Pickles and deep copies carry the episode: the constructor's arguments (EzPickle), then
        the core's episode and the env's own random stream."""
        return {**EzPickle.__getstate__(self), **_episode_of(self)}

    def __setstate__(self, st: dict[str, Any]) -> None:
        EzPickle.__setstate__(self, st)
        _restore(self, st)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        if seed is not None or not hasattr(self, "_seeded"):
            # the core draws from its own generator, derived from the env's so that seeding works
            self.core.seed(int(self.np_random.integers(2**63)) if seed is None else seed)
            self._seeded = True
        self.core.reset()
        self.core.apply_options(options)
        info = self._info(scored=False)
        if self.render_mode == "human":
            self.render()
        return self.core.obs[0].copy(), info

    def step(self, action):
        core = self.core
        if core.needs_reset:
            raise ResetNeeded("call reset() before step(): the env has no episode yet")
        if core.fast_single and getattr(action, "shape", None) == (2,) and action.dtype.kind in "iuf":
            # the hot path (kept lean: a single env's step is mostly Python overhead)
            x0, x1 = float(action[0]), float(action[1])
            if not (math.isfinite(x0) and math.isfinite(x1)):
                raise InputError(f"action contains NaN or inf: {action.tolist()}; actions must be finite")
            reward, reason = core.step_single(x0, x1)
            info = self._fast_info()
        else:
            core.step(core.check_actions(action))
            reward, reason = float(core.rewards[0]), int(core.reasons[0])
            info = self._info(scored=True)
        info["termination_reason"] = int(reason)
        if self.render_mode == "human":
            self.render()
        return self._obs_row.copy(), reward, reason != 0, False, info

    def _frame(self):
        """The current frame of env 0 (RGB array)."""
        if self.renderer == "mujoco":
            if self._mujoco is None:
                self._mujoco = _mujoco_frames(self.core)
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
        + _DOC
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
        _check_kwargs(kwargs, _ENV_KWARGS + _VECTOR_KWARGS)
        self.core = CEPAMBatch(num_envs, task=self.default_task if task is None else task, **kwargs)
        self.renderer = _check_renderer(self.core, renderer)
        if self.renderer == "mujoco":
            from ..mujoco._mj import require_mujoco

            require_mujoco()
        _expose(self, self.core)
        self._term_keys = tuple(f"reward_{t}" for t in self.core.task.reward_terms)
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
        return self.core.task.info_arrays(self.core, scored)

    def __getstate__(self) -> dict[str, Any]:
        """As the single env's: the episode (and the autoreset bookkeeping) travels along."""
        st = {**EzPickle.__getstate__(self), **_episode_of(self)}
        st["elapsed"], st["autoreset"] = self._elapsed.copy(), self._autoreset.copy()
        return st

    def __setstate__(self, st: dict[str, Any]) -> None:
        EzPickle.__setstate__(self, st)
        _restore(self, st)
        self._elapsed[:], self._autoreset[:] = st["elapsed"], st["autoreset"]

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        if seed is not None or not hasattr(self, "_seeded"):
            self.core.seed(int(self.np_random.integers(2**63)) if seed is None else seed)
            self._seeded = True
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
            truncated = (self._elapsed >= self.max_episode_steps) & ~terminated
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
                self._mujoco = _mujoco_frames(self.core)
            return tuple(self._mujoco.render_core(self.core, i) for i in range(self.num_envs))
        from .render import draw

        return tuple(draw(self.core, i) for i in range(self.num_envs))

    def close_extras(self, **kwargs):
        if self._mujoco is not None:
            self._mujoco.close()
            self._mujoco = None
