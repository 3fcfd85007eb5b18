"""Gymnasium environments of the CE-PAM (single and batched) over :class:`CEPAMBatch`."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import EzPickle
from gymnasium.vector import AutoresetMode, VectorEnv

from .. import plant as pl
from ..tasks import kernel as tk
from .core import CEPAMBatch

INFO_KEYS = ("length", "velocity", "stiffness", "stiffness_closed", "force", "pressure_c",
             "pressure_e", "temperature_c", "temperature_e", "air_used", "load_mass",
             "target_length", "target_stiffness")
# info keys read from aux, in the order tasks.kernel.env_step_single writes them
_AUX_INFO = dict(zip(("stiffness", "stiffness_closed", "force", "pressure_c", "pressure_e",
                      "temperature_c", "temperature_e", "air_used"), tk.AUX_INFO))
_AUX_ITEMS = tuple(_AUX_INFO.items())
_TERM_KEYS = tuple(f"reward_{name}" for name in tk.REWARD_TERMS)
# keys of a step's info in the order of CEPAMBatch.info_row (single env)
_STEP_KEYS = ("length", "velocity", *_AUX_INFO, "load_mass", "target_length", "target_stiffness",
              *_TERM_KEYS)
assert len(_STEP_KEYS) == tk.N_INFO and set(INFO_KEYS) <= set(_STEP_KEYS)


def _info_single(core: CEPAMBatch, scored: bool) -> dict[str, Any]:
    """:func:`_info_arrays` of env 0 as Python floats, built without temporary arrays (the
    single env's step is dominated by Python overhead, so this path is kept lean)."""
    aux = core.aux[0].tolist()
    k = min(max(int(core.t_idx[0]) - (1 if scored else 0), 0), core.n_steps - 1)
    state = core.state[0].tolist()
    info = {"length": state[pl.S_L], "velocity": state[pl.S_V]}
    for name, col in _AUX_ITEMS:
        info[name] = aux[col]
    info["load_mass"] = float(core.load[0, k])
    info["target_length"] = float(core.target_l[0, k])
    info["target_stiffness"] = float(core.target_k[0, k])
    if scored:
        info.update(zip(_TERM_KEYS, core.terms[0].tolist()))
    return info


_AUX_COLS = np.array(list(_AUX_INFO.values()))
_STATE_COLS = np.array([pl.S_L, pl.S_V])
_REASON_NAMES = np.array(tk.TERMINATION_REASONS, dtype=object)


def _info_arrays(core: CEPAMBatch, scored: bool) -> dict[str, np.ndarray]:
    """Per-env info arrays: true plant quantities (SI), the targets scored, reward terms. Each
    group is gathered in one copy and handed out as its rows (fresh arrays every step)."""
    k = np.minimum(np.maximum(core.t_idx - (1 if scored else 0), 0), core.n_steps - 1)
    r = np.arange(core.num_envs)
    out = dict(zip(("length", "velocity"), np.ascontiguousarray(core.state[:, _STATE_COLS].T)))
    out.update(zip(_AUX_INFO, np.ascontiguousarray(core.aux[:, _AUX_COLS].T)))
    out["load_mass"] = core.load[r, k]
    out["target_length"] = core.target_l[r, k]
    out["target_stiffness"] = core.target_k[r, k]
    if scored:
        out.update(zip(_TERM_KEYS, np.ascontiguousarray(core.terms.T)))
    return out


_PIN_KEYS = ("target_length", "target_stiffness", "load_mass")
RENDERERS = ("numpy", "mujoco")


def _check_renderer(renderer: str) -> None:
    """``renderer="numpy"``: the 2-D drawing of :mod:`cepam_gym.envs.render` (no extra needed);
    ``"mujoco"``: the 3-D rig of :class:`cepam_gym.mujoco.rig.RigRenderer` (the ``[mujoco]`` extra)."""
    if renderer not in RENDERERS:
        raise ValueError(f"renderer must be one of {RENDERERS}, got {renderer!r}")
    if renderer == "mujoco":
        from ..mujoco._mj import require_mujoco

        require_mujoco()  # fail now, with the install hint, rather than at the first render()


def _apply_options(core: CEPAMBatch, options: dict | None) -> None:
    """``reset(options=...)``: pin any of target_length [m], target_stiffness [N/m], load_mass [kg]
    for the whole episode (scalars, or per-env arrays for the vector env)."""
    if not options:
        return
    bad = set(options) - set(_PIN_KEYS)
    if bad:
        raise ValueError(f"reset options: unknown keys {sorted(bad)}; valid: {list(_PIN_KEYS)}")
    core.pin_targets(**options)


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
    a rig measures, scaled to about unit range.

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
    failure: ``info["termination_reason"]`` is ``"burst"`` or ``"non_finite_state"``.

    ## Arguments

    | kwarg | default | meaning |
    |---|---|---|
    | ``plant`` | ``None`` (balloon preset) | PlantParams, preset name, YAML path, or dict of unit-named keys |
    | ``action_mode`` | ``"valve"`` | see above |
    | ``control_dt``, ``sub_dt`` | 0.02, 5e-4 | seconds |
    | ``episode_seconds`` | 10.0 | length of the target and load schedule (beyond it the last targets hold); the episode itself is truncated by ``max_episode_steps`` (500 from the registration: pass both to change the episode length) |
    | ``reward_weights`` | ``{}`` | override any of the weights above |
    | ``randomize`` | ``None`` | ``{plant key: [low, high]}`` in the key's units, sampled per episode |
    | ``sensor_noise`` | ``None`` | ``{"length_mm", "velocity_mm_s", "pressure_kpa"}`` standard deviations |
    | ``action_latency_steps`` | 0 | actions reach the valves this many steps late |
    | ``supply_drift_kpa`` | 0.0 | random-walk intensity of the supply pressure, kPa/sqrt(s), clipped to +-20 % |
    | ``task_options`` | ``{}`` | override TaskSpec fields: ``length_range`` [m], ``load_range`` [kg], ``load_kinds``, ``segment_duration`` [s], ``stiffness_range`` [N/m], ``pressure_margin`` |
    | ``render_mode`` | ``None`` | ``"rgb_array"`` or ``"human"`` |
    | ``renderer`` | ``"numpy"`` | ``"numpy"`` (2-D drawing) or ``"mujoco"`` (3-D rig, ``pip install 'cepam-gym[mujoco]'``, headless with ``MUJOCO_GL=egl``) |

    ``reset(options={"target_length": m, "target_stiffness": N/m, "load_mass": kg})`` pins any of
    them for the episode (evaluation at chosen operating points; no reachability check).

    ## Version history

    * v0: initial release.
"""


class CEPAMEnv(gym.Env, EzPickle):
    __doc__ = "CE-PAM length and stiffness regulation under changing loads (single env)." + _DOC
    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 50}

    def __init__(self, task: str = "cepam", render_mode: str | None = None, renderer: str = "numpy",
                 **kwargs: Any):
        EzPickle.__init__(self, task=task, render_mode=render_mode, renderer=renderer, **kwargs)
        _check_renderer(renderer)
        self.renderer = renderer
        self.core = CEPAMBatch(1, task=task, **kwargs)
        self._obs_row = self.core.obs[0]
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self.core.control_dt)}
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.observation_space = spaces.Box(-10.0, 10.0, (self.core.obs_dim,), np.float32)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}")
        self.render_mode = render_mode
        self._renderer = None
        self._mujoco = None

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        if seed is not None or not hasattr(self, "_seeded"):
            # the core draws from its own generator, derived from the env's so that seeding works
            self.core.seed(int(self.np_random.integers(2**63)) if seed is None else seed)
            self._seeded = True
        self.core.reset()
        _apply_options(self.core, options)
        info = _info_single(self.core, scored=False)
        if self.render_mode == "human":
            self.render()
        return self.core.obs[0].copy(), info

    def step(self, action):
        core = self.core
        if core.fast_single and getattr(action, "shape", None) == (2,):
            # the hot path (kept lean: a single env's step is mostly Python overhead)
            x0, x1 = float(action[0]), float(action[1])
            if not (math.isfinite(x0) and math.isfinite(x1)):
                raise ValueError(f"action contains NaN or inf: {action!r}")
            reward, reason = core.step_single(x0, x1)
            info = dict(zip(_STEP_KEYS, core.info_row.tolist()))
        else:
            core.step(core.check_actions(action))
            reward, reason = float(core.rewards[0]), int(core.reasons[0])
            info = _info_single(core, scored=True)
        info["termination_reason"] = tk.TERMINATION_REASONS[reason]
        if self.render_mode == "human":
            self.render()
        return self._obs_row.copy(), reward, reason != 0, False, info

    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array'")
            return None
        if self.renderer == "mujoco":
            if self._mujoco is None:
                from ..mujoco.rig import RigRenderer

                self._mujoco = RigRenderer()
            frame = self._mujoco.render_core(self.core, 0)
        else:
            from .render import draw

            frame = draw(self.core, 0)
        if self.render_mode == "rgb_array":
            return frame
        if self._renderer is None:
            if self.renderer == "mujoco":
                from ..mujoco.video import FrameWindow

                self._renderer = FrameWindow(frame.shape)
            else:
                from .render import HumanWindow

                self._renderer = HumanWindow()
        self._renderer.show(frame)
        return None

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        if self._mujoco is not None:
            self._mujoco.close()
            self._mujoco = None


class CEPAMVectorEnv(VectorEnv, EzPickle):
    __doc__ = ("N CE-PAM envs stepped by one compiled kernel (``gym.make_vec(id, num_envs=N)``). "
               "Same spaces, rewards and kwargs as the single env; env i seeded with ``seed + i`` "
               "follows exactly the single env seeded with ``seed + i``. Autoreset: same step "
               "(the returned observation of a finished env is the first of its next episode; the "
               "last one is in ``infos['final_obs']``, its info in ``infos['final_info']``)." + _DOC)
    metadata = {"render_modes": ["rgb_array"], "autoreset_mode": AutoresetMode.SAME_STEP, "render_fps": 50}

    def __init__(self, num_envs: int = 1, task: str = "cepam", max_episode_steps: int | None = 500,
                 render_mode: str | None = None, renderer: str = "numpy", **kwargs: Any):
        EzPickle.__init__(self, num_envs=num_envs, task=task, max_episode_steps=max_episode_steps,
                          render_mode=render_mode, renderer=renderer, **kwargs)
        _check_renderer(renderer)
        self.renderer = renderer
        self._mujoco = None
        self.core = CEPAMBatch(num_envs, task=task, **kwargs)
        self.num_envs = self.core.num_envs
        self.max_episode_steps = max_episode_steps
        self.single_action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.single_observation_space = spaces.Box(-10.0, 10.0, (self.core.obs_dim,), np.float32)
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, self.num_envs)
        self.observation_space = gym.vector.utils.batch_space(self.single_observation_space, self.num_envs)
        if render_mode is not None and render_mode != "rgb_array":
            raise ValueError(f"the vector env renders only 'rgb_array', got {render_mode!r}")
        self.render_mode = render_mode
        self._elapsed = np.zeros(self.num_envs, dtype=np.int64)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        if seed is not None or not hasattr(self, "_seeded"):
            self.core.seed(int(self.np_random.integers(2**63)) if seed is None else seed)
            self._seeded = True
        self.core.reset()
        _apply_options(self.core, options)
        self._elapsed[:] = 0
        return self.core.obs.copy(), _info_arrays(self.core, scored=False)

    def step(self, actions):
        a = self.core.check_actions(actions)
        self.core.step(a)
        self._elapsed += 1
        terminated = self.core.reasons != 0
        truncated = (self._elapsed >= self.max_episode_steps) & ~terminated if self.max_episode_steps else \
            np.zeros(self.num_envs, dtype=bool)
        infos = _info_arrays(self.core, scored=True)
        infos["termination_reason"] = _REASON_NAMES[self.core.reasons]
        obs = self.core.obs.copy()
        done = terminated | truncated
        if done.any():
            idx = np.flatnonzero(done)
            infos["final_obs"] = np.where(done[:, None], obs, 0.0).astype(np.float32)
            infos["_final_obs"] = done
            infos["final_info"] = {k: v.copy() for k, v in infos.items() if not k.startswith("_") and k != "final_obs"}
            infos["_final_info"] = done
            self.core.reset(idx)
            self._elapsed[idx] = 0
            obs = self.core.obs.copy()
        return obs, self.core.rewards.copy(), terminated, truncated, infos

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        if self.renderer == "mujoco":
            if self._mujoco is None:
                from ..mujoco.rig import RigRenderer

                self._mujoco = RigRenderer()
            return tuple(self._mujoco.render_core(self.core, i) for i in range(self.num_envs))
        from .render import draw

        return tuple(draw(self.core, i) for i in range(self.num_envs))

    def close_extras(self, **kwargs):
        if self._mujoco is not None:
            self._mujoco.close()
            self._mujoco = None
