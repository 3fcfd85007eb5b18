"""Record a Minari dataset of a controller on a benchmark suite: the episodes the benchmark
scores (the suite's seed, its batched env, the controller acting on the whole batch), unless
another seed is asked for."""

from __future__ import annotations

import time

from ..bench.harness import record
from ..bench.headline import headline_score
from ..bench.metrics import normalized_score, score_traces
from ..bench.references import stored_entry
from ..bench.suites import SUITES, Suite
from ..control import check_controller_spec, make_controller
from ..control.baseline import UnsupportedEnvError
from ..envs.model import model_of
from ..errors import InputError
from . import naming, store
from .episodes import EpisodeRecorder


def check_inputs(
    suite: str,
    controller: str,
    episodes: int | None = None,
    max_steps: int | None = None,
    name: str | None = None,
    dataset_version: int = 0,
) -> tuple[Suite, str]:
    """``(suite, dataset id)``; ``InputError`` naming the first bad input, before any work (and
    before Minari is needed)."""
    if suite not in SUITES:
        raise InputError(f"unknown suite {suite!r}: choose from {', '.join(SUITES)}")
    check_controller_spec(controller)
    if episodes is not None and episodes < 1:
        raise InputError(f"--episodes must be >= 1, got {episodes}")
    full = _full_steps(SUITES[suite])
    if max_steps is not None and not 1 <= max_steps <= full:
        raise InputError(f"--max-steps must be in 1..{full} (the episode's length), got {max_steps}")
    return SUITES[suite], naming.dataset_id(SUITES[suite], controller, name, dataset_version)


def _controller(spec: str, suite: Suite):
    """``make_policy(venv)`` for the harness; a controller built for another kind of env (the rig's
    MPC on the joint) is bad input here, where the benchmark would skip the pair."""

    def make(venv):
        try:
            return make_controller(spec, venv)
        except UnsupportedEnvError as e:
            raise InputError(f"controller {spec!r} cannot drive suite {suite.name}: {e}") from e

    return make


def record_dataset(
    suite: str,
    controller: str,
    episodes: int | None = None,
    *,
    seed: int | None = None,
    max_steps: int | None = None,
    name: str | None = None,
    dataset_version: int = 0,
    overwrite: bool = False,
) -> dict:
    """Record ``episodes`` (default: the suite's 20) episodes of ``controller`` on ``suite`` (its
    seed unless ``seed``; at most ``max_steps`` steps each, default the env's 500) into the Minari
    dataset :func:`~cepam_gym.offline.naming.dataset_id` names. Returns a summary: ``dataset_id``,
    ``path``, the benchmark ``score`` of the recorded episodes, its ``headline`` and ``normalized``
    scores (against the suite's references: the benchmark's own when the episodes are the suite's),
    ``steps``, ``record_seconds``, ``size_mb``."""
    s, dataset_id = check_inputs(suite, controller, episodes, max_steps, name, dataset_version)
    store.require_minari()
    store.check_free(dataset_id, overwrite)  # fail before the rollout, which can take minutes
    n = episodes or s.episodes
    seed = s.seed if seed is None else int(seed)
    make = _controller(controller, s)
    built = []

    def make_and_keep(venv):
        built.append(venv)
        return make(venv)

    recorder = EpisodeRecorder(n, plants=lambda: model_of(built[0]).params)
    t0 = time.perf_counter()
    tr, track_k = record(
        make_and_keep,
        s.env_id,
        s.env_kwargs,
        n,
        seed,
        max_steps,
        s.traces,
        observer=recorder,
    )
    seconds = time.perf_counter() - t0
    metrics = score_traces(tr, track_k, s.traces)
    steps = int(tr["alive"].shape[0])
    ref = stored_entry(s.name, s.episodes, s.seed) or {}
    score = metrics["score"]
    summary = {
        "dataset_id": dataset_id,
        "suite": s.name,
        "controller": str(controller),
        "episodes": n,
        "seed": seed,
        "max_steps": steps,
        # the benchmark's measures of exactly these episodes (same episodes as the bench: same score)
        "score": metrics["score"],
        "score_ci95": metrics["score_ci95"],
        "failure_rate": metrics["failure_rate"],
        "mean_return": metrics["mean_return"],
        "headline": headline_score(score, ref["baseline"], ref["oracle"]) if "baseline" in ref else None,
        "normalized": normalized_score(score, ref["zero"], ref["oracle"]) if ref else None,
        "suite_episodes": (seed, n, steps) == (s.seed, s.episodes, _full_steps(s)),
        "record_seconds": seconds,
    }
    dataset = store.write(
        dataset_id,
        recorder.episodes(),
        s,
        seed=seed,
        controller=controller,
        extra={f"cepam_{k}": v for k, v in summary.items() if k != "dataset_id"},
        max_episode_steps=steps,
        overwrite=overwrite,
    )
    summary["steps"] = int(dataset.total_steps)
    summary["path"] = str(store.dataset_path(dataset_id))
    summary["size_mb"] = float(dataset.storage.metadata.get("dataset_size", float("nan")))
    return summary


def _full_steps(suite: Suite) -> int:
    import gymnasium as gym

    return int(gym.spec(suite.env_id).max_episode_steps)
