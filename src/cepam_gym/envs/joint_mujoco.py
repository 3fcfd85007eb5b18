"""``cepam_gym/CEPAMJoint-v0``: a 1-DOF hinge (elbow or wrist of a wearable device) driven by a
CE-PAM, simulated in MuJoCo.

The mechanism (rack and pinion, ``L = L_max - r theta``), the generalized force on the hinge and
the coupling choice (MuJoCo integrates the hinge; every plant sub-step imposes the muscle length
and rate from it, :mod:`cepam_gym.plant.coupling`) are in docs/mujoco.md. The task is the rig's
over that mechanism map (:mod:`cepam_gym.tasks.joint`): same schedules, reward terms,
termination, action mapping and observation machinery as the rig envs. Frames:
:mod:`cepam_gym.mujoco.joint_view`; baseline: :mod:`cepam_gym.control.joint_baseline`
(``make_controller("baseline", env)``).
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import EzPickle

from .. import plant as pl
from ..errors import InputError, UnexpectedKwargError
from ..mujoco._mj import require_mujoco
from ..mujoco.joint_sim import JointSimulator
from ..mujoco.joint_view import JointView
from ..physics import layout as ix
from ..planning.joint import apply_reset_options, joint_schedules
from ..planning.randomization import MAX_REDRAWS, sample_params
from ..plant.actions import check_action_mode, valve_commands
from ..tasks.contract import JOINT
from ..tasks.joint import JointGeometry, JointRewardWeights, JointTask, joint_layout
from ..tasks.reward import JOINT_ABS_REWARD, MAX_TERMS
from ..tasks.spec import TERMINATION_NAMES, TERMINATION_REASONS, check_kwargs
from . import step_kernel as tk
from .checks import (
    as_actions,
    check_randomize,
    check_timing,
    resolve_params,
)
from .step import NONFINITE, reward_terms, terminated

__all__ = ["CEPAMJointEnv", "REWARD_TERMS", "TERMINATION_REASONS"]

# JointTask fields v0 does not take: it draws set-points only (no v1 reference fields) and ends an
# episode on the published terminations (a burst)
_NOT_OPTIONS = ("scales", "references", "move_s", "terminations")
REWARD_TERMS = JOINT.reward_terms  # tasks.reward.JOINT_ABS_REWARD's terms, in order
_TERM_KEYS = JOINT.term_keys


_DOC = """

    The spec sheet of each joint id (action and observation tables with units, reward terms,
    starting state, episode end, arguments, version history) is generated from the code into the
    documentation: ``docs/envs/<id>.md`` on the site (``make docs``); the mechanism and the
    coupling: docs/mujoco.md.
"""


class CEPAMJointEnv(gym.Env, EzPickle):
    __doc__ = "A hinge driven by a CE-PAM: joint angle and joint stiffness under external torques." + _DOC
    metadata = {
        "render_modes": ["rgb_array", "human"],
        "render_fps": 50,
        "termination_reasons": TERMINATION_NAMES,
    }
    contract = JOINT  # names of its reward terms, info keys, reset options; what the score reads

    def __init__(
        self,
        plant=None,
        action_mode: str = "valve",
        control_dt: float = 0.02,
        sub_dt: float = 5e-4,
        episode_seconds: float = 10.0,
        joint: Mapping[str, float] | JointGeometry | None = None,
        task_options: Mapping[str, Any] | None = None,
        reward_weights: Mapping[str, float] | None = None,
        randomize: Mapping[str, Any] | None = None,
        render_mode: str | None = None,
        width: int = 480,
        height: int = 480,
        **unknown: Any,
    ):
        if unknown:  # Python's TypeError wording, and the valid names, in one line
            valid = sorted(inspect.signature(CEPAMJointEnv.__init__).parameters.keys() - {"self", "unknown"})
            raise UnexpectedKwargError.naming(type(self).__name__, sorted(unknown), valid)
        EzPickle.__init__(
            self,
            plant=plant,
            action_mode=action_mode,
            control_dt=control_dt,
            sub_dt=sub_dt,
            episode_seconds=episode_seconds,
            joint=joint,
            task_options=task_options,
            reward_weights=reward_weights,
            randomize=randomize,
            render_mode=render_mode,
            width=width,
            height=height,
        )
        self.mujoco = require_mujoco()
        self.mode = check_action_mode(action_mode)
        self.action_mode = action_mode
        self.n_sub, self.n_steps = check_timing(control_dt, sub_dt, episode_seconds)
        self.control_dt, self.sub_dt = float(control_dt), float(sub_dt)
        self.nominal = resolve_params(plant)
        self.randomize = check_randomize(randomize)
        self.geometry = JointGeometry.from_kwargs(joint)
        opts = check_kwargs(JointTask, task_options, "task_options", exclude=_NOT_OPTIONS)
        self.task = JointTask(**{k: tuple(v) if isinstance(v, list) else v for k, v in opts.items()})
        self.weights = JointRewardWeights(
            **check_kwargs(JointRewardWeights, reward_weights, "reward_weights", "terms")
        )
        self.nominal_row = self.nominal.to_array()
        pl.check_stability(self.nominal_row[None], self.sub_dt)
        self.task.check_range(self.geometry, self.nominal_row)
        self.angle_max = self.geometry.max_angle(self.nominal_row)
        self.setpoint_max = self.nominal.pressure_cap
        self.obs_layout = joint_layout(self.task, self.angle_max, self.nominal.supply_pressure)
        self.task_params = tk.task_params(
            JOINT_ABS_REWARD, self.weights, self.task.scales, self.obs_layout, self.setpoint_max
        )
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        clip = self.obs_layout.clip
        self.observation_space = spaces.Box(-clip, clip, (self.obs_layout.size,), np.float32)
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self.control_dt)}
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise InputError(
                f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}"
            )
        self.render_mode = render_mode
        self.width, self.height = int(width), int(height)
        self.view = JointView(self)
        self.params = self.nominal_row.copy()
        self._build(self.params)
        self.target_angle = np.zeros(self.n_steps)
        self.target_stiffness = np.zeros(self.n_steps)
        self.external_torque = np.zeros(self.n_steps)
        self.t_idx = 0
        self.prev_action = np.zeros(2)
        self.aux = np.zeros(pl.N_AUX)
        self.terms = np.zeros(MAX_TERMS)
        self._reset_done = False

    def _build(self, p) -> None:
        sim = self.sim = JointSimulator(
            self.mujoco, self.geometry, p, self.mode, self.sub_dt, self.width, self.height
        )
        self.model, self.data, self.link, self.geom_ids = sim.model, sim.data, sim.link, sim.geom_ids
        self.view.model_changed()

    # ------------------------------------------------------------------- reset
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        p, (*schedules, initial) = self._draw_episode()
        a0, k0 = apply_reset_options(options, schedules, initial, self.geometry, p)
        self.target_angle, self.target_stiffness, self.external_torque = schedules
        self.aux[:] = self.sim.reset(a0, k0, self.external_torque[0])
        self.t_idx = 0
        self.prev_action[:] = 0.0
        self._reset_done = True
        info = self._info(scored=False)
        if self.render_mode == "human":
            self.render()
        return self._obs(), info

    def _draw_episode(self):
        """The episode's plant row and schedules. A randomized plant that is unstable at the
        sub-step, leaves the task's angles outside the joint's range, or for which the task finds
        no reachable target is redrawn (at most ``MAX_REDRAWS`` times, counted in
        ``info["redraws"]``), then the nominal plant (checked when the env was built) is used:
        a bad draw never raises inside an autoreset."""
        self.redraws = 0
        for _ in range(MAX_REDRAWS + 1):
            p = sample_params(self.nominal, self.randomize, self.np_random, self.nominal_row)
            if self.randomize:
                try:
                    pl.check_stability(p[None], self.sub_dt)
                    self.task.check_range(self.geometry, p)
                except ValueError:
                    self.redraws += 1
                    continue
            try:
                out = joint_schedules(
                    self.np_random, self.task, self.geometry, p, self.n_steps, self.control_dt
                )
            except RuntimeError:
                if not self.randomize:
                    raise
                self.redraws += 1
                continue
            break
        else:
            p = self.nominal_row
            out = joint_schedules(self.np_random, self.task, self.geometry, p, self.n_steps, self.control_dt)
        if self.randomize:
            self.params = p.copy()
            self._build(p)
        return p, out

    # -------------------------------------------------------------------- step
    def step(self, action):
        if not self._reset_done:
            raise RuntimeError("call reset() before step()")
        a = np.clip(as_actions(action, 1, single=True)[0], -1.0, 1.0)
        k = min(self.t_idx, self.n_steps - 1)
        inp = self.link.inp
        inp[pl.I_CMD_C], inp[pl.I_CMD_E] = valve_commands(self.mode, a[0], a[1], self.setpoint_max)
        inp[pl.I_LOAD] = inp[pl.I_FEXT] = 0.0
        self.aux[:] = self.sim.step(float(self.external_torque[k]), self.n_sub)
        self.prev_action[:] = a
        th, om = self.joint_state()
        burst = self.aux[pl.A_BURST] != 0.0
        quantities = (
            th,
            float(self.target_angle[k]),
            om,
            self.joint_stiffness(),
            float(self.target_stiffness[k]),
            a[0],
            a[1],
            self.aux[pl.A_AIR],
            burst,
            True,
            self.task_params,
        )
        reward = reward_terms(*quantities, self.terms)
        self.t_idx += 1
        finite = self.aux[pl.A_FINITE] != 0.0 and math.isfinite(th) and math.isfinite(om)
        reason = terminated(*quantities) if finite else NONFINITE
        info = self._info(scored=True, k=k)
        info.update(zip(_TERM_KEYS, self.terms.tolist()))
        info["termination_reason"] = int(reason)  # named by metadata["termination_reasons"]
        if self.render_mode == "human":
            self.render()
        return self._obs(), (0.0 if reason == NONFINITE else reward), reason != 0, False, info

    # ------------------------------------------------------------ measurements
    def joint_state(self) -> tuple[float, float]:
        """``(angle [rad], angular velocity [rad/s])`` of the hinge."""
        return self.sim.joint_state()

    def joint_stiffness(self) -> float:
        """``K r^2`` [N m/rad]: the muscle's stiffness at constant pressures through the pinion."""
        return self.sim.joint_stiffness(self.aux)

    def _obs(self) -> np.ndarray:
        th, om = self.joint_state()
        k = min(self.t_idx, self.n_steps - 1)
        p, aux = self.params, self.aux
        return self.obs_layout.encode(
            [
                th,
                om,
                aux[pl.A_PC],
                aux[pl.A_PE],
                p[ix.P_SUP] - p[ix.P_ATM],
                self.target_angle[k],
                self.target_stiffness[k],
                self.prev_action[0],
                self.prev_action[1],
            ]
        )

    def _info(self, scored: bool, k: int | None = None) -> dict[str, Any]:
        if k is None:
            k = min(self.t_idx, self.n_steps - 1)
        return {
            **self.sim.measure(self.aux),
            "redraws": int(getattr(self, "redraws", 0)),
            "air_used": float(self.aux[pl.A_AIR]) if scored else 0.0,
            "external_torque": float(self.external_torque[k]),
            "target_angle": float(self.target_angle[k]),
            "target_stiffness": float(self.target_stiffness[k]),
        }

    # ------------------------------------------------------------------ render
    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array'")
            return None
        if self.render_mode == "rgb_array":
            return self.view.frame()
        self.view.show()
        return None

    def close(self):
        self.view.close()
