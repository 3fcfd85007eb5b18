"""``cepam_gym/CEPAMJoint-v0``: a 1-DOF hinge (elbow or wrist of a wearable device) driven by a
CE-PAM, simulated in MuJoCo, with its inverse-static baseline.

Mechanism (SI; the defaults suit the paper's small balloon CE-PAM, so the joint is a small one:
torques of a few hundredths of a N m)::

        mounting plate (at the shoulder end of the upper arm)
              |
           CE-PAM   length L, hanging along the upper arm
              |
           end cap + rack        L = L_max - r * theta
              |
      elbow ( pinion, radius r ) --- forearm + hand (mass m, centre of mass at l_c)

* The muscle's end cap carries a rack on a pinion of radius ``r`` (``lever_arm``) fixed to the
  forearm, so ``L = L_max - r theta``: ``theta = 0`` (arm hanging straight) is the muscle's upper
  end stop, and the lower stop ``L_min`` is full flexion ``(L_max - L_min) / r`` (1.8 rad by
  default). The end stops are the hinge's limits. A rack carries push and pull; with the
  default loads the muscle always pulls.
* Generalized force on the hinge (flexion positive), by virtual work with ``dL/dtheta = -r``::

      tau = -r (F + m_end g) - tau_ext - m g l_c sin(theta) - (c_joint + c r^2) omega

  ``F`` is the plant's push force, ``m_end g`` the end cap's weight (it moves down as the muscle
  extends), ``tau_ext >= 0`` the external torque (extension positive: the user's or the task's
  load), ``m g l_c sin(theta)`` the forearm's weight (MuJoCo's gravity), ``c`` the plant's
  viscous ``damping`` of the free end mapped through the pinion, plus the hinge's own damping.
  The end cap's mass enters as hinge armature ``m_end r^2``; Coulomb friction ``F_C`` as MuJoCo
  ``frictionloss`` ``F_C r``.
* Stiffness: ``K_joint = K r^2`` (the muscle's stiffness ``K = -dF/dL`` at constant pressures,
  mapped through the pinion). This is what the task sets and rewards; gravity adds
  ``m g l_c cos(theta)`` (reported as ``joint_stiffness_total``).

**Coupling choice.** MuJoCo integrates the hinge (``Euler``, implicit in damping, time step =
the plant sub-step ``sub_dt``); every sub-step the hinge angle and rate impose the muscle length
and rate on the plant, the plant advances its valves and air one sub-step with that motion and
returns its force (:mod:`cepam_gym.mujoco.coupling`). The alternative, a very stiff spring
between the plant's own free end and the joint, would add a fast mode the 0.5 ms sub-step cannot
resolve and an energy error of its own. With the imposed motion, the air's ``p dV`` work and the
work ``F dL`` done on the hinge come from the same ``L`` and ``v`` (virtual-work force form), so
energy is conserved up to the sub-step scheme's error, which is the plant's own and first order in
``sub_dt`` (``tests/test_mujoco.py`` checks that it halves with the sub-step, with sealed
chambers, and the static stiffness ``K r^2 + m g l_c cos(theta)``; docs/mujoco.md).
"""

from __future__ import annotations

import math
from dataclasses import fields
from typing import Any, Mapping

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import EzPickle

from .. import plant as pl
from ..control.baseline import InverseStaticController
from ..envs.core import _check_randomize, check_action_mode, check_timing, resolve_params
from ..params import PlantParams
from ..physics import api
from ..physics import layout as ix
from ._mj import make_renderer, require_mujoco
from .coupling import PlantLink
from .joint_task import JointGeometry, JointRewardWeights, JointTask, joint_schedules, joint_xml
from .rig import default_camera, geom_ids, set_muscle_geoms

TERMINATION_REASONS = ("", "burst", "non_finite_state")
REWARD_TERMS = ("angle", "stiffness", "effort", "air", "burst")
_OBS_CLIP = 10.0
_OMEGA_SCALE = 5.0  # rad/s
_K_SCALE = 1.0  # N m/rad
# one unit of the angle reward term: 10 deg, the error the joint benchmark scores as 1 (as 20 % of
# stiffness is, which JointRewardWeights.stiffness = 5 prices alike)
_ANGLE_UNIT = math.radians(10.0)


_DOC = """

    ## Description

    A 1-DOF hinge, the elbow (or wrist) of a small wearable or rehabilitation device, simulated in
    MuJoCo and driven by one CE-PAM through a rack and pinion of radius ``r`` (2.5 cm): the muscle
    length is ``L = L_max - r theta``, so the muscle's 15-19.5 cm span is a 0-1.8 rad flexion range.
    The forearm (0.15 kg, centre of mass 7 cm from the axis) hangs under gravity and an external
    extension torque changes over the episode (steps, ramps, sines, random). Task: hold a target
    joint angle AND a target joint stiffness ``K_joint = K r^2`` (the muscle's stiffness at
    constant pressures through the pinion), both changing every 2-4 s. Same plant, same action
    modes and the same reward structure as ``cepam_gym/CEPAM-v0``; the plant's valves and air run in
    :mod:`cepam_gym.plant`, the hinge in MuJoCo, coupled every 0.5 ms sub-step
    (:mod:`cepam_gym.mujoco.joint` explains the coupling). Needs ``pip install 'cepam-gym[mujoco]'``.

    ## Action space

    ``Box(-1, 1, (2,), float32)``: one command per chamber ``[CPAM, annulus]``. Out-of-range values
    are clipped; NaN, inf or a wrong shape raise ``ValueError``.

    | action_mode | meaning of a command |
    |---|---|
    | ``"valve"`` (default) | proportional valve spool set-point: -1 exhaust, 0 closed, +1 supply |
    | ``"pwm"`` | duty of two on/off solenoid valves (sign: supply or exhaust) |
    | ``"pressure"`` | gauge pressure set-point, -1 -> 0 kPa, +1 -> min(supply, burst), internal regulator |

    ## Observation space

    ``Box(-10, 10, (9,), float32)``: what a device measures, scaled to about unit range.

    | # | observation | scaling |
    |---|---|---|
    | 0 | joint angle theta | (theta - theta_max/2) / (theta_max/2), theta_max = 1.8 rad |
    | 1 | angular velocity | / 5 rad/s |
    | 2 | Pc (gauge) | / supply |
    | 3 | Pe (gauge) | / supply |
    | 4 | supply pressure (gauge) | / nominal supply |
    | 5 | target angle | as 0 |
    | 6 | target joint stiffness | / 1 N m/rad |
    | 7-8 | previous action | as is |

    ``info`` (SI): ``angle``, ``angular_velocity``, ``muscle_length``, ``muscle_force`` (push
    positive), ``muscle_torque`` (flexion positive), ``stiffness`` (muscle, N/m),
    ``joint_stiffness`` (``K r^2``), ``joint_stiffness_total`` (+ gravity ``m g l_c cos theta``),
    ``pressure_c``, ``pressure_e``, ``air_used``, ``external_torque``, ``target_angle``,
    ``target_stiffness``, after a step the reward terms and ``termination_reason``.

    ## Rewards

    ``reward = sum of terms``, each reported signed in ``info["reward_<term>"]``:

    | term | value | weight kwarg (default) |
    |---|---|---|
    | angle | ``-w |theta - theta*| / 10 deg`` (clipped at 5) | ``angle`` (1.0) |
    | stiffness | ``-w |K_joint - K*| / K*`` (clipped at 2) | ``stiffness`` (5.0: 20 % weighs like 10 deg, as in the benchmark score) |
    | effort | ``-w mean(a^2)`` | ``effort`` (0.05) |
    | air | ``-w (supply air this step) / 10 mg`` | ``air`` (0.05) |
    | burst | ``-w`` once when a chamber exceeds the burst pressure | ``burst`` (100) |

    ## Starting state

    At rest at a reachable (angle, stiffness) drawn like the targets, with the chamber pressures
    of the inverse static model for the first external torque.

    ## Episode end

    Truncated after ``max_episode_steps`` (500 = 10 s at 50 Hz). Terminated only on physical
    failure: ``info["termination_reason"]`` is an integer code (0 while running) named by
    ``metadata["termination_reasons"]``: 1 ``"burst"``, 2 ``"non_finite_state"``.

    ## Arguments

    | kwarg | default | meaning |
    |---|---|---|
    | ``plant`` | ``None`` (balloon preset) | PlantParams, preset name, YAML path, or dict of unit-named keys |
    | ``action_mode`` | ``"valve"`` | see above |
    | ``control_dt``, ``sub_dt`` | 0.02, 5e-4 | seconds; ``sub_dt`` is also MuJoCo's time step |
    | ``episode_seconds`` | 10.0 | length of the target and torque schedule |
    | ``joint`` | ``{}`` | override :class:`JointGeometry`: ``lever_arm``, ``link_length``, ``link_mass``, ``link_com`` [m, kg], ``joint_damping`` [N m s/rad] |
    | ``task_options`` | ``{}`` | override :class:`JointTask`: ``angle_range`` [rad], ``stiffness_range`` [N m/rad], ``torque_range`` [N m], ``load_kinds``, ``segment_duration`` [s], ``pressure_margin`` |
    | ``reward_weights`` | ``{}`` | override any weight above |
    | ``randomize`` | ``None`` | ``{plant key: [low, high]}`` in the key's units, sampled per episode |
    | ``render_mode`` | ``None`` | ``"rgb_array"`` or ``"human"`` (MuJoCo, headless with ``MUJOCO_GL=egl``) |
    | ``width``, ``height`` | 480, 480 | frame size |

    ``reset(options=...)``: ``target_angle`` [rad], ``target_stiffness`` [N m/rad] and
    ``external_torque`` [N m] pin the value for the whole episode; ``initial_angle`` [rad] and
    ``initial_stiffness`` [N m/rad] choose the starting point (no reachability check).

    ## Version history

    * v0: initial release.
"""

_PIN_KEYS = ("target_angle", "target_stiffness", "external_torque")
_INIT_KEYS = ("initial_angle", "initial_stiffness")


class CEPAMJointEnv(gym.Env, EzPickle):
    __doc__ = "A hinge driven by a CE-PAM: joint angle and joint stiffness under external torques." + _DOC
    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 50,
                "termination_reasons": ("none", "burst", "non_finite_state")}

    def __init__(self, plant=None, action_mode: str = "valve", control_dt: float = 0.02,
                 sub_dt: float = 5e-4, episode_seconds: float = 10.0,
                 joint: Mapping[str, float] | JointGeometry | None = None,
                 task_options: Mapping[str, Any] | None = None,
                 reward_weights: Mapping[str, float] | None = None,
                 randomize: Mapping[str, Any] | None = None, render_mode: str | None = None,
                 width: int = 480, height: int = 480):
        EzPickle.__init__(self, plant=plant, action_mode=action_mode, control_dt=control_dt,
                          sub_dt=sub_dt, episode_seconds=episode_seconds, joint=joint,
                          task_options=task_options, reward_weights=reward_weights,
                          randomize=randomize, render_mode=render_mode, width=width, height=height)
        self.mujoco = require_mujoco()
        self.mode = check_action_mode(action_mode)
        self.action_mode = action_mode
        self.n_sub, self.n_steps = check_timing(control_dt, sub_dt, episode_seconds)
        self.control_dt, self.sub_dt = float(control_dt), float(sub_dt)
        self.nominal = resolve_params(plant)
        self.randomize = _check_randomize(randomize)
        self.geometry = JointGeometry.from_kwargs(joint)
        opts = dict(task_options or {})
        names = {f.name for f in fields(JointTask)}
        if set(opts) - names:
            raise ValueError(f"task_options: unknown keys {sorted(set(opts) - names)}; valid: {sorted(names)}")
        self.task = JointTask(**{k: tuple(v) if isinstance(v, list) else v for k, v in opts.items()})
        wnames = {f.name for f in fields(JointRewardWeights)}
        if set(reward_weights or {}) - wnames:
            raise ValueError(f"reward_weights: unknown terms {sorted(set(reward_weights) - wnames)}; "
                             f"valid: {sorted(wnames)}")
        self.weights = JointRewardWeights(**dict(reward_weights or {}))
        self.nominal_row = self.nominal.to_array()
        pl.check_stability(self.nominal_row[None], self.sub_dt)
        self._check_task(self.nominal_row)
        self.angle_max = self.geometry.max_angle(self.nominal_row)
        self.setpoint_max = min(self.nominal.supply_pressure, self.nominal.burst_pressure)
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.observation_space = spaces.Box(-_OBS_CLIP, _OBS_CLIP, (9,), np.float32)
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self.control_dt)}
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}")
        self.render_mode = render_mode
        self.width, self.height = int(width), int(height)
        self.params = self.nominal_row.copy()
        self._build(self.params)
        self.target_angle = np.zeros(self.n_steps)
        self.target_stiffness = np.zeros(self.n_steps)
        self.external_torque = np.zeros(self.n_steps)
        self.t_idx = 0
        self.prev_action = np.zeros(2)
        self.aux = np.zeros(pl.N_AUX)
        self._renderer = None
        self._window = None
        self._reset_done = False

    # ------------------------------------------------------------------ set-up
    def _check_task(self, p) -> None:
        amax = self.geometry.max_angle(p)
        lo, hi = self.task.angle_range
        if hi > amax:
            raise ValueError(f"task angle_range {self.task.angle_range} rad exceeds the joint's range "
                             f"[0, {amax:.3g}] rad (muscle end stops through lever_arm "
                             f"{self.geometry.lever_arm} m)")

    def _build(self, p) -> None:
        mj = self.mujoco
        self.model = mj.MjModel.from_xml_string(
            joint_xml(self.geometry, p, self.sub_dt, self.width, self.height))
        self.data = mj.MjData(self.model)
        self.link = PlantLink(p, self.mode, self.sub_dt)
        self._geom_ids = geom_ids(mj, self.model, ("cpam", "epam", "cap", "rack"))
        if self._renderer_alive():
            self._renderer.close()
            self._renderer = None

    def _renderer_alive(self) -> bool:
        return getattr(self, "_renderer", None) is not None

    def _sample_params(self) -> np.ndarray:
        if not self.randomize:
            return self.nominal_row
        draw = {k: self.np_random.uniform(lo, hi) for k, (lo, hi) in self.randomize.items()}
        return PlantParams.from_dict(draw, base=self.nominal, where="randomize").to_array()

    # ------------------------------------------------------------------- reset
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        options = dict(options or {})
        bad = set(options) - set(_PIN_KEYS) - set(_INIT_KEYS)
        if bad:
            raise ValueError(f"reset options: unknown keys {sorted(bad)}; valid: {list(_PIN_KEYS + _INIT_KEYS)}")
        p = self._sample_params()
        if self.randomize:
            pl.check_stability(p[None], self.sub_dt)
            self._check_task(p)
            self.params = p.copy()
            self._build(p)
        ta, tk, torque, (a0, k0) = joint_schedules(self.np_random, self.task, self.geometry, p,
                                                   self.n_steps, self.control_dt)
        for key, arr in zip(_PIN_KEYS, (ta, tk, torque)):
            if key in options:
                v = float(options[key])
                if not math.isfinite(v):
                    raise ValueError(f"reset option {key} must be finite, got {options[key]!r}")
                if key == "target_stiffness" and not v > 0:  # the reward divides by it
                    raise ValueError(f"reset option target_stiffness must be > 0 N m/rad, got {v!r}")
                if key == "target_angle" and not 0.0 <= v <= self.geometry.max_angle(p):
                    raise ValueError(f"reset option target_angle is in radians and must lie within "
                                     f"[0, {self.geometry.max_angle(p):.3g}] rad, got {v!r}")
                arr[:] = v
        a0 = float(options.get("initial_angle", a0))
        k0 = float(options.get("initial_stiffness", k0))
        if not (0.0 <= a0 <= self.geometry.max_angle(p)) or not (math.isfinite(k0) and k0 > 0):
            raise ValueError(f"initial_angle must be within [0, {self.geometry.max_angle(p):.3g}] rad and "
                             f"initial_stiffness > 0, got {a0}, {k0}")
        self.target_angle, self.target_stiffness, self.external_torque = ta, tk, torque
        g = self.geometry
        L0 = float(g.length(a0, p))
        w0 = g.equivalent_weight(a0, torque[0], p)
        pc, pe, _ = api.static_pressures(L0, k0 / g.lever_arm ** 2, w0, p)
        cap = min(p[ix.P_SUP] - p[ix.P_ATM], p[ix.P_BURST])
        pc, pe = float(np.clip(pc, 0.0, cap)), float(np.clip(pe, 0.0, cap))
        mj = self.mujoco
        mj.mj_resetData(self.model, self.data)
        self.data.qpos[0] = a0
        mj.mj_forward(self.model, self.data)
        self.link.x[:] = pl.initial_state(p, L0, pc, pe)[0]
        self.link.begin()
        self.aux[:] = self.link.finish(L0, 0.0)
        self.aux[pl.A_AIR] = 0.0
        self.t_idx = 0
        self.prev_action[:] = 0.0
        self._reset_done = True
        info = self._info(scored=False)
        if self.render_mode == "human":
            self.render()
        return self._obs(), info

    # -------------------------------------------------------------------- step
    def step(self, action):
        if not self._reset_done:
            raise RuntimeError("call reset() before step()")
        a = np.asarray(action, dtype=np.float64)
        if a.shape != (2,):
            if a.size == 2:
                a = a.reshape(2)
            else:
                raise ValueError(f"action must have shape (2,), got {np.shape(action)}")
        if not np.isfinite(a).all():
            raise ValueError(f"action contains NaN or inf: {action!r}")
        a = np.clip(a, -1.0, 1.0)
        k = min(self.t_idx, self.n_steps - 1)
        tau_ext = float(self.external_torque[k])
        link, p, mj, m, d = self.link, self.params, self.mujoco, self.model, self.data
        if self.mode == pl.PRESSURE:
            half = 0.5 * self.setpoint_max
            link.inp[pl.I_CMD_C], link.inp[pl.I_CMD_E] = half * (a[0] + 1.0), half * (a[1] + 1.0)
        else:
            link.inp[pl.I_CMD_C], link.inp[pl.I_CMD_E] = a[0], a[1]
        link.inp[pl.I_LOAD] = 0.0
        link.inp[pl.I_FEXT] = 0.0
        r = self.geometry.lever_arm
        l_max, l_min = p[ix.L_MAX], p[ix.L_MIN]
        w_end = p[ix.M_END] * p[ix.GRAV]
        qpos, qvel, qfrc = d.qpos, d.qvel, d.qfrc_applied
        link.begin()
        for _ in range(self.n_sub):
            L = min(max(l_max - r * qpos[0], l_min), l_max)
            force = link.force(L, -r * qvel[0])
            qfrc[0] = -r * (force + w_end) - tau_ext
            mj.mj_step(m, d)
        L = min(max(l_max - r * qpos[0], l_min), l_max)
        self.aux[:] = link.finish(L, -r * qvel[0])
        self.prev_action[:] = a
        terms = self._reward_terms(a, k)
        self.t_idx += 1
        finite = self.aux[pl.A_FINITE] != 0.0 and np.isfinite(qpos[0]) and np.isfinite(qvel[0])
        reason = 2 if not finite else (1 if self.aux[pl.A_BURST] != 0.0 else 0)
        reward = float(sum(terms.values())) if finite else 0.0
        info = self._info(scored=True, k=k)
        info.update(terms)
        info["termination_reason"] = int(reason)  # named by metadata["termination_reasons"]
        if self.render_mode == "human":
            self.render()
        return self._obs(), reward, reason != 0, False, info

    # ------------------------------------------------------------ measurements
    def joint_state(self) -> tuple[float, float]:
        """``(angle [rad], angular velocity [rad/s])`` of the hinge."""
        return float(self.data.qpos[0]), float(self.data.qvel[0])

    def joint_stiffness(self) -> float:
        """``K r^2`` [N m/rad]: the muscle's stiffness at constant pressures through the pinion."""
        return float(self.aux[pl.A_STIFF] * self.geometry.lever_arm ** 2)

    def _reward_terms(self, a, k) -> dict[str, float]:
        w = self.weights
        th, _ = self.joint_state()
        kt = float(self.target_stiffness[k])
        terms = {
            "reward_angle": -w.angle * min(abs(th - float(self.target_angle[k])) / _ANGLE_UNIT, 5.0),
            "reward_stiffness": -w.stiffness * min(abs(self.joint_stiffness() - kt) / kt, 2.0),
            "reward_effort": -w.effort * 0.5 * float(a[0] ** 2 + a[1] ** 2),
            "reward_air": -w.air * float(self.aux[pl.A_AIR]) / 1e-5,
            "reward_burst": -w.burst if self.aux[pl.A_BURST] != 0.0 else 0.0,
        }
        return terms

    def _obs(self) -> np.ndarray:
        th, om = self.joint_state()
        k = min(self.t_idx, self.n_steps - 1)
        half = 0.5 * self.angle_max
        ps = self.nominal.supply_pressure
        p = self.params
        o = np.array([(th - half) / half, om / _OMEGA_SCALE, self.aux[pl.A_PC] / ps,
                      self.aux[pl.A_PE] / ps, (p[ix.P_SUP] - p[ix.P_ATM]) / ps,
                      (self.target_angle[k] - half) / half, self.target_stiffness[k] / _K_SCALE,
                      self.prev_action[0], self.prev_action[1]])
        return np.clip(np.nan_to_num(o), -_OBS_CLIP, _OBS_CLIP).astype(np.float32)

    def _info(self, scored: bool, k: int | None = None) -> dict[str, Any]:
        if k is None:
            k = min(self.t_idx, self.n_steps - 1)
        th, om = self.joint_state()
        g, p, aux = self.geometry, self.params, self.aux
        r = g.lever_arm
        ks = self.joint_stiffness()
        return {
            "angle": th, "angular_velocity": om,
            "muscle_length": float(self.link.x[pl.S_L]), "muscle_force": float(aux[pl.A_FORCE]),
            "muscle_torque": float(-r * aux[pl.A_FORCE]),
            "stiffness": float(aux[pl.A_STIFF]), "joint_stiffness": ks,
            "joint_stiffness_total": ks + float(g.link_mass * p[ix.GRAV] * g.link_com * math.cos(th)),
            "pressure_c": float(aux[pl.A_PC]), "pressure_e": float(aux[pl.A_PE]),
            "air_used": float(aux[pl.A_AIR]) if scored else 0.0,
            "external_torque": float(self.external_torque[k]),
            "target_angle": float(self.target_angle[k]),
            "target_stiffness": float(self.target_stiffness[k]),
        }

    # ------------------------------------------------------------------ render
    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array'")
            return None
        frame = self._frame()
        if self.render_mode == "rgb_array":
            return frame
        if self._window is None:
            from .video import FrameWindow

            self._window = FrameWindow(frame.shape)
        self._window.show(frame)
        return None

    def _frame(self) -> np.ndarray:
        mj, m, d = self.mujoco, self.model, self.data
        g, p = self.geometry, self.params
        r = g.lever_arm
        ids = self._geom_ids
        top = float(m.geom_pos[ids["plate"], 2]) - 0.005
        L = float(self.link.x[pl.S_L])
        set_muscle_geoms(m, ids, p, L, self.aux[pl.A_PC], self.aux[pl.A_PE], top, x=r)
        z_cap = top - L - 0.004
        m.geom_pos[ids["cap"]] = (r, 0.0, z_cap)
        rack_len = max(z_cap - 0.004, 0.002)  # from under the cap down to the pinion's tangent point
        m.geom_size[ids["rack"], 2] = 0.5 * rack_len
        m.geom_pos[ids["rack"]] = (r, 0.0, 0.5 * rack_len)
        mj.mj_kinematics(m, d)
        if self._renderer is None:
            self._renderer = make_renderer(mj, m, self.height, self.width)
            self._camera = default_camera(mj, (0.035, 0.0, 0.04), 0.6, azimuth=90.0, elevation=-8.0)
        ren = self._renderer
        ren.update_scene(d, camera=self._camera)
        k = min(max(self.t_idx - 1, 0), self.n_steps - 1)
        th_t = float(self.target_angle[k])
        y = -0.014
        hand_t = np.array([g.link_length * math.sin(th_t), y, -g.link_length * math.cos(th_t)])
        self._add_geom(mj.mjtGeom.mjGEOM_CAPSULE, 0.006, np.array([0.0, y, 0.0]), hand_t, (0.1, 0.75, 0.2, 0.5))
        tau = float(self.external_torque[k])
        if tau > 0:
            th, _ = self.joint_state()
            hand = np.array([g.link_length * math.sin(th), y - 0.03, -g.link_length * math.cos(th)])
            ext = -np.array([math.cos(th), 0.0, math.sin(th)])  # direction of extension at the hand
            self._add_geom(mj.mjtGeom.mjGEOM_ARROW, 0.006, hand, hand + ext * (0.02 + 2.5 * tau),
                           (0.95, 0.55, 0.1, 1.0))
        return ren.render().copy()

    def _add_geom(self, kind, width, a, b, rgba) -> None:
        mj = self.mujoco
        scn = self._renderer.scene
        if scn.ngeom >= scn.maxgeom:
            return
        geom = scn.geoms[scn.ngeom]
        mj.mjv_initGeom(geom, kind, np.zeros(3), np.zeros(3), np.eye(3).ravel(), np.asarray(rgba, dtype=np.float32))
        mj.mjv_connector(geom, kind, width, a, b)
        scn.ngeom += 1

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        if self._window is not None:
            self._window.close()
            self._window = None


# ---------------------------------------------------------------------- baseline
class JointInverseStaticController(InverseStaticController):
    """The rig's inverse-static baseline (:class:`cepam_gym.control.InverseStaticController`)
    through the joint geometry; ``reset(indices=None)`` / ``act(obs, info=None)`` like the
    benchmark harness's controllers, on single ``(9,)`` or batched ``(N, 9)`` observations.

    Per control step, with the *nominal* plant and geometry:

    1. angle, pressures and targets from the observation; muscle lengths ``L = L_max - r theta``;
    2. **external torque estimate** from the quasi-static balance of the hinge:
       ``tau_ext = -r (F(L, Pc, Pe) + m_end g) - m g l_c sin(theta)``, low-pass filtered;
    3. **inverse static model** at the target: the equivalent hanging weight at ``theta*``
       (:meth:`JointGeometry.equivalent_weight`) and the muscle stiffness ``K* = K_joint* / r^2``
       give the set-points (:meth:`InverseStaticController.setpoints`, the same projection of
       unreachable targets);
    4. the same pressure loop per chamber as the rig's baseline (feedforward from the ISO 6358
       flow plus PI), or the set-points themselves in ``"pressure"`` mode.
    """

    def __init__(self, env, gap_fraction: float = 0.5, kp: float = 0.2, ki: float = 0.5,
                 load_filter_s: float = 0.15):
        j = _joint_env_of(env)
        self.geometry = j.geometry
        self.setpoint_max = j.setpoint_max
        self.angle_max = j.angle_max
        self.task = j.task.muscle_spec(j.geometry, j.nominal_row)
        self._configure(j.nominal, j.nominal_row.copy(), j.action_mode, j.control_dt,
                        gap_fraction, kp, ki, load_filter_s)

    def act(self, obs, info=None) -> np.ndarray:
        single = np.ndim(obs) == 1
        obs = np.atleast_2d(np.asarray(obs, dtype=float))
        p, g = self.params, self.geometry
        half = 0.5 * self.angle_max
        ps = self.nominal.supply_pressure
        th = obs[:, 0] * half + half
        pc, pe = obs[:, 2] * ps, obs[:, 3] * ps
        th_t = obs[:, 5] * half + half
        k_t = obs[:, 6] * _K_SCALE / g.lever_arm ** 2
        L = g.length(th, p)
        r, grav = g.lever_arm, p[ix.GRAV]
        tau_now = -r * (api.force(L, pc, pe, p) + p[ix.M_END] * grav) - g.gravity_torque(th, grav)
        # the filtered load is the external torque [N m] here
        weight = g.equivalent_weight(th_t, np.maximum(self._filtered(tau_now), 0.0), p)
        pc_set, pe_set = self.setpoints(g.length(th_t, p), k_t, weight)
        return self._drive(pc_set, pe_set, L, pc, pe, self.setpoint_max, single)


def _joint_env_of(env) -> CEPAMJointEnv:
    e = env
    for _ in range(16):
        if isinstance(e, CEPAMJointEnv):
            return e
        nxt = getattr(e, "unwrapped", None)
        if nxt is e or nxt is None:
            nxt = getattr(e, "env", None)
        if nxt is None and getattr(e, "envs", None):  # a SyncVectorEnv: same nominal plant in each
            nxt = e.envs[0]
        if nxt is None:
            break
        e = nxt
    raise TypeError(f"cannot find a CEPAMJointEnv inside {env!r}")


def make_joint_controller(spec: str, env):
    """``baseline`` (:class:`JointInverseStaticController`), ``zero`` or ``random``, with the
    benchmark harness's ``reset``/``act`` protocol."""
    from ..bench.harness import RandomController, ZeroController

    if spec == "baseline":
        return JointInverseStaticController(env)
    if spec == "zero":
        return ZeroController(env)
    if spec == "random":
        return RandomController(env)
    raise ValueError(f"unknown controller {spec!r} for the joint env: use baseline, zero or random "
                     "(trained agents are trained on the rig's observations)")
