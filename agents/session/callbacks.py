"""The callback a training session runs inside SB3's ``learn``: it averages the env's reward terms
and errors into the log, triggers the periodic evaluations and checkpoints (the first one early),
moves the progress bar, and stops the session at the config's time limit."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Protocol

import numpy as np

from ..config.files import TrainConfig
from .progress import ProgressBar

FIRST_CHECKPOINT_FRACTION = 0.1  # of the session's steps
FIRST_CHECKPOINT_MINUTES = 2.0


def _next(n: int, due: int, every: int) -> int:
    """The first multiple of ``every`` steps after ``due`` that is past ``n`` (a step of ``learn``
    may cross several)."""
    return due + every * max(1, (n - due) // every + 1)


class Session(Protocol):
    """What the callback reads and drives of its training session (the trainer's ``Trainer``)."""

    cfg: TrainConfig
    progress: ProgressBar
    info_keys: list[str]
    track_stiffness: bool
    last_score: float | None
    best_score: float
    stopped_by_time: bool

    def evaluate(self, n: int) -> dict: ...

    def save_checkpoint(self, n: int, interrupted: bool = False) -> Path: ...

    def wall(self) -> float: ...


def info_sums(infos, keys, contract, track_stiffness: bool):
    """``(sums, count)`` of a step's infos (a list of dicts, or the native learner's dict of arrays
    with Gymnasium's masks): each reward term's sum over the envs and the summed position and
    stiffness errors, in the contract's units; None when the infos hold none of it. ``keys``: the
    position, its target, the stiffness, its target, then the reward terms (envs.info_keys)."""
    if isinstance(infos, dict):  # the native learner's dict of arrays (last-step entries)
        if not all(k in infos for k in keys):
            return None
        scored = np.ones(len(infos[keys[0]]), bool)
        for k in keys:  # Gymnasium's masks: the envs whose info holds the entry
            scored &= np.asarray(infos.get("_" + k, True), dtype=bool)
        vals = np.column_stack([np.asarray(infos[k], dtype=float)[scored] for k in keys])
    elif not infos or keys[0] not in infos[0]:
        return None
    else:
        vals = np.array([[inf[k] for k in keys] for inf in infos], dtype=float)
    row = {k: vals[:, j].sum() for j, k in enumerate(keys) if k.startswith("reward_")}
    trade = contract.trade  # e.g. length_error_mm, angle_error_deg
    row[f"{contract.position}_error_{trade.unit}"] = trade.scale * np.abs(vals[:, 0] - vals[:, 1]).sum()
    if track_stiffness:
        K, Kt = vals[:, 2], vals[:, 3]
        row["stiffness_error_pct"] = 100.0 * np.abs((K - Kt) / Kt).sum()
    return row, len(vals)


def make_callback_class():
    """The callback class (built on first use: SB3 is imported only when training)."""
    from stable_baselines3.common.callbacks import BaseCallback

    class RunCallback(BaseCallback):
        """Logs the env's reward terms and errors, evaluates, keeps the best model, checkpoints,
        and draws the progress bar (with the latest evaluation score)."""

        def __init__(self, session: Session):
            super().__init__(verbose=0)
            self.t = session
            self._sums: dict[str, float] = {}
            self._count = 0

        def _on_training_start(self) -> None:
            n = self.num_timesteps
            cfg = self.t.cfg
            self.next_log = _next(n, 0, cfg.log_every_steps)
            self.next_eval = _next(n, 0, cfg.eval.every_steps)
            self.next_ckpt = _next(n, 0, cfg.checkpoint.every_steps)
            # an early first checkpoint: a run killed early still has something to resume from
            remaining = max(1, cfg.total_timesteps - n)
            self.first_ckpt = n + max(1, int(FIRST_CHECKPOINT_FRACTION * remaining))
            self.first_ckpt_wall = time.perf_counter() + 60.0 * FIRST_CHECKPOINT_MINUTES
            self.t.progress.open(n, self.t.last_score, self.t.best_score)

        def _on_step(self) -> bool:
            self._accumulate(self.locals.get("infos") or [])
            n, cfg = self.num_timesteps, self.t.cfg
            if n >= self.next_log:
                self._log()
                self.next_log = _next(n, self.next_log, cfg.log_every_steps)
            if n >= self.next_eval:
                self.t.evaluate(n)
                self.next_eval = _next(n, self.next_eval, cfg.eval.every_steps)
            if self.first_ckpt is not None and (
                n >= self.first_ckpt or time.perf_counter() >= self.first_ckpt_wall
            ):
                self.first_ckpt = None
                if n < self.next_ckpt:
                    self.t.save_checkpoint(n)
            if n >= self.next_ckpt:
                self.first_ckpt = None
                self.t.save_checkpoint(n)
                self.next_ckpt = _next(n, self.next_ckpt, cfg.checkpoint.every_steps)
            self.t.progress.to(n)
            limit = cfg.time_limit_minutes
            if limit is not None and self.t.wall() >= 60.0 * limit:
                self.t.stopped_by_time = True
                return False
            return True

        def _accumulate(self, infos) -> None:
            got = info_sums(infos, self.t.info_keys, self.t.contract, self.t.track_stiffness)
            if got is not None:
                row, count = got
                for k, v in row.items():
                    self._sums[k] = self._sums.get(k, 0.0) + float(v)
                self._count += count

        def _log(self) -> None:
            if self._count:
                for k, v in self._sums.items():
                    self.logger.record(f"env/{k}", v / self._count)
            self.logger.record("time/wall_s", self.t.wall())
            self.logger.dump(self.num_timesteps)
            self._sums, self._count = {}, 0

    return RunCallback
