"""What a task asks: targets, loads, reward weights, reward units and observation scaling,
termination reasons. Frozen dataclasses."""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace

import numpy as np

from ..errors import InputError
from .reward import ABS_REWARD, BUILTIN_REWARDS, SCORE_REWARD, Reward
from .schedule import Schedule, check_schedules
from .termination import DEFAULT_TERMINATIONS, Termination, check_terminations, reason_names

LOAD_KINDS = ("constant", "step", "ramp", "sine", "random")
# the package's rewards by name (tasks.reward): "abs" the clipped absolute errors of the v0-v2 ids,
# "score" the score's squared per-step form of the v3 ids, zero within the settling allowance
# (tasks.contract, "Reward and score")
REWARD_FORMS = tuple(BUILTIN_REWARDS)
REFERENCE_KINDS = ("step", "min_jerk", "sine", "chirp", "stiffness_ramp")  # planning.references

# the published ids' termination reasons (tasks.termination: DEFAULT_TERMINATIONS): integer codes
# (what the step returns) and their names, index = code (``metadata["termination_reasons"]``)
TERMINATION_NAMES = reason_names(DEFAULT_TERMINATIONS)
TERMINATION_NONE, TERMINATION_BURST, TERMINATION_NONFINITE = range(len(TERMINATION_NAMES))
TERMINATION_REASONS = TERMINATION_NAMES


def check_kwargs(cls, given, what: str, noun: str = "keys", exclude=()) -> dict:
    """``given`` (a mapping or None) as a dict, after checking its keys are fields of dataclass
    ``cls`` (minus ``exclude``); ``ValueError`` naming the unknown keys and the valid ones."""
    given = dict(given or {})
    names = {f.name for f in fields(cls)} - set(exclude)
    bad = set(given) - names
    if bad:
        raise InputError(f"{what}: unknown {noun} {sorted(bad)}; valid: {sorted(names)}")
    return given


@dataclass(frozen=True)
class TaskScales:
    """Units of the reward terms and scales of the observation (SI).

    ``tracking_unit`` is one unit of the tracking term (1 cm of length on the rig, 10 deg of
    angle on the joint), which is clipped at ``tracking_clip`` units; the relative stiffness error
    is counted in units of ``stiffness_unit`` and clipped at ``stiffness_clip`` units; ``air_unit``
    is one unit of the air term (10 mg). The score-form reward (v3) squares the clipped units."""

    tracking_unit: float = 0.01  # m
    tracking_clip: float = 5.0
    stiffness_clip: float = 2.0
    stiffness_unit: float = 1.0  # relative stiffness error of one unit of the stiffness term
    air_unit: float = 1e-5  # kg
    velocity_scale: float = 0.1  # m/s per observation unit
    stiffness_scale: float = 1000.0  # N/m per observation unit
    obs_clip: float = 10.0

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if not (np.isfinite(v) and v > 0):
                raise InputError(f"task scale {f.name} must be finite and > 0, got {v!r}")


@dataclass(frozen=True)
class RewardWeights:
    """Weights of the rig's reward terms: the fields are the terms, in the kernel's slot order
    (:data:`cepam_gym.tasks.contract.RIG`), each reported signed as ``info["reward_<term>"]``."""

    length: float = 1.0  # per cm of |L - L*|
    # per unit relative stiffness error |K - K*| / K*: 2.5 makes 20 % cost what 5 mm costs, the
    # trade of the benchmark score (tasks.contract.RIG.trade; TaskContract.score_factor states the
    # relation and tests/tasks/test_contract.py holds it)
    stiffness: float = 2.5
    effort: float = 0.05  # per unit mean squared action
    air: float = 0.05  # per 10 mg of air drawn from the supply in one control step
    burst: float = 100.0  # once, when a bladder bursts (the episode then terminates)

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if not (np.isfinite(v) and v >= 0):
                raise InputError(f"reward weight {f.name} must be finite and >= 0, got {v!r}")


@dataclass(frozen=True)
class TaskSpec:
    """One task family. Lengths m, stiffness N/m, loads kg, times s (SI inside)."""

    name: str
    track_length: bool = True
    track_stiffness: bool = True
    fixed_length: float | None = None  # the stiffness task holds this length [m]
    length_range: tuple[float, float] = (0.155, 0.19)
    stiffness_range: tuple[float, float] = (200.0, 2500.0)  # clipped further to what is reachable
    load_range: tuple[float, float] = (0.0, 0.3)  # hanging load [kg]
    load_kinds: tuple[str, ...] = LOAD_KINDS
    segment_duration: tuple[float, float] = (2.0, 4.0)  # how long a target holds [s]
    pressure_margin: float = 0.85  # targets need pressures below this fraction of min(supply, burst)
    weights: RewardWeights = field(default_factory=RewardWeights)
    scales: TaskScales = field(default_factory=TaskScales)
    # reference shapes drawn per episode (planning.references.REFERENCE_KINDS); ("step",) is the v0
    # schedule: set-points held per segment, changing at once
    references: tuple[str, ...] = ("step",)
    move_s: float = 0.6  # duration of a minimum-jerk move between set-points [s] (lengthened if needed)
    # an unscored identification window before the scored tracking [s] (envs.id_window; 0: none)
    id_window_s: float = 0.0
    # the reward (tasks.reward): its terms, their expressions and default weights; ``weights`` holds
    # one weight per term (with_reward sets both)
    reward: Reward = ABS_REWARD
    # plant parameters the task drives step by step, each planned per episode (tasks.schedule;
    # e.g. a supply pressure that drops), reported in the info under their names
    schedules: tuple[Schedule, ...] = ()
    # what ends an episode (tasks.termination), checked in order after every step
    terminations: tuple[Termination, ...] = DEFAULT_TERMINATIONS

    def __post_init__(self):
        lo, hi = self.length_range
        if not 0 < lo < hi:
            raise InputError(f"length_range must be increasing and positive, got {self.length_range}")
        if not 0 <= self.load_range[0] <= self.load_range[1]:
            raise InputError(f"load_range must be 0 <= low <= high, got {self.load_range}")
        if not 0 < self.stiffness_range[0] < self.stiffness_range[1]:
            raise InputError(f"stiffness_range must be increasing and positive, got {self.stiffness_range}")
        bad = [k for k in self.load_kinds if k not in LOAD_KINDS]
        if bad or not self.load_kinds:
            raise InputError(f"load_kinds must be a non-empty subset of {LOAD_KINDS}, got {self.load_kinds}")
        if not 0 < self.segment_duration[0] <= self.segment_duration[1]:
            raise InputError(f"segment_duration must be 0 < low <= high, got {self.segment_duration}")
        if not 0 < self.pressure_margin <= 1:
            raise InputError(f"pressure_margin must be in (0, 1], got {self.pressure_margin}")
        if not (self.track_length or self.track_stiffness):
            raise InputError("a task must track the length, the stiffness or both")
        bad = [k for k in self.references if k not in REFERENCE_KINDS]
        if bad or not self.references:
            raise InputError(
                f"references must be a non-empty subset of {REFERENCE_KINDS}, got {self.references}"
            )
        if self.fixed_length is not None and {"sine", "chirp"} & set(self.references):
            raise InputError(
                f"task {self.name!r} holds a fixed length: sine and chirp length references do not apply"
            )
        if not (np.isfinite(self.move_s) and self.move_s > 0):
            raise InputError(f"move_s must be finite and > 0, got {self.move_s!r}")
        if not isinstance(self.reward, Reward):
            raise InputError(f"reward must be a tasks.reward.Reward, got {type(self.reward).__name__}")
        self.reward.weight_values(self.weights)
        object.__setattr__(self, "schedules", check_schedules(self.schedules))
        object.__setattr__(self, "terminations", check_terminations(self.terminations, f"task {self.name!r}"))
        w = self.id_window_s
        if isinstance(w, bool) or not isinstance(w, (int, float)) or not (np.isfinite(w) and 0 <= w <= 600):
            raise InputError(f"id_window_s is in seconds and must lie in [0, 600], got {w!r}")

    @property
    def termination_names(self) -> tuple[str, ...]:
        """The step's termination reasons, index = code (tasks.termination)."""
        return reason_names(self.terminations)

    @property
    def reward_form(self) -> str:
        """The reward's name (``"abs"``, ``"score"`` for the package's, or a declaration's own)."""
        return self.reward.name

    def with_reward(self, reward: Reward, **weights: float) -> TaskSpec:
        """This task paying ``reward`` (a :class:`~cepam_gym.tasks.reward.Reward`), at its default
        weights but for ``weights`` (term name -> weight)."""
        typ = reward.weights_type()
        check_kwargs(typ, weights, f"the weights of reward {reward.name!r}", "terms")
        return replace(self, reward=reward, weights=typ(**weights))


# The score's own units (tasks.contract.RIG.trade): 5 mm and 20 % are one unit each, squared by the
# "score" form; clips far outside any task's range (30 units is 15 cm, 25 units a 500 % error) keep a
# diverging state's reward finite without touching a ranking.
SCORE_SCALES = TaskScales(tracking_unit=0.005, tracking_clip=30.0, stiffness_unit=0.2, stiffness_clip=25.0)
# Squared errors at the score's trade (w = 1); a burst charged as an episode whose every one of its
# 500 steps scores the failure weight 2 (2^2 x 500); effort and air at prices measured not to change
# the ranking of any shipped controller (tests/bench/test_reward_ranking.py)
SCORE_WEIGHTS = RewardWeights(**{t.name: t.weight for t in SCORE_REWARD.terms})


def _v3(v1: TaskSpec, name: str) -> TaskSpec:
    """The v3 task ``name`` of a v1 task: the same references and loads, the score's reward."""
    return replace(v1, name=name, weights=SCORE_WEIGHTS, scales=SCORE_SCALES, reward=SCORE_REWARD)


TASKS = {
    "cepam": TaskSpec("cepam"),
    "length": TaskSpec("length", track_stiffness=False),
    # paper section XII: same length (17.5 cm), several stiffnesses
    # (default weights: the benchmark's trade of 5 mm against 20 %, as in the other tasks)
    "stiffness": TaskSpec("stiffness", fixed_length=0.175, load_range=(0.0, 0.15)),
    # v1: planned references (smooth moves, the paper's two profiles), announced in the observation
    "cepam_v1": TaskSpec("cepam_v1", references=("min_jerk", "sine", "chirp", "stiffness_ramp")),
    "length_v1": TaskSpec("length_v1", track_stiffness=False, references=("min_jerk", "sine", "chirp")),
    "stiffness_v1": TaskSpec(
        "stiffness_v1", fixed_length=0.175, load_range=(0.0, 0.15), references=("min_jerk", "stiffness_ramp")
    ),
}
# v3: the v1 tasks paying the score's per-step form
TASKS.update(
    {f"{stem}_v3": _v3(TASKS[f"{stem}_v1"], f"{stem}_v3") for stem in ("cepam", "length", "stiffness")}
)
