"""The adaptive MPC's load estimate as feature columns (``FeatureSpec.load_estimate_in_obs``).

``adaptive_mpc`` leads the sensor-only controllers on the nominal plant by its extended Kalman
filter on the load (:mod:`cepam_gym.control.adaptive_mpc`), which keeps an estimate over the whole
episode from the end cap's equation of motion; a student that sees a few frames and low-passed
copies has to infer the same from them. These columns hand it the filter's estimate, from the
sensors only: the load [kg] and the set-point gaps [100 kPa] of the nominal inverse static model
at that load (what the model says each chamber still needs, as the baseline's gaps at its own
low-passed estimate).
"""

from __future__ import annotations

import numpy as np

from .spec import GAP_UNIT_PA


class LoadEstimate:
    """``(N, 3)`` columns per batch of observations: the filtered load [kg] and the two gaps."""

    dim = 3

    def __init__(self, env, baseline):
        from cepam_gym.control.adaptive_mpc import AdaptiveMPC

        self.filter = AdaptiveMPC(env)  # only its filter runs; its planner never plans
        self.baseline = baseline

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        from cepam_gym.physics import layout as ix

        f = self.filter
        o = np.asarray(obs, dtype=float)
        L, pc, pe, L_t, K_t = f._decode(o)
        f.estimate(L, pc, pe, f.layout.value(o, "velocity"))
        load = f._x[:, 0]
        p = f.params
        pc_set, pe_set = self.baseline.setpoints(L_t, K_t, (p[ix.M_END] + load) * p[ix.GRAV])
        gaps = np.stack([pc_set - pc, pe_set - pe], axis=1) / GAP_UNIT_PA
        return np.concatenate([load[:, None], gaps], axis=1).astype(np.float32)

    def reset(self, indices=None) -> None:
        """Finished episodes' filters start again from the prior at their next observation."""
        self.filter._reset_filter(indices)

    def get_state(self):
        f = self.filter
        return None if f._x is None else tuple(a.copy() for a in (f._x, f._P, f._v_prev, f._rows, f._age))

    def set_state(self, state) -> None:
        f = self.filter
        if state is None:
            f._x = None
        else:
            f._x, f._P, f._v_prev, f._rows, f._age = state
