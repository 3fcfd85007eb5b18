"""The identification window's fits, remembered by what they were fitted to.

A window plays the same excitation whatever controller follows it, and its guard reads only the
sensors, so every controller scored on the same episode logs the same window and, without a time
budget, fits the same plant: the fit is a function of its log and its settings. Scoring several
agents and ``identify_mpc`` on one episode set (``compare``: five training seeds and the bar) then
fits each window once. A fit with a time budget depends on the machine's speed and is never
remembered.
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict

import numpy as np

CAPACITY = 4096  # fits kept (a few kB each): more than any suite's episode set


def fit_key(*parts) -> str:
    """A digest of a fit's inputs: arrays by dtype, shape and bytes, anything else by ``repr``."""
    h = hashlib.sha256()
    for p in parts:
        if isinstance(p, np.ndarray):
            a = np.ascontiguousarray(p)
            h.update(f"{a.dtype.str}{a.shape}".encode())
            h.update(a.tobytes())
        else:
            h.update(repr(p).encode())
        h.update(b"|")
    return h.hexdigest()


class FitMemo:
    """Fits by :func:`fit_key`, the least recently used dropped past ``capacity``; ``hits`` and
    ``misses`` count the lookups."""

    def __init__(self, capacity: int = CAPACITY):
        self.capacity = int(capacity)
        self._fits: OrderedDict[str, object] = OrderedDict()
        self.hits = self.misses = 0

    def get(self, key: str):
        fit = self._fits.get(key)
        if fit is None:
            self.misses += 1
            return None
        self.hits += 1
        self._fits.move_to_end(key)
        return fit

    def put(self, key: str, fit) -> None:
        self._fits[key] = fit
        self._fits.move_to_end(key)
        while len(self._fits) > self.capacity:
            self._fits.popitem(last=False)

    def clear(self) -> None:
        self._fits.clear()
        self.hits = self.misses = 0

    def __len__(self) -> int:
        return len(self._fits)


FITS = FitMemo()  # the process's window fits
