"""A recording replayed on the plant: many parameter rows at once, and the sensors' view of it.

The compiled driver :func:`_replay` runs the plant's own block kernel
(:func:`cepam_gym.plant.advance_block`, no other copy of the equations) over a whole recording:
one control step per sample of the recording's grid, the commands and the hanging load held over
it. Each parameter row is one plant of the batch, so the nominal parameters and every
finite-difference perturbation of a Jacobian run side by side, sharing the input trajectory; the
blocks of plants are independent and run on all cores (``prange``).

The sensors (:func:`sensed`) see a plant channel ``y`` late by ``delay``, scaled and offset:
``gain * y(t - delay) + bias``. They are applied after the simulation, so fitting them costs no
new run of the plant.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .. import plant as pl
from ..physics.layout import P_ATM, P_SUP
from ..plant.actions import valve_commands

CHANNELS = ("pressure_c", "pressure_e", "length")  # what a rig measures, SI (Pa gauge, Pa gauge, m)
N_CHANNELS = 3


@njit(parallel=True, cache=True, error_model="numpy")
def _replay(state0, commands, loads, params, mode, dt, n_sub, splits, out, supply):
    """Plants ``splits[b] .. splits[b + 1] - 1`` form block ``b``; each block runs the whole
    recording on its own (scratch and state of its own), blocks in parallel. ``out`` (N, T, 3):
    the channels at the start of every sample (``out[:, 0]`` is the initial state). ``supply``
    (T,) [Pa abs] the supply of each sample (written into ``params``), or empty: the rows' own."""
    n_t = commands.shape[0]
    for b in prange(splits.shape[0] - 1):
        lo = splits[b]
        n = splits[b + 1] - lo
        W = np.empty(pl.W_SIZE)
        state = state0.copy()
        inputs = np.zeros((state0.shape[0], pl.N_INPUT))
        aux = np.empty((state0.shape[0], pl.N_AUX))
        for i in range(lo, lo + n):
            pl.measure_row(state[i], params[i], aux[i])
            out[i, 0, 0] = aux[i, pl.A_PC]
            out[i, 0, 1] = aux[i, pl.A_PE]
            out[i, 0, 2] = state[i, pl.S_L]
        for k in range(n_t - 1):
            for i in range(lo, lo + n):
                if supply.shape[0] > 0:
                    params[i, P_SUP] = supply[k]
                inputs[i, pl.I_CMD_C] = commands[k, 0]
                inputs[i, pl.I_CMD_E] = commands[k, 1]
                inputs[i, pl.I_LOAD] = loads[k]
            pl.advance_block(state, inputs, params, lo, n, mode, dt, n_sub, state, aux, W)
            for i in range(lo, lo + n):
                out[i, k + 1, 0] = aux[i, pl.A_PC]
                out[i, k + 1, 1] = aux[i, pl.A_PE]
                out[i, k + 1, 2] = state[i, pl.S_L]


def _splits(n: int, threads: int) -> np.ndarray:
    """Block boundaries: at least one block per thread (when there are plants enough), at most
    ``pl.BLOCK`` plants per block, sizes as even as possible."""
    blocks = max(min(n, threads), -(-n // pl.BLOCK))
    return np.linspace(0, n, blocks + 1).round().astype(np.int64)


def replay(
    params: np.ndarray, commands, loads, mode: int, dt: float, n_sub: int, start, supply=None
) -> np.ndarray:
    """The channels (N, T, 3) [Pa, Pa, m] of ``N`` plants (parameter rows ``params``, (N, N_PARAMS))
    driven by ``commands`` (T, 2, plant inputs: spool set-points, duties or set-points [Pa]) and
    ``loads`` (T,) [kg], each held for ``n_sub`` sub-steps of ``dt``. ``start``: ``(length [m],
    pressure_c [Pa], pressure_e [Pa])`` at rest at the first sample. ``supply`` (T,) [Pa gauge]:
    the supply over each sample, for a supply that drifts (default: the rows' own, constant)."""
    import numba

    params = np.array(np.atleast_2d(params), dtype=float, order="C")  # a copy: the supply writes it
    if supply is None:
        supply_abs = np.empty(0)
    else:
        supply_abs = np.ascontiguousarray(supply, dtype=float) + params[0, P_ATM]
    n = params.shape[0]
    state0 = pl.initial_state(params, start[0], start[1], start[2])
    out = np.empty((n, len(commands), N_CHANNELS))
    splits = _splits(n, numba.get_num_threads())
    _replay(
        state0,
        np.ascontiguousarray(commands, dtype=float),
        np.ascontiguousarray(loads, dtype=float),
        params,
        int(mode),
        float(dt),
        int(n_sub),
        splits,
        out,
        supply_abs,
    )
    return out


def sensed(y: np.ndarray, h: float, delay, gain, bias) -> np.ndarray:
    """What the sensors report of plant channels ``y`` (..., T, 3) sampled every ``h`` s:
    ``gain * y(t - delay) + bias`` per channel (``delay`` [s] >= 0, linear interpolation between
    samples, the first sample held before the start)."""
    out = np.empty_like(y)
    t = np.arange(y.shape[-2]) * h
    for c in range(N_CHANNELS):
        shifted = np.maximum(t - delay[c], 0.0) / h
        i0 = np.minimum(np.floor(shifted).astype(int), y.shape[-2] - 1)
        i1 = np.minimum(i0 + 1, y.shape[-2] - 1)
        w = shifted - i0
        yc = y[..., c]
        out[..., c] = gain[c] * ((1.0 - w) * yc[..., i0] + w * yc[..., i1]) + bias[c]
    return out


def plant_commands(commands: np.ndarray, mode: int, pressure_cap: float) -> np.ndarray:
    """The plant's valve inputs of log commands (..., 2) in [-1, 1], mapped as the env maps its
    action (:func:`cepam_gym.plant.actions.valve_commands`): in pressure mode a gauge set-point in
    ``[0, pressure_cap]`` [Pa], otherwise the command itself."""
    cmd = np.asarray(commands, float)
    c, e = valve_commands(mode, cmd[..., 0], cmd[..., 1], float(pressure_cap))
    return np.stack([c, e], axis=-1)


def refinement(params: np.ndarray, sub_dt: float, limit: float = 1.0) -> int:
    """How many times to split ``sub_dt`` so the explicit air integration of every row of
    ``params`` stays stable and free of overshoot (:func:`cepam_gym.plant.stability_number`
    at most ``limit``): a fit may try fast valves on small volumes that the rig's own sub-step
    could not integrate."""
    return max(1, int(np.ceil(float(np.max(pl.stability_number(params, sub_dt))) / limit)))
