"""The paper's vertical test rig in MuJoCo: a 3-D view of the CE-PAM and, optionally, its mechanics.

The rig (paper Fig. 5, 16, 17): a mounting plate on a stand, the CE-PAM hanging from it inside a
guide tube, an end cap on its free end and a load hanging from the cap. In the model (SI, z up):

* ``plate``, ``stand``, ``arm``: the frame; ``tube``: a transparent guide tube with tick marks at
  the end stops ``L_min``, ``L_max`` (``stop_lo``, ``stop_hi``);
* ``epam`` and ``cpam``: two cylinders from the plate down to the end cap, length ``L``, diameters
  from :func:`cepam_gym.physics.muscle.braid_diameter` with the plant's parameter row (the CPAM
  inside the EPAM, which is drawn translucent). Colours follow the gauge pressures as a fraction
  of the supply: the annulus (EPAM) from pale to deep blue, the CPAM from pale to deep red;
* body ``free_end`` on a vertical slider (``qpos = L``): ``cap``, ``hook`` and ``load``, a steel
  block whose edge is ``(m / 7850 kg m^-3)^(1/3)`` (hidden at zero load);
* ``target``: a green disc at the target length.

:class:`RigRenderer` draws a :class:`~cepam_gym.envs.core.CEPAMBatch` (or any state) headless:
geometry is updated in ``model.geom_size``/``geom_pos``/``geom_rgba`` and the slider ``qpos``,
then ``mj_kinematics``; nothing is simulated. :class:`RigSimulator` instead runs the free end's
mechanics in MuJoCo (slider, gravity, viscous damping, end stops as joint limits) with the plant
force each sub-step (:mod:`cepam_gym.plant.coupling`).
"""

from __future__ import annotations

import numpy as np

from .. import plant as pl
from ..errors import InputError
from ..physics import layout as ix
from ..physics.muscle import braid_diameter
from ._mj import make_renderer, require_mujoco, scene_header

PLATE_Z = 0.36  # m: underside of the mounting plate, where the CE-PAM is clamped
STEEL_DENSITY = 7850.0  # kg/m^3: sets the drawn size of the hanging load
_CAP_HALF = 0.005
_HOOK = 0.012

RIG_XML = """
<mujoco model="cepam_rig">
  <compiler angle="radian"/>
  <option timestep="{dt}" integrator="Euler" gravity="0 0 -{g}"/>
{scene}  </asset>
  <default>
    <geom contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <light pos="0.4 -0.6 1.0" dir="-0.4 0.6 -1" diffuse="0.6 0.6 0.6" castshadow="true"/>
    <geom name="floor" type="plane" size="0.6 0.6 0.01" material="grid"/>
    <geom name="base" type="box" pos="-0.09 0 0.006" size="0.07 0.07 0.006" material="dark"/>
    <geom name="stand" type="cylinder" fromto="-0.09 0 0.01 -0.09 0 {stand_top}" size="0.008" material="metal"/>
    <geom name="arm" type="box" pos="-0.045 0 {arm_z}" size="0.05 0.012 0.008" material="metal"/>
    <geom name="plate" type="box" pos="0 0 {plate_z}" size="0.05 0.035 0.006" material="dark"/>
    <geom name="tube" type="cylinder" pos="0 0 {tube_z}" size="0.019 {tube_half}" rgba="0.75 0.85 0.95 0.13"/>
    <geom name="stop_lo" type="cylinder" pos="0 0 0.2" size="0.0215 0.0015" rgba="0.15 0.15 0.15 1"/>
    <geom name="stop_hi" type="cylinder" pos="0 0 0.2" size="0.0215 0.0015" rgba="0.15 0.15 0.15 1"/>
    <geom name="cpam" type="cylinder" pos="0 0 0.2" size="0.003 0.08" rgba="1 0.8 0.8 1"/>
    <geom name="epam" type="cylinder" pos="0 0 0.2" size="0.013 0.08" rgba="0.75 0.85 1 0.45"/>
    <geom name="target" type="cylinder" pos="0 0 0.2" size="0.026 0.0007" rgba="0.1 0.75 0.2 0.75"/>
    <body name="free_end" pos="0 0 {top}">
      <joint name="length" type="slide" axis="0 0 -1" range="{lmin} {lmax}" limited="true"
             damping="0" solreflimit="0.001 1"/>
      <!-- the COM sits 0.1 mm off the axis (no effect on a slider) so MuJoCo does not treat the body
           as "simple" and cache its mass: RigSimulator changes body_mass with the load -->
      <inertial pos="0 0.0001 0" mass="0.02" diaginertia="1e-6 1e-6 1e-6"/>
      <geom name="cap" type="cylinder" pos="0 0 -{cap}" size="0.016 {cap}" material="dark"/>
      <geom name="hook" type="capsule" fromto="0 0 -{cap2} 0 0 -{hook_end}" size="0.0015" material="metal"/>
      <geom name="load" type="box" pos="0 0 -0.05" size="0.01 0.01 0.01" material="metal"/>
    </body>
  </worldbody>
</mujoco>
"""


def rig_xml(params_row=None, sub_dt: float = 5e-4, width: int = 480, height: int = 480) -> str:
    """MJCF of the rig. ``params_row`` (a :class:`~cepam_gym.PlantParams` or a parameter row)
    sets the end stops and gravity; the rest of the geometry follows the state when drawn."""
    p = _row(params_row)
    top = PLATE_Z
    return RIG_XML.format(
        scene=scene_header(width, height),
        dt=sub_dt,
        g=p[ix.GRAV],
        plate_z=top + 0.006,
        arm_z=top + 0.02,
        stand_top=top + 0.028,
        tube_z=top - 0.105,
        tube_half=0.105,
        top=top,
        lmin=p[ix.L_MIN],
        lmax=p[ix.L_MAX],
        cap=_CAP_HALF,
        cap2=2 * _CAP_HALF,
        hook_end=2 * _CAP_HALF + _HOOK,
    )


def _row(params) -> np.ndarray:
    if params is None:
        from ..plant.params import PlantParams

        params = PlantParams()
    if hasattr(params, "to_array"):
        params = params.to_array()
    p = np.asarray(params, dtype=float)
    if p.shape != (ix.N_PARAMS,):
        raise InputError(f"expected one parameter row of {ix.N_PARAMS} columns, got shape {p.shape}")
    return p


def load_edge(load_mass: float) -> float:
    """Edge [m] of the steel block drawn for a hanging load of ``load_mass`` kg."""
    return float(np.cbrt(max(load_mass, 0.0) / STEEL_DENSITY))


def pressure_colors(pressure_c: float, pressure_e: float, supply_gauge: float):
    """RGBA of the CPAM (pale -> deep red) and of the EPAM annulus (pale -> deep blue, translucent)
    for gauge pressures as a fraction of the supply."""
    fc = float(np.clip(pressure_c / max(supply_gauge, 1.0), 0.0, 1.0))
    fe = float(np.clip(pressure_e / max(supply_gauge, 1.0), 0.0, 1.0))
    c = (1.0 - 0.15 * fc, 0.82 - 0.77 * fc, 0.82 - 0.77 * fc, 1.0)
    e = (0.8 - 0.75 * fe, 0.88 - 0.6 * fe, 1.0 - 0.1 * fe, 0.3)
    return c, e


def set_muscle_geoms(
    model,
    ids: dict,
    params_row,
    length: float,
    pressure_c: float,
    pressure_e: float,
    top: float,
    x: float = 0.0,
    y: float = 0.0,
) -> None:
    """Place the ``cpam`` and ``epam`` cylinders of a model: hanging from height ``top`` [m] at
    ``(x, y)``, length ``length`` [m], braid diameters and pressure colours from the plant row."""
    p = params_row
    d_c = braid_diameter(length, p[ix.BC], p[ix.NC])
    d_e = braid_diameter(length, p[ix.BE], p[ix.NE])
    colors = pressure_colors(pressure_c, pressure_e, p[ix.P_SUP] - p[ix.P_ATM])
    for name, d, rgba in (("cpam", d_c, colors[0]), ("epam", d_e, colors[1])):
        g = ids[name]
        model.geom_size[g, 0] = 0.5 * d
        model.geom_size[g, 1] = 0.5 * length
        model.geom_pos[g] = (x, y, top - 0.5 * length)
        model.geom_rgba[g] = rgba


def geom_ids(mujoco, model, movable=()) -> dict:
    """Name -> id of the geoms of a model; the ``movable`` ones get ``geom_sameframe = 0`` so
    that kinematics places them from ``model.geom_pos`` after we change it (MuJoCo otherwise
    copies the body frame for geoms compiled at the body origin)."""
    ids = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g): g for g in range(model.ngeom)}
    if hasattr(model, "geom_sameframe"):
        for name in movable:
            model.geom_sameframe[ids[name]] = 0
    return ids


def default_camera(mujoco, lookat, distance: float, azimuth: float = 125.0, elevation: float = -12.0):
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = lookat
    cam.distance = distance
    cam.azimuth = azimuth
    cam.elevation = elevation
    return cam


class RigRenderer:
    """Headless ``rgb_array`` frames of the rig (``height x width x 3`` uint8).

    ``render_core(core, i)`` draws env ``i`` of a :class:`~cepam_gym.envs.core.CEPAMBatch`;
    ``render(params_row, length, pressure_c, pressure_e, load_mass, target_length)`` any state.
    """

    def __init__(self, width: int = 480, height: int = 480, params=None):
        self.mujoco = mj = require_mujoco()
        self.width, self.height = int(width), int(height)
        self.model = mj.MjModel.from_xml_string(rig_xml(params, width=self.width, height=self.height))
        self.data = mj.MjData(self.model)
        self.ids = geom_ids(mj, self.model, ("cpam", "epam", "stop_lo", "stop_hi", "target", "load"))
        self.camera = default_camera(mj, (0.0, 0.0, PLATE_Z - 0.13), 0.42, azimuth=115.0, elevation=-10.0)
        self._renderer = None

    def render(
        self,
        params_row,
        length: float,
        pressure_c: float,
        pressure_e: float,
        load_mass: float = 0.0,
        target_length: float | None = None,
    ) -> np.ndarray:
        mj, m, d = self.mujoco, self.model, self.data
        p = _row(params_row)
        L = float(length)
        set_muscle_geoms(m, self.ids, p, L, pressure_c, pressure_e, PLATE_Z)
        for name, col in (("stop_lo", ix.L_MIN), ("stop_hi", ix.L_MAX)):
            m.geom_pos[self.ids[name]] = (0.0, 0.0, PLATE_Z - p[col])
        g = self.ids["target"]
        if target_length is None or not np.isfinite(target_length):
            m.geom_rgba[g, 3] = 0.0
        else:
            m.geom_rgba[g, 3] = 0.75
            m.geom_pos[g] = (0.0, 0.0, PLATE_Z - float(target_length))
        edge = load_edge(load_mass)
        g = self.ids["load"]
        m.geom_size[g] = (0.5 * edge, 0.5 * edge, 0.5 * edge)
        m.geom_pos[g] = (0.0, 0.0, -(2 * _CAP_HALF + _HOOK + 0.5 * edge))
        m.geom_rgba[g, 3] = 1.0 if edge > 1e-3 else 0.0
        d.qpos[0] = L
        mj.mj_kinematics(m, d)
        if self._renderer is None:
            self._renderer = make_renderer(mj, m, self.height, self.width)
        self._renderer.update_scene(d, camera=self.camera)
        return self._renderer.render().copy()

    def render_core(self, core, i: int = 0) -> np.ndarray:
        """Frame of env ``i`` of a :class:`~cepam_gym.envs.core.CEPAMBatch` (current targets)."""
        tl, _tk, load = (a[i] for a in core.current_targets())
        return self.render(
            core.params[i], core.state[i, pl.S_L], core.aux[i, pl.A_PC], core.aux[i, pl.A_PE], load, tl
        )

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


class RigSimulator:
    """One CE-PAM rig whose free end moves in MuJoCo (slider joint), the force from the plant.

    Mirrors :func:`cepam_gym.plant.step` for one plant: ``reset(state_row)`` then
    ``step(inputs_row) -> (state_row, aux_row)`` per control period (``n_sub`` sub-steps of
    ``sub_dt``). The free-end mass is ``end_mass + load_mass`` (updated from the inputs every
    step), gravity and viscous ``damping`` act on the slider, ``external_force`` (down positive) is
    applied with the plant force, the end stops are the slider's joint limits. Differences from the
    NumPy plant: the end stops are MuJoCo's soft limit constraints (``solreflimit`` 1 ms) instead of
    perfectly plastic stops, and Coulomb friction, if set, is MuJoCo's ``frictionloss``
    constraint. Away from the stops and without Coulomb friction the two agree to round-off.
    """

    def __init__(self, params=None, action_mode: str = "valve", sub_dt: float = 5e-4, n_sub: int = 40):
        self.mujoco = mj = require_mujoco()
        from ..plant.coupling import PlantLink

        if action_mode not in pl.MODES:
            raise InputError(f"action_mode must be one of {tuple(pl.MODES)}, got {action_mode!r}")
        self.p = p = _row(params)
        pl.check_stability(p[None], sub_dt)
        self.n_sub = int(n_sub)
        self.model = mj.MjModel.from_xml_string(rig_xml(p, sub_dt=sub_dt))
        self.data = mj.MjData(self.model)
        self.model.dof_damping[0] = p[ix.DAMP]
        self.model.dof_frictionloss[0] = p[ix.F_COUL]
        self._body = mj.mj_name2id(self.model, mj.mjtObj.mjOBJ_BODY, "free_end")
        self.link = PlantLink(p, pl.MODES[action_mode], sub_dt)

    def reset(self, state_row) -> None:
        """Start from a plant state row (e.g. from :func:`cepam_gym.plant.initial_state`)."""
        mj = self.mujoco
        mj.mj_resetData(self.model, self.data)
        self.link.x[:] = np.asarray(state_row, dtype=float).reshape(pl.N_STATE)
        self.data.qpos[0] = self.link.x[pl.S_L]
        self.data.qvel[0] = self.link.x[pl.S_V]
        mj.mj_forward(self.model, self.data)

    def step(self, inputs_row) -> tuple[np.ndarray, np.ndarray]:
        mj, m, d, link = self.mujoco, self.model, self.data, self.link
        link.inp[:] = np.asarray(inputs_row, dtype=float).reshape(pl.N_INPUT)
        m.body_mass[self._body] = self.p[ix.M_END] + link.inp[pl.I_LOAD]
        f_ext = link.inp[pl.I_FEXT]
        qpos, qvel, qfrc = d.qpos, d.qvel, d.qfrc_applied
        link.begin()
        for _ in range(self.n_sub):
            qfrc[0] = link.force(qpos[0], qvel[0]) + f_ext  # slider axis points down: extension +
            mj.mj_step(m, d)
        aux = link.finish(qpos[0], qvel[0])
        return link.x.copy(), aux.copy()
