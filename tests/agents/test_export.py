"""``cepam-gym export``: the ONNX file acts as the trained policy does, on the env's own observations."""

from __future__ import annotations

import shutil

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("onnxruntime")
pytest.importorskip("onnx")
pytestmark = pytest.mark.train

from cepam_gym.errors import InputError  # noqa: E402
from cepam_gym.rig.cli import noise_free_warning  # noqa: E402
from cepam_gym.rig.onnx_policy import OnnxPolicy  # noqa: E402
from cepam_gym_agents.config.files import TrainConfig, dump_config  # noqa: E402
from cepam_gym_agents.export import export  # noqa: E402
from cepam_gym_agents.policy import load_policy  # noqa: E402

ID = "cepam_gym/CEPAM-v2"
TOL = 1e-5

PPO_RUN = {
    "algorithm": "PPO",
    "total_timesteps": 256,
    "seed": 1,
    "env": {"id": ID, "num_envs": 2, "kwargs": {"episode_seconds": 2.0}},
    "agent": {"history": 3},
    "normalize": {"obs": True},
    "hyperparameters": {"n_steps": 64, "batch_size": 64, "n_epochs": 2},
    "policy_kwargs": {"net_arch": [16, 16]},
    "eval": {"every_steps": 100000, "episodes": 1},
    "checkpoint": {"every_steps": 100000},
    "log_every_steps": 100000,
}


@pytest.fixture(scope="module")
def ppo_run(tmp_path_factory):
    from cepam_gym_agents.train import train

    run = tmp_path_factory.mktemp("export") / "ppo"
    assert train(TrainConfig.from_dict(PPO_RUN), run, quiet=True) == 0
    return run


def _recorded_gap(agent, onnx_policy, steps: int = 60, seed: int = 5) -> float:
    """Largest |ONNX action - SB3 policy action| along episodes of 3 envs driven by the SB3 policy
    (each policy keeps its own history of the observations it is shown)."""
    venv = gym.make_vec(ID, num_envs=3, episode_seconds=2.0)
    obs, _ = venv.reset(seed=seed)
    agent.reset()
    onnx_policy.reset()
    gap = 0.0
    for _ in range(steps):
        a = agent.act(obs)
        b = onnx_policy.act(obs)
        assert b.shape == a.shape and b.dtype == np.float32
        gap = max(gap, float(np.max(np.abs(a - b))))
        obs, *_ = venv.step(a)
    venv.close()
    return gap


def test_an_exported_ppo_with_history_and_normalisation_acts_as_the_trained_policy(ppo_run, tmp_path):
    meta = export(ppo_run, tmp_path / "policy.onnx")
    assert meta["history"] == 3 and meta["normalized"] and meta["env_id"] == ID
    env = gym.make_vec(ID, num_envs=3, episode_seconds=2.0)
    agent = load_policy(ppo_run, env)
    pol = OnnxPolicy(tmp_path / "policy.onnx")
    assert pol.history == 3 and pol.env_id == ID and pol.obs_dim == env.observation_space.shape[1]
    # the run's env kwargs travel with the file: deploy knows it was trained without sensor noise
    assert pol.env_kwargs == {"episode_seconds": 2.0}
    assert "was trained without sensor noise" in noise_free_warning(pol)
    gap = _recorded_gap(agent, pol)
    print(f"PPO (history 3, VecNormalize): max |ONNX - SB3| = {gap:.2e}")
    assert gap <= TOL
    # the history is in the graph: the same observation after different pasts gives different actions
    o = np.zeros((1, pol.obs_dim), np.float32)
    pol.reset()
    first = pol.act(o)
    pol.act(o + 1.0)
    assert not np.allclose(pol.act(o), first)


@pytest.mark.parametrize("algorithm", ["SAC", "TD3", "PPO"])
def test_a_bare_model_with_its_statistics_exports_with_the_action_map(algorithm, tmp_path):
    import stable_baselines3 as sb3
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    model = getattr(sb3, algorithm)("MlpPolicy", gym.make(ID), policy_kwargs={"net_arch": [8]}, seed=0)
    model.save(str(tmp_path / "agent.zip"))
    vn = VecNormalize(DummyVecEnv([lambda: gym.make(ID)]), norm_reward=False)
    rng = np.random.default_rng(0)
    vn.obs_rms.mean = rng.uniform(-1, 1, vn.obs_rms.mean.shape)
    vn.obs_rms.var = rng.uniform(0.05, 0.2, vn.obs_rms.var.shape)
    vn.save(str(tmp_path / "vec_normalize.pkl"))
    meta = export(tmp_path / "agent.zip", tmp_path / "p.onnx")
    assert meta["algorithm"] == algorithm and meta["normalized"]
    assert "env_kwargs" not in meta and OnnxPolicy(tmp_path / "p.onnx").env_kwargs is None  # unknown
    env = gym.make_vec(ID, num_envs=3)
    gap = _recorded_gap(load_policy(tmp_path / "agent.zip", env), OnnxPolicy(tmp_path / "p.onnx"), steps=30)
    print(f"{algorithm} (bare model, VecNormalize): max |ONNX - SB3| = {gap:.2e}")
    assert gap <= TOL


def _run_dir(tmp_path, **changes):
    d = {"algorithm": "PPO", "env": {"id": ID}, **changes}
    run = tmp_path / "run"
    run.mkdir()
    dump_config(TrainConfig.from_dict(d), run / "config.yaml")
    (run / "model.zip").write_bytes(b"never read")
    return run


@pytest.mark.parametrize(
    "changes, match",
    [
        ({"algorithm": "RecurrentPPO"}, "recurrent policy"),
        ({"agent": {"residual": True}}, "agent.residual"),
        ({"agent": {"obs_filters_s": [0.5]}}, "obs_filters_s"),
    ],
)
def test_what_is_not_one_graph_is_refused_in_one_line(changes, match, tmp_path):
    run = _run_dir(tmp_path, **changes)
    with pytest.raises(InputError, match=match):
        export(run, tmp_path / "p.onnx")
    assert not (tmp_path / "p.onnx").exists()


def test_the_command_line_exports_and_refuses(ppo_run, tmp_path, capsys):
    from cepam_gym import cli

    assert cli.main(["export", "--run", str(ppo_run), "--out", str(tmp_path / "p.onnx")]) == 0
    assert "wrote" in capsys.readouterr().out and (tmp_path / "p.onnx").is_file()
    bad = _run_dir(tmp_path, algorithm="RecurrentPPO")
    assert cli.main(["export", "--run", str(bad), "--out", str(tmp_path / "q.onnx")]) == 2
    err = capsys.readouterr().err
    assert "recurrent" in err and "Traceback" not in err


def test_a_policy_for_another_env_is_refused(ppo_run, tmp_path):
    export(ppo_run, tmp_path / "p.onnx")
    pol = OnnxPolicy(tmp_path / "p.onnx")
    with pytest.raises(InputError, match="trained on"):
        pol.check_env(pol.obs_dim + 2, "valve")
    with pytest.raises(InputError, match="observation must have shape"):
        pol.act(np.zeros(pol.obs_dim + 1))
    shutil.copy(tmp_path / "p.onnx", tmp_path / "broken.onnx")
    (tmp_path / "broken.onnx").write_bytes(b"not a model")
    with pytest.raises(InputError, match="not a loadable ONNX model"):
        OnnxPolicy(tmp_path / "broken.onnx")
