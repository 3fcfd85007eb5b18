"""The planner's inner loop, compiled: simulate candidate plans through the plant's own block
kernel and accumulate the benchmark's objective along them.

One call simulates M candidate plans of H control steps (all envs' populations together), a block
of :data:`cepam_gym.plant.BLOCK` plants at a time through the whole horizon (the block's scratch
stays in cache), on the rig (:func:`cepam_gym.plant.advance_block`) or on the hinge
(:func:`cepam_gym.plant.advance_block_hinge`). Positions and stiffnesses are compared in muscle
coordinates: a hinge's angle and joint-stiffness targets are mapped to the muscle's length and
stiffness before the call (``theta = (L_max - L) / r``, ``K_joint = K r^2``), which keeps the
score's trade exact (the relative stiffness error is the same, and an angle norm is a length norm
times ``r``).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .. import plant as pl
from ..plant.actions import plant_inputs
from .objective import step_error_sq

# parallel over blocks of plants (the envs' kernels do the same; NUMBA_NUM_THREADS caps it)
_pjit = njit(cache=True, error_model="numpy", parallel=True)


@_pjit
def rollout_cost(
    state,  # (M, N_STATE) start states
    params,  # (M, N_PARAMS)
    hinge,  # (1 or M, N_HINGE); unused on the rig
    mech,  # plant.RIG or plant.HINGE
    mode,
    dt,
    n_sub,
    setpoint_max,  # [Pa]: gauge set-point of the action +1 in pressure mode
    actions,  # (M, H, 2) env actions in [-1, 1]
    target_l,  # (M, H) target muscle length [m]
    target_k,  # (M, H) target muscle stiffness [N/m]
    load,  # (M, H): hanging mass [kg] (rig) or external force on the muscle [N] (hinge)
    weight,  # (M, H): weight of each step's tracking error (0 where the score leaves it out)
    track_stiffness,
    length_norm,  # [m]: the length error that scores 1
    stiffness_norm,  # relative stiffness error that scores 1
    burst_cost,
    effort_weight,
    cost,  # (M,) out
):
    m, h = actions.shape[0], actions.shape[1]
    n_blocks = (m + pl.BLOCK - 1) // pl.BLOCK
    for b in prange(n_blocks):
        lo = b * pl.BLOCK
        n = min(pl.BLOCK, m - lo)
        W = np.empty(pl.W_SIZE)
        x = np.empty((n, pl.N_STATE))
        inputs = np.zeros((n, pl.N_INPUT))
        aux = np.empty((n, pl.N_AUX))
        p = np.empty((n, params.shape[1]))
        hg = np.empty((n, hinge.shape[1]))
        for i in range(n):
            x[i] = state[lo + i]
            p[i] = params[lo + i]
            hg[i] = hinge[0 if hinge.shape[0] == 1 else lo + i]
            cost[lo + i] = 0.0
        for t in range(h):
            for i in range(n):
                a0, a1 = actions[lo + i, t, 0], actions[lo + i, t, 1]
                plant_inputs(inputs[i], mode, mech, a0, a1, setpoint_max, load[lo + i, t])
            if mech == pl.HINGE:
                pl.advance_block_hinge(x, inputs, p, hg, 0, n, mode, dt, n_sub, x, aux, W)
            else:
                pl.advance_block(x, inputs, p, 0, n, mode, dt, n_sub, x, aux, W)
            for i in range(n):
                r = lo + i
                c = step_error_sq(
                    x[i, pl.S_L],
                    target_l[r, t],
                    aux[i, pl.A_STIFF],
                    target_k[r, t],
                    weight[r, t],
                    track_stiffness,
                    length_norm,
                    stiffness_norm,
                )
                a0, a1 = actions[r, t, 0], actions[r, t, 1]
                c += burst_cost * aux[i, pl.A_BURST] + effort_weight * (a0 * a0 + a1 * a1)
                cost[r] += c
        for i in range(n):
            if not np.isfinite(cost[lo + i]):
                cost[lo + i] = np.inf
