"""Registers the environment ids with Gymnasium (called on ``import cepam_gym``), from the version
table :mod:`cepam_gym.versions`.

The names below are views of that table, kept for code that reads them: :data:`ENV_IDS` (the rig
ids with native vector entry points -> their default kwargs), :data:`JOINT_ENV_IDS` (the joint on
the batched kernel -> entry point, vector entry point, kwargs) and :data:`MUJOCO_ENV_IDS` (ids
that need the ``[mujoco]`` extra, imported only by ``gym.make`` -> entry point).

Gymnasium's notice on ``make`` that an id "is out of date" names the newest version of its family,
which is the recommended one (``v2``); it shows on the supported v1 and the legacy v0 ids alike.
"""

from __future__ import annotations

import gymnasium as gym

from .versions import MAX_EPISODE_STEPS, PREVIEW_STEPS, VERSIONS

__all__ = [
    "ENV_IDS",
    "JOINT_ENV_IDS",
    "MAX_EPISODE_STEPS",
    "MUJOCO_ENV_IDS",
    "PREVIEW_STEPS",
    "register_envs",
]

ENV_IDS: dict[str, dict] = {k: v.kwargs for k, v in VERSIONS.items() if v.mechanism == "rig"}
JOINT_ENV_IDS: dict[str, tuple[str, str, dict]] = {
    k: (v.entry_point, v.vector_entry_point, v.kwargs)
    for k, v in VERSIONS.items()
    if v.mechanism == "hinge" and v.vector_entry_point is not None
}
MUJOCO_ENV_IDS: dict[str, str] = {k: v.entry_point for k, v in VERSIONS.items() if v.extra == "mujoco"}


def register_envs() -> None:
    for env_id, row in VERSIONS.items():
        if env_id in gym.registry:
            continue
        extra = {"vector_entry_point": row.vector_entry_point} if row.vector_entry_point else {}
        gym.register(
            id=env_id,
            entry_point=row.entry_point,
            max_episode_steps=MAX_EPISODE_STEPS,
            kwargs=row.kwargs,
            **extra,
        )
