"""Scores of a controller on recorded traces (pure numpy; tested on hand-made traces).

Traces are arrays of shape (T, N) (time, episode): ``length``, ``target_length`` [m],
``stiffness``, ``target_stiffness`` [N/m], ``air_used`` [kg per step], ``reward``, ``alive``
(bool: the episode had not failed before this step), plus ``failed`` (N,) and ``dt`` [s].

The **combined score** (lower is better) is
``length_rmse_mm / 5 mm + stiffness_rmse_pct / 20 % + 2 * failure_rate`` (the stiffness term only
where the task tracks stiffness): a controller that is off by 5 mm and 20 % everywhere scores 2.

A suite's :class:`TraceSpec` says what the ``length`` and ``stiffness`` columns hold: the rig's
muscle length [m] and stiffness [N/m] (:data:`RIG`, the default), or the joint's angle [rad] and
joint stiffness [N m/rad] (:data:`JOINT`: ``angle_rmse_deg`` instead of ``length_rmse_mm``, settled
within 2 deg, overshoot on steps of at least 5 deg, ``angle_rmse_deg / 10 deg`` in the score).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

LENGTH_BAND = 1e-3  # m: "settled" means within 1 mm ...
STIFFNESS_BAND = 0.05  # ... and within 5 % of the stiffness target
MIN_STEP = 2e-3  # m: overshoot is measured on target changes of at least 2 mm

_TRACE_COLUMNS = ("length", "target_length", "stiffness", "target_stiffness", "pressure_c",
                  "pressure_e", "load_mass", "air_used")


@dataclass(frozen=True)
class TraceSpec:
    """What a suite's trace columns hold and how the tracked quantity is scored and plotted.

    ``info_keys`` maps each trace column to the env's ``info`` key; ``scale`` converts the SI
    ``length`` column to ``unit``, and the metric is named ``f"{quantity}_rmse_{unit}"``;
    ``band`` and ``min_step`` are SI; ``score_norm`` (in ``unit``) is the error that scores 1."""

    quantity: str = "length"
    unit: str = "mm"
    scale: float = 1000.0
    band: float = LENGTH_BAND
    min_step: float = MIN_STEP
    score_norm: float = 5.0
    info_keys: dict[str, str] = field(default_factory=lambda: {k: k for k in _TRACE_COLUMNS})
    # plots: (label, unit, scale from SI) of the tracked quantity, the stiffness and the load
    plot_quantity: tuple[str, str, float] = ("length", "cm", 100.0)
    plot_stiffness: tuple[str, str, float] = ("stiffness", "N/m", 1.0)
    plot_load: tuple[str, str, float] = ("load", "g", 1000.0)

    @property
    def rmse_key(self) -> str:
        return f"{self.quantity}_rmse_{self.unit}"


RIG = TraceSpec()
JOINT = TraceSpec(
    quantity="angle", unit="deg", scale=180.0 / np.pi, band=np.deg2rad(2.0), min_step=np.deg2rad(5.0),
    score_norm=10.0,
    info_keys={"length": "angle", "target_length": "target_angle", "stiffness": "joint_stiffness",
               "target_stiffness": "target_stiffness", "pressure_c": "pressure_c",
               "pressure_e": "pressure_e", "load_mass": "external_torque", "air_used": "air_used"},
    plot_quantity=("angle", "deg", 180.0 / np.pi), plot_stiffness=("joint stiffness", "N m/rad", 1.0),
    plot_load=("external torque", "mN m", 1000.0))


def _rms(x, mask):
    return float(np.sqrt(np.mean(x[mask] ** 2))) if mask.any() else float("nan")


def settling_and_overshoot(tr: dict, track_stiffness: bool, spec: TraceSpec = RIG):
    """Mean settling time [s] over target segments and mean overshoot [% of the step]."""
    T, N = tr["length"].shape
    settle, over = [], []
    for n in range(N):
        tl = tr["target_length"][:, n]
        tk = tr["target_stiffness"][:, n]
        change = np.flatnonzero(np.r_[True, (np.diff(tl) != 0) | (np.diff(tk) != 0)])
        bounds = list(change) + [T]
        alive = tr["alive"][:, n]
        for s, e in zip(bounds[:-1], bounds[1:]):
            if not alive[s:e].all():
                continue
            err_l = np.abs(tr["length"][s:e, n] - tl[s])
            ok = err_l < spec.band
            if track_stiffness:
                ok &= np.abs(tr["stiffness"][s:e, n] - tk[s]) < STIFFNESS_BAND * tk[s]
            # settled at the first index from which it stays inside the band to the segment's end
            bad = np.flatnonzero(~ok)
            first = 0 if bad.size == 0 else bad[-1] + 1
            settle.append((first if first < e - s else e - s) * tr["dt"])
            prev = tl[s - 1] if s > 0 else tr["length"][0, n]
            step = tl[s] - prev
            if abs(step) >= spec.min_step:
                beyond = (tr["length"][s:e, n] - tl[s]) * np.sign(step)
                over.append(100.0 * max(beyond.max(), 0.0) / abs(step))
    return (float(np.mean(settle)) if settle else float("nan"),
            float(np.mean(over)) if over else 0.0)


def score_traces(tr: dict, track_stiffness: bool = True, spec: TraceSpec = RIG) -> dict:
    alive = tr["alive"]
    e_len = tr["length"] - tr["target_length"]
    out = {"episodes": int(alive.shape[1]),
           spec.rmse_key: spec.scale * _rms(e_len, alive)}
    if track_stiffness:
        rel = (tr["stiffness"] - tr["target_stiffness"]) / tr["target_stiffness"]
        out["stiffness_rmse_pct"] = 100.0 * _rms(rel, alive)
    else:
        out["stiffness_rmse_pct"] = None
    out["settling_time_s"], out["overshoot_pct"] = settling_and_overshoot(tr, track_stiffness, spec)
    returns = np.where(alive, tr["reward"], 0.0).sum(axis=0)
    k = max(1, int(np.ceil(0.1 * returns.size)))
    out["mean_return"] = float(returns.mean())
    out["cvar10_return"] = float(np.sort(returns)[:k].mean())
    out["failure_rate"] = float(np.mean(tr["failed"]))
    out["air_g_per_episode"] = float(1000.0 * np.where(alive, tr["air_used"], 0.0).sum(axis=0).mean())
    score = out[spec.rmse_key] / spec.score_norm + 2.0 * out["failure_rate"]
    if track_stiffness:
        score += out["stiffness_rmse_pct"] / 20.0
    out["score"] = float(score)
    return out
