"""Reference points below any real controller: valves shut (``zero``) and random commands (``random``)."""

from __future__ import annotations

import numpy as np


def _action_dim(env) -> int:
    """Size of one action of ``env`` (single, Gymnasium vector or SB3 vector env); 2 when the env
    does not say (every CE-PAM env sends one command per chamber)."""
    space = getattr(env, "single_action_space", None) or getattr(env, "action_space", None)
    shape = getattr(space, "shape", None)
    return int(shape[-1]) if shape else 2


class ZeroController:
    """All valves closed (or zero set-points): the plant drifts under the load."""

    def __init__(self, env):
        self.n_actions = _action_dim(env)

    def reset(self, indices=None) -> None:
        pass

    def act(self, obs, info=None) -> np.ndarray:
        return np.zeros(np.shape(obs)[:-1] + (self.n_actions,), dtype=np.float32)


class RandomController:
    """Uniform random commands in ``[-1, 1]``, seeded."""

    def __init__(self, env, seed: int = 0):
        self.n_actions = _action_dim(env)
        self.rng = np.random.default_rng(seed)

    def reset(self, indices=None) -> None:
        pass

    def act(self, obs, info=None) -> np.ndarray:
        return self.rng.uniform(-1, 1, np.shape(obs)[:-1] + (self.n_actions,)).astype(np.float32)
