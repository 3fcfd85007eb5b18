"""The joint's step info, declared once: each key with its value as an expression of what the
step measured (:class:`Measured`). The joint's contract (:data:`cepam_gym.tasks.contract.JOINT`)
takes its keys from here, and both info builders of the hinge task
(:class:`~cepam_gym.tasks.hinge_task.HingeTask`: Python floats for a single env, arrays for a
batch) evaluate the same expressions, so the two can never disagree on what a key holds."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Measured(NamedTuple):
    """What one step of the joint measured, per env (floats for one env, arrays for a batch), SI."""

    L: object  # muscle length [m]
    v: object  # its rate [m/s]
    theta: object  # joint angle [rad]
    force: object  # muscle force [N], extension positive
    stiff: object  # muscle stiffness [N/m]
    pc: object  # chamber gauge pressures [Pa]
    pe: object
    air: object  # air drawn in the step [kg] (0 at a reset)
    load: object  # external torque of the step [N m]
    target_angle: object  # [rad]
    target_stiffness: object  # [N m/rad]
    grav: object  # gravity [m/s^2]
    r: float  # the rack's lever arm [m]
    link_mass: float  # [kg]
    link_com: float  # [m]


def _joint_stiffness(m: Measured):
    return m.stiff * m.r**2


HINGE_INFO = (
    ("angle", lambda m: m.theta),
    ("angular_velocity", lambda m: -m.v / m.r),
    ("muscle_length", lambda m: m.L),
    ("muscle_force", lambda m: m.force),
    ("muscle_torque", lambda m: -m.r * m.force),
    ("stiffness", lambda m: m.stiff),
    ("joint_stiffness", _joint_stiffness),
    # the link's weight adds m g l_c cos(theta) to the stiffness the joint shows
    (
        "joint_stiffness_total",
        lambda m: _joint_stiffness(m) + m.link_mass * m.grav * m.link_com * np.cos(m.theta),
    ),
    ("pressure_c", lambda m: m.pc),
    ("pressure_e", lambda m: m.pe),
    ("air_used", lambda m: m.air),
    ("external_torque", lambda m: m.load),
    ("target_angle", lambda m: m.target_angle),
    ("target_stiffness", lambda m: m.target_stiffness),
)
INFO_KEYS = tuple(k for k, _ in HINGE_INFO)


def hinge_info(m: Measured) -> dict:
    """The declared info of measurements ``m``."""
    return {key: value(m) for key, value in HINGE_INFO}
