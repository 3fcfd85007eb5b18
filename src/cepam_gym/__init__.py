"""cepam-gym: reinforcement-learning environments for the compound extensor PAM (CE-PAM).

``import cepam_gym`` registers ``cepam_gym/CEPAM-v0``, ``cepam_gym/CEPAMLength-v0`` and
``cepam_gym/CEPAMStiffness-v0`` with Gymnasium (single and native vector entry points). It never
imports torch or stable-baselines3.
"""

from .plant.params import PlantParams, preset
from .registration import ENV_IDS, register_envs

__version__ = "0.1.0"
__all__ = ["ENV_IDS", "PlantParams", "preset", "register_envs"]

register_envs()
