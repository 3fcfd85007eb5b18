"""Integrations: Gymnasium id strings and RL Zoo3 with the shipped hyperparams/."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym.registration import ENV_IDS

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_ids_resolve_after_import(env_id):
    assert env_id in gym.registry
    env = gym.make(env_id)
    try:
        obs, _ = env.reset(seed=0)
        assert env.observation_space.contains(obs)
        obs, *_ = env.step(env.action_space.sample())
        assert np.all(np.isfinite(obs))
    finally:
        env.close()


def test_module_prefixed_id_make():
    env = gym.make("cepam_gym:cepam_gym/CEPAM-v0")
    try:
        assert env.spec.id == "cepam_gym/CEPAM-v0"
        env.reset(seed=0)
        env.step(env.action_space.sample())
    finally:
        env.close()


def test_module_prefixed_id_make_vec():
    from cepam_gym.envs.cepam import CEPAMVectorEnv

    venv = gym.make_vec("cepam_gym:cepam_gym/CEPAM-v0", num_envs=4)
    try:
        assert isinstance(venv, CEPAMVectorEnv)  # the native batched env, not a SyncVectorEnv
        assert venv.num_envs == 4
        obs, _ = venv.reset(seed=0)
        assert obs.shape[0] == 4
        obs, rew, term, trunc, _ = venv.step(venv.action_space.sample())
        assert rew.shape == (4,) and np.all(np.isfinite(obs))
    finally:
        venv.close()


def test_module_prefixed_id_in_fresh_interpreter():
    """The prefix imports the package: no explicit ``import cepam_gym`` needed."""
    code = (
        "import gymnasium as gym; "
        "e = gym.make('cepam_gym:cepam_gym/CEPAMLength-v0'); e.reset(seed=0); "
        "v = gym.make_vec('cepam_gym:cepam_gym/CEPAM-v0', num_envs=4); v.reset(seed=0); "
        "print(type(v).__name__)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "CEPAMVectorEnv" in out.stdout


ZOO_ALGOS = {"ppo": "PPO", "sac": "SAC", "td3": "TD3", "ppo_lstm": "RecurrentPPO"}


@pytest.mark.parametrize("algo", list(ZOO_ALGOS))
def test_hyperparams_files_have_all_ids(algo):
    """v0 ids (ppo, sac): the benchmark's randomized suite as the training distribution. v1 ids
    (every algorithm): the values of the reference curves' config ``configs/v1_<algo>.yaml`` and
    the suite each id is trained on there. v2 ids: the same values and their v1 suite's v2 twin
    (nominal-v2 for CEPAM-v2, ...)."""
    import yaml

    pytest.importorskip("stable_baselines3")
    from cepam_gym.bench.suites import SUITES
    from cepam_gym_agents.config.files import load_config
    from cepam_gym_agents.curves import CONFIG_OF, SUITE_OF

    with open(ROOT / "hyperparams" / f"{algo}.yml") as f:
        hp = yaml.load(f, Loader=yaml.UnsafeLoader)  # as rl_zoo3 loads them
    from cepam_gym.registration import JOINT_ENV_IDS

    new = ("-v1", "-v2")
    ids = [i for i in ENV_IDS if i.endswith(new) or (i.endswith("-v0") and algo in ("ppo", "sac"))]
    ids += [i for i in JOINT_ENV_IDS if i.endswith(new)]
    assert {i for i in ids if i.endswith("-v2")} == {
        "cepam_gym/CEPAM-v2",
        "cepam_gym/CEPAMLength-v2",
        "cepam_gym/CEPAMStiffness-v2",
        "cepam_gym/CEPAMJoint-v2",
    }
    assert set(ids) <= set(hp)
    for env_id in ids:
        kw = hp[env_id]["env_kwargs"]
        if env_id.endswith(new):
            suite = SUITE_OF[env_id.replace("-v2", "-v1")].replace("-v1", env_id[-3:])
            assert SUITES[suite].env_id == env_id
            assert kw == SUITES[suite].env_kwargs, env_id
            cfg = load_config(CONFIG_OF[ZOO_ALGOS[algo]])
            assert hp[env_id]["n_envs"] == cfg.env.num_envs
            for key, value in cfg.hyperparameters.items():
                if key == "action_noise":
                    assert (hp[env_id]["noise_type"], hp[env_id]["noise_std"]) == (
                        value["type"],
                        value["sigma"],
                    )
                else:
                    assert hp[env_id][key] == pytest.approx(value), (env_id, key)
        else:  # the training distribution is the benchmark's randomized suite
            randomized = SUITES["randomized"].env_kwargs
            assert kw["randomize"] == randomized["randomize"]
            assert kw["sensor_noise"] == randomized["sensor_noise"]
    for env_id in ids:
        env = gym.make(env_id, **hp[env_id]["env_kwargs"])  # the kwargs are accepted
        env.reset(seed=0)
        env.close()


@pytest.mark.slow
def test_rl_zoo3_train_ppo(tmp_path):
    # find, not import: importing rl_zoo3 patches Gymnasium's TimeLimit in this process (its
    # gym_patches add info["TimeLimit.truncated"]), which would leak into every later test
    import importlib.util

    if importlib.util.find_spec("rl_zoo3") is None:
        pytest.skip("rl_zoo3 is not installed (the [zoo] extra)")
    cmd = [
        sys.executable,
        "-m",
        "rl_zoo3.train",
        "--algo",
        "ppo",
        "--env",
        "cepam_gym/CEPAM-v0",
        "--gym-packages",
        "cepam_gym",
        "-conf",
        str(ROOT / "hyperparams" / "ppo.yml"),
        "-n",
        "500",
        "-f",
        str(tmp_path),
        "--seed",
        "0",
        "--num-threads",
        "1",
    ]
    env = {**os.environ, "MPLBACKEND": "Agg"}
    out = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=300, env=env)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    run = tmp_path / "ppo" / "cepam_gym-CEPAM-v0_1"
    assert (run / "cepam_gym-CEPAM-v0.zip").is_file()
    assert (run / "cepam_gym-CEPAM-v0" / "vecnormalize.pkl").is_file()
    # the benchmark's loader finds RL Zoo3's statistics and env id in its layout
    from cepam_gym_agents.policy import load_policy, locate

    assert locate(run).env_id() == "cepam_gym/CEPAM-v0"
    venv = gym.make_vec("cepam_gym/CEPAM-v0", num_envs=2)
    assert load_policy(run, venv).normalizer is not None
