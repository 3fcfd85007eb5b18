"""The plant's friction elements tracked from the measured length: a practical observer.

The plant's braid friction is a set of Maxwell-slip elements (:mod:`cepam_gym.physics.friction`):
each deflects with the free end's motion and is held at its presliding displacement while it
slides. The elements are rate-independent, so their deflections follow from the measured length
alone (a play operator on the displacement), and their force from the measured pressures. A model
that balances only the air's force against the hanging weight (the baseline's and the MPC's load
estimate, paper Eq. 25) attributes the part of the weight friction holds to the load; with this
observer it balances the friction's too. Used by ``baseline_friction``, ``mpc_friction`` and the
agents' friction-aware features (docs/benchmark.md, "What the oracle's privileges are worth").
"""

from __future__ import annotations

import numpy as np

N_ELEMENTS = 3  # the plant's Maxwell-slip elements (state columns S_Z1..S_Z3)


class FrictionObserver:
    """Per-env deflections ``z`` (N, 3) [m]; ``reset(indices)`` starts episodes at rest."""

    def __init__(self):
        self.z: np.ndarray | None = None
        self._last_l: np.ndarray | None = None

    def reset(self, indices=None) -> None:
        if indices is None or self.z is None:
            self.z = self._last_l = None
        else:
            self._last_l[np.asarray(indices)] = np.nan

    def force(self, L, pc, pe, rows: np.ndarray) -> np.ndarray:
        """Advance the deflections to the measured lengths ``L`` (N,) and return the elements'
        push force (N,) [N] at the measured gauge pressures; ``rows``: (1, N_PARAMS) for all envs
        or (N, N_PARAMS), the model's friction parameters."""
        from ..physics.friction import friction_force, friction_slip

        n = len(L)
        if self.z is None or len(self.z) != n:
            self.z, self._last_l = np.zeros((n, N_ELEMENTS)), np.full(n, np.nan)
        fresh = np.isnan(self._last_l)
        self.z[fresh] = 0.0  # a new episode starts at rest, its elements relaxed
        dl = np.where(fresh, 0.0, L - self._last_l)
        self._last_l = np.array(L, dtype=float)
        f = np.empty(n)
        for i in range(n):
            row = rows[0] if len(rows) == 1 else rows[i]
            self.z[i] = friction_slip(row, dl[i], *self.z[i])
            f[i] = friction_force(row, pc[i], pe[i], *self.z[i])
        return f

    def get_state(self):
        return None if self.z is None else (self.z.copy(), self._last_l.copy())

    def set_state(self, state) -> None:
        if state is None:
            self.z = self._last_l = None
        else:
            self.z, self._last_l = state[0].copy(), state[1].copy()
