"""The progress bar of a training session (tqdm on stderr), showing the latest evaluation score
beside the inverse-model baseline's on the same evaluation episodes.
On a terminal it redraws twice a second; in a log file (batch jobs) every 30 s, so logs stay short."""

from __future__ import annotations

import sys


class ProgressBar:
    """Opened at the first step of ``learn`` (nothing with ``quiet``); :meth:`to` moves it to a
    step count, :meth:`score` shows the evaluation scores."""

    def __init__(self, total: int, desc: str, quiet: bool):
        self.total, self.desc, self.quiet = total, desc, quiet
        self.bar = None
        self._n = 0
        self.baseline: float | None = None  # the baseline's score on the evaluation episodes

    def open(self, n: int, last_score: float | None, best_score: float) -> None:
        if self.quiet or self.bar is not None:
            return
        from tqdm import tqdm

        tty = sys.stderr.isatty()
        self.bar = tqdm(
            total=self.total,
            initial=n,
            unit="step",
            unit_scale=True,
            dynamic_ncols=True,
            mininterval=0.5 if tty else 30.0,
            file=sys.stderr,
            desc=self.desc,
        )
        self._n = n
        self.score(last_score, best_score)

    def to(self, n: int) -> None:
        if self.bar is not None and n > self._n:
            self.bar.update(n - self._n)
            self._n = n

    def score(self, last: float | None, best: float) -> None:
        if self.bar is None:
            return
        if last is None:
            self.bar.set_postfix_str("eval score: -")
        else:
            beside = "" if self.baseline is None else f", baseline {self.baseline:.3f}"
            self.bar.set_postfix_str(f"eval score {last:.3f} (best {best:.3f}{beside}, lower is better)")

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None
