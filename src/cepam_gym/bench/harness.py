"""Run any controller on the fixed suites and score it (``cepam-gym bench``)."""

from __future__ import annotations

import numpy as np

from ..control import make_controller
from ..control.trivial import RandomController, ZeroController  # noqa: F401  (their old home)
from ..envs.id_window import INFO_KEY as WINDOW_KEY
from ..envs.model import NoModelError, model_of
from ..progress import advance
from .metrics import RIG, TraceSpec, score_traces
from .suites import SUITES, Suite

TRACE_KEYS = tuple(RIG.info_keys)  # the trace columns (a suite's TraceSpec maps them to info keys)


def _env_facts(venv) -> tuple[int, float, bool, int]:
    """``(n_steps, control_dt, tracks_stiffness, window_steps)`` of an env on the batched kernel
    (its plant model, :func:`~cepam_gym.envs.model.model_of`) or of a gymnasium vector env of
    single envs (``get_attr``: ``n_steps``, ``control_dt``, ``task``; the MuJoCo joint)."""
    try:
        model = model_of(venv)
    except NoModelError:
        pass
    else:
        return model.n_steps, model.control_dt, model.track_stiffness, model.window_steps
    n_steps, dt, task = (venv.get_attr(k)[0] for k in ("n_steps", "control_dt", "task"))
    return int(n_steps), float(dt), bool(getattr(task, "track_stiffness", True)), 0


def drop_window(traces: dict, window: np.ndarray) -> dict:
    """The traces of :func:`record` without the identification window's steps (``window`` (T, N)
    bool, ``info["window"]``: :mod:`cepam_gym.envs.id_window`): the leading rows in which every
    episode is in its window. An episode that failed in its window stays failed (a later window
    of the env, after its autoreset, is not scored: the episode is no longer alive)."""
    lead = int(np.argmin(window.all(axis=1))) if not window.all() else len(window)
    return {k: v[lead:] if isinstance(v, np.ndarray) and v.ndim == 2 else v for k, v in traces.items()}


def record(
    make_policy,
    env_id: str,
    env_kwargs: dict,
    episodes: int,
    seed: int,
    max_steps: int | None = None,
    spec: TraceSpec = RIG,
    observer=None,
) -> tuple[dict, bool]:
    """Run the policy ``make_policy(venv)`` builds (an object with ``reset``/``act``) on
    ``episodes`` seeded episodes in one batched env; return ``(traces, tracks_stiffness)`` with
    the traces :func:`~cepam_gym.bench.metrics.score_traces` scores; ``spec.info_keys`` says which
    ``info`` key fills each trace column. The one rollout loop of the harness, of the agents'
    periodic evaluation and of the offline datasets: ``observer`` (optional) is told
    ``start(obs, info)`` after the reset and ``step(actions, obs, rewards, terminated, truncated,
    info)`` after every step (:mod:`cepam_gym.offline.episodes` keeps the transitions). An
    identification window (:mod:`cepam_gym.envs.id_window`) is run and left out of the traces
    (:func:`drop_window`); ``max_steps`` counts the steps after it."""
    import gymnasium as gym

    venv = gym.make_vec(env_id, num_envs=episodes, **env_kwargs)
    n_steps, control_dt, track_k, n_window = _env_facts(venv)
    steps = n_window + max_steps if max_steps else n_steps
    policy = make_policy(venv)
    obs, info = venv.reset(seed=seed)
    policy.reset()
    if observer is not None:
        observer.start(obs, info)
    tr = {k: np.zeros((steps, episodes)) for k in TRACE_KEYS}
    tr["reward"] = np.zeros((steps, episodes))
    tr["alive"] = np.ones((steps, episodes), dtype=bool)
    window = np.zeros((steps, episodes), dtype=bool)
    alive = np.ones(episodes, dtype=bool)
    for t in range(steps):
        actions = policy.act(obs, info)
        obs, reward, term, trunc, info = venv.step(actions)
        if observer is not None:
            observer.step(actions, obs, reward, term, trunc, info)
        src = info.get("final_info", info) if (term | trunc).any() else info
        for k in TRACE_KEYS:
            tr[k][t] = src[spec.info_keys[k]]
        if n_window:
            window[t] = src[WINDOW_KEY]
        tr["reward"][t] = reward
        tr["alive"][t] = alive
        alive &= ~term
        if (term | trunc).any():
            policy.reset(np.flatnonzero(term | trunc))
        advance(1 / steps)
    tr["failed"] = ~alive
    tr["dt"] = control_dt
    venv.close()
    return (drop_window(tr, window) if n_window else tr), track_k


def run_suite(
    controller_spec: str,
    suite: Suite | str,
    episodes: int | None = None,
    max_steps: int | None = None,
    **controller_options,
) -> tuple[dict, dict]:
    """Run ``episodes`` seeded episodes of a suite under the controller ``controller_spec`` names
    (:func:`cepam_gym.control.make_controller`, given ``controller_options``); return
    ``(metrics, traces)``."""
    suite = SUITES[suite] if isinstance(suite, str) else suite
    tr, track_k = record(
        lambda venv: make_controller(controller_spec, venv, **controller_options),
        suite.env_id,
        suite.env_kwargs,
        episodes or suite.episodes,
        suite.seed,
        max_steps,
        suite.traces,
    )
    metrics = {"suite": suite.name, "controller": controller_spec, **score_traces(tr, track_k, suite.traces)}
    return metrics, tr


# the oracle's check: its score and return on the first CHECK_STEPS control steps (3 s) of the
# first CHECK_EPISODES episodes of a suite, stored beside its full score. The test suite re-runs
# this short run (a change of the plant, the suite or the oracle moves it as it moves the full
# score): the oracle's cost is that of simulating its candidate plans, in proportion to the
# episodes and the steps it drives.
CHECK_STEPS = 150
CHECK_EPISODES = 3


def seeded(name: str, seed: int | None = None) -> Suite:
    """Suite ``name``, its episodes drawn from ``seed`` instead of its own (None: its own)."""
    import dataclasses

    suite = SUITES[name]
    return suite if seed is None else dataclasses.replace(suite, seed=seed)


def measure_references(name: str, episodes: int | None = None, seed: int | None = None) -> dict:
    """The zero controller's, the baseline's and the oracle's scores on suite ``name`` (its
    episodes drawn from ``seed``, default its own), the zero controller's and the oracle's mean
    episode returns, and the oracle's check (``oracle_check``: :func:`oracle_check`): an entry of
    the stored references (:mod:`cepam_gym.bench.references`) with the episodes it was measured
    on."""
    suite = seeded(name, seed)
    zero, _ = run_suite("zero", suite, episodes)
    baseline, _ = run_suite("baseline", suite, episodes)
    oracle, _ = run_suite("oracle", suite, episodes)
    return {
        "seed": suite.seed,
        "episodes": zero["episodes"],
        "zero": zero["score"],
        "baseline": baseline["score"],
        "oracle": oracle["score"],
        "zero_return": zero["mean_return"],
        "oracle_return": oracle["mean_return"],
        "oracle_check": oracle_check(name, seed),
    }


def oracle_check(name: str, seed: int | None = None) -> dict:
    """The oracle on the first :data:`CHECK_STEPS` control steps of the first
    :data:`CHECK_EPISODES` episodes of suite ``name`` (drawn from ``seed``, default its own;
    ``{"episodes", "steps", "score", "mean_return"}``): what ``measure_references`` stores and
    the test suite re-runs."""
    suite = seeded(name, seed)
    tr, track_k = record(
        lambda venv: make_controller("oracle", venv),
        suite.env_id,
        suite.env_kwargs,
        min(CHECK_EPISODES, suite.episodes),
        suite.seed,
        CHECK_STEPS,
        suite.traces,
    )
    m = score_traces(tr, track_k, suite.traces)
    return {
        "episodes": tr["alive"].shape[1],
        "steps": len(tr["alive"]),
        "score": m["score"],
        "mean_return": m["mean_return"],
    }
