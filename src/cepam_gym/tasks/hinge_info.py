"""The joint's step info, declared once: each key with its value as an expression of what the
step measured, in :func:`hinge_info`. The joint's contract (:data:`cepam_gym.tasks.contract.JOINT`)
takes its keys from here, and both info builders of the hinge task
(:class:`~cepam_gym.envs.hinge_task.HingeTask`: Python floats for a single env, arrays for a
batch) evaluate the same expressions, so the two can never disagree on what a key holds."""

from __future__ import annotations

import numpy as np


def hinge_info(
    L, v, theta, force, stiff, pc, pe, air, load, target_angle, target_stiffness, grav, r, link_mass, link_com
) -> dict:  # noqa: E501
    """The joint's info of what one step measured, per env (floats for one env's step, where a
    table of functions or a record would cost a call per key; arrays for a batch), SI: the muscle's
    length ``L`` [m] and rate ``v``, the joint angle ``theta`` [rad], the muscle's force [N] and
    stiffness ``stiff`` [N/m], the chamber gauge pressures [Pa], the air drawn in the step [kg] (0
    at a reset), the external torque ``load`` [N m], the targets, gravity, the rack's lever arm
    ``r`` [m] and the link's mass [kg] and centre of mass [m]."""
    ks = stiff * r**2
    return {
        "angle": theta,
        "angular_velocity": -v / r,
        "muscle_length": L,
        "muscle_force": force,
        "muscle_torque": -r * force,
        "stiffness": stiff,
        "joint_stiffness": ks,
        # the link's weight adds m g l_c cos(theta) to the stiffness the joint shows
        "joint_stiffness_total": ks + link_mass * grav * link_com * np.cos(theta),
        "pressure_c": pc,
        "pressure_e": pe,
        "air_used": air,
        "external_torque": load,
        "target_angle": target_angle,
        "target_stiffness": target_stiffness,
    }


INFO_KEYS = tuple(hinge_info(*([1.0] * 15)))  # the keys, in order
