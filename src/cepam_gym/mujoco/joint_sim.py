"""The hinge of ``cepam_gym/CEPAMJoint-v0`` in MuJoCo, driven by one plant through the coupling.

Every plant sub-step: the hinge angle and rate impose the muscle length ``L = L_max - r theta``
and rate ``-r omega`` (clamped to the end stops), the plant returns its push force
(:class:`~cepam_gym.plant.coupling.PlantLink`), and MuJoCo steps the hinge under the generalized
force ``tau = -r (F + m_end g) - tau_ext`` (gravity of the link, damping, armature and friction
are in the MJCF, :func:`~cepam_gym.mujoco.joint_sim.joint_xml`). docs/mujoco.md derives it.
"""

from __future__ import annotations

import math

import numpy as np

from .. import plant as pl
from ..physics import api
from ..physics import layout as ix
from ..plant.coupling import PlantLink
from ..plant.params import pressure_cap_of
from ..tasks.joint import JointGeometry
from ._mj import scene_header
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


JOINT_XML = """
<mujoco model="cepam_joint">
  <compiler angle="radian"/>
  <option timestep="{dt}" integrator="Euler" gravity="0 0 -{g}">
    <flag energy="enable"/>
  </option>
{scene}    <material name="shell" rgba="0.93 0.78 0.62 1" specular="0.2"/>
  </asset>
  <default>
    <geom contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <light pos="0.3 -0.6 0.9" dir="-0.3 0.6 -0.9" diffuse="0.6 0.6 0.6" castshadow="true"/>
    <geom name="floor" type="plane" pos="0 0 {floor}" size="0.6 0.6 0.01" material="grid"/>
    <geom name="upper_arm" type="capsule" fromto="-0.03 0.03 0 -0.03 0.03 {top}" size="0.022" material="shell"/>
    <geom name="bracket" type="box" pos="-0.002 0.02 {top}" size="0.03 0.02 0.005" material="dark"/>
    <geom name="plate" type="box" pos="{r} 0 {plate_z}" size="0.022 0.022 0.005" material="dark"/>
    <geom name="cpam" type="cylinder" pos="{r} 0 0.1" size="0.003 0.08" rgba="1 0.8 0.8 1"/>
    <geom name="epam" type="cylinder" pos="{r} 0 0.1" size="0.013 0.08" rgba="0.75 0.85 1 0.3"/>
    <geom name="cap" type="cylinder" pos="{r} 0 0.05" size="0.015 {cap}" material="dark"/>
    <geom name="rack" type="box" pos="{r} 0 0.03" size="0.002 0.004 0.01" material="metal"/>
    <geom name="axle" type="cylinder" fromto="0 -0.02 0 0 0.035 0" size="0.004" material="metal"/>
    <body name="forearm" pos="0 0 0">
      <joint name="elbow" type="hinge" axis="0 -1 0" range="0 {qmax}" limited="true"
             damping="{damping}" armature="{armature}" frictionloss="{friction}" solreflimit="{solref} 1"/>
      <inertial pos="0 0 -{lc}" mass="{m}" diaginertia="{inertia} {inertia} 1e-6"/>
      <geom name="pinion" type="cylinder" fromto="0 -0.006 0 0 0.006 0" size="{r}" material="metal"/>
      <geom name="link" type="capsule" fromto="0 -0.014 0 0 -0.014 -{l}" size="0.014" material="shell"/>
      <geom name="hand" type="sphere" pos="0 -0.014 -{l}" size="0.024" material="shell"/>
    </body>
  </worldbody>
</mujoco>
"""


def joint_xml(geom: JointGeometry, p, sub_dt: float = 5e-4, width: int = 480, height: int = 480) -> str:
    """MJCF of the joint for plant parameter row ``p`` (end stops, end mass, damping, gravity)."""
    r = geom.lever_arm
    top = float(p[ix.L_MAX]) + 0.045  # the plate: room for the end cap and the rack at theta = 0
    return JOINT_XML.format(
        scene=scene_header(width, height),
        dt=sub_dt,
        g=p[ix.GRAV],
        floor=-(geom.link_length + 0.08),
        top=top,
        plate_z=top + 0.005,
        r=r,
        cap=0.004,
        qmax=geom.max_angle(p),
        damping=geom.joint_damping + p[ix.DAMP] * r * r,
        armature=p[ix.M_END] * r * r,
        friction=p[ix.F_COUL] * r,
        solref=max(0.002, 2.0 * sub_dt),
        lc=geom.link_com,
        m=geom.link_mass,
        inertia=geom.com_inertia,
        l=geom.link_length,
    )
