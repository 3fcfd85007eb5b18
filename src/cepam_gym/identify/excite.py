"""Excitation schedules to play on a rig, and the logs a simulated rig writes from them.

A schedule (:func:`schedule`) starts with both chambers exhausted (one second, inside the
unscored warm-up: whatever the rig held before is forgotten), then cycles through three kinds of
segment on both valves, each exciting something else (Ljung 1999, ch. 13), each started from
pressures the valves pin whatever the rig (a quarter second with each valve fully open to the
supply or the exhaust):

* steps: a command pulse of random size and sign, then the valves shut: the pressure ramps show
  the valve conductance against the chamber volume, the holds the heat transfer and the leaks;
* chirps: a sine sweeping 0.5-8 Hz, the two valves in quadrature: the spool lag and the
  damping of the free end, frequency by frequency;
* pseudo-random binary sequences: random switching on a 20 ms clock: broad-band, and the many
  reversals of the length show the friction's hysteresis.

The hanging load changes between segments (a few loads, ``loads_g``), so the data see the muscle
at several lengths for the same pressures. :func:`simulate_log` plays a schedule on a plant and
returns the log its sensors (delay, gain, bias, white noise) would write.
"""

from __future__ import annotations

import numpy as np

from .. import plant as pl
from ..errors import InputError
from ..plant.params import PlantParams
from .simulate import plant_commands, replay, sensed

EXHAUST_S = 1.0
SEGMENT_S = 2.5  # one segment of one kind
ANCHOR_S = 0.25  # each segment starts from known pressures: each valve fully open to supply or exhaust
ANCHORS = ((-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0))
KINDS = ("steps", "chirp", "prbs")


def _steps(n: int, fs: float, rng, mode: str) -> np.ndarray:
    u = np.zeros(n)
    k = 0
    while k < n:
        if mode == "pressure":  # set-points: held levels
            hold = int(rng.uniform(0.3, 1.2) * fs)
            u[k : k + hold] = rng.uniform(-1.0, 1.0)
            k += hold
            continue
        pulse = int(rng.uniform(0.03, 0.4) * fs)
        u[k : k + pulse] = rng.choice((-1.0, 1.0)) * np.exp(rng.uniform(np.log(0.05), 0.0))
        k += pulse + int(rng.uniform(0.2, 0.8) * fs)
    return u


def _chirp(n: int, fs: float, phase: float, mode: str) -> np.ndarray:
    t = np.arange(n) / fs
    f0, f1 = 0.5, 8.0
    T = n / fs
    # exponential sweep: as many periods per octave at the low end as at the high end
    phi = 2 * np.pi * f0 * T / np.log(f1 / f0) * (np.exp(t / T * np.log(f1 / f0)) - 1.0)
    amp = 0.7 if mode == "pressure" else 0.35
    return amp * np.sin(phi + phase)


def _prbs(n: int, fs: float, rng, mode: str) -> np.ndarray:
    clock = max(1, int(0.02 * fs))
    flips = rng.random(n // clock + 1) < 0.3
    level = np.where(np.cumsum(flips) % 2 == 0, 1.0, -1.0)
    amp = rng.choice((0.6, 0.9)) if mode == "pressure" else rng.choice((0.15, 0.4))
    return amp * np.repeat(level, clock)[:n]


def schedule(
    duration_s: float = 60.0,
    rate_hz: float = 500.0,
    mode: str = "valve",
    loads_g=(0.0, 100.0, 200.0),
    seed: int = 0,
) -> dict[str, np.ndarray]:
    """The command schedule (columns of the log format without the measured ones)."""
    if mode not in pl.MODES:
        raise InputError(f"mode must be one of {sorted(pl.MODES)}, got {mode!r}")
    if not duration_s > EXHAUST_S + 1.0:
        raise InputError(f"duration must exceed {EXHAUST_S + 1.0:g} s, got {duration_s:g}")
    if not 50.0 <= rate_hz <= 2000.0:
        raise InputError(f"rate must be 50-2000 Hz, got {rate_hz:g}")
    if not loads_g or min(loads_g) < 0:
        raise InputError(f"loads must be one or more masses >= 0 g, got {list(loads_g)}")
    rng = np.random.default_rng(seed)
    n = int(round(duration_s * rate_hz)) + 1
    cmd = np.zeros((n, 2))
    load = np.zeros(n)
    k0 = int(EXHAUST_S * rate_hz)
    cmd[:k0] = -1.0
    load[:k0] = loads_g[0]
    seg, anchor = int(SEGMENT_S * rate_hz), int(ANCHOR_S * rate_hz)
    for i, lo in enumerate(range(k0, n, seg)):
        # an open valve pins the pressure at the supply or the atmosphere whatever the rig's
        # dynamics: played open loop, the pressures cannot drift off for more than a segment
        cmd[lo : lo + anchor] = ANCHORS[i % len(ANCHORS)]
        if mode == "pressure":
            cmd[lo : lo + anchor] = np.maximum(cmd[lo : lo + anchor], -1.0)
        lo += anchor
        m = max(0, min(seg - anchor, n - lo))
        kind = KINDS[i % len(KINDS)]
        for c in range(2):
            if kind == "steps":
                cmd[lo : lo + m, c] = _steps(m, rate_hz, rng, mode)
            elif kind == "chirp":
                cmd[lo : lo + m, c] = _chirp(m, rate_hz, 0.5 * np.pi * c, mode)
            else:
                cmd[lo : lo + m, c] = _prbs(m, rate_hz, rng, mode)
        # the load changes every full cycle of the three kinds, so each kind sees each load
        load[lo - anchor : lo + m] = loads_g[(i // len(KINDS)) % len(loads_g)]
    return {
        "time_s": np.arange(n) / rate_hz,
        "command_c": np.clip(cmd[:, 0], -1, 1),
        "command_e": np.clip(cmd[:, 1], -1, 1),
        "load_g": load,
    }


def simulate_log(
    columns: dict[str, np.ndarray],
    params: PlantParams,
    mode: str = "valve",
    sub_dt: float = 5e-4,
    delay_s=(0.0, 0.0, 0.0),
    gain=(1.0, 1.0, 1.0),
    bias=(0.0, 0.0, 0.0),
    noise=(200.0, 200.0, 3e-5),
    seed: int = 0,
) -> dict[str, np.ndarray]:
    """``columns`` (a :func:`schedule`) with the measured columns a rig of ``params`` writes:
    sensors late by ``delay_s``, scaled by ``gain``, offset by ``bias`` [Pa, Pa, m], white noise
    of ``noise`` standard deviation [Pa, Pa, m] (default: 0.2 kPa and 0.03 mm, about 0.2 % of
    each channel's spread on an excitation log)."""
    t = np.asarray(columns["time_s"], float)
    h = float(np.median(np.diff(t)))
    n_sub = max(1, int(round(h / sub_dt)))
    m = pl.MODES[mode]
    p = params.to_array()
    cmds = plant_commands(
        np.column_stack([columns["command_c"], columns["command_e"]]), m, params.pressure_cap
    )
    start = (0.5 * (params.min_length + params.max_length), 0.0, 0.0)
    y = replay(p[None], cmds, np.asarray(columns["load_g"]) * 1e-3, m, h / n_sub, n_sub, start)[0]
    y = sensed(y, h, np.asarray(delay_s, float), np.asarray(gain, float), np.asarray(bias, float))
    y = y + np.random.default_rng(seed + 1_000_003).normal(size=y.shape) * np.asarray(noise, float)
    out = dict(columns)
    out["pressure_c_kpa"] = y[:, 0] * 1e-3
    out["pressure_e_kpa"] = y[:, 1] * 1e-3
    out["length_cm"] = y[:, 2] * 1e2
    return out
