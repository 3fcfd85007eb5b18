"""Registers the environment ids with Gymnasium (called on ``import cepam_gym``)."""

from __future__ import annotations

import gymnasium as gym

ENV_IDS = {
    "cepam_gym/CEPAM-v0": "cepam",
    "cepam_gym/CEPAMLength-v0": "length",
    "cepam_gym/CEPAMStiffness-v0": "stiffness",
}
MAX_EPISODE_STEPS = 500  # 10 s at 50 Hz
# ids that need the [mujoco] extra (imported only by gym.make): not in ENV_IDS, which lists the
# rig envs with native vector entry points
MUJOCO_ENV_IDS = {"cepam_gym/CEPAMJoint-v0": "cepam_gym.mujoco.joint:CEPAMJointEnv"}
# The v0 ids keep the v0 plant (preset balloon_v0), so every published v0 figure reproduces; a
# user's own ``plant=`` still wins. The default plant of ``PlantParams()`` is plant v1.
V0_PLANT = "balloon_v0"


def register_envs() -> None:
    for env_id, task in ENV_IDS.items():
        if env_id in gym.registry:
            continue
        gym.register(
            id=env_id,
            entry_point="cepam_gym.envs.cepam:CEPAMEnv",
            vector_entry_point="cepam_gym.envs.cepam:CEPAMVectorEnv",
            max_episode_steps=MAX_EPISODE_STEPS,
            kwargs={"task": task, "plant": V0_PLANT},
        )
    for env_id, entry_point in MUJOCO_ENV_IDS.items():
        if env_id not in gym.registry:
            gym.register(id=env_id, entry_point=entry_point, max_episode_steps=MAX_EPISODE_STEPS,
                         kwargs={"plant": V0_PLANT})
