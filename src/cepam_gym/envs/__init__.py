"""Gymnasium environments (single and native vector), the SB3 adapter, and the plant model they
declare to controllers (:func:`model_of`)."""

from .cepam import CEPAMEnv, CEPAMVectorEnv
from .model import EnvModel, NoModelError, model_of

__all__ = ["CEPAMEnv", "CEPAMVectorEnv", "EnvModel", "NoModelError", "model_of"]
