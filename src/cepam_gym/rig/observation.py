"""A rig's measurements as the env's observation, through the env's own encoding.

:class:`RigObserver` writes a :class:`~cepam_gym.rig.protocol.Reading` into a one-env
:class:`~cepam_gym.envs.state.EnvState` (the length and its rate into the plant state row, the
pressures into the ``aux`` row, the supply into the parameter row, the episode's targets into its
schedules, the last applied command) and runs the envs' observation kernel on it
(:func:`cepam_gym.envs.step_kernel.observe`: the layout's scaling, clip and the reference preview).
So a policy sees on the rig exactly the columns it saw in training, computed by the same code.

A rig does not measure the length's rate: it is the finite difference of the readings, low-passed
with time constant ``velocity_filter_s`` (noise on a difference over one period would swamp it).
"""

from __future__ import annotations

import math

import numpy as np

from .. import plant as pl
from .._jit import bound
from ..envs.records import allocate
from ..envs.state import EnvState, dims
from ..envs.step_kernel import observe
from ..errors import InputError
from ..physics import layout as ix
from .protocol import Reading


class RigObserver:
    """Observations of a rig for the env described by ``model`` (an
    :class:`~cepam_gym.envs.model.EnvModel` of a rig id), over the episode's references
    ``target_l`` [m] and ``target_k`` [N/m] (one value per control step)."""

    def __init__(self, model, target_l, target_k, velocity_filter_s: float = 0.02):
        if model.mech != pl.RIG:
            raise InputError(
                "only the rig envs (a hanging load on the muscle) run on a rig; the joint does not"
            )
        tl = np.asarray(target_l, dtype=float).ravel()
        tk = np.asarray(target_k, dtype=float).ravel()
        if tl.size == 0 or tl.shape != tk.shape or not (np.all(np.isfinite(tl)) and np.all(np.isfinite(tk))):
            raise InputError("the references must be finite and of one length (one value per control step)")
        self.model = model
        self.n_steps = tl.size
        self.s = allocate(EnvState, dims(1, tl.size, model.obs_dim, noise=False))
        self.s.params[0] = model.nominal.to_array()
        self.s.target_l[0], self.s.target_k[0] = tl, tk
        self.dt = float(model.control_dt)
        self.velocity_filter_s = float(velocity_filter_s)
        self._last: Reading | None = None
        self._velocity = 0.0
        # the compiled entry point for these argument types: no type dispatch each step
        self._observe = bound(observe, (self.s, pl.RIG, model.task_params))

    def reset(self) -> None:
        """Forget the readings (the velocity estimate starts again)."""
        self._last, self._velocity = None, 0.0

    def velocity(self, reading: Reading) -> float:
        """The length's rate [m/s] estimated from this reading and the previous one."""
        last, self._last = self._last, reading
        if last is None or reading.time <= last.time:
            return self._velocity
        dt = reading.time - last.time
        raw = (reading.length - last.length) / dt
        alpha = 1.0 - math.exp(-dt / self.velocity_filter_s) if self.velocity_filter_s > 0 else 1.0
        self._velocity += alpha * (raw - self._velocity)
        return self._velocity

    def observe(self, reading: Reading, step: int, prev_action, velocity: float | None = None) -> np.ndarray:
        """The observation (obs_dim,) float32 at control step ``step`` of the episode (the targets
        of that step and the preview after it), ``prev_action`` the command last applied;
        ``velocity`` [m/s] overrides the estimate (:meth:`velocity`)."""
        s = self.s
        v = self.velocity(reading) if velocity is None else float(velocity)
        s.state[0, pl.S_L] = reading.length
        s.state[0, pl.S_V] = v
        s.aux[0, pl.A_PC] = reading.pressure_c
        s.aux[0, pl.A_PE] = reading.pressure_e
        s.params[0, ix.P_SUP] = reading.supply + s.params[0, ix.P_ATM]
        s.prev_action[0] = prev_action
        s.t_idx[0] = int(step)
        self._observe(s, pl.RIG, self.model.task_params)
        return s.obs[0].copy()

    def targets(self, step: int) -> tuple[float, float]:
        """``(target length [m], target stiffness [N/m])`` of control step ``step``."""
        k = min(int(step), self.n_steps - 1)
        return float(self.s.target_l[0, k]), float(self.s.target_k[0, k])
