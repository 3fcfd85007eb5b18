"""A task's terminations, declared once: named conditions that end an episode.

A :class:`Termination` is a name, a compiled condition over the step's quantities (the reward's
:data:`~cepam_gym.tasks.reward.STEP_QUANTITIES`: the tracked position and its target, its rate,
the stiffness and its target, the applied commands, the air drawn, ``burst``, ``counted``) and
``task.<TaskParams field>``, and one line of doc. A task's ``terminations`` (a tuple, checked in
order) become the step's reason codes: 0 ``"none"``, then one code per declaration in its order,
then ``"non_finite_state"`` (the step's own check of the plant's state and reward, which no task
can leave out). The env's ``metadata["termination_reasons"]`` names them, ``info["termination_reason"]``
is the code of the step, and an episode terminates on any code but 0.

The package's tasks end an episode when a bladder bursts (:data:`BURST`), so their codes are
0 ``none``, 1 ``burst``, 2 ``non_finite_state``. A termination charges nothing by itself: a task
that should pay for one adds a reward term with the same condition
(:class:`~cepam_gym.tasks.reward.Term`, as the ``burst`` term does).
"""

from __future__ import annotations

import keyword
from dataclasses import dataclass

from ..errors import InputError
from .reward import STEP_QUANTITIES, names_read

NONE_NAME, NONFINITE_NAME = "none", "non_finite_state"
MAX_TERMINATIONS = 8
# what a condition may name besides the step's quantities
_ALSO_NAMED = {"task", "math", "abs", "min", "max", "float", "int", "bool"}


@dataclass(frozen=True)
class Termination:
    """One reason to end an episode: ``condition`` (a numba expression, true when the episode
    ends after the step) over :data:`~cepam_gym.tasks.reward.STEP_QUANTITIES` and ``task.<field>``;
    ``doc`` says what it means (the spec pages show it)."""

    name: str
    condition: str
    doc: str = ""

    def __post_init__(self):
        if not (isinstance(self.name, str) and self.name.isidentifier()) or keyword.iskeyword(self.name):
            raise InputError(f"termination name {self.name!r} is not a valid name")
        if self.name in (NONE_NAME, NONFINITE_NAME):
            raise InputError(f"termination name {self.name!r} is reserved (the step's own reasons)")
        try:
            read, _ = names_read(self.condition)
        except (SyntaxError, TypeError, ValueError) as e:
            raise InputError(
                f"termination {self.name!r}: condition is not a Python expression: {e}"
            ) from None
        unknown = read - set(STEP_QUANTITIES) - _ALSO_NAMED
        if unknown:
            raise InputError(
                f"termination {self.name!r} reads {sorted(unknown)}, which the step does not have; "
                f"it may read {sorted(STEP_QUANTITIES)}, task.<parameter> and math"
            )

    def task_attributes(self) -> set[str]:
        """The :class:`~cepam_gym.envs.task_params.TaskParams` fields the condition reads."""
        return names_read(self.condition)[1]


BURST = Termination("burst", "burst", "a bladder burst in the step (a chamber exceeded its burst pressure)")
DEFAULT_TERMINATIONS = (BURST,)  # every published id's


def check_terminations(terminations, owner: str) -> tuple[Termination, ...]:
    """``terminations`` as a tuple of :class:`Termination` with distinct names (``InputError``
    naming ``owner`` otherwise)."""
    if isinstance(terminations, Termination) or not isinstance(terminations, (tuple, list)):
        raise InputError(f"{owner}: terminations must be a tuple of Termination, got {terminations!r}")
    out = tuple(terminations)
    bad = [t for t in out if not isinstance(t, Termination)]
    if bad:
        raise InputError(f"{owner}: terminations must be Termination objects, got {bad[0]!r}")
    names = [t.name for t in out]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise InputError(f"{owner}: termination names used twice: {twice}")
    if len(out) > MAX_TERMINATIONS:
        raise InputError(f"{owner}: at most {MAX_TERMINATIONS} terminations, got {len(out)}")
    return out


def reason_names(terminations) -> tuple[str, ...]:
    """The reason names of a task's terminations, index = code."""
    return (NONE_NAME, *(t.name for t in terminations), NONFINITE_NAME)
