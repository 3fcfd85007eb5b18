"""cepam-gym: reinforcement-learning environments for the compound extensor PAM (CE-PAM).

``import cepam_gym`` registers sixteen ids with Gymnasium: ``cepam_gym/CEPAM``, ``CEPAMLength``,
``CEPAMStiffness`` and ``CEPAMJoint``, each as ``-v0``, ``-v1``, ``-v2`` and ``-v3`` (single and
native vector entry points; ``CEPAMJoint-v0`` runs in MuJoCo, the ``[mujoco]`` extra). **Start from
``cepam_gym/CEPAM-v3``** (:data:`RECOMMENDED_ID`): the planned-reference tasks on plant v2, the
best calibrated, with the reward that is the benchmark score's per-step form and a rig's sensor
noise in the observation. ``v2`` and ``v1`` are supported, ``v0`` legacy (kept so published
figures reproduce). The
version table (:data:`VERSIONS`, :mod:`cepam_gym.versions`, docs/versions.md) lists every id's
task, plant, preview, suites and status, and says what a version number promises. It never
imports torch or stable-baselines3.
"""

from .plant.params import PlantParams, preset
from .registration import ENV_IDS, register_envs
from .versions import RECOMMENDED_ID, VERSIONS

__version__ = "1.0.0"  # the one source of the version (pyproject.toml reads it)
__all__ = ["ENV_IDS", "RECOMMENDED_ID", "VERSIONS", "PlantParams", "preset", "register_envs"]

register_envs()
