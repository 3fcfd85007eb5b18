"""The Task object (dm_control's split): everything an env is asked to do, handed to the env core.

An env (:class:`cepam_gym.envs.core.CEPAMBatch` and the Gymnasium classes over it) is the plant,
the arrays of N envs and the Gymnasium API; it knows nothing of lengths, angles, loads or torques.
A :class:`Task` owns the rest:

* the mechanism the muscle drives (``mech``: the rig's free end or a hinge) and its constants;
* its observation layout (named columns, preview count included) and its settings as the compiled
  step reads them (:class:`~cepam_gym.envs.task_params.TaskParams`);
* its plant checks (which randomized plants can run it) and its reference planning;
* where an episode starts, what ``reset(options=...)`` pins, and the ``info`` it reports;
* its contract (:mod:`cepam_gym.tasks.contract`): reward-term names and weights, info keys,
  termination names, reset options, what the score reads (the kernel computes the terms,
  :mod:`cepam_gym.envs.step_kernel`).

Two tasks exist: :class:`~cepam_gym.envs.rig_task.RigTask` (the paper's vertical rig) and
:class:`~cepam_gym.envs.hinge_task.HingeTask` (a joint driven through a rack and pinion).
:func:`cepam_gym.envs.task_registry.make_task` builds one from an env's kwargs.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import InputError
from ..tasks.layout import ObsLayout

MAX_PREVIEW_STEPS = 100


def check_preview_steps(preview_steps) -> int:
    """The preview count as an int (``ValueError`` naming the kwarg)."""
    if (
        isinstance(preview_steps, bool)
        or not isinstance(preview_steps, (int, np.integer, float))
        or int(preview_steps) != preview_steps
        or not 0 <= preview_steps <= MAX_PREVIEW_STEPS
    ):
        raise InputError(
            f"preview_steps must be an integer in [0, {MAX_PREVIEW_STEPS}] (control steps announced), "
            f"got {preview_steps!r}"
        )
    return int(preview_steps)


class Task:
    """What an env is asked to do. Subclasses fill the attributes and implement the methods; the
    env core calls them with its env state ``s`` (:class:`~cepam_gym.envs.state.EnvState`, as
    dm_control's Task is handed ``physics``), the only thing they read and write of the env
    (``s.target_l``, ``s.target_k``, ``s.load``: the task's position target, stiffness target and
    load of every control step, in the task's SI units; ``s.state``, ``s.aux``... for the info)."""

    mechanism: Any  # its tasks.mechanism.Mechanism: the load mapping, measured view and geometry
    name: str
    preview_steps: int
    track_stiffness: bool
    contract: Any  # its tasks.contract.TaskContract: names of terms, info, options, what the score reads
    pin_keys: tuple[str, ...]  # reset(options=...) keys (the contract's)
    renderers: tuple[str, ...]  # the first is the default
    spec: Any  # the task's frozen parameters (a TaskSpec or a JointTask)

    @property
    def reward(self):
        """The task's reward declaration (:class:`~cepam_gym.tasks.reward.Reward`)."""
        return self.spec.reward

    @property
    def mech(self) -> int:
        """The mechanics the plant kernel integrates (:data:`cepam_gym.plant.RIG` or ``HINGE``):
        the mechanism's code."""
        return self.mechanism.code

    @property
    def terminations(self) -> tuple:
        """What ends an episode (:class:`~cepam_gym.tasks.termination.Termination`, in order)."""
        return tuple(self.spec.terminations)

    @property
    def termination_names(self) -> tuple[str, ...]:
        """The step's termination reasons, index = code (``metadata["termination_reasons"]``)."""
        return self.spec.termination_names

    @property
    def schedules(self) -> tuple:
        """The plant parameters the task drives step by step (:mod:`cepam_gym.tasks.schedule`)."""
        return tuple(getattr(self.spec, "schedules", ()))

    @property
    def reward_terms(self) -> tuple[str, ...]:
        """The reward's term names, in order (``info["reward_<term>"]``)."""
        return self.reward.names

    @property
    def term_keys(self) -> tuple[str, ...]:
        """``info`` keys of the reward terms."""
        return self.reward.term_keys

    def bind(self, nominal, sub_dt: float, control_dt: float = 0.02) -> None:
        """Check the task against the env's nominal plant, sub-step and control period
        (``ValueError`` naming what does not fit) and compute what depends on them (layout, task
        parameters)."""
        raise NotImplementedError

    layout: ObsLayout
    params: Any  # its TaskParams (envs.task_params)

    def hinge_row(self) -> np.ndarray:
        """The mechanism's constants (:mod:`cepam_gym.physics.hinge`; zeros for the rig)."""
        raise NotImplementedError

    def randomizer(self, randomize, sub_dt: float):
        """The :class:`~cepam_gym.planning.randomization.Randomizer` of this task's plant checks."""
        raise NotImplementedError

    def plan(self, rngs: list, rows: np.ndarray, n_steps: int, control_dt: float) -> tuple:
        """``(target_l, target_k, load, initial)`` of envs drawing from ``rngs`` on parameter
        ``rows``; ``RuntimeError`` when no reachable target exists for some row."""
        raise NotImplementedError

    def start(self, s, idx: np.ndarray, initial: np.ndarray) -> None:
        """Envs ``idx`` of state ``s`` at rest at their ``initial`` (position, stiffness) rows."""
        raise NotImplementedError

    def apply_options(self, s, options: dict) -> None:
        """``reset(options=...)`` on every env of state ``s`` (keys :attr:`pin_keys`)."""
        raise NotImplementedError

    def info_single(self, s, scored: bool) -> dict[str, Any]:
        """The info of env 0 as Python floats (the single env's hot path)."""
        raise NotImplementedError

    # the info keys of a step taken by the single env's one-call step, in the order of the values
    # it writes to its info row (envs.single_slabs; ``redraws`` and ``termination_reason`` follow);
    # None: the single env builds the info with :meth:`info_single`
    step_keys: tuple[str, ...] | None = None

    def info_arrays(self, s, scored: bool) -> dict[str, np.ndarray]:
        """Per-env info arrays (SI)."""
        raise NotImplementedError

    def pin(self, s, values: dict, idx: np.ndarray) -> None:
        """Hold pinned targets for the episode of envs ``idx`` of state ``s`` (the env's
        ``pin_targets``)."""
        raise NotImplementedError(f"the {self.name} task pins targets through reset(options=...)")
