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


def run_suite(controller_spec: str, suite: Suite | str, episodes: int | None = None,
              max_steps: int | None = None) -> tuple[dict, dict]:
    """Run ``episodes`` seeded episodes in one batched env; return ``(metrics, traces)``."""
    import gymnasium as gym

    suite = SUITES[suite] if isinstance(suite, str) else suite
    n = episodes or suite.episodes
    venv = gym.make_vec(suite.env_id, num_envs=n, **suite.env_kwargs)
    core = venv.unwrapped.core
    steps = max_steps or core.n_steps
    ctl = make_controller(controller_spec, venv)
    obs, info = venv.reset(seed=suite.seed)
    ctl.reset()
    tr = {k: np.zeros((steps, n)) for k in TRACE_KEYS}
    tr["reward"] = np.zeros((steps, n))
    tr["alive"] = np.ones((steps, n), dtype=bool)
    alive = np.ones(n, dtype=bool)
    for t in range(steps):
        action = ctl.act(obs, info)
        obs, reward, term, trunc, info = venv.step(action)
        src = info.get("final_info", info) if (term | trunc).any() else info
        for k in TRACE_KEYS:
            tr[k][t] = src[k]
        tr["reward"][t] = reward
        tr["alive"][t] = alive
        alive &= ~term
        if (term | trunc).any():
            ctl.reset(np.flatnonzero(term | trunc))
    tr["failed"] = ~alive
    tr["dt"] = core.control_dt
    venv.close()
    metrics = {"suite": suite.name, "controller": controller_spec, **score_traces(tr, core.task.track_stiffness)}
    return metrics, tr
