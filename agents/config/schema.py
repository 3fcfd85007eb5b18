"""The training config's schema: one frozen dataclass per section (env, normalize, agent, eval,
checkpoint) and :class:`TrainConfig` holding them, each with the ``parse`` that checks its section
of the YAML (the layout and the defaults are described in :mod:`cepam_gym_agents.config.files`)."""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from cepam_gym.versions import RECOMMENDED_ID

from ..learners.algorithm import ALGORITHMS, ON_POLICY, check_hyperparameters, check_policy_kwargs
from .adaptation import AdaptationConfig
from .agent import AgentConfig
from .checks import (
    ConfigError,
    as_bool,
    as_float,
    as_int,
    as_mapping,
    as_widths,
    check_keys,
    numbers_deep,
)


# --------------------------------------------------------------------------- sections
@dataclass(frozen=True)
class EnvConfig:
    """``suite`` (optional) starts the kwargs from a benchmark suite's (e.g. ``randomized``: the
    same plant spread, noise and drift); ``kwargs`` are then merged over them, key by key. The
    resolved config stores the merged kwargs."""

    id: str = RECOMMENDED_ID
    num_envs: int = 8
    suite: str | None = None
    kwargs: dict = field(default_factory=dict)

    @classmethod
    def parse(cls, data: Any) -> EnvConfig:
        d = as_mapping(data, "env")
        check_keys(d, cls, "env")
        suite = d.get("suite")
        base: dict = {}
        if suite is not None:
            from cepam_gym.bench.suites import SUITES

            if suite not in SUITES:
                raise ConfigError(f"env.suite: unknown suite {suite!r}; choose from {list(SUITES)}")
            base = numbers_deep(SUITES[suite].env_kwargs)
        env_id = d.get("id", cls.id)
        import gymnasium as gym

        import cepam_gym  # noqa: F401  (registers the ids)

        if not isinstance(env_id, str) or env_id not in gym.registry:
            ids = sorted(k for k in gym.registry if k.startswith("cepam_gym/"))
            raise ConfigError(f"env.id: unknown environment {env_id!r}; registered CE-PAM ids: {ids}")
        kwargs = {**base, **numbers_deep(as_mapping(d.get("kwargs"), "env.kwargs"))}
        _check_env_kwargs(kwargs, "env.kwargs")
        return cls(env_id, as_int(d.get("num_envs", cls.num_envs), "env.num_envs", 1), suite, kwargs)


def _check_env_kwargs(kwargs: Mapping, where: str) -> None:
    """Reject kwargs the CE-PAM envs do not take (their values are checked by the env itself)."""
    from cepam_gym.envs.cepam import CEPAMVectorEnv
    from cepam_gym.envs.core import CEPAMBatch

    names = set(inspect.signature(CEPAMBatch.__init__).parameters) | set(
        inspect.signature(CEPAMVectorEnv.__init__).parameters
    )
    names -= {"self", "kwargs", "num_envs", "task", "render_mode"}
    bad = sorted(set(kwargs) - names)
    if bad:
        raise ConfigError(f"{where}: unknown env kwarg {bad[0]!r}; valid: {sorted(names)}")


@dataclass(frozen=True)
class NormalizeConfig:
    obs: bool = False
    reward: bool = False
    clip_obs: float = 10.0
    clip_reward: float = 10.0

    @property
    def enabled(self) -> bool:
        return self.obs or self.reward

    @classmethod
    def parse(cls, data: Any) -> NormalizeConfig:
        if data is None or data is False:
            return cls()
        if data is True:
            return cls(obs=True, reward=True)
        d = as_mapping(data, "normalize")
        check_keys(d, cls, "normalize")
        return cls(
            as_bool(d.get("obs", False), "normalize.obs"),
            as_bool(d.get("reward", False), "normalize.reward"),
            as_float(d.get("clip_obs", 10.0), "normalize.clip_obs", 0.0),
            as_float(d.get("clip_reward", 10.0), "normalize.clip_reward", 0.0),
        )


@dataclass(frozen=True)
class EvalConfig:
    """Periodic evaluation: ``episodes`` seeded episodes, scored with the benchmark's combined
    score (lower is better); the best model is kept. ``suite`` names a benchmark suite whose env
    id and kwargs are used (with this ``seed``, not the suite's, so that the benchmark's own
    episodes are never used to pick the model); without it, the training env is used."""

    every_steps: int = 20000
    episodes: int = 16
    suite: str | None = None
    seed: int = 12345

    @classmethod
    def parse(cls, data: Any) -> EvalConfig:
        d = as_mapping(data, "eval")
        check_keys(d, cls, "eval")
        suite = d.get("suite")
        if suite is not None:
            from cepam_gym.bench.suites import SUITES

            if suite not in SUITES:
                raise ConfigError(f"eval.suite: unknown suite {suite!r}; choose from {list(SUITES)}")
        return cls(
            as_int(d.get("every_steps", cls.every_steps), "eval.every_steps", 1),
            as_int(d.get("episodes", cls.episodes), "eval.episodes", 1),
            suite,
            as_int(d.get("seed", cls.seed), "eval.seed", 0),
        )


@dataclass(frozen=True)
class CheckpointConfig:
    every_steps: int = 50000
    keep: int = 2  # checkpoints kept on disk (the newest)
    replay_buffer: bool = True  # off-policy algorithms: save the replay buffer for --resume

    @classmethod
    def parse(cls, data: Any) -> CheckpointConfig:
        d = as_mapping(data, "checkpoint")
        check_keys(d, cls, "checkpoint")
        return cls(
            as_int(d.get("every_steps", cls.every_steps), "checkpoint.every_steps", 1),
            as_int(d.get("keep", cls.keep), "checkpoint.keep", 1),
            as_bool(d.get("replay_buffer", True), "checkpoint.replay_buffer"),
        )


@dataclass(frozen=True)
class StudentConfig:
    """A student distilled from a privileged teacher by DAgger (Ross et al. 2011), the RMA recipe's
    first phase (Kumar et al. 2021): the teacher (default the oracle, which reads the true state,
    plant, load and reference horizon) labels every state the student visits; the student sees
    only what the agent's features give it (``agent``: observation history, filters).

    * ``suites``: suite name -> number of envs: the plants trained on (a mix of the nominal and the
      randomized plant, so robustness is not bought with nominal accuracy); episodes are drawn
      from the training seed, never the suites' own.
    * ``iterations``: rounds of collect-then-fit; round 0 is driven by the teacher, later rounds by
      the student, the teacher taking over a step with probability ``beta``.
    * ``gradient_steps``, ``batch_size``, ``learning_rate``: the supervised fit per round (Adam,
      cosine-decayed, on all data so far; actions scaled by their standard deviation).
    * ``net_arch``: the actor's hidden layers (tanh), saved as an SB3 PPO policy so that every tool
      that loads a run loads the student.
    * ``teacher_options``: keyword arguments of the teacher's constructor, e.g. a cheaper search
      for an MPC teacher (``{population: 24, iterations: 3}``: the fields of
      :class:`cepam_gym.control.planner.CEMConfig`); the labels are most of a student's time. A
      teacher that reads the benchmark's schedule (the oracle, ``oracle_causal``) plans the
      settling allowance too (``allowance_weight`` 1 unless set here: the score's 0 leaves its
      commands there arbitrary to a student).
    * ``adaptation``: with ``agent.plant_features``, the second phase (:mod:`.adaptation`)."""

    teacher: str = "oracle"
    suites: dict = field(default_factory=lambda: {"nominal-v1": 32, "randomized-v1": 32})
    iterations: int = 4
    beta: float = 0.2
    gradient_steps: int = 2500
    batch_size: int = 512
    learning_rate: float = 1e-3
    net_arch: list = field(default_factory=lambda: [256, 256])
    teacher_options: dict = field(default_factory=dict)
    adaptation: AdaptationConfig | None = None

    @classmethod
    def parse(cls, data: Any) -> StudentConfig | None:
        if data is None:
            return None
        d = as_mapping(data, "student")
        check_keys(d, cls, "student")
        teacher = d.get("teacher", cls.teacher)
        if not isinstance(teacher, str) or not teacher:
            raise ConfigError(f"student.teacher must be a controller name, got {teacher!r}")
        suites = as_mapping(d.get("suites", cls().suites), "student.suites")
        from cepam_gym.bench.suites import SUITES

        if not suites:
            raise ConfigError("student.suites must name at least one suite (suite: number of envs)")
        for name in suites:
            if name not in SUITES:
                raise ConfigError(f"student.suites: unknown suite {name!r}; choose from {list(SUITES)}")
        counts = {str(k): as_int(v, f"student.suites.{k}", 1) for k, v in suites.items()}
        arch = as_widths(d.get("net_arch", cls().net_arch), "student.net_arch")
        beta = as_float(d.get("beta", cls.beta), "student.beta", 0.0)
        if beta > 1:
            raise ConfigError(f"student.beta is a probability in [0, 1], got {beta!r}")
        options = dict(as_mapping(d.get("teacher_options", {}), "student.teacher_options"))
        return cls(
            teacher,
            counts,
            as_int(d.get("iterations", cls.iterations), "student.iterations", 1),
            beta,
            as_int(d.get("gradient_steps", cls.gradient_steps), "student.gradient_steps", 1),
            as_int(d.get("batch_size", cls.batch_size), "student.batch_size", 1),
            as_float(d.get("learning_rate", cls.learning_rate), "student.learning_rate", 0.0),
            arch,
            {str(k): v for k, v in options.items()},
            AdaptationConfig.parse(d.get("adaptation")),
        )


LEARNERS = ("sb3", "native")
NATIVE_ALGORITHMS = ("PPO", "RecurrentPPO", "SAC", "TD3")


def _learner(name: Any, algo: str, hp: dict, agent: AgentConfig, student: Any) -> str:
    """The checked ``learner``: ``native`` (:mod:`agents.learners.native_ppo`,
    :mod:`agents.learners.native_offpolicy`) runs PPO, RecurrentPPO, SAC or TD3 on arrays from the
    vector env, through the agent's features (:mod:`agents.learners.native_collection`) but for the
    privileged critic and the plant's columns (they read the env beside the features: not carried
    to the native learner)."""
    if name not in LEARNERS:
        raise ConfigError(f"learner must be one of {list(LEARNERS)}, got {name!r}")
    if name == "sb3":
        return name
    why = None
    if algo not in NATIVE_ALGORITHMS:
        why = f"algorithm {algo} (the native learner runs {', '.join(NATIVE_ALGORITHMS)})"
    elif student is not None:
        why = "a student section (a student is distilled, not trained by PPO)"
    elif agent.privileged_critic or agent.plant_features:
        why = "agent.privileged_critic or agent.plant_features"
    elif hp.get("use_sde"):
        why = "hyperparameters.use_sde (the native learner samples plain Gaussian actions)"
    elif algo != "PPO" and isinstance(hp.get("train_freq"), (list, tuple)):
        why = "a train_freq in episodes (the native learner counts vector steps)"
    if why:
        raise ConfigError(f"learner: native does not take {why}; use learner: sb3")
    return name


def _torch_threads(value: Any) -> int | str:
    if value == "auto":
        return value
    try:
        return as_int(value, "torch_threads", 1)
    except ConfigError:
        raise ConfigError(f"torch_threads must be an integer >= 1 or 'auto', got {value!r}") from None


# --------------------------------------------------------------------------- the config
@dataclass(frozen=True)
class TrainConfig:
    algorithm: str
    total_timesteps: int = 100_000
    seed: int = 0
    torch_threads: int | str = 1  # or "auto": chosen while the run goes on (agents.session.torch_threads)
    env: EnvConfig = field(default_factory=EnvConfig)
    normalize: NormalizeConfig = field(default_factory=NormalizeConfig)
    agent: AgentConfig = field(default_factory=AgentConfig)
    hyperparameters: dict = field(default_factory=dict)
    policy_kwargs: dict = field(default_factory=dict)
    eval: EvalConfig = field(default_factory=EvalConfig)
    checkpoint: CheckpointConfig = field(default_factory=CheckpointConfig)
    log_every_steps: int = 5000
    time_limit_minutes: float | None = None
    student: StudentConfig | None = None
    learner: str = "sb3"  # "native": rollouts from the vector env as arrays (agents.learners.native_*)

    @classmethod
    def from_dict(cls, data: Any) -> TrainConfig:
        d = as_mapping(data, "config")
        check_keys(d, cls, "")
        if "algorithm" not in d:
            raise ConfigError(f"config needs 'algorithm' (one of {list(ALGORITHMS)})")
        algo = d["algorithm"]
        names = {a.upper(): a for a in ALGORITHMS}
        if not isinstance(algo, str) or algo.upper() not in names:
            raise ConfigError(f"algorithm must be one of {list(ALGORITHMS)}, got {algo!r}")
        algo = names[algo.upper()]
        hp = check_hyperparameters(
            algo, numbers_deep(as_mapping(d.get("hyperparameters"), "hyperparameters"))
        )
        pk = check_policy_kwargs(algo, numbers_deep(as_mapping(d.get("policy_kwargs"), "policy_kwargs")))
        if algo in ON_POLICY and "action_noise" in hp:
            raise ConfigError(f"hyperparameters.action_noise is for SAC and TD3, not {algo}")
        agent = AgentConfig.parse(d.get("agent"))
        if agent.privileged_critic and algo != "PPO":
            raise ConfigError(
                f"agent.privileged_critic is built for PPO (an asymmetric actor-critic), not {algo}"
            )
        if d.get("student") is not None and algo != "PPO":
            raise ConfigError(f"a student is saved as a PPO policy: algorithm must be PPO, not {algo}")
        learner = _learner(d.get("learner", cls.learner), algo, hp, agent, d.get("student"))
        out = cls(
            algorithm=algo,
            learner=learner,
            total_timesteps=as_int(d.get("total_timesteps", cls.total_timesteps), "total_timesteps", 1),
            seed=as_int(d.get("seed", cls.seed), "seed", 0),
            torch_threads=_torch_threads(d.get("torch_threads", cls.torch_threads)),
            env=EnvConfig.parse(d.get("env")),
            normalize=NormalizeConfig.parse(d.get("normalize")),
            agent=agent,
            hyperparameters=hp,
            policy_kwargs=pk,
            eval=EvalConfig.parse(d.get("eval")),
            checkpoint=CheckpointConfig.parse(d.get("checkpoint")),
            log_every_steps=as_int(d.get("log_every_steps", cls.log_every_steps), "log_every_steps", 1),
            time_limit_minutes=None
            if d.get("time_limit_minutes") is None
            else as_float(d["time_limit_minutes"], "time_limit_minutes", 0.0),
            student=StudentConfig.parse(d.get("student")),
        )
        if agent.plant_features:
            _check_plant_features(out)
        elif out.student is not None and out.student.adaptation is not None:
            raise ConfigError(
                "student.adaptation estimates the plant a student is told: it needs agent.plant_features"
            )
        return out

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    def replace(self, **changes) -> TrainConfig:
        return dataclasses.replace(self, **changes)


def _has_window(env_kwargs: dict) -> bool:
    """Whether env kwargs start each episode with an identification window."""
    options = env_kwargs.get("task_options") or {}
    return float(options.get("id_window_s", 0.0) or 0.0) > 0.0


def _check_plant_features(cfg: TrainConfig) -> None:
    """An agent told the plant trains on the true plant (no window: the teacher and the agent
    would drive the window, told the plant from its first step) and is evaluated as deployed,
    behind an identification window whose fit it is told."""
    from cepam_gym.bench.suites import SUITES

    if cfg.algorithm == "RecurrentPPO":
        raise ConfigError(
            "agent.plant_features is built for feed-forward policies: a recurrent policy's state would "
            "carry the identification window's excitation into the tracking"
        )
    window_eval = cfg.eval.suite is not None and _has_window(SUITES[cfg.eval.suite].env_kwargs)
    if not window_eval:
        raise ConfigError(
            "agent.plant_features: eval.suite must start its episodes with an identification window "
            f"(e.g. randomized-id-v2; got {cfg.eval.suite!r}): deployed, the agent is told that window's fit"
        )
    trained = {"env": cfg.env.kwargs}
    if cfg.student is not None:
        trained.update({f"student.suites.{n}": SUITES[n].env_kwargs for n in cfg.student.suites})
    windowed = [where for where, kwargs in trained.items() if _has_window(kwargs)]
    if windowed:
        raise ConfigError(
            f"agent.plant_features trains on the true plant without a window; {', '.join(windowed)} "
            "start episodes with an identification window (use e.g. randomized-v2)"
        )
