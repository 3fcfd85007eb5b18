"""Registers the environment ids with Gymnasium (called on ``import cepam_gym``)."""

from __future__ import annotations

import gymnasium as gym

ENV_IDS = {
    "cepam_gym/CEPAM-v0": "cepam",
    "cepam_gym/CEPAMLength-v0": "length",
    "cepam_gym/CEPAMStiffness-v0": "stiffness",
}
MAX_EPISODE_STEPS = 500  # 10 s at 50 Hz


def register_envs() -> None:
    for env_id, task in ENV_IDS.items():
        if env_id in gym.registry:
            continue
        gym.register(
            id=env_id,
            entry_point="cepam_gym.envs.cepam:CEPAMEnv",
            vector_entry_point="cepam_gym.envs.cepam:CEPAMVectorEnv",
            max_episode_steps=MAX_EPISODE_STEPS,
            kwargs={"task": task},
        )
