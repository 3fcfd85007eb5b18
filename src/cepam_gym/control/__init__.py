"""Controllers that need no learning: the inverse-static-model baseline and trivial policies."""

from .baseline import InverseStaticController

__all__ = ["InverseStaticController"]
