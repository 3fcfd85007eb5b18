"""Run any controller on the fixed suites and score it (``cepam-gym bench``)."""

from __future__ import annotations

import numpy as np

import cepam_gym  # noqa: F401  (registers the ids)

from .metrics import score_traces
from .suites import SUITES, Suite

TRACE_KEYS = ("length", "target_length", "stiffness", "target_stiffness", "pressure_c",
              "pressure_e", "load_mass", "air_used")


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
    """``baseline``, ``zero``, ``random``, or a run directory / model file of a trained agent."""
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


def record(make_policy, env_id: str, env_kwargs: dict, episodes: int, seed: int,
           max_steps: int | None = None) -> tuple[dict, bool]:
    """Run the policy ``make_policy(venv)`` builds (an object with ``reset``/``act``) on
    ``episodes`` seeded episodes in one batched env; return ``(traces, tracks_stiffness)`` with
    the traces :func:`~cepam_gym.bench.metrics.score_traces` scores. The one rollout loop of the
    harness and of the agents' periodic evaluation."""
    import gymnasium as gym

    venv = gym.make_vec(env_id, num_envs=episodes, **env_kwargs)
    core = venv.unwrapped.core
    steps = max_steps or core.n_steps
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
            tr[k][t] = src[k]
        tr["reward"][t] = reward
        tr["alive"][t] = alive
        alive &= ~term
        if (term | trunc).any():
            policy.reset(np.flatnonzero(term | trunc))
    tr["failed"] = ~alive
    tr["dt"] = core.control_dt
    venv.close()
    return tr, core.task.track_stiffness


def run_suite(controller_spec: str, suite: Suite | str, episodes: int | None = None,
              max_steps: int | None = None) -> tuple[dict, dict]:
    """Run ``episodes`` seeded episodes of a suite; return ``(metrics, traces)``."""
    suite = SUITES[suite] if isinstance(suite, str) else suite
    tr, track_k = record(lambda venv: make_controller(controller_spec, venv), suite.env_id,
                         suite.env_kwargs, episodes or suite.episodes, suite.seed, max_steps)
    metrics = {"suite": suite.name, "controller": controller_spec, **score_traces(tr, track_k)}
    return metrics, tr
