"""Frames of ``cepam_gym/CEPAMJoint-v0``: the MuJoCo model posed at the env's state, with the
target angle (a translucent green forearm) and the external torque (an orange arrow at the hand)."""

from __future__ import annotations

import math

import numpy as np

from .. import plant as pl
from ..physics import layout as ix
from ._mj import make_renderer, require_mujoco
from .joint_sim import joint_xml
from .rig import default_camera, geom_ids, set_muscle_geoms


class JointView:
    """Renders a :class:`~cepam_gym.envs.joint_mujoco.CEPAMJointEnv` (``frame()``: an RGB array;
    ``show()``: the same in a window). Rebuild it when the env rebuilds its model."""

    def __init__(self, env):
        self.env = env
        self._renderer = None
        self._camera = None
        self._window = None

    def frame(self) -> np.ndarray:
        env = self.env
        mj, m, d = env.mujoco, env.model, env.data
        g, p = env.geometry, env.params
        r = g.lever_arm
        ids = env.geom_ids
        top = float(m.geom_pos[ids["plate"], 2]) - 0.005
        L = float(env.link.x[pl.S_L])
        set_muscle_geoms(m, ids, p, L, env.aux[pl.A_PC], env.aux[pl.A_PE], top, x=r)
        z_cap = top - L - 0.004
        m.geom_pos[ids["cap"]] = (r, 0.0, z_cap)
        rack_len = max(z_cap - 0.004, 0.002)  # from under the cap down to the pinion's tangent point
        m.geom_size[ids["rack"], 2] = 0.5 * rack_len
        m.geom_pos[ids["rack"]] = (r, 0.0, 0.5 * rack_len)
        mj.mj_kinematics(m, d)
        if self._renderer is None:
            self._renderer = make_renderer(mj, m, env.height, env.width)
            self._camera = default_camera(mj, (0.035, 0.0, 0.04), 0.6, azimuth=90.0, elevation=-8.0)
        ren = self._renderer
        ren.update_scene(d, camera=self._camera)
        k = min(max(env.t_idx - 1, 0), env.n_steps - 1)
        th_t = float(env.target_angle[k])
        y = -0.014
        hand_t = np.array([g.link_length * math.sin(th_t), y, -g.link_length * math.cos(th_t)])
        self._add_geom(
            mj.mjtGeom.mjGEOM_CAPSULE, 0.006, np.array([0.0, y, 0.0]), hand_t, (0.1, 0.75, 0.2, 0.5)
        )
        tau = float(env.external_torque[k])
        if tau > 0:
            th, _ = env.joint_state()
            hand = np.array([g.link_length * math.sin(th), y - 0.03, -g.link_length * math.cos(th)])
            ext = -np.array([math.cos(th), 0.0, math.sin(th)])  # direction of extension at the hand
            self._add_geom(
                mj.mjtGeom.mjGEOM_ARROW, 0.006, hand, hand + ext * (0.02 + 2.5 * tau), (0.95, 0.55, 0.1, 1.0)
            )
        return ren.render().copy()

    def model_changed(self) -> None:
        """The env rebuilt its MuJoCo model: the next frame needs a new renderer."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def show(self) -> None:
        frame = self.frame()
        if self._window is None:
            from ..viewer import FrameWindow

            self._window = FrameWindow(frame.shape)
        self._window.show(frame)

    def _add_geom(self, kind, width, a, b, rgba) -> None:
        mj = self.env.mujoco
        scn = self._renderer.scene
        if scn.ngeom >= scn.maxgeom:
            return
        geom = scn.geoms[scn.ngeom]
        mj.mjv_initGeom(
            geom, kind, np.zeros(3), np.zeros(3), np.eye(3).ravel(), np.asarray(rgba, dtype=np.float32)
        )
        mj.mjv_connector(geom, kind, width, a, b)
        scn.ngeom += 1

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        if self._window is not None:
            self._window.close()
            self._window = None


class BatchJointFrames:
    """MuJoCo frames of env ``i`` of a batched joint env core (``cepam_gym/CEPAMJoint-v1``): the v0 renderer
    (:class:`~cepam_gym.mujoco.joint_view.JointView`) on a MuJoCo model of the hinge whose
    angle is copied from the batch (nothing is simulated in MuJoCo)."""

    def __init__(self, core, width: int = 480, height: int = 480):
        self.core, self.width, self.height = core, width, height
        self.mujoco = require_mujoco()
        self._xml, self._geom_ids = joint_xml, geom_ids
        self.model = None
        self._p = None
        self.view = JointView(self)

    def render_core(self, core, i: int) -> np.ndarray:
        mj = self.mujoco
        p = core.params[i if core.params.shape[0] > 1 else 0]
        if self._p is None or not np.array_equal(p, self._p):  # a randomized plant: a new model
            self._p = p.copy()
            self.model = mj.MjModel.from_xml_string(
                self._xml(core.task.geometry, p, core.sub_dt, self.width, self.height)
            )
            self.data = mj.MjData(self.model)
            self.geom_ids = self._geom_ids(mj, self.model, ("cpam", "epam", "cap", "rack"))
            self.view.model_changed()
        # what JointView reads of an env: this one's state
        self.geometry, self.params, self.n_steps = core.task.geometry, p, core.n_steps
        self.aux, self.t_idx = core.aux[i], int(core.t_idx[i])
        self.target_angle, self.external_torque = core.target_l[i], core.load[i]
        self.link = self  # JointView reads link.x[S_L]
        self.x = core.state[i]
        self.data.qpos[0] = self.joint_state()[0]
        return self.view.frame()

    def joint_state(self) -> tuple[float, float]:
        r = self.core.task.geometry.lever_arm
        return float((self.params[ix.L_MAX] - self.x[pl.S_L]) / r), float(-self.x[pl.S_V] / r)

    def close(self) -> None:
        self.view.close()
