"""``info["stiffness_protocol"]``: the stiffness a rig would read at the current state.

The envs regulate, reward and target the tangent stiffness ``-dF/dL`` (``info["stiffness"]``). A
rig measures the protocol (secant) stiffness of the paper's experiments: weights hung one at a
time, ``mean(m g / dL)`` (:mod:`cepam_gym.physics.secant`). This wrapper adds it to every step's
``info`` of a rig env (``cepam_gym/CEPAM-*``, ``CEPAMLength-*``, ``CEPAMStiffness-*``), computed
quasi-statically at the step's length and chamber pressures with the episode's plant, so an agent or
a study can compare the two. Opt-in (about 50 us per step): ``ProtocolStiffnessInfo(gym.make(id))``.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from ..errors import InputError
from ..physics import secant

DEFAULT_LOADS_G = (50.0, 100.0, 150.0, 200.0, 250.0, 300.0)  # the paper's span (Fig. 6, 11, 24)


class ProtocolStiffnessInfo(gym.Wrapper):
    """Adds ``info["stiffness_protocol"]`` [N/m] (nan if every weight reaches the upper stop)."""

    def __init__(self, env: gym.Env, loads_g=DEFAULT_LOADS_G):
        super().__init__(env)
        loads = np.asarray(loads_g, dtype=float)
        if loads.ndim != 1 or loads.size == 0 or not np.all(loads > 0):
            raise InputError(f"loads_g must be a non-empty list of positive weights in g, got {loads_g!r}")
        self._loads_kg = loads * 1e-3

    def _add(self, info: dict) -> dict:
        row = self.env.unwrapped.core.params[0]
        weights = self._loads_kg * row[secant.ix.GRAV]
        info["stiffness_protocol"] = float(
            secant.secant_stiffness(
                float(info["length"]), float(info["pressure_c"]), float(info["pressure_e"]), row, weights
            )
        )
        return info

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        return obs, self._add(info)

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        return obs, reward, terminated, truncated, self._add(info)
