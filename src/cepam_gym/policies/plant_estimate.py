"""The plant an agent is told where no identification window runs: an adaptation module's estimate.

An agent told the plant (``agent.plant_features``) reads the plant's columns
(:func:`cepam_gym.identify.window_identifier.plant_columns`): in training the true plant's,
deployed behind an identification window the window's fit. On episodes without a window (the
randomized suites themselves) it can be told instead what an adaptation module estimates from
the sensors' recent history, the second phase of Kumar et al. (2021, RMA): a network from the
last frames (length, its rate, both pressures, the supply, the targets, the commands sent) to the
plant's columns, fitted in simulation where the true plant is known
(``agents/learners/adaptation.py``). Deployed it is plain numpy (this module): the weights, the
input normalization and the range of the plants it was fitted on are one ``.npz`` file in the run
directory (:data:`PlantEstimator.FILE`), and no estimate leaves that range.

:class:`EstimatedPlant` has the identifier's interface (``step``, ``rows``, ``reset``) with no
window: the policy drives from the first step, told the nominal plant's columns' estimate from a
history filled with its first frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cepam_gym.errors import InputError
from cepam_gym.tasks.layout import OBS_FIELDS

# what the estimate reads of each frame: what the rig measures, the targets and the commands sent
INPUTS = OBS_FIELDS


@dataclass(frozen=True)
class PlantEstimator:
    """The frozen network: ``history`` control steps seen, every ``stride``-th of them an input
    frame of :data:`INPUTS`; hidden layers ELU, the output the plant's columns clipped to
    ``[low, high]`` (the fitted plants' range)."""

    history: int
    stride: int
    weights: tuple  # (out, in) arrays, one per layer
    biases: tuple
    mean: np.ndarray  # the inputs' normalization
    std: np.ndarray
    low: np.ndarray
    high: np.ndarray
    inputs: tuple = INPUTS

    FILE = "plant_estimator.npz"

    @property
    def frames(self) -> int:
        """Input frames: the newest step and every ``stride``-th before it within ``history``."""
        return len(range(self.history - 1, -1, -self.stride))

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """Columns (N, k) float32 from flattened input frames (N, frames * len(inputs))."""
        h = (np.asarray(x, dtype=np.float32) - self.mean) / self.std
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            h = h @ w.T + b
            if i < len(self.weights) - 1:
                h = np.where(h > 0, h, np.expm1(np.minimum(h, 0)))
        return np.clip(h, self.low, self.high).astype(np.float32)

    def save(self, path: Path) -> None:
        arrays = {f"w{i}": w for i, w in enumerate(self.weights)}
        arrays.update({f"b{i}": b for i, b in enumerate(self.biases)})
        np.savez(
            path,
            history=self.history,
            stride=self.stride,
            mean=self.mean,
            std=self.std,
            low=self.low,
            high=self.high,
            inputs=np.array(self.inputs),
            **arrays,
        )

    @classmethod
    def load(cls, path: Path) -> PlantEstimator:
        try:
            return cls._read(path)
        except (OSError, KeyError, ValueError) as e:
            raise InputError(f"{path}: not a plant estimator file ({e})") from None

    @classmethod
    def _read(cls, path: Path) -> PlantEstimator:
        with np.load(path) as z:
            n = sum(1 for k in z.files if k.startswith("w"))
            f32 = np.float32
            return cls(
                int(z["history"]),
                int(z["stride"]),
                tuple(z[f"w{i}"].astype(f32) for i in range(n)),
                tuple(z[f"b{i}"].astype(f32) for i in range(n)),
                z["mean"].astype(f32),
                z["std"].astype(f32),
                z["low"].astype(f32),
                z["high"].astype(f32),
                tuple(str(s) for s in z["inputs"]),
            )


class InputFrames:
    """Each env's last ``history`` frames of the observation's ``inputs``, every ``stride``-th an
    input of the estimate; an env's first observation of an episode fills its history (the plant
    at rest before it)."""

    def __init__(self, layout, inputs=INPUTS, history: int = 1, stride: int = 1):
        missing = [c for c in inputs if c not in layout.names]
        if missing:
            raise InputError(f"the plant estimator reads {missing}, which this env does not observe")
        if history < 1 or stride < 1:
            raise InputError(f"the plant estimator's history and stride must be >= 1: {history}, {stride}")
        self.cols = [layout.names.index(c) for c in inputs]
        self.history, self.stride = int(history), int(stride)
        self.buf: np.ndarray | None = None  # (N, history, inputs)
        self.fresh: np.ndarray | None = None

    def reset(self, indices=None) -> None:
        if indices is None or self.buf is None:
            self.buf = None
        else:
            self.fresh[np.asarray(indices)] = True

    def push(self, obs: np.ndarray) -> np.ndarray:
        """Add a batch of observations; the inputs (N, frames * inputs), oldest frame first."""
        f = np.asarray(obs, dtype=np.float32)[:, self.cols]
        if self.buf is None or len(self.buf) != len(f):
            self.buf = np.repeat(f[:, None], self.history, axis=1)
            self.fresh = np.zeros(len(f), dtype=bool)
        if self.fresh.any():
            self.buf[self.fresh] = f[self.fresh][:, None]
            self.fresh[:] = False
        self.buf = np.roll(self.buf, -1, axis=1)
        self.buf[:, -1] = f
        return self.inputs()

    def inputs(self) -> np.ndarray:
        return np.ascontiguousarray(self.buf[:, :: -self.stride][:, ::-1]).reshape(len(self.buf), -1)


class EstimatedPlant:
    """The identifier of an env without a window: ``step(obs)`` pushes the frame and estimates,
    ``rows`` (N, N_PARAMS) the plant each env is told (the estimate's columns on the nominal
    row, :func:`~cepam_gym.identify.window_identifier.rows_of_columns`)."""

    window = 0

    def __init__(self, model, estimator: PlantEstimator):
        self.nominal = model.nominal
        self.estimator = estimator
        e = estimator
        self.frames = InputFrames(model.obs_layout, e.inputs, e.history, e.stride)
        self.rows: np.ndarray | None = None

    def reset(self, indices=None) -> None:
        self.frames.reset(indices)

    def step(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(zero actions (N, 2), in a window (N,) all False, tracking starts (N,) all False)``,
        as :meth:`~cepam_gym.identify.window_identifier.WindowIdentifier.step` with no window."""
        from cepam_gym.identify.window_identifier import rows_of_columns

        n = len(obs)
        self.rows = rows_of_columns(self.estimator(self.frames.push(obs)), self.nominal)
        no = np.zeros(n, dtype=bool)
        return np.zeros((n, 2), dtype=np.float32), no, no
