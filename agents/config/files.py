"""Training configs: YAML files (``configs/``, shipped as package data) read into frozen dataclasses
(:mod:`.schema`), validated on load. This module finds and reads the files and is where every
config name is imported from.

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
      start_at_base: false        # with residual or target_shift: the untrained policy is its base
      baseline_in_obs: false      # append the baseline's action to the observation
      history: 1                  # stack this many consecutive observations
      target_shift: false         # true: the policy also shifts the baseline's length/stiffness targets
      target_shift_length_mm: 5.0
      target_shift_angle_deg: 2.0 # the hinge ids: the joint angle's shift instead of the length's
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

from pathlib import Path

import yaml

# the public names of the config, importable from here as before the split
from ..learners.algorithm import ACTIVATIONS, ALGORITHMS, NOISE_TYPES, ON_POLICY, algorithm_class, policy_name
from .checks import ConfigError, parse_number
from .schema import (
    AgentConfig,
    CheckpointConfig,
    EnvConfig,
    EvalConfig,
    NormalizeConfig,
    TrainConfig,
)

__all__ = [
    "ACTIVATIONS",
    "ALGORITHMS",
    "NOISE_TYPES",
    "ON_POLICY",
    "AgentConfig",
    "CheckpointConfig",
    "ConfigError",
    "EnvConfig",
    "EvalConfig",
    "NormalizeConfig",
    "TrainConfig",
    "algorithm_class",
    "dump_config",
    "load_config",
    "parse_number",
    "policy_name",
    "resolve_config_path",
    "shipped_configs",
]


def shipped_configs() -> dict:
    """The configs shipped with the package, by name (``quick`` -> ``quick.yaml``): ``configs/``
    of the repository, installed as the package data ``cepam_gym_agents.configs``."""
    from importlib.resources import files

    root = files("cepam_gym_agents.configs")
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
