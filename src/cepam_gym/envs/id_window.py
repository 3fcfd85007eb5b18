"""The identification window: unscored control steps on the episode's own plant before its tracking.

A rig is identified before it is controlled. With the task option ``id_window_s > 0`` (a field of
:class:`~cepam_gym.tasks.spec.TaskSpec`, ``task_options={"id_window_s": 10.0}``) every episode
starts with ``id_window_s`` seconds (:func:`window_steps` control steps) on the plant and load the
episode was drawn with, then runs its tracking unchanged:

* **the window**: the controller's actions drive the plant as usual, under the same safety limits
  (a burst ends the episode and counts as a failure). The targets hold the episode's starting
  point; the load is the one the tracking starts under. The reward counts only the burst term
  (tracking, effort and air are not scored) and ``info["window"]`` is True for each step taken in
  it (and for the reset's info when the episode starts with one). The observation is the task's
  own, column for column: a policy or controller of the id acts on the window's env as it is.
* **its end**: the plant is put back at rest at the episode's starting point (:func:`restart`,
  as the reset started it; the supply drift, if any, goes on) and the tracking runs as it would
  without the window: the same references, loads and plant, step for step. The benchmark's
  harness leaves the window's steps out of the score (:func:`cepam_gym.bench.harness.record`).

An episode is ``window_steps + n_steps`` control steps long; a vector env's ``max_episode_steps``
counts the tracking only (the window is added to it).
"""

from __future__ import annotations

import numpy as np

INFO_KEY = "window"  # info: the step was taken in the identification window


def window_steps(spec, control_dt: float) -> int:
    """Control steps of the window of task spec ``spec`` (0 without one; joint specs have none)."""
    seconds = float(getattr(spec, "id_window_s", 0.0) or 0.0)
    return int(round(seconds / control_dt)) if seconds > 0 else 0


def prepend(plan: tuple, n_window: int) -> tuple:
    """``(target_l, target_k, load, initial)`` of a task's plan with ``n_window`` steps in front:
    the targets hold the starting point, the load the tracking's first load."""
    if not n_window:
        return plan
    tl, tk, load, initial = plan
    m = tl.shape[0]
    hold = lambda col: np.repeat(np.asarray(col, dtype=float)[:, None], n_window, axis=1)  # noqa: E731
    return (
        np.concatenate([hold(initial[:, 0]), tl], axis=1),
        np.concatenate([hold(initial[:, 1]), tk], axis=1),
        np.concatenate([hold(load[:, 0]), load], axis=1),
        initial.reshape(m, 2),
    )


def in_window(t_idx: np.ndarray, n_window: int, scored: bool) -> np.ndarray:
    """Per env: the step just taken (``scored``; the next one after a reset) is in the window."""
    return (np.asarray(t_idx) - (1 if scored else 0)) < n_window


def unscore(s, stepped: np.ndarray, reward) -> None:
    """The reward of envs ``stepped`` (a bool mask: their step was in the window) of env state
    ``s``: only the terms of ``reward`` (a :class:`~cepam_gym.tasks.reward.Reward`) that charge a
    failure are kept (a failure is a failure: the burst term), the others are zeroed."""
    if stepped.any():
        keep = np.zeros(s.terms.shape[1], dtype=bool)
        keep[list(reward.failure_columns)] = True
        rows = np.flatnonzero(stepped)
        s.terms[np.ix_(rows, np.flatnonzero(~keep))] = 0.0
        s.rewards[rows] = s.terms[rows][:, keep].sum(axis=1)
