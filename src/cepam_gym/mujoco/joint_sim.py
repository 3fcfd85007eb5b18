"""The hinge of ``cepam_gym/CEPAMJoint-v0`` in MuJoCo, driven by one plant through the coupling.

Every plant sub-step: the hinge angle and rate impose the muscle length ``L = L_max - r theta``
and rate ``-r omega`` (clamped to the end stops), the plant returns its push force
(:class:`~cepam_gym.mujoco.coupling.PlantLink`), and MuJoCo steps the hinge under the generalized
force ``tau = -r (F + m_end g) - tau_ext`` (gravity of the link, damping, armature and friction
are in the MJCF, :func:`~cepam_gym.mujoco.joint_task.joint_xml`). docs/mujoco.md derives it.
"""

from __future__ import annotations

import math

import numpy as np

from .. import plant as pl
from ..params import pressure_cap_of
from ..physics import api
from ..physics import layout as ix
from .coupling import PlantLink
from .joint_task import JointGeometry, joint_xml
from .rig import geom_ids


class JointSimulator:
    """MuJoCo model and data of the hinge for plant parameter row ``p`` and the plant it carries
    (``link``: state ``link.x``, valve inputs ``link.inp``)."""

    def __init__(
        self,
        mujoco,
        geometry: JointGeometry,
        p: np.ndarray,
        mode: int,
        sub_dt: float,
        width: int = 480,
        height: int = 480,
    ):
        self.mujoco, self.geometry, self.p = mujoco, geometry, p
        self.model = mujoco.MjModel.from_xml_string(joint_xml(geometry, p, sub_dt, width, height))
        self.data = mujoco.MjData(self.model)
        self.link = PlantLink(p, mode, sub_dt)
        self.geom_ids = geom_ids(mujoco, self.model, ("cpam", "epam", "cap", "rack"))

    def reset(self, angle: float, joint_stiffness: float, external_torque: float) -> np.ndarray:
        """At rest at ``angle`` [rad] with the chamber pressures of the inverse static model for
        ``joint_stiffness`` [N m/rad] under ``external_torque`` [N m] (clipped to
        ``[0, min(supply, burst)]``); returns the plant's ``aux`` (no air used yet)."""
        g, p, mj = self.geometry, self.p, self.mujoco
        L0 = float(g.length(angle, p))
        w0 = g.equivalent_weight(angle, external_torque, p)
        pc, pe, _ = api.static_pressures(L0, joint_stiffness / g.lever_arm**2, w0, p)
        cap = pressure_cap_of(p)
        pc, pe = float(np.clip(pc, 0.0, cap)), float(np.clip(pe, 0.0, cap))
        mj.mj_resetData(self.model, self.data)
        self.data.qpos[0] = angle
        mj.mj_forward(self.model, self.data)
        self.link.x[:] = pl.initial_state(p, L0, pc, pe)[0]
        self.link.begin()
        aux = self.link.finish(L0, 0.0)
        aux[pl.A_AIR] = 0.0
        return aux

    def step(self, external_torque: float, n_sub: int) -> np.ndarray:
        """``n_sub`` coupled sub-steps with the valve inputs in ``link.inp``; returns ``aux``."""
        link, p, mj, m, d = self.link, self.p, self.mujoco, self.model, self.data
        r = self.geometry.lever_arm
        l_max, l_min = p[ix.L_MAX], p[ix.L_MIN]
        w_end = p[ix.M_END] * p[ix.GRAV]
        qpos, qvel, qfrc = d.qpos, d.qvel, d.qfrc_applied
        link.begin()
        for _ in range(n_sub):
            L = min(max(l_max - r * qpos[0], l_min), l_max)
            force = link.force(L, -r * qvel[0])
            qfrc[0] = -r * (force + w_end) - external_torque
            mj.mj_step(m, d)
        L = min(max(l_max - r * qpos[0], l_min), l_max)
        return link.finish(L, -r * qvel[0])

    # ------------------------------------------------------------ measurements
    def joint_state(self) -> tuple[float, float]:
        """``(angle [rad], angular velocity [rad/s])`` of the hinge."""
        return float(self.data.qpos[0]), float(self.data.qvel[0])

    def joint_stiffness(self, aux) -> float:
        """``K r^2`` [N m/rad]: the muscle's stiffness at constant pressures through the pinion."""
        return float(aux[pl.A_STIFF] * self.geometry.lever_arm**2)

    def measure(self, aux) -> dict[str, float]:
        """The mechanism's quantities (SI) with the plant's ``aux``: angle, rate, muscle length,
        force and torque, muscle and joint stiffness (with gravity's ``m g l_c cos theta`` in
        ``joint_stiffness_total``), gauge pressures."""
        th, om = self.joint_state()
        g, p = self.geometry, self.p
        ks = self.joint_stiffness(aux)
        return {
            "angle": th,
            "angular_velocity": om,
            "muscle_length": float(self.link.x[pl.S_L]),
            "muscle_force": float(aux[pl.A_FORCE]),
            "muscle_torque": float(-g.lever_arm * aux[pl.A_FORCE]),
            "stiffness": float(aux[pl.A_STIFF]),
            "joint_stiffness": ks,
            "joint_stiffness_total": ks + float(g.link_mass * p[ix.GRAV] * g.link_com * math.cos(th)),
            "pressure_c": float(aux[pl.A_PC]),
            "pressure_e": float(aux[pl.A_PE]),
        }
