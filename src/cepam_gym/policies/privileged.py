"""What only the simulator knows, for an asymmetric critic (Pinto et al. 2018, "Asymmetric actor
critic for image-based robot learning"): the critic of a training run may condition its value on
the true plant and load, the actor never does (the training package's asymmetric policy).

One row per env, read from the privileged facts of the env's plant model
(:class:`cepam_gym.envs.model.EnvModel`) after a step, all scaled to order one:

* the plant parameters as ``log(value / nominal)`` (0 for the nominal plant; every column with a
  positive nominal value, so a randomized key, the supply drift and friction all show);
* the load mass at the current step, in units of 100 g;
* the true (noise-free) tracking errors: length minus target in units of 5 mm, and
  ``log(stiffness / target stiffness)`` (0 on a length-only task);
* the friction elements' slip deflections (plant v1), in mm.

These are the quantities the baseline's nominal model gets wrong on a randomized plant; the
benchmark's score weighs 5 mm like 20 % of stiffness, hence the scales.
"""

from __future__ import annotations

import numpy as np

_LOAD_UNIT_KG = 0.1
_LENGTH_UNIT_M = 5e-3
_SLIP_UNIT_M = 1e-3


class PrivilegedView:
    """``view()`` -> (N, dim) float32 of the envs of ``model`` (their ``EnvModel``) as they are now."""

    def __init__(self, model):
        from cepam_gym import plant as pl

        self.model = model
        nominal = model.nominal.to_array()
        self._cols = np.flatnonzero(nominal > 0)
        self._log_nominal = np.log(nominal[self._cols])
        self._slip = [pl.S_Z1, pl.S_Z2, pl.S_Z3]
        self._stiff, self._length = pl.A_STIFF, pl.S_L
        self.dim = len(self._cols) + 1 + 2 + len(self._slip)

    def view(self) -> np.ndarray:
        c = self.model
        p = np.clip(np.log(np.maximum(c.params[:, self._cols], 1e-300)) - self._log_nominal, -5.0, 5.0)
        target_l, target_k, load = c.current_targets()
        length_err = (c.state[:, self._length] - target_l) / _LENGTH_UNIT_M
        if c.track_stiffness:
            k = np.maximum(c.aux[:, self._stiff], 1e-3)
            stiff_err = np.log(k / np.maximum(target_k, 1e-3))
        else:
            stiff_err = np.zeros(c.num_envs)
        out = np.concatenate(
            [
                p,
                (load / _LOAD_UNIT_KG)[:, None],
                np.clip(length_err, -20.0, 20.0)[:, None],
                np.clip(stiff_err, -5.0, 5.0)[:, None],
                c.state[:, self._slip] / _SLIP_UNIT_M,
            ],
            axis=1,
        )
        return np.nan_to_num(out).astype(np.float32)
