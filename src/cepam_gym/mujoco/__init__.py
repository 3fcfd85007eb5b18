"""MuJoCo around the CE-PAM: a 3-D view of the paper's rig, episode videos, and a joint it drives.

Nothing here imports :mod:`mujoco` at import time (``import cepam_gym`` stays light); the classes
import it when built and raise an ``ImportError`` naming the extra (``pip install
'cepam-gym[mujoco]'``) if it is missing. Headless rendering needs an OpenGL back-end: when
``MUJOCO_GL`` is unset and there is no display, ``egl`` is selected before MuJoCo is imported.

* :mod:`cepam_gym.mujoco.rig`: MJCF of the vertical test rig; :class:`~cepam_gym.mujoco.rig.RigRenderer`
  (``rgb_array`` frames of a :class:`~cepam_gym.envs.core.CEPAMBatch`, used by
  ``gym.make("cepam_gym/CEPAM-v0", render_mode="rgb_array", renderer="mujoco")``) and
  :class:`~cepam_gym.mujoco.rig.RigSimulator` (the free end's mechanics run in MuJoCo).
* :mod:`cepam_gym.mujoco.joint`: ``cepam_gym/CEPAMJoint-v0``, a hinge driven by a CE-PAM through a
  pinion; :mod:`cepam_gym.mujoco.joint_sim`: the hinge in MuJoCo with the coupled plant;
  :mod:`cepam_gym.mujoco.joint_view`: its frames; :mod:`cepam_gym.mujoco.joint_task`: its
  geometry, task, reward weights and scales, observation layout and MJCF (no MuJoCo import). The
  baseline is :class:`cepam_gym.control.joint_baseline.JointInverseStaticController`.
* :mod:`cepam_gym.mujoco.video`: ``cepam-gym video``.
* :mod:`cepam_gym.mujoco.coupling`: the plant sub-step with the length imposed by MuJoCo.
"""

__all__ = ["rig", "joint", "joint_sim", "joint_task", "joint_view", "video", "coupling"]
