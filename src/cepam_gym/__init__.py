"""cepam-gym: reinforcement-learning environments for the compound extensor PAM (CE-PAM).

``import cepam_gym`` registers every id of :data:`ENV_IDS` (the rig tasks, v0 to v2) and the joint
ids ``cepam_gym/CEPAMJoint-v0`` to ``-v2`` with Gymnasium (single and native vector entry points);
the recommended id is ``cepam_gym/CEPAM-v2``. It never imports torch or stable-baselines3.
"""

from .plant.params import PlantParams, preset
from .registration import ENV_IDS, register_envs

__version__ = "1.0.0"  # the one source of the version (pyproject.toml reads it)
__all__ = ["ENV_IDS", "PlantParams", "preset", "register_envs"]

register_envs()
