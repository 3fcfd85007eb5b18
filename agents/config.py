"""Training configs: YAML files (``configs/``, shipped as package data) as frozen dataclasses,
validated on load.

Layout of a config (every section optional except ``algorithm``; defaults below)::

    algorithm: SAC                # SAC | PPO | TD3 | RecurrentPPO (sb3-contrib, an LSTM policy)
    total_timesteps: 300000       # environment steps, summed over the parallel envs
    seed: 0
    torch_threads: 1
    env:
      id: cepam_gym/CEPAM-v0      # any registered id
      num_envs: 16                # plants stepped together by the native batched env
      suite: null                 # start the kwargs from a benchmark suite's (e.g. randomized)
      kwargs: {}                  # env kwargs (randomize, sensor_noise, reward_weights, ...)
    normalize: {obs: false, reward: false, clip_obs: 10.0, clip_reward: 10.0}  # VecNormalize
    agent:                        # what the policy sees and sends (see AgentConfig)
      residual: false             # true: action = baseline action + residual_scale * policy action
      residual_scale: 0.5
      baseline_in_obs: false      # append the baseline's action to the observation
      history: 1                  # stack this many consecutive observations
      target_shift: false         # true: the policy also shifts the baseline's length/stiffness targets
      target_shift_length_mm: 5.0
      target_shift_stiffness: 0.4 # stiffness target times exp(+-0.4) at most
      target_shift_filter_s: 0.0  # low-pass time constant of the shifts [s] (0: none)
      obs_filters_s: []           # append low-passed observations with these time constants [s]
      privileged_critic: false    # PPO: the critic also sees the true plant, load and errors
    hyperparameters: {}           # passed to the SB3 constructor, checked against its signature
    policy_kwargs: {}             # e.g. {net_arch: [256, 256], activation_fn: relu}
    eval: {every_steps: 20000, episodes: 16, suite: null, seed: 12345}
    checkpoint: {every_steps: 50000, keep: 2, replay_buffer: true}
    log_every_steps: 5000
    time_limit_minutes: null      # stop after this much training wall time (saved; run.json
                                  # status stopped_by_time_limit)

Unknown keys are rejected with the key's path and the valid keys. Numbers are parsed as numbers
even where YAML 1.1 (PyYAML) reads them as strings (``1e-3``, ``3e5``). Units: steps and episodes
are counts; everything physical lives in the env kwargs, which use the env's unit-named keys.
"""

from __future__ import annotations

import dataclasses
import inspect
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from cepam_gym.errors import InputError

ALGORITHMS = ("SAC", "PPO", "TD3", "RecurrentPPO")
ON_POLICY = ("PPO", "RecurrentPPO")
# constructor arguments the trainer sets itself (or that cannot come from YAML)
_RESERVED = {
    "self",
    "policy",
    "env",
    "seed",
    "verbose",
    "tensorboard_log",
    "device",
    "policy_kwargs",
    "_init_setup_model",
    "replay_buffer_class",
    "rollout_buffer_class",
}
ACTIVATIONS = {
    "relu": "ReLU",
    "tanh": "Tanh",
    "elu": "ELU",
    "leaky_relu": "LeakyReLU",
    "gelu": "GELU",
    "silu": "SiLU",
}
NOISE_TYPES = ("normal", "ornstein_uhlenbeck")

_NUMBER = re.compile(r"^[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?$")


class ConfigError(InputError):
    """A training config is invalid; the message names the offending key."""


# --------------------------------------------------------------------------- parsing helpers
def parse_number(value: Any) -> Any:
    """``'1e-3'`` -> 0.001 (YAML 1.1 leaves such scalars as strings); other values unchanged."""
    if isinstance(value, str) and _NUMBER.match(value.strip()):
        v = float(value)
        return int(v) if re.fullmatch(r"[+-]?\d+", value.strip()) else v
    return value


def _numbers_deep(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {k: _numbers_deep(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_numbers_deep(v) for v in value]
    return parse_number(value)


def _int(value: Any, where: str, minimum: int | None = None) -> int:
    v = parse_number(value)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or v != v or int(v) != v:
        raise ConfigError(f"{where} must be an integer, got {value!r}")
    v = int(v)
    if minimum is not None and v < minimum:
        raise ConfigError(f"{where} must be >= {minimum}, got {v}")
    return v


def _float(value: Any, where: str, minimum: float | None = None) -> float:
    v = parse_number(value)
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ConfigError(f"{where} must be a number, got {value!r}")
    v = float(v)
    if not v == v or v in (float("inf"), float("-inf")):
        raise ConfigError(f"{where} must be finite, got {value!r}")
    if minimum is not None and v < minimum:
        raise ConfigError(f"{where} must be >= {minimum}, got {v}")
    return v


def _bool(value: Any, where: str) -> bool:
    if not isinstance(value, bool):
        raise ConfigError(f"{where} must be true or false, got {value!r}")
    return value


def _mapping(value: Any, where: str) -> dict:
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise ConfigError(f"{where} must be a mapping, got {type(value).__name__} {value!r}")
    bad = [k for k in value if not isinstance(k, str)]
    if bad:
        raise ConfigError(f"{where}: keys must be strings, got {bad!r}")
    return dict(value)


def _check_keys(data: Mapping, cls, where: str) -> None:
    valid = [f.name for f in dataclasses.fields(cls)]
    bad = [k for k in data if k not in valid]
    if bad:
        label = f"in {where}" if where else "at the top level"
        raise ConfigError(
            f"unknown config key {bad[0]!r} {label}"
            f"{' (also: ' + ', '.join(map(repr, bad[1:])) + ')' if bad[1:] else ''}; "
            f"valid keys: {valid}"
        )


# --------------------------------------------------------------------------- sections
@dataclass(frozen=True)
class EnvConfig:
    """``suite`` (optional) starts the kwargs from a benchmark suite's (e.g. ``randomized``: the
    same plant spread, noise and drift); ``kwargs`` are then merged over them, key by key. The
    resolved config stores the merged kwargs."""

    id: str = "cepam_gym/CEPAM-v0"
    num_envs: int = 8
    suite: str | None = None
    kwargs: dict = field(default_factory=dict)

    @classmethod
    def parse(cls, data: Any) -> EnvConfig:
        d = _mapping(data, "env")
        _check_keys(d, cls, "env")
        suite = d.get("suite")
        base: dict = {}
        if suite is not None:
            from cepam_gym.bench.suites import SUITES

            if suite not in SUITES:
                raise ConfigError(f"env.suite: unknown suite {suite!r}; choose from {list(SUITES)}")
            base = _numbers_deep(SUITES[suite].env_kwargs)
        env_id = d.get("id", cls.id)
        import gymnasium as gym

        import cepam_gym  # noqa: F401  (registers the ids)

        if not isinstance(env_id, str) or env_id not in gym.registry:
            ids = sorted(k for k in gym.registry if k.startswith("cepam_gym/"))
            raise ConfigError(f"env.id: unknown environment {env_id!r}; registered CE-PAM ids: {ids}")
        kwargs = {**base, **_numbers_deep(_mapping(d.get("kwargs"), "env.kwargs"))}
        _check_env_kwargs(kwargs, "env.kwargs")
        return cls(env_id, _int(d.get("num_envs", cls.num_envs), "env.num_envs", 1), suite, kwargs)


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
        d = _mapping(data, "normalize")
        _check_keys(d, cls, "normalize")
        return cls(
            _bool(d.get("obs", False), "normalize.obs"),
            _bool(d.get("reward", False), "normalize.reward"),
            _float(d.get("clip_obs", 10.0), "normalize.clip_obs", 0.0),
            _float(d.get("clip_reward", 10.0), "normalize.clip_reward", 0.0),
        )


def _filters(value: Any, where: str) -> list:
    if not isinstance(value, (list, tuple)):
        raise ConfigError(f"{where} must be a list of time constants in seconds, got {value!r}")
    out = [_float(v, f"{where}[{i}]", 0.0) for i, v in enumerate(value)]
    if any(v <= 0 for v in out):
        raise ConfigError(f"{where}: time constants must be > 0 s, got {value!r}")
    return out


@dataclass(frozen=True)
class AgentConfig:
    """What the policy sees and sends, on top of the inverse-model baseline
    (:class:`cepam_gym.control.InverseStaticController`, nominal model):

    * ``target_shift``: the policy's first actions move the targets the baseline is given: the
      length by up to ``target_shift_length_mm``, the stiffness by a factor up to
      ``exp(+-target_shift_stiffness)`` (length-only tasks: the length shift only), low-pass
      filtered with time constant ``target_shift_filter_s`` if > 0. The baseline then computes
      pressures and valve commands for the shifted targets.
    * ``residual``: the policy's (remaining) two actions are added to the valve commands:
      ``clip(baseline + residual_scale * a, -1, 1)``.
    * ``baseline_in_obs``: the baseline's action is appended to the observation (not with
      ``target_shift``: the baseline acts only after the policy has chosen the shift).
    * ``history``: the last ``history`` observations are stacked.
    * ``obs_filters_s``: low-passed copies of the observation (one per time constant, seconds,
      restarted with each episode) are appended: a cheap memory over seconds.
    * ``privileged_critic`` (PPO): an asymmetric actor-critic (Pinto et al. 2018). During training
      the critic also sees what only the simulator knows (:mod:`agents.privileged`: the true plant
      parameters, the load, the true errors); the actor's input masks those columns out, and a
      deployed policy is given NaN there (:mod:`agents.asymmetric`).

    With neither ``target_shift`` nor ``residual`` the policy drives the valves directly."""

    residual: bool = False
    residual_scale: float = 0.5
    baseline_in_obs: bool = False
    history: int = 1
    target_shift: bool = False
    target_shift_length_mm: float = 5.0
    target_shift_stiffness: float = 0.4
    target_shift_filter_s: float = 0.0  # first-order low-pass of the shifts (0: none) [s]
    obs_filters_s: list = field(
        default_factory=list
    )  # time constants [s] of low-passed copies of the observation
    privileged_critic: bool = False

    @property
    def uses_baseline(self) -> bool:
        return self.residual or self.baseline_in_obs or self.target_shift

    @classmethod
    def parse(cls, data: Any) -> AgentConfig:
        d = _mapping(data, "agent")
        _check_keys(d, cls, "agent")
        out = cls(
            _bool(d.get("residual", False), "agent.residual"),
            _float(d.get("residual_scale", 0.5), "agent.residual_scale", 0.0),
            _bool(d.get("baseline_in_obs", False), "agent.baseline_in_obs"),
            _int(d.get("history", 1), "agent.history", 1),
            _bool(d.get("target_shift", False), "agent.target_shift"),
            _float(d.get("target_shift_length_mm", 5.0), "agent.target_shift_length_mm", 0.0),
            _float(d.get("target_shift_stiffness", 0.4), "agent.target_shift_stiffness", 0.0),
            _float(d.get("target_shift_filter_s", 0.0), "agent.target_shift_filter_s", 0.0),
            _filters(d.get("obs_filters_s", []), "agent.obs_filters_s"),
            _bool(d.get("privileged_critic", False), "agent.privileged_critic"),
        )
        if out.target_shift and out.baseline_in_obs:
            raise ConfigError(
                "agent.baseline_in_obs cannot be used with agent.target_shift (the baseline "
                "acts after the policy has chosen the shift); drop one of them"
            )
        return out


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
        d = _mapping(data, "eval")
        _check_keys(d, cls, "eval")
        suite = d.get("suite")
        if suite is not None:
            from cepam_gym.bench.suites import SUITES

            if suite not in SUITES:
                raise ConfigError(f"eval.suite: unknown suite {suite!r}; choose from {list(SUITES)}")
        return cls(
            _int(d.get("every_steps", cls.every_steps), "eval.every_steps", 1),
            _int(d.get("episodes", cls.episodes), "eval.episodes", 1),
            suite,
            _int(d.get("seed", cls.seed), "eval.seed", 0),
        )


@dataclass(frozen=True)
class CheckpointConfig:
    every_steps: int = 50000
    keep: int = 2  # checkpoints kept on disk (the newest)
    replay_buffer: bool = True  # off-policy algorithms: save the replay buffer for --resume

    @classmethod
    def parse(cls, data: Any) -> CheckpointConfig:
        d = _mapping(data, "checkpoint")
        _check_keys(d, cls, "checkpoint")
        return cls(
            _int(d.get("every_steps", cls.every_steps), "checkpoint.every_steps", 1),
            _int(d.get("keep", cls.keep), "checkpoint.keep", 1),
            _bool(d.get("replay_buffer", True), "checkpoint.replay_buffer"),
        )


def algorithm_class(name: str):
    """The SB3 (or sb3-contrib) class of an algorithm named in :data:`ALGORITHMS`."""
    if name == "RecurrentPPO":
        try:
            import sb3_contrib
        except ImportError:
            raise ConfigError(
                "algorithm RecurrentPPO needs sb3-contrib: pip install 'cepam-gym[train]' "
                "(or pip install sb3-contrib)"
            ) from None
        return sb3_contrib.RecurrentPPO
    import stable_baselines3 as sb3

    return getattr(sb3, name)


def policy_name(algorithm: str) -> str:
    """The policy alias the trainer asks the algorithm for: an LSTM policy for RecurrentPPO."""
    return "MlpLstmPolicy" if algorithm == "RecurrentPPO" else "MlpPolicy"


def _check_hyperparameters(algorithm: str, hp: dict) -> dict:
    """Hyperparameters exist in the algorithm's constructor; numbers typed like its defaults."""
    cls = algorithm_class(algorithm)
    params = inspect.signature(cls.__init__).parameters
    valid = sorted(set(params) - _RESERVED)
    out = {}
    for key, value in hp.items():
        if key not in params or key in _RESERVED:
            why = " (set by the trainer or another section)" if key in _RESERVED else ""
            raise ConfigError(
                f"hyperparameters: unknown key {key!r} for {algorithm}{why}; valid keys: {valid}"
            )
        default = params[key].default
        where = f"hyperparameters.{key}"
        if key == "action_noise":
            out[key] = _check_noise(value, where)
        elif isinstance(default, bool):
            out[key] = _bool(value, where)
        elif isinstance(default, int) and isinstance(value, (int, float)) and not isinstance(value, bool):
            out[key] = _int(value, where)
        elif isinstance(default, float) and isinstance(value, (int, float)) and not isinstance(value, bool):
            out[key] = float(value)
        elif isinstance(default, (int, float)) and isinstance(value, str) and key != "ent_coef":
            raise ConfigError(f"{where} must be a number, got {value!r}")
        else:
            out[key] = value
    return out


def _check_noise(value: Any, where: str) -> dict | None:
    if value is None:
        return None
    d = _mapping(value, where)
    bad = sorted(set(d) - {"type", "sigma"})
    if bad:
        raise ConfigError(f"{where}: unknown key {bad[0]!r}; valid keys: ['sigma', 'type']")
    kind = d.get("type", "normal")
    if kind not in NOISE_TYPES:
        raise ConfigError(f"{where}.type must be one of {NOISE_TYPES}, got {kind!r}")
    return {"type": kind, "sigma": _float(d.get("sigma", 0.1), f"{where}.sigma", 0.0)}


def _check_policy_kwargs(algorithm: str, pk: dict) -> dict:
    cls = algorithm_class(algorithm)
    policy_cls = cls.policy_aliases[policy_name(algorithm)]
    params = inspect.signature(policy_cls.__init__).parameters
    valid = sorted(set(params) - {"self", "observation_space", "action_space", "lr_schedule"})
    out = {}
    for key, value in pk.items():
        if key not in valid:
            raise ConfigError(
                f"policy_kwargs: unknown key {key!r} for {algorithm}'s {policy_name(algorithm)}; "
                f"valid keys: {valid}"
            )
        if key == "activation_fn":
            if value not in ACTIVATIONS:
                raise ConfigError(
                    f"policy_kwargs.activation_fn must be one of {sorted(ACTIVATIONS)}, got {value!r}"
                )
        out[key] = value
    return out


# --------------------------------------------------------------------------- the config
@dataclass(frozen=True)
class TrainConfig:
    algorithm: str
    total_timesteps: int = 100_000
    seed: int = 0
    torch_threads: int = 1
    env: EnvConfig = field(default_factory=EnvConfig)
    normalize: NormalizeConfig = field(default_factory=NormalizeConfig)
    agent: AgentConfig = field(default_factory=AgentConfig)
    hyperparameters: dict = field(default_factory=dict)
    policy_kwargs: dict = field(default_factory=dict)
    eval: EvalConfig = field(default_factory=EvalConfig)
    checkpoint: CheckpointConfig = field(default_factory=CheckpointConfig)
    log_every_steps: int = 5000
    time_limit_minutes: float | None = None

    @classmethod
    def from_dict(cls, data: Any) -> TrainConfig:
        d = _mapping(data, "config")
        _check_keys(d, cls, "")
        if "algorithm" not in d:
            raise ConfigError(f"config needs 'algorithm' (one of {list(ALGORITHMS)})")
        algo = d["algorithm"]
        names = {a.upper(): a for a in ALGORITHMS}
        if not isinstance(algo, str) or algo.upper() not in names:
            raise ConfigError(f"algorithm must be one of {list(ALGORITHMS)}, got {algo!r}")
        algo = names[algo.upper()]
        hp = _check_hyperparameters(
            algo, _numbers_deep(_mapping(d.get("hyperparameters"), "hyperparameters"))
        )
        pk = _check_policy_kwargs(algo, _numbers_deep(_mapping(d.get("policy_kwargs"), "policy_kwargs")))
        if algo in ON_POLICY and "action_noise" in hp:
            raise ConfigError(f"hyperparameters.action_noise is for SAC and TD3, not {algo}")
        agent = AgentConfig.parse(d.get("agent"))
        if agent.privileged_critic and algo != "PPO":
            raise ConfigError(
                f"agent.privileged_critic is built for PPO (an asymmetric actor-critic), not {algo}"
            )
        return cls(
            algorithm=algo,
            total_timesteps=_int(d.get("total_timesteps", cls.total_timesteps), "total_timesteps", 1),
            seed=_int(d.get("seed", cls.seed), "seed", 0),
            torch_threads=_int(d.get("torch_threads", cls.torch_threads), "torch_threads", 1),
            env=EnvConfig.parse(d.get("env")),
            normalize=NormalizeConfig.parse(d.get("normalize")),
            agent=agent,
            hyperparameters=hp,
            policy_kwargs=pk,
            eval=EvalConfig.parse(d.get("eval")),
            checkpoint=CheckpointConfig.parse(d.get("checkpoint")),
            log_every_steps=_int(d.get("log_every_steps", cls.log_every_steps), "log_every_steps", 1),
            time_limit_minutes=None
            if d.get("time_limit_minutes") is None
            else _float(d["time_limit_minutes"], "time_limit_minutes", 0.0),
        )

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    def replace(self, **changes) -> TrainConfig:
        return dataclasses.replace(self, **changes)


def shipped_configs() -> dict:
    """The configs shipped with the package, by name (``quick`` -> ``quick.yaml``): ``configs/``
    of the repository, installed as the package data ``cepam_gym_agents.configs``."""
    from importlib.resources import files

    root = files(f"{__package__}.configs")
    return {f.name.rsplit(".", 1)[0]: f for f in root.iterdir() if f.name.endswith((".yaml", ".yml"))}


def resolve_config_path(path: str | Path):
    """A config file: the path itself if it exists, else the shipped config of that name
    (``quick``, ``quick.yaml`` or ``configs/quick.yaml``: the repository's ``configs/`` is what the
    package ships). A shipped config is an :mod:`importlib.resources` traversable (``read_text``)."""
    p = Path(path)
    if p.is_file():
        return p
    shipped = shipped_configs()
    stem = p.stem if p.suffix in (".yaml", ".yml") else p.name
    if p.parent in (Path("."), Path("configs")) and stem in shipped:
        return shipped[stem]
    raise ConfigError(f"config file not found: {p} (shipped configs: {sorted(shipped)})")


def load_config(path: str | Path) -> TrainConfig:
    """Read and validate a training config (YAML). Errors name the file and the key."""
    p = resolve_config_path(path)
    try:
        data = yaml.safe_load(p.read_text())
    except yaml.YAMLError as e:
        raise ConfigError(f"{p}: not valid YAML: {e}") from None
    try:
        return TrainConfig.from_dict(data)
    except ConfigError as e:
        raise ConfigError(f"{p}: {e}") from None


def dump_config(cfg: TrainConfig, path: str | Path) -> None:
    Path(path).write_text(yaml.safe_dump(cfg.to_dict(), sort_keys=False))
