"""The headline score: the share of the gap from the inverse-model baseline to the oracle that a
controller closes, in points.

    headline = 100 (baseline - score) / (baseline - oracle)

``score``, ``baseline`` and ``oracle`` are combined scores (:func:`cepam_gym.bench.metrics.combined_score`,
lower is better) on the same episodes: 0 is the inverse-static-model baseline
(:class:`cepam_gym.control.InverseStaticController`, registered as ``baseline``; its joint variant
on the joint suites), 100 the privileged oracle (:mod:`cepam_gym.control.oracle`), a negative
headline is worse than the baseline (the zero controller reads about -1000 on ``nominal-v2``),
above 100 better than the oracle. ``cepam-gym bench`` and ``cepam-gym eval`` print it per row,
beside the D4RL-style normalized score (:func:`cepam_gym.bench.metrics.normalized_score`, zero
controller 0, oracle 100), the one with a low end common to every suite.

Why this scale (docs/benchmark.md, "The headline score"): on the normalized score every practical
controller sits between 69 and 98, because the zero controller's error is 3-60 times theirs; on
this one the baseline, the MPC and the oracle are 20 points or more apart on the recommended
suites, and the comparison with the baseline, the reference the project is built to beat, is the
number itself.
"""

from __future__ import annotations

import math

from ..errors import InputError

# the controllers whose scores are the two ends (registered names of cepam_gym.control)
BASELINE = "baseline"
ORACLE = "oracle"

LEGEND = (
    "headline = 100 (baseline - score) / (baseline - oracle): 0 = the inverse-model baseline, "
    "100 = the oracle, < 0 worse than the baseline; normalized: 0 = valves shut, 100 = the oracle (D4RL)"
)


def headline_score(score: float, baseline: float, oracle: float) -> float:
    """``100 (baseline - score) / (baseline - oracle)``: 0 at the baseline's score, 100 at the
    oracle's, negative below the baseline. Lower raw scores are better, so the baseline must score
    higher (worse) than the oracle; a degenerate span raises :class:`~cepam_gym.errors.InputError`."""
    span = baseline - oracle
    if not (math.isfinite(span) and span > 0):
        raise InputError(
            f"the headline score needs the baseline ({baseline}) to score worse (higher) than the "
            f"oracle ({oracle}) on the same episodes"
        )
    return float(100.0 * (baseline - score) / span)
