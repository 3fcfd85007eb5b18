"""Each task's contract: what its env emits and how it is judged, declared once.

A :class:`TaskContract` holds the names and facts every layer reads:

* the terms of the package's rewards (:mod:`cepam_gym.tasks.reward`: ``abs`` and ``score``) and
  their weights: the fields of the task's weights dataclass
  (:class:`~cepam_gym.tasks.spec.RewardWeights`, :class:`~cepam_gym.tasks.joint.JointRewardWeights`),
  in the declared order, each reported signed as ``info["reward_<term>"]`` (a task given another
  reward declaration reports that one's terms: ``Task.term_keys``);
* the info keys of every reset and step, and the termination names
  (``info["termination_reason"]`` is an index into :data:`TERMINATION_NAMES`);
* the ``reset(options=...)`` keys it pins;
* with the rig tasks' option ``id_window_s`` (an unscored identification window before the
  tracking, :mod:`cepam_gym.envs.id_window`), one more info key, ``window``: True for a step taken
  in the window (and at a reset that starts one); the window's reward is its burst term alone and
  the score leaves its steps out;
* what the benchmark's score reads of the info (``score_keys``: trace column -> info key) and its
  trade (:class:`ScoreTrade`: the errors that score 1, the weight of a failure).

The envs name their info masks and metadata from it, the agents'
logging its keys, :mod:`cepam_gym.control.objective` its trade and columns, and the docs build
(``docs/gen_env_pages.py``) its reset options and termination names.

Reward and score
----------------
The v3 ids (``TaskSpec.reward_form == "score"``) pay the score's own per-step form: on a step the
score counts (:func:`cepam_gym.control.objective.scored_steps`: not within the settling
allowance after a jump of a target) ``r_x = -w_x (e_x / x_norm)^2`` and
``r_K = -w_K ((K / K* - 1) / 0.2)^2`` with ``w_x = w_K = 1``, zero on the steps it leaves out; a
burst is charged ``failure_weight^2 x max_episode_steps`` once (the return of an episode whose
every step scores ``failure_weight``); effort and air are priced too little to change a ranking.
The mean return of a suite is then minus the number of scored steps times the sum of the squared
RMS terms (the score's squared form), which orders controllers as the score does except within a
tie of 2 %: no per-step reward orders every pair as a sum of two RMS terms does
(tests/bench/test_reward_ranking.py checks it on every v3 headline suite). The earlier ids keep
the reward below.

The reward of the earlier ids of a step is the sum of its terms, among them
``r_x = -w_x min(|e_x| / u, clip_x)`` (``e_x`` the position error, ``u`` the task's ``tracking_unit``) and
``r_K = -w_K min(|K / K* - 1|, clip_K)``. The score of a suite is
``RMS(e_x) / x_norm + RMS(K / K* - 1) / 0.2 + 2 x failure rate`` over the steps it counts. The
default weights make the same trade as the score (:meth:`TaskContract.score_factor`):
``w_x x_norm / u = 0.2 w_K = 1 / c``, so on every step whose errors are below the clips

    |e_x| / x_norm + |K / K* - 1| / 0.2 = -c (r_x + r_K)      (c = 2 on the rig, 1 on the joint)

exactly: the score's per-step error is the reward's tracking and stiffness terms, rescaled. The
two still rank policies differently, because the score (a) takes the root mean square of the
errors where the reward sums their absolute values, so a large transient costs more in the score;
(b) leaves out the settling allowance after each jump of a target (v1 and later suites), which
the reward counts; (c) does not count the effort and air terms; (d) weighs a failed episode 2 in
the failure rate where the reward charges the burst weight once and then stops. docs/benchmark.md
quotes what each reason weighs (``benchmarks/reward_vs_score.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from ..errors import InputError
from .hinge_info import INFO_KEYS as HINGE_INFO_KEYS
from .joint import INIT_KEYS, PIN_KEYS, JointRewardWeights
from .reward import ABS_REWARD
from .rig_info import INFO_KEYS as RIG_INFO_KEYS
from .spec import TERMINATION_NAMES, RewardWeights

# the trace columns the benchmark scores (bench.harness records them; TraceSpec.info_keys maps
# each to the task's info key)
TRACE_COLUMNS = (
    "length",
    "target_length",
    "stiffness",
    "target_stiffness",
    "pressure_c",
    "pressure_e",
    "load_mass",
    "air_used",
)


@dataclass(frozen=True)
class ScoreTrade:
    """What the benchmark counts as good: a position error of ``score_norm`` (in ``unit``,
    ``scale`` per SI unit) and a relative stiffness error of ``stiffness_norm`` each score 1;
    a failed episode scores ``failure_weight`` (:func:`cepam_gym.control.objective.combined_score`)."""

    unit: str
    scale: float  # display units per SI unit
    score_norm: float  # in ``unit``
    stiffness_norm: float = 0.2
    failure_weight: float = 2.0
    # the planned-reference suites (task version >= 1) leave out ``allowance_s`` after each jump of
    # a target: a change of more than ``jump_position`` (SI) or of ``jump_stiffness`` (relative)
    # within one control step
    allowance_s: float = 0.5
    jump_position: float = 1e-3
    jump_stiffness: float = 0.05

    @property
    def position_norm(self) -> float:
        """The position error [SI: m or rad] that scores 1."""
        return self.score_norm / self.scale


@dataclass(frozen=True)
class TaskContract:
    """One task family's names and facts (see the module docstring)."""

    name: str  # "rig" or "joint"
    position: str  # the tracked position: its info key and the first reward term
    position_unit: str  # SI unit of the position
    stiffness_unit: str  # SI unit of the stiffness target
    weights: type  # the weights dataclass: its fields are the reward terms, its defaults the weights
    info_keys: tuple[str, ...]  # every reset and step info (a step's adds the terms and the reason)
    pin_keys: tuple[str, ...]  # reset(options=...) keys
    score_keys: dict  # trace column (TRACE_COLUMNS) -> info key
    trade: ScoreTrade
    termination_names: tuple[str, ...] = TERMINATION_NAMES

    def __post_init__(self):
        terms = self.reward_terms
        declared = ABS_REWARD.renamed({"length": self.position}).names
        if terms != declared:
            raise ValueError(
                f"{self.name}: the weights' fields must be the package reward's terms {declared}"
            )
        read = set(self.score_keys.values())
        if set(self.score_keys) != set(TRACE_COLUMNS) or not read <= set(self.info_keys):
            raise ValueError(f"{self.name}: score_keys must map {TRACE_COLUMNS} to info keys")

    @property
    def reward_terms(self) -> tuple[str, ...]:
        """The package rewards' terms, in order (the weights dataclass's fields)."""
        return tuple(f.name for f in fields(self.weights))

    @property
    def term_keys(self) -> tuple[str, ...]:
        """``info`` keys of the reward terms (``reward_<term>``)."""
        return tuple(f"reward_{t}" for t in self.reward_terms)

    @property
    def step_keys(self) -> tuple[str, ...]:
        """Every key of a step's info."""
        return (*self.info_keys, *self.term_keys, "termination_reason")

    def score_factor(self, weights, tracking_unit: float) -> float:
        """``c`` with ``|e_x| / x_norm + |K / K* - 1| / stiffness_norm = -c (r_x + r_K)`` on every
        step whose errors are below the reward's clips, for reward ``weights`` (an instance of
        :attr:`weights`) and the task's ``tracking_unit``; ``ValueError`` when the weights trade
        position against stiffness otherwise than the score (then no such ``c`` exists)."""
        w = [getattr(weights, t) for t in self.reward_terms[:2]]
        c_x = tracking_unit / (w[0] * self.trade.position_norm) if w[0] > 0 else math.inf
        c_k = 1.0 / (w[1] * self.trade.stiffness_norm) if w[1] > 0 else math.inf
        if not math.isclose(c_x, c_k, rel_tol=1e-12):
            raise InputError(
                f"the {self.name} reward weights {w} trade {self.position} against stiffness "
                f"otherwise than the score ({self.trade.score_norm} {self.trade.unit} ~ "
                f"{self.trade.stiffness_norm:.0%})"
            )
        return c_x


RIG = TaskContract(
    name="rig",
    position="length",
    position_unit="m",
    stiffness_unit="N/m",
    weights=RewardWeights,
    info_keys=(*RIG_INFO_KEYS, "redraws"),  # declared with what each reads: tasks.rig_info
    pin_keys=("target_length", "target_stiffness", "load_mass"),
    score_keys={k: k for k in TRACE_COLUMNS},
    trade=ScoreTrade(unit="mm", scale=1000.0, score_norm=5.0),
)

JOINT = TaskContract(
    name="joint",
    position="angle",
    position_unit="rad",
    stiffness_unit="N m/rad",
    weights=JointRewardWeights,
    info_keys=(*HINGE_INFO_KEYS, "redraws"),  # declared with how each is computed: tasks.hinge_info
    pin_keys=PIN_KEYS + INIT_KEYS,
    score_keys={
        "length": "angle",
        "target_length": "target_angle",
        "stiffness": "joint_stiffness",
        "target_stiffness": "target_stiffness",
        "pressure_c": "pressure_c",
        "pressure_e": "pressure_e",
        "load_mass": "external_torque",
        "air_used": "air_used",
    },
    trade=ScoreTrade(unit="deg", scale=180.0 / math.pi, score_norm=10.0),
)

CONTRACTS = {c.name: c for c in (RIG, JOINT)}
