"""The progress bar of the long commands (``bench``, ``eval``, ``dataset``, ``compare``,
``identify``): tqdm's, on stderr, with its estimate of the time left. Shown only when stderr is a
terminal (tqdm's ``disable=None``), so logs and pipes get none; absent when tqdm is not installed
(it comes with the ``[train]`` extra).

A command opens one bar over its runs (``with runs(total, "bench")``); the harness's rollout loop
(:func:`cepam_gym.bench.harness.record`) advances the open bar by a fraction of a run per control
step, so the estimate moves within a long run (the MPC's and the oracle's) and not only between
runs. ``identify`` counts the fit's evaluations instead (:func:`cepam_gym.identify.fit.solve`)."""

from __future__ import annotations

import contextlib
import sys

_open = None  # the bar of the running command, if any


@contextlib.contextmanager
def runs(total: int, desc: str, unit: str = "runs"):
    """A bar over ``total`` runs (or other ``unit``) while the block runs (nested bars: the outer
    one only)."""
    global _open
    bar = None
    if _open is None:
        try:
            from tqdm import tqdm
        except ImportError:  # the library's core does not need tqdm
            tqdm = None
        if tqdm is not None:
            fmt = "{desc}: {n:.1f}/{total} " + unit + " |{bar}| {elapsed} elapsed, {remaining} left"
            bar = tqdm(total=total, desc=desc, file=sys.stderr, disable=None, leave=False, bar_format=fmt)
            _open = bar
    try:
        yield bar
    finally:
        if bar is not None:
            bar.close()
            _open = None


def advance(fraction: float) -> None:
    """Move the open bar on by ``fraction`` of a run (nothing when no bar is open)."""
    if _open is not None:
        _open.update(fraction)
