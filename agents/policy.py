"""A trained agent as a controller: ``load_policy(run_dir, env)`` (used by the benchmark harness,
``cepam-gym bench --controller runs/<run>``) and the evaluation loop used during training.

A run directory (written by ``cepam-gym train``) holds ``config.yaml`` and the models:
``best_model.zip`` (best periodic evaluation), ``model.zip`` (end of training) and
``checkpoints/``; each with its ``VecNormalize`` statistics if the config normalizes observations.
"""

from __future__ import annotations

import pickle
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cepam_gym.cli_errors import guarded_load
from cepam_gym.errors import InputError
from cepam_gym.policies import Features, FeatureSpec, obs_batch

from .config.agent import feature_spec
from .config.files import TrainConfig, algorithm_class
from .learners.bc_policy import BCPolicy, is_bc_run, load_bc_policy
from .session.model_files import (
    NORMALIZER_NAMES,
    ZOO_RECORD,
    algorithm_of,
    normalizer_beside,
    zoo_normalizes_obs,
    zoo_params_dir,
    zoo_record,
)
from .session.torch_threads import inference_threads

MODEL_CHOICES = ("best", "final", "latest")


class AgentPolicy:
    """Deterministic policy of a trained model: ``act(obs)`` maps (N, obs_dim) -> (N, 2) float32
    or (obs_dim,) -> (2,), through the run's features, observation normalization and residual."""

    def __init__(self, model, features: Features, normalizer=None):
        self.model = model
        self.features = features
        self.normalizer = normalizer
        self.obs_dim = features.raw_dim
        want = model.observation_space.shape
        if want != (features.dim,):
            raise InputError(
                f"the model expects observations of shape {want}, the features give "
                f"({features.dim},): wrong env for this agent?"
            )
        if model.action_space.shape != (features.n_actions,):
            raise InputError(
                f"the model sends actions of shape {model.action_space.shape}, the agent config "
                f"expects ({features.n_actions},): wrong env for this agent?"
            )
        # a recurrent policy (RecurrentPPO) carries its LSTM state between calls
        self.recurrent = hasattr(model.policy, "lstm_actor")
        self._lstm = None
        self._starts: np.ndarray | None = None

    def reset(self, indices=None) -> None:
        self.features.reset(indices)
        if indices is None or self._starts is None:
            self._lstm = self._starts = None
        else:
            self._starts[np.asarray(indices)] = True

    def act(self, obs, info=None) -> np.ndarray:
        o, single = obs_batch(obs, self.obs_dim)
        f, base = self.features(o)
        if self.normalizer is not None:
            f = self.normalizer.normalize_obs(f)
        if self.recurrent:
            if self._starts is None or len(self._starts) != len(o):
                self._lstm, self._starts = None, np.ones(len(o), dtype=bool)
            a, self._lstm = self.model.predict(
                f, state=self._lstm, episode_start=self._starts, deterministic=True
            )
            self._starts[:] = False
        else:
            a, _ = self.model.predict(f, deterministic=True)
        out = self.features.action(np.asarray(a, dtype=np.float32).reshape(len(o), -1), base)
        if self.features.window is not None:  # the identification window's excitation drives there
            in_window, excitation = self.features.window
            out = np.where(in_window[:, None], excitation, out).astype(np.float32)
        return out[0] if single else out


# --------------------------------------------------------------------------- loading
def _files(run: Path, which: str) -> tuple[Path, Path | None]:
    """(model zip, VecNormalize pickle or None) of a run directory."""
    from .session.checkpoints import SAVED, read_index

    candidates = {kind: (run / model, run / norm) for kind, (model, norm) in SAVED.items()}
    meta = read_index(run)
    if meta is not None:
        candidates["latest"] = (
            run / meta["model"],
            run / meta["vecnormalize"] if meta.get("vecnormalize") else None,
        )
    order = [which] if which != "auto" else ["best", "final", "latest"]
    for key in order:
        if key in candidates and candidates[key][0].is_file():
            model, norm = candidates[key]
            return model, norm if norm is not None and norm.is_file() else None
    raise FileNotFoundError(
        f"no {'model' if which == 'auto' else which + ' model'} in run directory {run} "
        f"(looked for best_model.zip, model.zip, checkpoints/latest.json)"
    )


def load_run_config(run: str | Path) -> TrainConfig:
    import yaml

    path = Path(run) / "config.yaml"
    if not path.is_file():
        raise FileNotFoundError(f"{run} is not a training run directory: no config.yaml")
    return guarded_load(path, "run config", lambda: TrainConfig.from_dict(yaml.safe_load(path.read_text())))


def load_normalizer(path: Path | None):
    if path is None:
        return None

    def load():
        with open(path, "rb") as f:
            return pickle.load(f)

    vn = guarded_load(path, "observation normalizer", load)
    return vn if vn.norm_obs else None


@dataclass(frozen=True)
class ModelFiles:
    """A model to load and what came with it: its VecNormalize statistics (``None`` if none was
    found), the ``cepam-gym train`` run directory holding its ``config.yaml`` and RL Zoo3's
    ``<env name>/`` folder (each ``None`` when absent: a bare SB3 model has neither)."""

    model: Path
    normalizer: Path | None
    run: Path | None = None
    zoo: Path | None = None

    def env_id(self) -> str | None:
        """The env id the model was trained on, where its record names it."""
        if self.run is not None:
            return load_run_config(self.run).env.id
        if self.zoo is not None:
            return zoo_record(self.zoo, ZOO_RECORD).get("env")
        return None


def locate(spec: str | Path, which: str = "auto") -> ModelFiles:
    """The files of the agent ``spec`` names: a run directory of ``cepam-gym train`` (``which``
    model), an RL Zoo3 run folder, or a model ``.zip`` (with the run directory around it, if any)."""
    spec = Path(spec)
    if which not in (*MODEL_CHOICES, "auto"):
        raise InputError(f"which must be one of {('auto',) + MODEL_CHOICES}, got {which!r}")
    if spec.suffix == ".zip":
        if not spec.is_file():
            raise InputError(f"model file {spec} does not exist")
        runs = [d for d in (spec.parent, spec.parent.parent) if (d / "config.yaml").is_file()]
        run = runs[0] if runs and (runs[0] == spec.parent or spec.parent.name == "checkpoints") else None
        return ModelFiles(spec, normalizer_beside(spec), run, zoo_params_dir(spec.parent))
    if not spec.is_dir():
        raise InputError(
            f"unknown controller {str(spec)!r}: not a run directory or model .zip "
            f"(use baseline, zero, random, or a trained agent's run directory)"
        )
    if (spec / "config.yaml").is_file():
        model, norm = _files(spec, which)
        return ModelFiles(model, norm or normalizer_beside(model), spec, zoo_params_dir(spec))
    if (zoo := zoo_params_dir(spec)) is not None:  # RL Zoo3: best_model.zip, <env name>.zip
        names = {"best": "best_model.zip", "final": f"{zoo.name}.zip"}
        for key in ["best", "final"] if which == "auto" else [which]:
            if key in names and (spec / names[key]).is_file():
                model = spec / names[key]
                return ModelFiles(model, normalizer_beside(model), None, zoo)
        raise InputError(f"no {which} model in RL Zoo3 run {spec} (looked for {sorted(names.values())})")
    raise InputError(f"{spec} is not a training run directory: no config.yaml (nor an RL Zoo3 run)")


def _normalizer(files: ModelFiles, cfg: TrainConfig | None):
    """The observation normalizer the model was trained with; refused (``InputError``) when its
    record says it normalised observations and no statistics are found, never dropped silently."""
    if cfg is not None:
        wants, record = cfg.normalize.obs, f"normalize.obs in {files.run / 'config.yaml'}"
    elif files.zoo is not None:
        wants, record = zoo_normalizes_obs(files.zoo), f"normalize in {files.zoo / 'config.yml'}"
    else:
        wants, record = None, None
    if files.normalizer is not None:
        return load_normalizer(files.normalizer)
    if wants:
        raise InputError(
            f"{files.model} was trained on normalised observations ({record}) but no VecNormalize "
            f"statistics are beside it (looked for: {'; '.join(NORMALIZER_NAMES)}): refusing to score "
            "it without them"
        )
    if wants is None:
        warnings.warn(
            f"no VecNormalize statistics beside {files.model} (looked for: {'; '.join(NORMALIZER_NAMES)}) "
            "and no record says it was trained without: scoring it on raw observations",
            stacklevel=3,
        )
    return None


def load_policy(spec: str | Path, env, which: str = "auto") -> AgentPolicy | BCPolicy:
    """The agent of a run directory (or ``run_dir/<file>.zip``, an RL Zoo3 run, a bare SB3 model
    ``.zip``), ready to act on ``env`` (a Gymnasium single or vector CE-PAM env, or the SB3
    adapter), with the observation normalisation it was trained with (:func:`_normalizer`).
    ``which``: ``auto`` (best model, else final, else the latest checkpoint), ``best``, ``final``
    or ``latest``. A behaviour-cloning run directory (:mod:`cepam_gym_agents.bc`) gives its
    :class:`~cepam_gym_agents.learners.bc_policy.BCPolicy`. A model without a ``config.yaml`` drives the
    valves directly (no baseline features), as RL Zoo3 and plain SB3 train."""
    import torch

    if is_bc_run(Path(spec)):  # a behaviour-cloning run (python -m cepam_gym_agents.bc): its own files
        return load_bc_policy(Path(spec), env)
    files = locate(spec, which)
    cfg = load_run_config(files.run) if files.run is not None else None
    from cepam_gym.envs.model import model_of

    env_model = model_of(env)
    if cfg is not None:
        trained_mode = cfg.env.kwargs.get("action_mode", "valve")
    else:
        trained_mode = zoo_record(files.zoo, "config.yml").get("env_kwargs", {}) if files.zoo else {}
        trained_mode = (trained_mode or {}).get("action_mode", "valve")
    if env_model.action_mode != trained_mode:
        raise InputError(
            f"agent {spec} was trained with action_mode={trained_mode!r}, "
            f"the env uses {env_model.action_mode!r}"
        )
    algorithm = cfg.algorithm if cfg is not None else algorithm_of(files.model)
    torch.set_num_threads(inference_threads(cfg.torch_threads) if cfg is not None else 1)
    model = guarded_load(
        files.model,
        f"{algorithm} model",
        algorithm_class(algorithm).load,
        str(files.model),
        device="cpu",
    )
    normalizer = _normalizer(files, cfg)
    features = Features(env, feature_spec(cfg.agent) if cfg is not None else FeatureSpec(), env_model.obs_dim)
    if features.plant_dim and files.run is not None:  # told the plant: its adaptation module, if fitted
        from cepam_gym.policies.plant_estimate import PlantEstimator

        if (files.run / PlantEstimator.FILE).is_file():
            features.plant_estimator = PlantEstimator.load(files.run / PlantEstimator.FILE)
    return AgentPolicy(model, features, normalizer)


# --------------------------------------------------------------------------- evaluation
def evaluate(make_policy, env_id: str, env_kwargs: dict, episodes: int, seed: int, spec=None) -> dict:
    """Score the policy ``make_policy(venv)`` builds for the eval env (an object with
    ``reset``/``act``) on ``episodes`` seeded episodes with the benchmark's rollout and metrics
    (``spec``: the suite's :class:`~cepam_gym.bench.metrics.TraceSpec`, default the v0 rig's)."""
    from cepam_gym.bench.harness import record
    from cepam_gym.bench.metrics import RIG, score_traces

    spec = RIG if spec is None else spec
    tr, track_k = record(make_policy, env_id, env_kwargs, episodes, seed, spec=spec)
    return score_traces(tr, track_k, spec)


def baseline_score(env_id: str, env_kwargs: dict, episodes: int, seed: int, spec=None) -> float | None:
    """The inverse-model baseline's score on the episodes :func:`evaluate` scores an agent on (the
    same env, seed and episodes; 0.5 s for 16 episodes on a busy 2-core machine), to show beside
    the agent's; None
    where the baseline cannot drive the env."""
    from cepam_gym.control import make_controller
    from cepam_gym.control.baseline import UnsupportedEnvError
    from cepam_gym.errors import InputError

    try:
        m = evaluate(lambda venv: make_controller("baseline", venv), env_id, env_kwargs, episodes, seed, spec)
    except (InputError, UnsupportedEnvError):
        return None
    return float(m["score"])


def trained_env_id(spec: str | Path) -> str | None:
    """The env id the agent ``spec`` (what :func:`load_policy` takes) was trained on, as its record
    names it (``config.yaml``, RL Zoo3's ``args.yml``); None for a behaviour-cloning run or a bare
    model without a record. ``cepam-gym bench`` reads it (as ``load_policy.env_id_of``) to score an
    agent on its own id's headline suites."""
    if is_bc_run(Path(spec)):
        return None
    return locate(spec).env_id()


load_policy.env_id_of = trained_env_id  # the loader protocol of cepam_gym.control.registry.agent_env_id
