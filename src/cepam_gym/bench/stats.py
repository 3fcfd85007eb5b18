"""Aggregates over training seeds for agent tables: the interquartile mean (IQM) with a 95 %
stratified-bootstrap interval (Agarwal et al. 2021), through ``rliable`` (an optional dependency,
imported only here and only when called). Controller rows carry their own interval over episodes
(:func:`cepam_gym.bench.metrics.score_interval`)."""

from __future__ import annotations

import numpy as np

MIN_SEEDS = 5  # fewer seeds make the interquartile mean and its interval meaningless


def iqm_interval(scores: dict[str, list[float]], reps: int = 2000, seed: int = 0) -> dict[str, tuple]:
    """``{task: (iqm, lo, hi)}`` of per-seed scores ``{task: [score of seed 0, 1, ...]}`` plus
    ``"all"`` over the tasks (stratified: seeds are resampled within each task). Raises
    ``ImportError`` naming the install command without rliable, ``ValueError`` with fewer than
    :data:`MIN_SEEDS` seeds per task."""
    try:
        from rliable import library as rly
        from rliable import metrics
    except ImportError as e:
        raise ImportError(
            "agent tables aggregate seeds with rliable (IQM, stratified bootstrap): pip install rliable"
        ) from e
    few = {k: len(v) for k, v in scores.items() if len(v) < MIN_SEEDS}
    if few:
        raise ValueError(f"an IQM over seeds needs at least {MIN_SEEDS} seeds per task, got {few}")
    n = min(len(v) for v in scores.values())
    tasks = list(scores)
    # rliable takes {algorithm: (runs, tasks)}; one "algorithm" per task, and one for all tasks
    table = {k: np.asarray(scores[k][:n], dtype=float)[:, None] for k in tasks}
    table["all"] = np.stack([np.asarray(scores[k][:n], dtype=float) for k in tasks], axis=1)
    np.random.seed(seed)  # rliable's bootstrap draws from numpy's global stream
    point, ci = rly.get_interval_estimates(table, lambda x: np.array([metrics.aggregate_iqm(x)]), reps=reps)
    return {k: (float(point[k][0]), float(ci[k][0, 0]), float(ci[k][1, 0])) for k in table}
