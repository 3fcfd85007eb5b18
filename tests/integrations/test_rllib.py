"""Ray RLlib integration: cepam_gym.rllib's env creator and examples/rllib_ppo.py.

The seeding and validation tests need no Ray (the creator is plain Gymnasium); the EnvContext,
registry and end-to-end tests skip without the [distributed] extra."""

from __future__ import annotations

import json
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

from cepam_gym import rllib
from cepam_gym.bench.suites import RANDOMIZE

ROOT = Path(__file__).resolve().parents[2]


class Ctx(dict):
    """Stands in for RLlib's EnvContext (a dict with index attributes) where Ray is not needed."""

    def __init__(self, cfg, worker_index=0, vector_index=0):
        super().__init__(cfg)
        self.worker_index, self.vector_index = worker_index, vector_index


@pytest.fixture(autouse=True)
def fresh_instances(monkeypatch):
    # as in a new env-runner process: no envs made yet
    monkeypatch.setattr(rllib, "_instances", defaultdict(int))


def test_import_does_not_pull_ray_or_torch():
    code = (
        "import sys, cepam_gym, cepam_gym.rllib; "
        "bad = [m for m in ('ray', 'torch') if m in sys.modules]; assert not bad, bad"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr


def test_env_seed_distinct_and_reproducible():
    seeds = {rllib.env_seed(7, w, v, k) for w in range(4) for v in range(3) for k in range(3)}
    assert len(seeds) == 4 * 3 * 3
    assert all(0 <= s < 2**63 for s in seeds)
    assert rllib.env_seed(7, 2, 1, 0) == rllib.env_seed(7, 2, 1, 0)
    assert rllib.env_seed(7, 2, 1, 0) != rllib.env_seed(8, 2, 1, 0)
    # no "seed + worker_index" overlap: base 0 worker 1 is not base 1 worker 0
    assert rllib.env_seed(0, 1) != rllib.env_seed(1, 0)
    assert rllib.env_seed(None, 1) != rllib.env_seed(None, 1)  # no base seed: fresh entropy
    with pytest.raises(ValueError, match="worker_index"):
        rllib.env_seed(0, -1)


def _first_obs_and_plant(env):
    obs, _ = env.reset()
    return obs, env.unwrapped.core.params.copy()


def test_runners_and_sub_envs_are_seeded_and_randomized_differently():
    cfg = {"seed": 3, "randomize": RANDOMIZE, "sensor_noise": {"length_mm": 0.2}}
    envs = [rllib.make_env(Ctx(cfg, worker_index=w)) for w in (1, 1, 2)]  # two sub-envs of runner 1
    try:
        seeds = [e.get_wrapper_attr("runner_seed") for e in envs]
        assert seeds == [rllib.env_seed(3, 1, 0, 0), rllib.env_seed(3, 1, 0, 1), rllib.env_seed(3, 2, 0, 0)]
        plants = [_first_obs_and_plant(e)[1] for e in envs]
        # the randomized plant differs between all three (same env_config, different streams)
        for i in range(3):
            for j in range(i + 1, 3):
                assert not np.allclose(plants[i], plants[j])
    finally:
        for e in envs:
            e.close()


def test_same_context_reproduces_in_a_new_process(monkeypatch):
    cfg = {"seed": 3, "randomize": RANDOMIZE}
    a = rllib.make_env(Ctx(cfg, worker_index=2, vector_index=1))
    monkeypatch.setattr(rllib, "_instances", defaultdict(int))  # "another process"
    b = rllib.make_env(Ctx(cfg, worker_index=2, vector_index=1))
    try:
        (oa, pa), (ob, pb) = _first_obs_and_plant(a), _first_obs_and_plant(b)
        np.testing.assert_array_equal(oa, ob)
        np.testing.assert_array_equal(pa, pb)
        act = np.array([0.3, -0.2], np.float32)
        np.testing.assert_array_equal(a.step(act)[0], b.step(act)[0])
    finally:
        a.close()
        b.close()


def test_seed_passed_by_rllib_is_rederived_per_runner():
    """RLlib's .debugging(seed=S) resets runner w with S + w (spread + i over sub-envs): the
    wrapper spawns it with the indices, so runners never share a stream."""
    cfg = {"randomize": RANDOMIZE}
    e1, e2 = rllib.make_env(Ctx(cfg, worker_index=1)), rllib.make_env(Ctx(cfg, worker_index=2))
    try:
        p1 = (e1.reset(seed=5), e1.unwrapped.core.params.copy())[1]
        p2 = (e2.reset(seed=5), e2.unwrapped.core.params.copy())[1]
        assert not np.allclose(p1, p2)
        p1_again = (e1.reset(seed=5), e1.unwrapped.core.params.copy())[1]
        np.testing.assert_array_equal(p1, p1_again)
    finally:
        e1.close()
        e2.close()


def test_env_config_keys_are_passed_to_the_env():
    env = rllib.make_env(
        {"id": "cepam_gym/CEPAMLength-v0", "seed": 0, "max_episode_steps": 3, "action_mode": "pressure"}
    )
    try:
        assert env.unwrapped.core.obs_dim == 8  # the length task has no stiffness target
        assert env.unwrapped.core.action_mode == "pressure"
        env.reset()
        truncated = [env.step(np.zeros(2, np.float32))[3] for _ in range(3)]
        assert truncated == [False, False, True]
    finally:
        env.close()


@pytest.mark.parametrize(
    "cfg, match",
    [
        ({"sensor_nosie": {"length_mm": 0.2}}, r"unknown key 'sensor_nosie'.*valid keys:.*'sensor_noise'"),
        ({"task": "length"}, r"unknown key 'task'"),  # the task comes from the id
        ({"id": "CartPole-v1"}, r"env_config\['id'\]: unknown id 'CartPole-v1'"),
        ({"seed": -1}, r"env_config\['seed'\] must be a non-negative integer"),
        ({"seed": 1.5}, r"env_config\['seed'\]"),
        ({"num_envs": 4}, r"vector_entry_point.*gym_env_vectorize_mode='sync'"),
    ],
)
def test_bad_env_config_rejected(cfg, match):
    with pytest.raises(ValueError, match=match):
        rllib.make_env(cfg)


def test_register_env_without_ray_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # makes `import ray` fail
    with pytest.raises(ImportError, match=r'pip install "cepam-gym\[distributed\]"'):
        rllib.register_env()


def test_register_env_and_rllib_env_context():
    pytest.importorskip("ray")
    from ray.rllib.env.env_context import EnvContext
    from ray.tune.registry import ENV_CREATOR, _global_registry

    assert rllib.register_env("cepam_gym_test") == "cepam_gym_test"
    creator = _global_registry.get(ENV_CREATOR, "cepam_gym_test")
    env = creator(EnvContext({"seed": 11}, worker_index=3, vector_index=2))
    try:
        assert env.get_wrapper_attr("runner_seed") == rllib.env_seed(11, 3, 2, 0)
    finally:
        env.close()
    with pytest.raises(ValueError, match="name"):
        rllib.register_env("")


@pytest.mark.slow
def test_rllib_example_end_to_end(tmp_path):
    pytest.importorskip("ray")
    pytest.importorskip("torch")
    cmd = [
        sys.executable,
        str(ROOT / "examples" / "rllib_ppo.py"),
        "--num-env-runners",
        "2",
        "--iterations",
        "2",
        "--train-batch",
        "200",
        "--minibatch",
        "100",
        "--epochs",
        "2",
        "--max-episode-steps",
        "50",
        "--hidden",
        "32",
        "32",
        "--seed",
        "4",
        "--out",
        str(tmp_path),
    ]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    assert out.stdout.count("iter ") == 2
    (summary_path,) = tmp_path.glob("*/summary.json")
    summary = json.loads(summary_path.read_text())
    # each remote runner built its env in its own process: the seeds are exactly the derived ones
    assert summary["runner_seeds"]["1"] == [rllib.env_seed(4, 1, 0, 0)]
    assert summary["runner_seeds"]["2"] == [rllib.env_seed(4, 2, 0, 0)]
    last = summary["iterations"][-1]
    assert last["env_steps"] >= 2 * 200
    assert last["episode_len_mean"] == 50
    # every reward term is a penalty: returns are negative, and above the worst case per step
    # (length error clipped at 5 cm: -5, stiffness -2.5 * 2, effort -0.05, air well under -0.1)
    assert -50 * 10.2 < last["episode_return_mean"] < 0
    ckpt = Path(summary["checkpoint"])
    assert (ckpt / "rllib_checkpoint.json").is_file() and (ckpt / "algorithm_state.pkl").is_file()


@pytest.mark.slow
def test_tune_sweep_example_reports_each_trial(tmp_path):
    pytest.importorskip("ray.tune")
    pytest.importorskip("stable_baselines3")
    # one PPO rollout (64 envs x 128 steps) per trial, two trials, two evaluation episodes each
    cmd = [
        sys.executable,
        str(ROOT / "examples" / "tune_sweep.py"),
        "--config",
        "quick",
        "--total-timesteps",
        "8192",
        "--eval-episodes",
        "2",
        "--grid",
        "learning_rate=1e-4,3e-4",
        "--out",
        str(tmp_path),
    ]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    scores = [ln for ln in out.stdout.splitlines() if ln.startswith("score ")]
    assert len(scores) == 2 and "0.0001" in out.stdout and "0.0003" in out.stdout
    values = [float(ln.split()[1]) for ln in scores]
    assert values == sorted(values) and all(np.isfinite(values)) and all(v > 0 for v in values)
    summaries = [json.loads(p.read_text()) for p in tmp_path.glob("sweep/*/run/summary.json")]
    assert len(summaries) == 2 and all(s["steps"] >= 8192 for s in summaries)
