"""Run any controller on the fixed suites and score it (``cepam-gym bench``)."""

from __future__ import annotations

import sys

import numpy as np

import cepam_gym  # noqa: F401  (registers the ids)

from .metrics import RIG, TraceSpec, score_traces
from .suites import SUITES, Suite

TRACE_KEYS = tuple(RIG.info_keys)  # the trace columns (a suite's TraceSpec maps them to info keys)


class ZeroController:
    """All valves closed (or zero set-points): the plant drifts under the load."""

    def __init__(self, env):
        self.n = None

    def reset(self, indices=None):
        pass

    def act(self, obs, info=None):
        return np.zeros(np.shape(obs)[:-1] + (2,), dtype=np.float32)


class RandomController:
    """Uniform random commands, seeded."""

    def __init__(self, env, seed: int = 0):
        self.rng = np.random.default_rng(seed)

    def reset(self, indices=None):
        pass

    def act(self, obs, info=None):
        return self.rng.uniform(-1, 1, np.shape(obs)[:-1] + (2,)).astype(np.float32)


def make_controller(spec: str, env):
    """``baseline``, ``zero``, ``random``, or a run directory / model file of a trained agent.
    On a joint env (``cepam_gym/CEPAMJoint-v0``) the joint's controllers
    (:func:`cepam_gym.mujoco.joint.make_joint_controller`)."""
    if _is_joint_env(env):
        from ..mujoco.joint import make_joint_controller

        return make_joint_controller(spec, env)
    if spec == "baseline":
        from ..control import InverseStaticController

        return InverseStaticController(env)
    if spec == "zero":
        return ZeroController(env)
    if spec == "random":
        return RandomController(env)
    try:
        from agents.policy import load_policy  # the [train] extra; issue 5
    except ImportError as e:
        raise ValueError(f"unknown controller {spec!r}: use baseline, zero, random, or a trained "
                         f"agent's run directory (needs the [train] extra: {e})") from None
    return load_policy(spec, env)


def _is_joint_env(env) -> bool:
    # a joint env exists only once its module is imported: never import mujoco just to check
    joint = sys.modules.get("cepam_gym.mujoco.joint")
    if joint is None:
        return False
    try:
        joint._joint_env_of(env)
    except TypeError:
        return False
    return True


def _env_facts(venv) -> tuple[int, float, bool]:
    """``(n_steps, control_dt, tracks_stiffness)`` of a native batched rig env (its ``core``) or
    of a gymnasium vector env of single envs (``get_attr``: ``n_steps``, ``control_dt``, ``task``)."""
    core = getattr(venv.unwrapped, "core", None)
    if core is not None:
        return core.n_steps, core.control_dt, core.task.track_stiffness
    n_steps, dt, task = (venv.get_attr(k)[0] for k in ("n_steps", "control_dt", "task"))
    return int(n_steps), float(dt), bool(getattr(task, "track_stiffness", True))


def record(make_policy, env_id: str, env_kwargs: dict, episodes: int, seed: int,
           max_steps: int | None = None, spec: TraceSpec = RIG) -> tuple[dict, bool]:
    """Run the policy ``make_policy(venv)`` builds (an object with ``reset``/``act``) on
    ``episodes`` seeded episodes in one batched env; return ``(traces, tracks_stiffness)`` with
    the traces :func:`~cepam_gym.bench.metrics.score_traces` scores; ``spec.info_keys`` says which
    ``info`` key fills each trace column. The one rollout loop of the harness and of the agents'
    periodic evaluation."""
    import gymnasium as gym

    venv = gym.make_vec(env_id, num_envs=episodes, **env_kwargs)
    n_steps, control_dt, track_k = _env_facts(venv)
    steps = max_steps or n_steps
    policy = make_policy(venv)
    obs, info = venv.reset(seed=seed)
    policy.reset()
    tr = {k: np.zeros((steps, episodes)) for k in TRACE_KEYS}
    tr["reward"] = np.zeros((steps, episodes))
    tr["alive"] = np.ones((steps, episodes), dtype=bool)
    alive = np.ones(episodes, dtype=bool)
    for t in range(steps):
        obs, reward, term, trunc, info = venv.step(policy.act(obs, info))
        src = info.get("final_info", info) if (term | trunc).any() else info
        for k in TRACE_KEYS:
            tr[k][t] = src[spec.info_keys[k]]
        tr["reward"][t] = reward
        tr["alive"][t] = alive
        alive &= ~term
        if (term | trunc).any():
            policy.reset(np.flatnonzero(term | trunc))
    tr["failed"] = ~alive
    tr["dt"] = control_dt
    venv.close()
    return tr, track_k


def run_suite(controller_spec: str, suite: Suite | str, episodes: int | None = None,
              max_steps: int | None = None) -> tuple[dict, dict]:
    """Run ``episodes`` seeded episodes of a suite; return ``(metrics, traces)``."""
    suite = SUITES[suite] if isinstance(suite, str) else suite
    tr, track_k = record(lambda venv: make_controller(controller_spec, venv), suite.env_id,
                         suite.env_kwargs, episodes or suite.episodes, suite.seed, max_steps,
                         suite.traces)
    metrics = {"suite": suite.name, "controller": controller_spec,
               **score_traces(tr, track_k, suite.traces)}
    return metrics, tr
