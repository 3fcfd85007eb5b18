"""Registers the environment ids with Gymnasium (called on ``import cepam_gym``)."""

from __future__ import annotations

import warnings

import gymnasium as gym

# The v0 ids keep the v0 plant (preset balloon_v0), so every published v0 figure reproduces; a
# user's own ``plant=`` still wins. The default plant of ``PlantParams()`` (and of the v1 ids) is
# plant v1.
V0_PLANT = "balloon_v0"
# The v2 ids: the v1 tasks on plant v2 (preset balloon_v2: a slack CPAM acts through its seal,
# contact-area friction; calibrated through the paper's protocols on the dynamic plant,
# docs/calibration.md "Plant v2"). The tasks' stiffness targets stay tangent stiffnesses -dF/dL
# (docs/physics.md "Plant v2": the protocol's secant stiffness is reported beside them).
V2_PLANT = "balloon_v2"
# rig ids -> their default kwargs (a user's own kwargs win). v1: planned references announced
# PREVIEW_STEPS control steps ahead (0.2 s at 50 Hz) in the observation.
PREVIEW_STEPS = 10
ENV_IDS: dict[str, dict] = {
    "cepam_gym/CEPAM-v0": {"task": "cepam", "plant": V0_PLANT},
    "cepam_gym/CEPAMLength-v0": {"task": "length", "plant": V0_PLANT},
    "cepam_gym/CEPAMStiffness-v0": {"task": "stiffness", "plant": V0_PLANT},
    "cepam_gym/CEPAM-v1": {"task": "cepam_v1", "preview_steps": PREVIEW_STEPS},
    "cepam_gym/CEPAMLength-v1": {"task": "length_v1", "preview_steps": PREVIEW_STEPS},
    "cepam_gym/CEPAMStiffness-v1": {"task": "stiffness_v1", "preview_steps": PREVIEW_STEPS},
    "cepam_gym/CEPAM-v2": {"task": "cepam_v1", "preview_steps": PREVIEW_STEPS, "plant": V2_PLANT},
    "cepam_gym/CEPAMLength-v2": {"task": "length_v1", "preview_steps": PREVIEW_STEPS, "plant": V2_PLANT},
    "cepam_gym/CEPAMStiffness-v2": {
        "task": "stiffness_v1",
        "preview_steps": PREVIEW_STEPS,
        "plant": V2_PLANT,
    },
}
MAX_EPISODE_STEPS = 500  # 10 s at 50 Hz
# ids that need the [mujoco] extra (imported only by gym.make): not in ENV_IDS, which lists the
# rig envs with native vector entry points
MUJOCO_ENV_IDS = {"cepam_gym/CEPAMJoint-v0": "cepam_gym.envs.joint_mujoco:CEPAMJointEnv"}
# the joint on the batched kernel (MuJoCo only to render): id -> (entry point, vector entry point,
# default kwargs)
JOINT_ENV_IDS: dict[str, tuple[str, str, dict]] = {
    "cepam_gym/CEPAMJoint-v1": (
        "cepam_gym.envs.joint:CEPAMJointV1Env",
        "cepam_gym.envs.joint:CEPAMJointVectorEnv",
        {"task": "joint_v1", "preview_steps": PREVIEW_STEPS},
    ),
    "cepam_gym/CEPAMJoint-v2": (
        "cepam_gym.envs.joint:CEPAMJointV1Env",
        "cepam_gym.envs.joint:CEPAMJointVectorEnv",
        {"task": "joint_v1", "preview_steps": PREVIEW_STEPS, "plant": V2_PLANT},
    ),
}


def register_envs() -> None:
    # v1 stays the recommended version until plant v2 meets its calibration goal (its suites and
    # references exist): Gymnasium's "v1 is out of date, upgrade to v2" would send users to it. The
    # v0 ids keep their notice that a v1 exists.
    warnings.filterwarnings(
        "ignore", message=r".*cepam_gym/\w+-v1 is out of date", category=DeprecationWarning
    )
    for env_id, kwargs in ENV_IDS.items():
        if env_id in gym.registry:
            continue
        gym.register(
            id=env_id,
            entry_point="cepam_gym.envs.cepam:CEPAMEnv",
            vector_entry_point="cepam_gym.envs.cepam:CEPAMVectorEnv",
            max_episode_steps=MAX_EPISODE_STEPS,
            kwargs=dict(kwargs),
        )
    for env_id, (entry_point, vector_entry_point, kwargs) in JOINT_ENV_IDS.items():
        if env_id not in gym.registry:
            gym.register(
                id=env_id,
                entry_point=entry_point,
                vector_entry_point=vector_entry_point,
                max_episode_steps=MAX_EPISODE_STEPS,
                kwargs=dict(kwargs),
            )
    for env_id, entry_point in MUJOCO_ENV_IDS.items():
        if env_id not in gym.registry:
            gym.register(
                id=env_id,
                entry_point=entry_point,
                max_episode_steps=MAX_EPISODE_STEPS,
                kwargs={"plant": V0_PLANT},
            )
