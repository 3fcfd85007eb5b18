"""MuJoCo around the CE-PAM: rendering, and the MuJoCo reference simulations the kernels are
checked against. Nothing else lives here: the joint's task is :mod:`cepam_gym.tasks.joint`, its
envs are :mod:`cepam_gym.envs.joint` (batched kernel) and :mod:`cepam_gym.envs.joint_mujoco`
(``cepam_gym/CEPAMJoint-v0``, in MuJoCo), the plant sub-step with the mechanics handed to MuJoCo is
:mod:`cepam_gym.plant.coupling`, and ``cepam-gym video`` is :mod:`cepam_gym.video`.

Nothing here imports :mod:`mujoco` at import time (``import cepam_gym`` stays light); the classes
import it when built and raise an ``ImportError`` naming the extra (``pip install
'cepam-gym[mujoco]'``) if it is missing. Headless rendering needs an OpenGL back-end: when
``MUJOCO_GL`` is unset and there is no display, ``egl`` is selected before MuJoCo is imported.

* :mod:`cepam_gym.mujoco.rig`: MJCF of the vertical test rig; :class:`~cepam_gym.mujoco.rig.RigRenderer`
  (``rgb_array`` frames of any object with the env core's arrays, used by
  ``gym.make("cepam_gym/CEPAM-v0", render_mode="rgb_array", renderer="mujoco")``) and
  :class:`~cepam_gym.mujoco.rig.RigSimulator` (the free end's mechanics run in MuJoCo);
* :mod:`cepam_gym.mujoco.joint_sim`: the hinge in MuJoCo with the coupled plant, and its MJCF;
* :mod:`cepam_gym.mujoco.joint_view`: the joint's frames.
"""

__all__ = ["joint_sim", "joint_view", "rig"]
