"""An excitation schedule played on a rig through the deploy loop (``cepam-gym excite --rig``).

The schedule is :func:`cepam_gym.identify.excite.schedule` at the loop's rate, one command pair
per control step (:class:`ScheduleController`); the loop is :func:`cepam_gym.rig.deploy.run`, so
the commands pass the safety supervisor and every step is logged in ``identify``'s CSV format:
the log is what ``cepam-gym identify --data`` fits.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..identify.excite import schedule
from .deploy import DeployResult, run
from .observation import RigObserver
from .supervisor import SafetyLimits, Supervisor


class ScheduleController:
    """Plays ``commands`` (T, 2), one row per :meth:`act`; the last row holds after the end."""

    def __init__(self, commands):
        self.commands = np.asarray(commands, dtype=float).reshape(-1, 2)
        self.k = 0

    def reset(self, indices=None) -> None:
        self.k = 0

    def act(self, obs, info=None) -> np.ndarray:
        row = self.commands[min(self.k, len(self.commands) - 1)]
        self.k += 1
        return row


def excite(
    rig,
    model,
    seconds: float,
    load_kg: float,
    log_path,
    seed: int = 0,
    limits: SafetyLimits | None = None,
    model_based: bool = True,
) -> DeployResult:
    """Play ``seconds`` of the excitation schedule of ``model``'s action mode at its control rate
    (``model``: the env's :class:`~cepam_gym.envs.model.EnvModel`, a rig id) on ``rig`` under the
    supervisor, the rig's hanging load ``load_kg`` written in the log ``log_path``.
    ``model_based``: the supervisor's leak balance on ``model``'s nominal plant too (else only its
    model-free checks: a rig whose model is not known yet, the one this excitation identifies)."""
    if not load_kg >= 0:
        raise InputError(f"the load must be a mass >= 0 kg, got {load_kg!r}")
    cols = schedule(seconds, 1.0 / model.control_dt, model.action_mode, (load_kg * 1e3,), seed)
    commands = np.column_stack([cols["command_c"], cols["command_e"]])
    n = len(commands)
    # the observer only feeds the controller, which ignores it: any reference in the envs' range
    rest = np.full(n, model.nominal.min_length)
    observer = RigObserver(model, rest, np.full(n, 100.0))
    limits = limits or SafetyLimits.from_plant(model.nominal)
    supervisor = Supervisor(limits, model.control_dt, model=model if model_based else None)
    return run(rig, ScheduleController(commands), observer, supervisor, load_kg, n_steps=n, log_path=log_path)
