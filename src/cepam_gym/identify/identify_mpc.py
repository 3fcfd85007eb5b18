"""Identify, then control: the MPC on a plant fitted to the episode's identification window.

On an env whose episodes start with an identification window (:mod:`cepam_gym.envs.id_window`), per
env and from the sensors only:

1. **the window** and **the fit** (:class:`~cepam_gym.identify.window_identifier.WindowIdentifier`):
   the project's excitation, guarded against bursts, then its output-error identification with
   the static parameters that carry the randomization's gap freed (the braid angles, the bladder's
   wall and modulus), the moving mass (the load is not announced) and the valve, friction, volume
   and damping parameters, within a per-episode budget of evaluations and seconds;
2. **the tracking**: the practical MPC (:class:`~cepam_gym.control.mpc.ModelPredictiveController`,
   the planner of ``mpc`` and ``mpc_known_params``) planning through each env's fitted plant, its
   supply pressure the measured one, its load estimated from the sensors as the MPC's.

It reads only what a rig's engineer knows of the env (:class:`~cepam_gym.envs.model.EnvModel`'s
fixed facts: the nominal plant, the timing, the window's length, the observation layout), never
its privileged rows, states or schedules. It lives with the identification it runs (the
controller registry names it lazily, ``identify_mpc``).
"""

from __future__ import annotations

import numpy as np

from ..control.baseline import rig_model_of
from ..control.mpc import ModelPredictiveController
from ..physics import layout as ix
from .window_fit import FREE
from .window_identifier import WindowIdentifier


class IdentifyMPC(ModelPredictiveController):
    """``reset(indices=None)`` / ``act(obs, info=None)`` on batched (or single) observations.
    ``max_nfev``: the evaluations of the log each env's fit may take; ``budget_s``: optionally,
    its seconds (None: no time budget, so the score does not depend on the machine);
    ``starts``: its starting points (the nominal plant, then random ones); ``free``: the
    parameters fitted (:data:`cepam_gym.identify.window_fit.FREE`); ``staged``: each env's plant is
    the better of the direct fit and a staged one (dynamics first; default)."""

    def __init__(
        self,
        env,
        config=None,
        budget_s: float | None = None,
        max_nfev: int = 100,
        starts: int = 1,
        free: tuple[str, ...] = FREE,
        seed: int = 0,
        staged: bool = True,
        **overrides,
    ):
        super().__init__(env, config, **overrides)
        self.identifier = WindowIdentifier(
            rig_model_of(env), "identify_mpc", budget_s, max_nfev, starts, tuple(free), seed, staged
        )
        self.window = self.identifier.window
        self.excitation = self.identifier.excitation

    @property
    def fits(self) -> list:
        """Every fit of the controller's life (WindowFit), for reports."""
        return self.identifier.fits

    @property
    def fit_seconds(self) -> float:
        """The seconds the last step that fitted spent on its fits."""
        return self.identifier.fit_seconds

    def reset(self, indices=None) -> None:
        super().reset(indices)
        if getattr(self, "identifier", None) is not None:
            self.identifier.reset(indices)

    def model_rows(self, n: int) -> np.ndarray:
        return self.identifier.rows

    def act(self, obs, info=None) -> np.ndarray:
        single = np.ndim(obs) == 1
        obs = np.atleast_2d(np.asarray(obs, dtype=float))
        out, in_window, _ = self.identifier.step(obs)
        track = np.flatnonzero(~in_window)
        if track.size:
            supply = self.layout.value(obs, "supply_pressure")
            self.identifier.rows[:, ix.P_SUP] = supply + self.params[ix.P_ATM]  # the supply as measured now
            out[track] = self._plan_all(obs)[track]
        return out[0] if single else out

    def _plan_all(self, obs) -> np.ndarray:
        """The MPC's actions for every env (those still in their window are planned and ignored:
        the planner runs the batch as one)."""
        return np.atleast_2d(super().act(obs))
