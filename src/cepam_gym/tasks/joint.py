"""The joint task of ``cepam_gym/CEPAMJoint-v0``: the rig's task over a mechanism map.

The hinge geometry maps the muscle to the joint (length <-> angle, muscle stiffness <-> joint
stiffness, loads <-> the rig's equivalent hanging weight); through it the joint reuses the task
layer: target schedules (:mod:`cepam_gym.planning.schedules`), reward terms, termination and action
mapping (:mod:`cepam_gym.envs.step_kernel`), observation layout (:mod:`cepam_gym.tasks.layout`). Here:
the geometry, targets and torque profiles, reward weights and scales, the observation layout, and
the MJCF model. The env itself is :mod:`cepam_gym.envs.joint_mujoco`; docs/mujoco.md explains the
mechanism and the coupling."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import ClassVar

import numpy as np

from ..errors import InputError
from ..physics import layout as ix
from ..physics.hinge import H_DAMP, H_INERTIA, H_MASS_MOMENT, H_R, N_HINGE
from .layout import ObsColumn, ObsLayout, preview_fields
from .reward import JOINT_ABS_REWARD, Reward
from .spec import LOAD_KINDS, TaskScales, TaskSpec
from .termination import DEFAULT_TERMINATIONS, Termination, reason_names


@dataclass(frozen=True)
class JointGeometry:
    """The hinge and its link. Lengths m, masses kg, damping N m s/rad."""

    lever_arm: float = 0.025  # pinion radius r: muscle length per radian
    link_length: float = 0.14  # elbow to hand
    link_mass: float = 0.15  # forearm segment + hand of the device
    link_com: float = 0.07  # elbow to the link's centre of mass
    joint_damping: float = 0.01  # hinge viscous damping (besides the muscle's own, mapped)

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if not (isinstance(v, (int, float)) and math.isfinite(v)):
                raise InputError(f"joint geometry {f.name} must be a finite number, got {v!r}")
        for name in ("lever_arm", "link_length", "link_mass", "link_com"):
            if not getattr(self, name) > 0:
                raise InputError(f"joint geometry {name} must be > 0, got {getattr(self, name)}")
        if self.joint_damping < 0:
            raise InputError(f"joint geometry joint_damping must be >= 0, got {self.joint_damping}")
        if self.link_com > self.link_length:
            raise InputError(
                f"link_com ({self.link_com} m) must not exceed link_length ({self.link_length} m)"
            )

    @classmethod
    def from_kwargs(cls, joint: Mapping[str, float] | JointGeometry | None) -> JointGeometry:
        if joint is None:
            return cls()
        if isinstance(joint, JointGeometry):
            return joint
        names = {f.name for f in fields(cls)}
        bad = set(joint) - names
        if bad:
            raise InputError(f"joint: unknown keys {sorted(bad)}; valid: {sorted(names)}")
        return cls(**{k: float(v) for k, v in joint.items()})

    @property
    def com_inertia(self) -> float:
        """The link's moment of inertia about its centre of mass [kg m^2]: a rod of
        ``link_length`` (the MJCF's ``diaginertia``)."""
        return self.link_mass * self.link_length**2 / 12.0

    @property
    def axis_inertia(self) -> float:
        """The link's moment of inertia about the hinge [kg m^2]: :attr:`com_inertia` moved to
        the axis by ``link_com`` (what MuJoCo computes from the MJCF)."""
        return self.com_inertia + self.link_mass * self.link_com**2

    def hinge_row(self) -> np.ndarray:
        """The hinge row of the batched kernel (:data:`cepam_gym.physics.hinge.HINGE_FIELDS`):
        the same mechanism as the MJCF of :func:`joint_xml`."""
        h = np.zeros(N_HINGE)
        h[H_R], h[H_INERTIA] = self.lever_arm, self.axis_inertia
        h[H_MASS_MOMENT], h[H_DAMP] = self.link_mass * self.link_com, self.joint_damping
        return h

    # geometry through the pinion, for a plant parameter row p (or the transposed rows of a batch)
    def length(self, angle, p):
        """Muscle length [m] at joint angle [rad]: ``L = L_max - r theta``."""
        return p[ix.L_MAX] - self.lever_arm * np.asarray(angle, dtype=float)

    def angle(self, length, p):
        """Joint angle [rad] at muscle length [m]."""
        return (p[ix.L_MAX] - np.asarray(length, dtype=float)) / self.lever_arm

    def max_angle(self, p) -> float:
        """Full flexion [rad]: the muscle's lower end stop."""
        return float((p[ix.L_MAX] - p[ix.L_MIN]) / self.lever_arm)

    def gravity_torque(self, angle, g):
        """Extension torque [N m] of the link's weight at ``angle``: ``m g l_c sin(theta)``."""
        return self.link_mass * g * self.link_com * np.sin(angle)

    def equivalent_weight(self, angle, external_torque, p):
        """The downward force [N] on the muscle's free end that the joint's loads amount to (what
        the rig's hanging weight is): ``m_end g + (tau_ext + m g l_c sin theta) / r``."""
        g = p[ix.GRAV]
        return (
            p[ix.M_END] * g
            + (np.asarray(external_torque, dtype=float) + self.gravity_torque(angle, g)) / self.lever_arm
        )


@dataclass(frozen=True)
class JointRewardWeights:
    angle: float = 1.0  # per 10 deg of |theta - theta*| (clipped at 5)
    stiffness: float = 5.0  # per unit relative error |K_joint - K*| / K* (clipped at 2): 20 % ~ 10 deg
    effort: float = 0.05  # per unit mean squared action
    air: float = 0.05  # per 10 mg of supply air in one control step
    burst: float = 100.0  # once, when a chamber exceeds the burst pressure

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if not (np.isfinite(v) and v >= 0):
                raise InputError(f"reward weight {f.name} must be finite and >= 0, got {v!r}")


@dataclass(frozen=True)
class JointTask:
    """Targets and loads of the joint task. Angles rad, stiffness N m/rad, torques N m, times s."""

    angle_range: tuple[float, float] = (0.2, 1.6)  # targets; muscle 19.0-15.5 cm with r = 2.5 cm
    stiffness_range: tuple[float, float] = (0.15, 0.8)  # joint stiffness K r^2, clipped to what is reachable
    torque_range: tuple[float, float] = (0.0, 0.04)  # external extension torque
    load_kinds: tuple[str, ...] = LOAD_KINDS  # profile of the external torque
    segment_duration: tuple[float, float] = (2.0, 4.0)
    pressure_margin: float = 0.85
    # reference shapes drawn per episode (planning.references; ("step",): the v0 set-points)
    references: tuple[str, ...] = ("step",)
    move_s: float = 0.6  # duration of a minimum-jerk move between set-points [s]
    # the joint task always tracks a joint stiffness (read by the bench, the trainer's logging)
    track_stiffness: ClassVar[bool] = True
    # one unit of the angle reward term: 10 deg, the error the joint benchmark scores as 1 (as 20 %
    # of stiffness is, which JointRewardWeights.stiffness = 5 prices alike); angular velocity per
    # 5 rad/s and joint stiffness per 1 N m/rad in the observation
    scales: TaskScales = TaskScales(tracking_unit=math.radians(10.0), velocity_scale=5.0, stiffness_scale=1.0)
    # the default reward weights (a user's reward_weights override them) and the reward
    # (tasks.reward: the score's form on the v3 joint)
    weights: JointRewardWeights = JointRewardWeights()
    reward: Reward = JOINT_ABS_REWARD
    # what ends an episode (tasks.termination), checked in order after every step
    terminations: tuple[Termination, ...] = DEFAULT_TERMINATIONS

    def __post_init__(self):
        lo, hi = self.angle_range
        if not 0 <= lo < hi:
            raise InputError(f"angle_range must be increasing and >= 0, got {self.angle_range}")
        if not 0 < self.stiffness_range[0] < self.stiffness_range[1]:
            raise InputError(f"stiffness_range must be increasing and positive, got {self.stiffness_range}")
        if not 0 <= self.torque_range[0] <= self.torque_range[1]:
            raise InputError(
                f"torque_range must be 0 <= low <= high (extension torques), got {self.torque_range}"
            )
        # the fields shared with the rig's TaskSpec are checked by TaskSpec itself
        TaskSpec(
            "joint",
            load_kinds=tuple(self.load_kinds),
            segment_duration=tuple(self.segment_duration),
            pressure_margin=self.pressure_margin,
            references=tuple(self.references),
            move_s=self.move_s,
            terminations=self.terminations,
        )
        object.__setattr__(self, "terminations", tuple(self.terminations))
        if not isinstance(self.reward, Reward):
            raise InputError(f"reward must be a tasks.reward.Reward, got {type(self.reward).__name__}")
        self.reward.weight_values(self.weights)

    @property
    def termination_names(self) -> tuple[str, ...]:
        """The step's termination reasons, index = code (tasks.termination)."""
        return reason_names(self.terminations)

    @property
    def reward_form(self) -> str:
        """The reward's name (``"abs"``, ``"score"``, or a declaration's own)."""
        return self.reward.name

    def check_range(self, geom: JointGeometry, p) -> None:
        """``ValueError`` when the target angles exceed the joint's range for plant row ``p``."""
        amax = geom.max_angle(p)
        if self.angle_range[1] > amax:
            raise InputError(
                f"task angle_range {self.angle_range} rad exceeds the joint's range "
                f"[0, {amax:.3g}] rad (muscle end stops through lever_arm {geom.lever_arm} m)"
            )

    def muscle_spec(self, geom: JointGeometry, p) -> TaskSpec:
        """The same task seen by the muscle (lengths, stiffness K = K_joint / r^2), for the
        plant-side helpers (:func:`~cepam_gym.planning.schedules.stiffness_interval`,
        :func:`~cepam_gym.planning.schedules.load_profile`). Its ``load_range`` holds the *torque*
        range [N m]: it only shapes the external-torque profile."""
        r2 = geom.lever_arm**2
        l_hi, l_lo = (float(geom.length(a, p)) for a in self.angle_range)
        return TaskSpec(
            "joint",
            length_range=(l_lo, l_hi),
            stiffness_range=(self.stiffness_range[0] / r2, self.stiffness_range[1] / r2),
            load_range=tuple(self.torque_range),
            load_kinds=tuple(self.load_kinds),
            segment_duration=tuple(self.segment_duration),
            pressure_margin=self.pressure_margin,
            references=tuple(self.references),
            move_s=self.move_s,
        )


# the quantities the joint env measures, in the order of the rig's OBS_FIELDS
JOINT_FIELDS = (
    "angle",
    "angular_velocity",
    "pressure_c",
    "pressure_e",
    "supply_pressure",
    "target_angle",
    "target_stiffness",
    "previous_action_c",
    "previous_action_e",
)


def joint_layout(
    task: JointTask, max_angle: float, supply_pressure: float, preview_steps: int = 0
) -> ObsLayout:
    """The joint env's observation: angles about half of full flexion ``max_angle`` [rad],
    pressures per nominal ``supply_pressure`` [Pa], the task's velocity and stiffness scales; then
    ``preview_steps`` preview columns of target angle and target stiffness
    (:func:`~cepam_gym.tasks.layout.preview_fields`, scaled like the targets)."""
    s, half, ps = task.scales, 0.5 * max_angle, supply_pressure
    cols = (
        ObsColumn("angle", half, half, "rad"),
        ObsColumn("angular_velocity", s.velocity_scale, 0.0, "rad/s"),
        ObsColumn("pressure_c", ps, 0.0, "Pa"),
        ObsColumn("pressure_e", ps, 0.0, "Pa"),
        ObsColumn("supply_pressure", ps, 0.0, "Pa"),
        ObsColumn("target_angle", half, half, "rad"),
        ObsColumn("target_stiffness", s.stiffness_scale, 0.0, "N m/rad"),
        ObsColumn("previous_action_c"),
        ObsColumn("previous_action_e"),
    )
    names = preview_fields(preview_steps, True, "angle")
    cols += tuple(
        ObsColumn(name, c.scale, c.offset, c.unit)
        for name in names
        for c in [cols[5] if name.startswith("target_angle") else cols[6]]
    )
    return ObsLayout(cols, JOINT_FIELDS + names, s.obs_clip, preview_steps, "angle")


PIN_KEYS = ("target_angle", "target_stiffness", "external_torque")  # reset options held all episode
INIT_KEYS = ("initial_angle", "initial_stiffness")  # reset options of the starting point
