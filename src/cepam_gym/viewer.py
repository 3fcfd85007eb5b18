"""The window of ``render_mode="human"``: RGB frames of any size shown with matplotlib.

One class for every env that renders for a person (the rig's 2-D drawing, the rig's MuJoCo view,
the MuJoCo joint); it sits below all of them so that none imports another's module to get it.
"""

from __future__ import annotations

import numpy as np


class FrameWindow:
    """Shows RGB frames of shape ``shape`` (``(height, width, 3)``) in a matplotlib window."""

    def __init__(self, shape):
        try:
            import matplotlib.pyplot as plt
        except ImportError as e:  # pragma: no cover
            raise ImportError("render_mode='human' needs matplotlib: pip install matplotlib") from e
        self._plt = plt
        plt.ion()
        h, w = shape[:2]
        self._fig, ax = plt.subplots(figsize=(w / 100, h / 100), dpi=100)
        ax.axis("off")
        self._fig.subplots_adjust(0, 0, 1, 1)
        self._im = ax.imshow(np.zeros((h, w, 3), dtype=np.uint8))

    def show(self, frame: np.ndarray) -> None:
        self._im.set_data(frame)
        self._plt.pause(0.001)

    def close(self) -> None:
        self._plt.close(self._fig)
