"""Ray RLlib integration: an env creator that seeds every env runner and sub-env differently.

Needs the ``[distributed]`` extra (``pip install "cepam-gym[distributed]"``). Ray is imported only
inside :func:`register_env`, so importing this module (and ``import cepam_gym``) stays light.

Usage (new API stack)::

    from ray.rllib.algorithms.ppo import PPOConfig
    from cepam_gym.integrations.rllib import register_env

    name = register_env()                       # "cepam_gym", in Ray's env registry
    config = (PPOConfig()
              .environment(name, env_config={"id": "cepam_gym/CEPAM-v3", "seed": 0,
                                             "sensor_noise": {"length_mm": 0.2}})
              .env_runners(num_env_runners=2))
    algo = config.build_algo()

``env_config`` holds the env's own kwargs (``randomize``, ``sensor_noise``, ``reward_weights``,
``task_options``, ...; see :class:`cepam_gym.envs.cepam.CEPAMEnv`) plus :data:`EXTRA_KEYS`:

* ``id``: the Gymnasium id (default the recommended ``cepam_gym/CEPAM-v3``);
* ``seed``: base seed (int >= 0, or ``None`` for fresh OS entropy);
* ``max_episode_steps``: override the registration's 500.

Unknown keys raise ``ValueError`` naming the key.

Seeding. Every env gets its own seed, ``env_seed(seed, worker_index, vector_index, instance)``: a
``numpy.random.SeedSequence`` with the base seed as entropy and the indices as spawn key, so
streams are independent (no ``seed + i`` overlaps between runners). ``instance`` numbers the envs
this process made for the same (worker_index, vector_index): RLlib's new API stack hands the same
``EnvContext`` (``vector_index`` 0) to all ``num_envs_per_env_runner`` sub-envs of a runner, so the
creation order is what tells them apart. If RLlib itself passes a seed to ``reset`` (when the
algorithm config sets ``.debugging(seed=S)``: the runner resets its vector env with
``S + worker_index``, which Gymnasium's sync vector env spreads as ``+ i`` over sub-envs), that
seed replaces the base seed in the same derivation, so it too gives distinct, reproducible streams.

Use RLlib's default ``gym_env_vectorize_mode="sync"``. ``"vector_entry_point"`` (our native
batched env) is rejected: RLlib 2.60 passes the creator ``env_ctx | {"num_envs": n}``, a plain
dict without ``worker_index``, so every runner would be seeded alike. ``"async"`` runs the creator
in one subprocess per sub-env, where each creation is the first, so sub-envs of one runner then
share a seed unless RLlib's own ``.debugging(seed=...)`` is set.
"""

from __future__ import annotations

import inspect
from collections import defaultdict
from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np

from ..errors import InputError
from ..registration import ENV_IDS, JOINT_ENV_IDS, MUJOCO_ENV_IDS, register_envs
from ..versions import RECOMMENDED_ID

DEFAULT_ID = RECOMMENDED_ID
DEFAULT_NAME = "cepam_gym"
EXTRA_KEYS = ("id", "seed", "max_episode_steps")
INSTALL_HINT = 'Ray RLlib is not installed: pip install "cepam-gym[distributed]"'

# envs made so far in this process per (base seed, worker_index, vector_index); see module doc
_instances: defaultdict[tuple, int] = defaultdict(int)


def _require_ray():
    try:
        import ray  # noqa: F401
        from ray.tune.registry import register_env as ray_register_env
    except ImportError as e:
        raise ImportError(INSTALL_HINT) from e
    return ray_register_env


def env_seed(base_seed: int | None, worker_index: int = 0, vector_index: int = 0, instance: int = 0) -> int:
    """The seed of one env: base seed (``None``: fresh OS entropy) spawned by the indices.

    63 bits: a non-negative int64, as Gymnasium's and numpy's seeding take it."""
    for name, v in (("worker_index", worker_index), ("vector_index", vector_index), ("instance", instance)):
        if int(v) != v or v < 0:
            raise InputError(f"{name} must be a non-negative integer, got {v!r}")
    ss = np.random.SeedSequence(base_seed, spawn_key=(int(worker_index), int(vector_index), int(instance)))
    return int(ss.generate_state(1, np.uint64)[0] >> np.uint64(1))


def valid_keys(env_id: str) -> tuple[str, ...]:
    """env_config keys accepted for ``env_id``: the env's constructor kwargs plus EXTRA_KEYS."""
    register_envs()
    known = sorted(ENV_IDS) + sorted(JOINT_ENV_IDS) + sorted(MUJOCO_ENV_IDS)
    if env_id not in known:
        raise InputError(f"env_config['id']: unknown id {env_id!r}; valid: {known}")
    if env_id in JOINT_ENV_IDS:
        from ..envs.core import CEPAMBatch
        from ..envs.joint import CEPAMJointKernelEnv

        # as the rig's: the env forwards **kwargs to CEPAMBatch (the joint's geometry included)
        sources = (CEPAMJointKernelEnv.__init__, CEPAMBatch.__init__)
        fixed = {"task", "num_envs"}
    elif env_id in ENV_IDS:
        from ..envs.cepam import CEPAMEnv
        from ..envs.core import CEPAMBatch

        # CEPAMEnv forwards **kwargs to CEPAMBatch; the task comes from the id
        sources = (CEPAMEnv.__init__, CEPAMBatch.__init__)
        fixed = {"task", "num_envs"}
    else:
        from gymnasium.envs.registration import load_env_creator

        sources = (load_env_creator(MUJOCO_ENV_IDS[env_id]).__init__,)  # imports the [mujoco] extra
        fixed = set()
    names = {
        p.name
        for f in sources
        for p in inspect.signature(f).parameters.values()
        if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)
    }
    return tuple(sorted(names - {"self"} - fixed)) + EXTRA_KEYS


def check_env_config(env_config: Mapping[str, Any]) -> tuple[str, int | None, dict[str, Any]]:
    """Split and validate an env_config: ``(id, base seed, kwargs for gym.make)``."""
    if not isinstance(env_config, Mapping):
        raise TypeError(f"env_config must be a mapping, got {type(env_config).__name__}")
    if "num_envs" in env_config:
        raise InputError(
            "env_config['num_envs']: got RLlib's gym_env_vectorize_mode='vector_entry_point', "
            "which drops the EnvContext (worker_index), so runners could not be seeded "
            "apart; use the default gym_env_vectorize_mode='sync' and "
            "env_runners(num_envs_per_env_runner=n)"
        )
    env_id = env_config.get("id", DEFAULT_ID)
    if not isinstance(env_id, str):
        raise TypeError(f"env_config['id'] must be a string, got {env_id!r}")
    allowed = valid_keys(env_id)
    unknown = sorted(set(env_config) - set(allowed), key=str)
    if unknown:
        more = f" (and {unknown[1:]})" if unknown[1:] else ""
        raise InputError(
            f"env_config: unknown key {unknown[0]!r}{more} for {env_id}; valid keys: {list(allowed)}"
        )
    seed = env_config.get("seed")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0):
        raise InputError(f"env_config['seed'] must be a non-negative integer or None, got {seed!r}")
    kwargs = {k: v for k, v in env_config.items() if k not in ("id", "seed")}
    return env_id, (None if seed is None else int(seed)), kwargs


class RunnerSeeded(gym.Wrapper):
    """Seeds the wrapped env with its own derived seed (see the module doc).

    ``runner_seed`` is the seed of the first reset when RLlib passes none; a seed passed to
    ``reset`` is re-derived with the same indices."""

    def __init__(
        self, env: gym.Env, base_seed: int | None, worker_index: int, vector_index: int, instance: int
    ):
        super().__init__(env)
        self.worker_index, self.vector_index, self.instance = worker_index, vector_index, instance
        self.runner_seed = env_seed(base_seed, worker_index, vector_index, instance)
        self._seeded = False

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        if seed is not None:
            seed = env_seed(seed, self.worker_index, self.vector_index, self.instance)
        elif not self._seeded:
            seed = self.runner_seed
        self._seeded = True
        return self.env.reset(seed=seed, options=options)


def make_env(env_config: Mapping[str, Any]) -> gym.Env:
    """RLlib env creator: ``env_config`` is RLlib's ``EnvContext`` (a dict with ``worker_index``
    and ``vector_index`` attributes) or a plain dict (indices 0)."""
    env_id, base_seed, kwargs = check_env_config(env_config)
    worker_index = int(getattr(env_config, "worker_index", 0) or 0)  # None on a local runner
    vector_index = int(getattr(env_config, "vector_index", 0) or 0)
    key = (base_seed, worker_index, vector_index)
    instance = _instances[key]
    _instances[key] += 1
    env = gym.make(env_id, **kwargs)
    return RunnerSeeded(env, base_seed, worker_index, vector_index, instance)


def register_env(name: str = DEFAULT_NAME) -> str:
    """Register :func:`make_env` in Ray's env registry under ``name``; returns ``name``.

    Call it in the driver before building the algorithm (Ray ships the registry to the env
    runners; they import ``cepam_gym`` by reference, so it must be installed on every node)."""
    if not isinstance(name, str) or not name:
        raise InputError(f"name must be a non-empty string, got {name!r}")
    ray_register_env = _require_ray()
    ray_register_env(name, make_env)
    return name
