"""``cepam_gym/CEPAMJoint-v1`` to ``-v3``: the CE-PAM hinge on the batched kernel (single and vector env).

The same hinge as ``cepam_gym/CEPAMJoint-v0`` (:mod:`cepam_gym.envs.joint_mujoco`, which MuJoCo
integrates), here integrated by the plant's own block kernel: :func:`cepam_gym.plant.advance_block_hinge`
runs the hinge as the rig's load step in muscle coordinates (:mod:`cepam_gym.physics.hinge`), and
the task kernel (:mod:`cepam_gym.envs.step`) scores it through the mechanism map
(angle ``(L_max - L) / r``, joint stiffness ``K r^2``). The env is the rig's
(:mod:`cepam_gym.envs.cepam`) given the joint's Task object
(:class:`~cepam_gym.envs.hinge_task.HingeTask`); the classes here only name that default task and
carry the spec sheet. MuJoCo stays the reference (``tests/envs/test_joint_v1.py`` checks the two agree)
and draws the frames (:class:`~cepam_gym.mujoco.joint_view.BatchJointFrames`).
"""

from __future__ import annotations

from .cepam import TERMINATION_NAMES, CEPAMEnv, CEPAMVectorEnv
from .hinge_task import INFO_KEYS, JOINT_TASKS, REWARD_TERMS

__all__ = [
    "INFO_KEYS",
    "JOINT_TASKS",
    "REWARD_TERMS",
    "CEPAMJointKernelEnv",
    "CEPAMJointV1Env",
    "CEPAMJointVectorEnv",
]


_DOC = """

    The spec sheet of each joint id (action and observation tables with units, reward terms,
    starting state, episode end, arguments, version history) is generated from the code into the
    documentation: ``docs/envs/<id>.md`` on the site (``make docs``); the mechanism and the
    coupling: docs/mujoco.md.
"""


class CEPAMJointKernelEnv(CEPAMEnv):
    __doc__ = "A hinge driven by a CE-PAM on the batched kernel: joint angle and stiffness references." + _DOC
    metadata = {
        "render_modes": ["rgb_array", "human"],
        "render_fps": 50,
        "termination_reasons": TERMINATION_NAMES,
    }
    default_task = "joint_v1"


# the class's former name, kept for code that imports it
CEPAMJointV1Env = CEPAMJointKernelEnv


class CEPAMJointVectorEnv(CEPAMVectorEnv):
    __doc__ = (
        "N CE-PAM hinges stepped by one compiled kernel "
        "(``gym.make_vec('cepam_gym/CEPAMJoint-v1', num_envs=N)``); the rig vector env's "
        "conventions (autoreset modes, info masks, seeding) with the joint's task." + _DOC
    )
    default_task = "joint_v1"
