"""Gymnasium environments (single and native vector) and the SB3 adapter."""

from .cepam import CEPAMEnv, CEPAMVectorEnv

__all__ = ["CEPAMEnv", "CEPAMVectorEnv"]
