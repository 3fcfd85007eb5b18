"""The env core's random streams: one per env and purpose, so an env's draws never depend on the
batch it is in (:meth:`RandomStreams.seed`), and the buffered normals of its sensor noise and
supply drift."""

from __future__ import annotations

import numpy as np

from ..planning.rng import Streams
from . import step_kernel as tk

# standard normals drawn per env and step (5 sensor-noise channels, 1 supply drift), buffered
_N_NORMALS = 6
_NORMAL_CHUNK = 32


class RandomStreams:
    """The random streams of :class:`~cepam_gym.envs.core.CEPAMBatch` (a base class of it: these
    methods read its ``num_envs``, ``stream``, ``planned``, ``has_noise``, ``supply_drift``,
    ``noise_sd`` and env state ``s``)."""

    def seed(self, seed: int | None) -> None:
        """Per-env random streams spawned from ``numpy.random.SeedSequence(seed)``.

        Env i of the batch owns stream ``self.stream + i``: the seed sequence
        ``SeedSequence(seed, spawn_key=(stream + i,))`` (``SeedSequence(seed).spawn(n)[i]`` for
        ``stream == 0``), whose children feed (0) parameter draws and the task's own schedules,
        (1) sensor noise and supply drift and, for a task that declares schedules of plant
        parameters, (2) those (:mod:`cepam_gym.tasks.schedule`; the first two children do not depend
        on it). Streams of different seeds, and of different envs of one seed,
        are independent (no ``seed + i`` overlaps); an env's draws never depend on the batch it is
        in, so env i of a batch seeded ``s`` follows exactly a single env seeded ``s`` whose
        ``stream`` kwarg is i. ``None``: fresh OS entropy."""
        root = np.random.SeedSequence(seed)
        rngs, self.noise_rngs, self.schedule_rngs = [], [], []
        for i in range(self.num_envs):
            env_ss = np.random.SeedSequence(root.entropy, spawn_key=(self.stream + i,))
            main, noise, *declared = env_ss.spawn(3 if self.planned else 2)
            rngs.append(np.random.Generator(np.random.PCG64(main)))
            self.noise_rngs.append(np.random.Generator(np.random.PCG64(noise)))
            self.schedule_rngs += [np.random.Generator(np.random.PCG64(d)) for d in declared]
        # the reset's compiled draws keep the main streams' states as rows between resets
        self.streams = Streams(rngs)
        # buffered standard normals per env (columns: 5 sensor-noise channels, supply drift),
        # refilled _NORMAL_CHUNK steps at a time from each env's own noise stream
        draws = self.has_noise or bool(self.supply_drift)
        self._normals = np.zeros((self.num_envs if draws else 0, _NORMAL_CHUNK, _N_NORMALS))
        self._normal_pos = np.full(self.num_envs, _NORMAL_CHUNK, dtype=np.int64)

    def _next_normals(self, idx: np.ndarray | None = None) -> np.ndarray:
        """One row of standard normals per env of ``idx`` (all if None), each from its own stream."""
        pos = self._normal_pos if idx is None else self._normal_pos[idx]
        if (pos >= _NORMAL_CHUNK).any():
            envs = np.arange(self.num_envs) if idx is None else np.asarray(idx)
            for i in envs[pos >= _NORMAL_CHUNK]:
                self._normals[i] = self.noise_rngs[i].standard_normal((_NORMAL_CHUNK, _N_NORMALS))
                self._normal_pos[i] = 0
            pos = self._normal_pos if idx is None else self._normal_pos[idx]
        rows = np.arange(self.num_envs) if idx is None else idx
        out = self._normals[rows, pos]
        self._normal_pos[rows] += 1
        return out

    def _draw_noise(self, idx: np.ndarray | None = None) -> np.ndarray | None:
        """Fresh sensor noise of the envs ``idx`` (all if None), written in place (the kernel's
        argument tuple holds this buffer). With supply drift on, the drift's normal comes from
        the same row, so every step consumes one row of each env's stream. Returns the drift
        normals (None when neither noise nor drift is on)."""
        if self.has_noise or self.supply_drift:
            z = self._next_normals(idx)
            if self.has_noise:
                if idx is None:
                    self.s.noise[:] = z[:, : tk.N_NOISE] * self.noise_sd
                else:
                    self.s.noise[idx] = z[:, : tk.N_NOISE] * self.noise_sd
            return z[:, tk.N_NOISE]
        return None
