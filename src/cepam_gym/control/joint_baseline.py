"""The inverse-static baseline of ``cepam_gym/CEPAMJoint-v0``: the rig's baseline through the
joint's mechanism map (:class:`~cepam_gym.tasks.joint.JointGeometry`). Needs no MuJoCo:
it reads the env's nominal plant, geometry and observation layout."""

from __future__ import annotations

from ..envs.model import env_layers
from ..tasks.joint import JointGeometry
from ..tasks.mechanism import HingeMechanism
from .baseline import InverseStaticController


class JointInverseStaticController(InverseStaticController):
    """The rig's inverse-static baseline (:class:`cepam_gym.control.InverseStaticController`)
    through the joint geometry; ``reset(indices=None)`` / ``act(obs, info=None)`` like the
    benchmark harness's controllers, on single ``(9,)`` or batched ``(N, 9)`` observations.

    Its ``act`` is the rig's, through the joint's :class:`~cepam_gym.tasks.mechanism.HingeMechanism`.
    Per control step, with the *nominal* plant and geometry:

    1. angle, pressures and targets from the observation (by column name); muscle lengths
       ``L = L_max - r theta``;
    2. **external torque estimate** from the quasi-static balance of the hinge:
       ``tau_ext = -r (F(L, Pc, Pe) + m_end g) - m g l_c sin(theta)``, low-pass filtered;
    3. **inverse static model** at the target: the equivalent hanging weight at ``theta*``
       (:meth:`JointGeometry.equivalent_weight`) and the muscle stiffness ``K* = K_joint* / r^2``
       give the set-points (:meth:`InverseStaticController.setpoints`, the same projection of
       unreachable targets);
    4. the same pressure loop per chamber as the rig's baseline (feedforward from the ISO 6358
       flow plus PI), or the set-points themselves in ``"pressure"`` mode.
    """

    def __init__(
        self, env, gap_fraction: float = 0.5, kp: float = 0.2, ki: float = 0.5, load_filter_s: float = 0.15
    ):
        j = find_joint_env(env)
        self.geometry = j.geometry
        self.mechanism = HingeMechanism(geometry=j.geometry)
        self.setpoint_max = j.setpoint_max
        self.layout = j.obs_layout
        self.task = j.task.muscle_spec(j.geometry, j.nominal_row)
        self._configure(
            j.nominal, j.nominal_row.copy(), j.action_mode, j.control_dt, gap_fraction, kp, ki, load_filter_s
        )


def find_joint_env(env):
    """The joint env inside ``env`` (wrappers, a vector env of joint envs); ``TypeError`` if none.
    Recognised by its :class:`JointGeometry`, so this module never imports the env (or MuJoCo)."""
    for e in env_layers(env, into_vector=True):
        if isinstance(getattr(e, "geometry", None), JointGeometry) and hasattr(e, "obs_layout"):
            return e
    raise TypeError(f"cannot find a CEPAMJointEnv inside {env!r}")
