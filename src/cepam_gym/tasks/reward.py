"""A task's reward, declared once: named terms, each a compiled expression with a default weight.

A :class:`Reward` is what MyoSuite's ``DEFAULT_RWD_KEYS_AND_WEIGHTS`` and ``get_reward_dict`` are
to its tasks, made compilable: each :class:`Term` is a name, a Python expression over the step's
quantities (:data:`STEP_QUANTITIES`, and the reward's own named ``quantities``) and its weight
``w``, a default weight, and one line of doc. The step of an env is built from it: the reward
function ``reward_terms`` (:func:`reward_source`) writes each term's signed value into the env's
``terms`` row in the declared order and returns their sum, and the term names become the info keys
``reward_<name>``, the ``reward_weights`` kwarg's keys and the spec sheet's rows.

The package's own declarations (:data:`ABS_REWARD`, :data:`SCORE_REWARD`: the earlier ids' and
the v3 ids' rewards) are compiled into the package's step (``tasks/_reward_builtin.py`` is
generated from them: ``python -m cepam_gym.tasks.step_source``, and a test checks it is current);
a declaration from user code gets a step module of its own (:mod:`cepam_gym.tasks.step_source`),
compiled once per machine and cached like the package's.

Expressions are numba code: they read the quantities below, ``task`` (the
:class:`~cepam_gym.tasks.task_params.TaskParams`: ``task.track_unit``, ``task.air_unit`` ...),
``w`` (the term's weight) and the ``math`` module, and give a float; a term should be <= 0 (a
cost), which the envs' tests check of the package's terms.
"""

from __future__ import annotations

import dataclasses
import keyword
import math
from dataclasses import dataclass

from ..errors import InputError

# what a term's expression may read of the step (SI; on the joint the position is the angle)
STEP_QUANTITIES = {
    "x": "the tracked position after the step [m, or rad on the joint]",
    "x_target": "its target at the step [m or rad]",
    "v": "the position's rate [m/s or rad/s]",
    "K": "the stiffness the task sets [N/m, or N m/rad on the joint]",
    "K_target": "its target [N/m or N m/rad]",
    "a0": "the applied command of the contractor chamber, in [-1, 1]",
    "a1": "the applied command of the extensor chamber, in [-1, 1]",
    "air": "the supply air drawn in the step [kg]",
    "burst": "whether a bladder burst in the step (the episode then terminates)",
    "counted": "whether the benchmark's score counts the step (not within the settling allowance)",
}
MAX_TERMS = 8  # the terms row of the env state holds at most this many


@dataclass(frozen=True)
class Term:
    """One reward term: ``expr`` (a numba expression, see the module doc) gives its signed value,
    ``weight`` its default weight (read as ``w``)."""

    name: str
    expr: str
    weight: float
    doc: str = ""


@dataclass(frozen=True)
class Reward:
    """A reward: ``terms`` in their order (the reward is their sum, added in that order),
    ``quantities`` named intermediate values ``(name, expression)`` computed once before the terms
    (each may read the earlier ones), ``allowance`` whether the step computes ``counted`` (the
    score's settling allowance: a loop over the last half second of targets, so only rewards
    that read it pay for it), ``failure_terms`` the terms that charge a failure (kept in an
    identification window, where the others are zeroed: :mod:`cepam_gym.tasks.window`)."""

    name: str
    terms: tuple[Term, ...]
    quantities: tuple[tuple[str, str], ...] = ()
    allowance: bool = False
    doc: str = ""
    failure_terms: tuple[str, ...] = ("burst",)

    def __post_init__(self):
        names = [t.name for t in self.terms]
        if not 1 <= len(names) <= MAX_TERMS:
            raise InputError(f"reward {self.name!r}: 1 to {MAX_TERMS} terms, got {len(names)}")
        local = [q for q, _ in self.quantities]
        for n in names + local:
            if not n.isidentifier() or keyword.iskeyword(n):
                raise InputError(f"reward {self.name!r}: {n!r} is not a valid name")
        taken = set(STEP_QUANTITIES) | {"task", "w", "math", "terms"}
        clash = sorted((set(local) & taken) | {n for n in set(names + local) if (names + local).count(n) > 1})
        if clash:
            raise InputError(f"reward {self.name!r}: names used twice or reserved: {clash}")
        for t in self.terms:
            if not (math.isfinite(t.weight) and t.weight >= 0):
                raise InputError(f"reward {self.name!r}: term {t.name} weight must be finite and >= 0")
        for label, text in [(t.name, t.expr) for t in self.terms] + list(self.quantities):
            try:
                compile(text, f"<reward {self.name}: {label}>", "eval")
            except SyntaxError as e:
                raise InputError(f"reward {self.name!r}: {label}: not a Python expression: {e.msg}") from None
        unknown = sorted(set(self.failure_terms) - set(names))
        if unknown:
            raise InputError(f"reward {self.name!r}: failure_terms {unknown} are not terms of it")
        if "counted" in self.code() and not self.allowance:
            raise InputError(f"reward {self.name!r} reads `counted`: declare it with allowance=True")

    @property
    def names(self) -> tuple[str, ...]:
        """The term names, in order."""
        return tuple(t.name for t in self.terms)

    @property
    def term_keys(self) -> tuple[str, ...]:
        """``info`` keys of the terms (``reward_<term>``)."""
        return tuple(f"reward_{n}" for n in self.names)

    @property
    def failure_columns(self) -> tuple[int, ...]:
        """The columns of :attr:`failure_terms` in the env state's ``terms`` rows."""
        return tuple(self.names.index(n) for n in self.failure_terms)

    def code(self) -> str:
        """What the compiled reward computes (names left out): two rewards with the same code share
        one compiled function."""
        return repr((self.allowance, self.quantities, tuple(t.expr for t in self.terms)))

    def renamed(self, renames: dict[str, str], weights: dict[str, float] | None = None) -> Reward:
        """The same reward (the same code) with terms renamed and default weights changed (the
        joint's ``angle`` is the rig's ``length``)."""
        weights = weights or {}
        terms = tuple(
            dataclasses.replace(t, name=renames.get(t.name, t.name), weight=weights.get(t.name, t.weight))
            for t in self.terms
        )
        return dataclasses.replace(self, terms=terms)

    def weights_type(self) -> type:
        """A frozen dataclass whose fields are the terms with their default weights (the
        ``weights`` of a task spec that uses this reward; ``reward_weights`` overrides them)."""
        return dataclasses.make_dataclass(
            f"{self.name.title().replace('_', '')}Weights",
            [(t.name, float, dataclasses.field(default=float(t.weight))) for t in self.terms],
            frozen=True,
        )

    def weight_values(self, weights) -> tuple[float, ...]:
        """The weights of ``weights`` (an object with one attribute per term, e.g. a
        :class:`~cepam_gym.tasks.spec.RewardWeights`) in term order, checked."""
        out = []
        for n in self.names:
            v = getattr(weights, n, None)
            if v is None:
                raise InputError(f"reward {self.name!r}: no weight for {n!r} (terms: {list(self.names)})")
            out.append(float(v))
        return tuple(out)


# the position and stiffness errors in the task's units, clipped (TaskScales)
_ERRORS = (
    ("e_x", "min(abs(x - x_target) / task.track_unit, task.track_clip)"),
    (
        "e_k",
        "min(abs(K - K_target) / K_target / task.stiff_unit, task.stiff_clip) if task.track_k != 0 else 0.0",
    ),
)


_EFFORT = Term("effort", "-w * 0.5 * (a0 * a0 + a1 * a1)", 0.05, "per unit mean squared action")
_AIR = Term("air", "-w * air / task.air_unit", 0.05, "per air unit drawn from the supply in one step")
_BURST = Term("burst", "-w if burst else 0.0", 100.0, "once, when a bladder bursts")

ABS_REWARD = Reward(
    name="abs",
    terms=(
        Term("length", "-w * e_x", 1.0, "per tracking unit of |x - x*|, clipped"),
        Term("stiffness", "-w * e_k if task.track_k != 0 else 0.0", 2.5, "per unit of |K / K* - 1|, clipped"),
        _EFFORT,
        _AIR,
        _BURST,
    ),
    quantities=_ERRORS,
    doc="absolute errors, every step paid (v0-v2)",
)

SCORE_REWARD = Reward(
    name="score",
    terms=(
        Term("length", "-w * e_x * e_x if counted else 0.0", 1.0, "squared error in the score's unit"),
        Term(
            "stiffness",
            "-w * e_k * e_k if counted and task.track_k != 0 else 0.0",
            1.0,
            "squared relative error in the score's unit",
        ),
        dataclasses.replace(_EFFORT, weight=1e-4),
        dataclasses.replace(_AIR, weight=1e-4),
        dataclasses.replace(_BURST, weight=2000.0),
    ),
    quantities=_ERRORS,
    allowance=True,
    doc="the benchmark score's per-step form, zero in the settling allowance (v3)",
)

# the package's rewards, in the order of the package's compiled step (TaskParams.reward_index)
BUILTIN_REWARDS = {r.name: r for r in (ABS_REWARD, SCORE_REWARD)}
# the joint's: the rig's code on the joint's angle (rad) and joint stiffness, its own default weights
# (20 % of stiffness prices as 10 deg: tasks.joint.JointRewardWeights)
JOINT_ABS_REWARD = ABS_REWARD.renamed({"length": "angle"}, {"stiffness": 5.0})
JOINT_SCORE_REWARD = SCORE_REWARD.renamed({"length": "angle"})
