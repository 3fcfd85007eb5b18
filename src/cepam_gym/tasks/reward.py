"""A task's reward, declared once: named terms, each a compiled expression with a default weight.

A :class:`Reward` is what MyoSuite's ``DEFAULT_RWD_KEYS_AND_WEIGHTS`` and ``get_reward_dict`` are
to its tasks, made compilable: each :class:`Term` is a name, a Python expression over the step's
quantities (:data:`STEP_QUANTITIES`, and the reward's own named ``quantities``) and its weight
``w``, a default weight, and one line of doc. The step of an env is built from it: the reward
function ``reward_terms`` (:func:`reward_source`) writes each term's signed value into the env's
``terms`` row in the declared order and returns their sum, and the term names become the info keys
``reward_<name>``, the ``reward_weights`` kwarg's keys and the spec sheet's rows.

The package's own declarations (:data:`ABS_REWARD`, :data:`SCORE_REWARD`: the earlier ids' and
the v3 ids' rewards) are compiled into the package's step (``envs/_reward_builtin.py`` is
generated from them: ``python -m cepam_gym.envs.write_reward_builtin``, and a test checks it is current);
a declaration from user code gets a step module of its own (:mod:`cepam_gym.envs.step_source`),
compiled once per machine and cached like the package's.

Expressions are numba code: they read the quantities below, ``task`` (the
:class:`~cepam_gym.envs.task_params.TaskParams`: ``task.track_unit``, ``task.air_unit`` ...),
``w`` (the term's weight) and the ``math`` module, and give a float; a term should be <= 0 (a
cost), which the envs' tests check of the package's terms.
"""

from __future__ import annotations

import ast
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
# what else an expression may name: the task's parameters, the term's weight, math and a few builtins
_ALSO_NAMED = {"task", "w", "math", "abs", "min", "max", "float", "int", "bool"}


def names_read(text: str) -> tuple[set[str], set[str]]:
    """``(names, task attributes)`` an expression reads."""
    tree = ast.parse(text, mode="eval")
    names = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
    attrs = {
        n.attr
        for n in ast.walk(tree)
        if isinstance(n, ast.Attribute) and isinstance(n.value, ast.Name) and n.value.id == "task"
    }
    return names, attrs


@dataclass(frozen=True)
class Term:
    """One reward term: ``expr`` (a numba expression, see the module doc) gives its signed value,
    ``weight`` its default weight (read as ``w``), ``doc`` its formula as the spec pages show it
    (``{unit}``, ``{clip}``, ``{kunit}``, ``{kclip}``, ``{air}``: the task's scales)."""

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
    identification window, where the others are zeroed: :mod:`cepam_gym.envs.id_window`; None: the
    term ``burst`` if the reward has one)."""

    name: str
    terms: tuple[Term, ...]
    quantities: tuple[tuple[str, str], ...] = ()
    allowance: bool = False
    doc: str = ""
    failure_terms: tuple[str, ...] | None = None

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
        known = set(STEP_QUANTITIES) | _ALSO_NAMED
        for label, text in list(self.quantities) + [(t.name, t.expr) for t in self.terms]:
            try:
                read, _ = names_read(text)
            except SyntaxError as e:
                raise InputError(f"reward {self.name!r}: {label}: not a Python expression: {e.msg}") from None
            if read - known:
                raise InputError(
                    f"reward {self.name!r}: {label} reads {sorted(read - known)}, which the step does not "
                    f"have; it may read {sorted(STEP_QUANTITIES)}, the quantities declared before it, "
                    f"task.<parameter>, w and math"
                )
            if label in local:
                known.add(label)
        unknown = sorted(set(self.failure_terms or ()) - set(names))
        if unknown:
            raise InputError(f"reward {self.name!r}: failure_terms {unknown} are not terms of it")
        texts = [e for _, e in self.quantities] + [t.expr for t in self.terms]
        if any("counted" in names_read(e)[0] for e in texts) and not self.allowance:
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
        failure = ("burst",) if self.failure_terms is None else self.failure_terms
        return tuple(self.names.index(n) for n in failure if n in self.names)

    def task_attributes(self) -> set[str]:
        """The :class:`~cepam_gym.envs.task_params.TaskParams` fields the expressions read."""
        texts = [e for _, e in self.quantities] + [t.expr for t in self.terms]
        return set().union(*(names_read(e)[1] for e in texts))

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


_EFFORT = Term("effort", "-w * 0.5 * (a0 * a0 + a1 * a1)", 0.05, "-w mean(a^2)")
_AIR = Term("air", "-w * air / task.air_unit", 0.05, "-w (air drawn from the supply this step) / {air}")
_BURST = Term("burst", "-w if burst else 0.0", 100.0, "-w, once, when a chamber exceeds the burst pressure")
_K_NOTE = "K the stiffness at constant pressures; counted when the task tracks stiffness"

ABS_REWARD = Reward(
    name="abs",
    terms=(
        Term("length", "-w * e_x", 1.0, "-w min(|x - x*| / {unit}, {clip})"),
        Term(
            "stiffness",
            "-w * e_k if task.track_k != 0 else 0.0",
            2.5,
            "-w min(|K - K*| / K*, {kclip}), " + _K_NOTE,
        ),
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
        Term(
            "length",
            "-w * e_x * e_x if counted else 0.0",
            1.0,
            "-w min(|x - x*| / {unit}, {clip})^2 on the steps the score counts, else 0",
        ),
        Term(
            "stiffness",
            "-w * e_k * e_k if counted and task.track_k != 0 else 0.0",
            1.0,
            "-w min(|K / K* - 1| / {kunit}, {kclip})^2 on the steps the score counts, else 0; " + _K_NOTE,
        ),
        dataclasses.replace(_EFFORT, weight=1e-4),
        dataclasses.replace(_AIR, weight=1e-4),
        dataclasses.replace(
            _BURST,
            weight=2000.0,
            doc=_BURST.doc + " (the return of an episode whose every step scores the failure weight 2)",
        ),
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


def distinct(rewards) -> list[Reward]:
    """The first of ``rewards`` with each compiled code, in order: the branches of one compiled
    reward function (:func:`reward_index`)."""
    out: dict[str, Reward] = {}
    for r in rewards:
        out.setdefault(r.code(), r)
    return list(out.values())


def reward_index(reward: Reward) -> int:
    """The ``TaskParams.reward_index`` of ``reward``: its branch in the package's step, or 0 in a
    step of its own."""
    codes = [r.code() for r in distinct(BUILTIN_REWARDS.values())]
    return codes.index(reward.code()) if reward.code() in codes else 0


def is_builtin(reward: Reward) -> bool:
    """Whether the package's compiled step computes ``reward``."""
    return any(r.code() == reward.code() for r in BUILTIN_REWARDS.values())
