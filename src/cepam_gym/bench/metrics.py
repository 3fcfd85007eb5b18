"""Scores of a controller on recorded traces (pure numpy; tested on hand-made traces).

Traces are arrays of shape (T, N) (time, episode): ``length``, ``target_length`` [m],
``stiffness``, ``target_stiffness`` [N/m], ``air_used`` [kg per step], ``reward``, ``alive``
(bool: the episode had not failed before this step), plus ``failed`` (N,) and ``dt`` [s].

The **combined score** (lower is better) is
``length_rmse_mm / 5 mm + stiffness_rmse_pct / 20 % + 2 * failure_rate`` (the stiffness term only
where the task tracks stiffness): a controller that is off by 5 mm and 20 % everywhere scores 2.

**Tracking with a settling allowance** (the v1 suites, ``TraceSpec.allowance_s > 0``): the
headline errors ``*_rmse_*`` and the score leave out the ``allowance_s`` seconds after each
*discontinuous* target change (a jump larger than ``jump_length`` or ``jump_stiffness`` in one
step; smooth references move less), where no controller can follow a valve-limited transient;
the response to those jumps is scored apart (``rise_time_s``, ``overshoot_pct``,
``settling_time_s``), and the errors over every step stay in the output (``*_rmse_*_raw``).
With ``allowance_s = 0`` (the v0 suites) the raw and headline errors are the same.

**Normalized score** (:func:`normalized_score`, as D4RL normalises returns; Fu et al. 2020):
``100 (score_zero - score) / (score_zero - score_oracle)``: 0 is the zero controller (valves
closed), 100 the privileged oracle (:mod:`cepam_gym.control.oracle`) on the same suite.

A suite's :class:`TraceSpec` says what the ``length`` and ``stiffness`` columns hold: the rig's
muscle length [m] and stiffness [N/m] (:data:`RIG`, the default), or the joint's angle [rad] and
joint stiffness [N m/rad] (:data:`JOINT`: ``angle_rmse_deg`` instead of ``length_rmse_mm``, settled
within 2 deg, overshoot on steps of at least 5 deg, ``angle_rmse_deg / 10 deg`` in the score).
"""

from __future__ import annotations

import numpy as np

from ..control.objective import (  # noqa: F401  (re-exported: the bench's names)
    FAILURE_WEIGHT,
    JOINT,
    JOINT_V1,
    LENGTH_BAND,
    MIN_STEP,
    RIG,
    RIG_V1,
    STIFFNESS_BAND,
    TraceSpec,
    combined_score,
    scored_steps,
)
from ..control.objective import jumps as _jumps

# the objective is defined once, beside the planner that optimises it (control.objective)
from ..errors import InputError


def _rms(x, mask):
    return float(np.sqrt(np.mean(x[mask] ** 2))) if mask.any() else float("nan")


def jumps(tr: dict, track_stiffness: bool, spec: TraceSpec = RIG) -> np.ndarray:
    """(T, N) bool: the target jumps at this step (a change larger than the spec's jump sizes)."""
    return _jumps(tr["target_length"], tr["target_stiffness"], track_stiffness, spec)


def tracking_mask(tr: dict, track_stiffness: bool, spec: TraceSpec = RIG) -> np.ndarray:
    """(T, N) bool: the steps the headline error counts: alive, and not within
    ``spec.allowance_s`` after a jump of the target (all alive steps when the allowance is 0)."""
    steps = scored_steps(tr["target_length"], tr["target_stiffness"], track_stiffness, spec, tr["dt"])
    return tr["alive"] & steps


def rise_time(tr: dict, track_stiffness: bool, spec: TraceSpec = RIG) -> float:
    """Mean 10-90 % rise time [s] of the length (or angle) after jumps of at least ``min_step``
    (NaN without such jumps); a response that never reaches 90 % before the next jump counts
    the whole segment."""
    T, N = tr["length"].shape
    j = jumps(tr, track_stiffness, spec)
    out = []
    for n in range(N):
        starts = np.flatnonzero(j[:, n])
        for a, b in zip(starts, list(starts[1:]) + [T]):
            prev = tr["target_length"][a - 1, n]
            step = tr["target_length"][a, n] - prev
            if abs(step) < spec.min_step or not tr["alive"][a:b, n].all():
                continue
            frac = (tr["length"][a:b, n] - prev) / step
            t10 = np.flatnonzero(frac >= 0.1)
            t90 = np.flatnonzero(frac >= 0.9)
            end = t90[0] if t90.size else b - a
            out.append((end - (t10[0] if t10.size else 0)) * tr["dt"])
    return float(np.mean(out)) if out else float("nan")


def normalized_score(score: float, zero_score: float, oracle_score: float) -> float:
    """``100 (zero - score) / (zero - oracle)``: 0 = the zero controller, 100 = the oracle (lower
    raw scores are better; a controller better than the oracle scores above 100)."""
    span = zero_score - oracle_score
    if not (np.isfinite(span) and span > 0):
        raise InputError(
            f"normalization needs the zero controller ({zero_score}) to score worse "
            f"(higher) than the oracle ({oracle_score})"
        )
    return float(100.0 * (zero_score - score) / span)


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
    return (float(np.mean(settle)) if settle else float("nan"), float(np.mean(over)) if over else 0.0)


def score_interval(
    tr: dict, track_stiffness: bool = True, spec: TraceSpec = RIG, n_boot: int = 2000, seed: int = 0
) -> tuple[float, float]:
    """95 % percentile-bootstrap interval of the combined score over episodes: episodes are
    resampled with replacement and the score recomputed from their pooled squared errors (the
    score pools steps across episodes, so the episodes' sums are what resampling moves)."""
    tracked = tracking_mask(tr, track_stiffness, spec)
    n = tracked.shape[1]
    count = tracked.sum(axis=0)
    sq_l = np.where(tracked, (tr["length"] - tr["target_length"]) ** 2, 0.0).sum(axis=0)
    if track_stiffness:
        rel = (tr["stiffness"] - tr["target_stiffness"]) / tr["target_stiffness"]
        sq_k = np.where(tracked, rel**2, 0.0).sum(axis=0)
    idx = np.random.default_rng(seed).integers(0, n, size=(n_boot, n))
    cnt = np.maximum(count[idx].sum(axis=1), 1)
    k_rmse = np.sqrt(sq_k[idx].sum(axis=1) / cnt) if track_stiffness else None
    boot = combined_score(
        np.sqrt(sq_l[idx].sum(axis=1) / cnt), k_rmse, np.asarray(tr["failed"], float)[idx].mean(axis=1), spec
    )
    lo, hi = np.percentile(boot, [2.5, 97.5])
    return float(lo), float(hi)


def score_traces(tr: dict, track_stiffness: bool = True, spec: TraceSpec = RIG) -> dict:
    alive = tr["alive"]
    tracked = tracking_mask(tr, track_stiffness, spec)
    e_len = tr["length"] - tr["target_length"]
    out = {"episodes": int(alive.shape[1]), spec.rmse_key: spec.scale * _rms(e_len, tracked)}
    if track_stiffness:
        rel = (tr["stiffness"] - tr["target_stiffness"]) / tr["target_stiffness"]
        out["stiffness_rmse_pct"] = 100.0 * _rms(rel, tracked)
    else:
        out["stiffness_rmse_pct"] = None
    if spec.allowance_s > 0:
        out[spec.rmse_key + "_raw"] = spec.scale * _rms(e_len, alive)
        out["stiffness_rmse_pct_raw"] = 100.0 * _rms(rel, alive) if track_stiffness else None
        out["tracked_fraction"] = float(tracked.sum() / max(alive.sum(), 1))
        out["rise_time_s"] = rise_time(tr, track_stiffness, spec)
    out["settling_time_s"], out["overshoot_pct"] = settling_and_overshoot(tr, track_stiffness, spec)
    returns = np.where(alive, tr["reward"], 0.0).sum(axis=0)
    k = max(1, int(np.ceil(0.1 * returns.size)))
    out["mean_return"] = float(returns.mean())
    out["cvar10_return"] = float(np.sort(returns)[:k].mean())
    out["failure_rate"] = float(np.mean(tr["failed"]))
    out["air_g_per_episode"] = float(1000.0 * np.where(alive, tr["air_used"], 0.0).sum(axis=0).mean())
    out["score"] = combined_score(
        out[spec.rmse_key] / spec.scale,
        out["stiffness_rmse_pct"] / 100.0 if track_stiffness else None,
        out["failure_rate"],
        spec,
    )
    out["score_ci95"] = list(score_interval(tr, track_stiffness, spec))
    return out
