"""Training from the CLI (agents/): configs, tiny training runs, resume, Ctrl-C, loading."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("stable_baselines3")
pytestmark = pytest.mark.train

from cepam_gym_agents.config.files import ALGORITHMS, ConfigError, TrainConfig, load_config  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]

TINY = {
    "algorithm": "SAC",
    "total_timesteps": 300,
    "seed": 3,
    "env": {
        "id": "cepam_gym/CEPAM-v0",
        "num_envs": 2,
        "kwargs": {"episode_seconds": 2.0, "max_episode_steps": 100},
    },
    "agent": {"residual": True, "residual_scale": 0.5, "baseline_in_obs": True, "history": 2},
    "normalize": {"obs": True},
    "hyperparameters": {
        "learning_rate": "1e-3",
        "learning_starts": 50,
        "batch_size": 32,
        "buffer_size": "1e4",
    },
    "policy_kwargs": {"net_arch": [16, 16], "activation_fn": "tanh"},
    "eval": {"every_steps": 150, "episodes": 2},
    "checkpoint": {"every_steps": 100},
    "log_every_steps": 50,
}


def _cfg(**changes) -> TrainConfig:
    d = json.loads(json.dumps(TINY))
    d.update(changes)
    return TrainConfig.from_dict(d)


# --------------------------------------------------------------------------- configs
def test_shipped_configs_load():
    paths = sorted((ROOT / "configs").glob("*.yaml"))
    assert {"quick.yaml"} <= {p.name for p in paths}
    for p in paths:
        cfg = load_config(p)
        assert cfg.algorithm in ALGORITHMS and cfg.total_timesteps > 0


def test_numbers_parse_as_numbers_including_yaml11_exponents():
    cfg = _cfg()
    assert cfg.hyperparameters["learning_rate"] == pytest.approx(1e-3)
    assert (
        isinstance(cfg.hyperparameters["buffer_size"], int) and cfg.hyperparameters["buffer_size"] == 10_000
    )
    # straight from YAML text: PyYAML reads 3e-4 and 2e5 as strings
    raw = yaml.safe_load(
        "algorithm: PPO\ntotal_timesteps: 2e5\nhyperparameters: {learning_rate: 3e-4, n_steps: 64}"
    )
    assert isinstance(raw["hyperparameters"]["learning_rate"], str)
    cfg = TrainConfig.from_dict(raw)
    assert cfg.total_timesteps == 200_000 and cfg.hyperparameters["learning_rate"] == pytest.approx(3e-4)


@pytest.mark.parametrize(
    "changes, key",
    [
        ({"learnin_rate": 1e-3}, "learnin_rate"),
        ({"env": {"id": "cepam_gym/CEPAM-v0", "num_env": 4}}, "num_env"),
        ({"env": {"id": "cepam_gym/CEPAM-v0", "kwargs": {"randomise": {}}}}, "randomise"),
        ({"hyperparameters": {"n_epochs": 4}}, "n_epochs"),  # a PPO key given to SAC
        ({"hyperparameters": {"seed": 4}}, "seed"),
        ({"policy_kwargs": {"netarch": [8]}}, "netarch"),
        ({"eval": {"every": 10}}, "every"),
        ({"agent": {"residual_scal": 1.0}}, "residual_scal"),
        ({"checkpoint": {"every_step": 10}}, "every_step"),
    ],
)
def test_unknown_keys_are_named(changes, key):
    with pytest.raises(ConfigError, match=f"'{key}'") as e:
        _cfg(**changes)
    assert "valid" in str(e.value)


@pytest.mark.parametrize(
    "changes, match",
    [
        ({"algorithm": "DQN"}, "algorithm must be one of"),
        ({"total_timesteps": "lots"}, "total_timesteps must be an integer"),
        ({"total_timesteps": 1.5}, "total_timesteps must be an integer"),
        ({"env": {"id": "cepam_gym/Nope-v0"}}, "unknown environment 'cepam_gym/Nope-v0'"),
        ({"hyperparameters": {"batch_size": "big"}}, "hyperparameters.batch_size must be a number"),
        ({"policy_kwargs": {"activation_fn": "sigmoidish"}}, "activation_fn must be one of"),
        ({"eval": {"suite": "nope"}}, "eval.suite: unknown suite 'nope'"),
        ({"agent": {"history": 0}}, "agent.history must be >= 1"),
        ({"agent": {"friction_observer": True}}, "agent.friction_observer changes the baseline's load"),
    ],
)
def test_bad_values_are_named(changes, match):
    with pytest.raises(ConfigError, match=match):
        _cfg(**changes)


def test_cli_reports_bad_key_with_file_name(tmp_path, capsys):
    from cepam_gym_agents import train

    p = tmp_path / "bad.yaml"
    p.write_text("algorithm: SAC\nhyperparameters: {gamma: 0.9, tau_: 0.1}\n")
    assert train.main(["--config", str(p), "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err
    assert "'tau_'" in err and "bad.yaml" in err
    assert not (tmp_path / "run").exists()


# --------------------------------------------------------------------------- training runs
@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    from cepam_gym_agents.train import train

    run = tmp_path_factory.mktemp("agents") / "tiny"
    assert train(_cfg(), run, quiet=True) == 0
    return run


@pytest.mark.slow  # trains
def test_tiny_run_writes_model_config_and_logs(tiny_run):
    run = tiny_run
    for name in (
        "model.zip",
        "vecnormalize.pkl",
        "best_model.zip",
        "config.yaml",
        "run.json",
        "evaluations.json",
        "summary.json",
        "checkpoints/latest.json",
    ):
        assert (run / name).is_file(), name
    # the resolved config reproduces the run
    assert load_config(run / "config.yaml") == _cfg()
    meta = json.loads((run / "run.json").read_text())
    assert meta["seed"] == 3 and meta["status"] == "finished"
    assert (
        meta["versions"]["stable-baselines3"] and meta["versions"]["torch"] and meta["versions"]["cepam-gym"]
    )
    assert list((run / "tb").glob("events.out.tfevents.*"))
    header = (run / "logs" / "progress_0.csv").read_text().splitlines()[0].split(",")
    for key in (
        "env/reward_length",
        "env/reward_stiffness",
        "env/length_error_mm",
        "env/stiffness_error_pct",
        "eval/score",
    ):
        assert key in header
    evals = json.loads((run / "evaluations.json").read_text())
    assert [e["step"] for e in evals] == [150, 300, 300]  # schedule + the final one
    assert all(np.isfinite(e["score"]) for e in evals)
    from stable_baselines3 import SAC

    assert SAC.load(str(run / "model.zip")).num_timesteps == 300


def test_the_logged_info_keys_are_the_training_tasks_own():
    """The session logs what the task's contract names: the joint's angle, joint stiffness and
    reward terms are in the infos SB3 hands the callback (not the rig's length)."""
    from cepam_gym.integrations.sb3 import make_sb3_vec_env
    from cepam_gym.tasks.contract import JOINT, RIG
    from cepam_gym_agents.session.envs import info_keys

    assert info_keys(RIG)[:2] == ["length", "target_length"] and "reward_length" in info_keys(RIG)
    keys = info_keys(JOINT)
    assert keys[:4] == ["angle", "target_angle", "joint_stiffness", "target_stiffness"]
    assert {f"reward_{t}" for t in JOINT.reward_terms} <= set(keys)
    env = make_sb3_vec_env("cepam_gym/CEPAMJoint-v1", num_envs=2, seed=0)
    env.reset()
    _, _, _, infos = env.step(np.zeros((2, 2), np.float32))
    assert all(set(keys) <= set(inf) for inf in infos)
    env.close()


@pytest.mark.slow  # trains
def test_joint_training_logs_its_env_terms(tmp_path):
    from cepam_gym_agents.train import train

    cfg = _cfg(
        env={"id": "cepam_gym/CEPAMJoint-v1", "num_envs": 2, "kwargs": {"max_episode_steps": 100}},
        agent={},
        total_timesteps=100,
        eval={"every_steps": 100, "episodes": 1},
    )
    assert train(cfg, tmp_path / "joint", quiet=True) == 0
    header = (tmp_path / "joint" / "logs" / "progress_0.csv").read_text().splitlines()[0].split(",")
    for key in ("env/reward_angle", "env/reward_stiffness", "env/angle_error_deg", "env/stiffness_error_pct"):
        assert key in header, key


@pytest.mark.slow  # trains
def test_load_policy_acts_deterministically(tiny_run):
    import gymnasium as gym

    from cepam_gym_agents.policy import load_policy

    venv = gym.make_vec("cepam_gym/CEPAM-v0", num_envs=3)
    obs, _ = venv.reset(seed=0)
    pol = load_policy(tiny_run, venv)
    pol.reset()
    a1 = pol.act(obs)
    pol.reset()
    a2 = pol.act(obs)
    assert a1.shape == (3, 2) and a1.dtype == np.float32
    np.testing.assert_array_equal(a1, a2)
    assert np.all(np.abs(a1) <= 1)
    pol.reset()
    single = pol.act(obs[0])
    assert single.shape == (2,) and single.dtype == np.float32
    np.testing.assert_allclose(single, a1[0], atol=1e-6)  # per-env state: same first action
    with pytest.raises(ValueError, match="observation must have shape"):
        pol.act(np.zeros(5))
    venv.close()


@pytest.mark.slow  # trains
def test_load_policy_rejects_wrong_env(tiny_run):
    import gymnasium as gym

    from cepam_gym_agents.policy import load_policy

    env = gym.make_vec("cepam_gym/CEPAMLength-v0", num_envs=1)  # 8 observations, not 9
    with pytest.raises(ValueError, match="wrong env"):
        load_policy(tiny_run, env)
    env = gym.make_vec("cepam_gym/CEPAM-v0", num_envs=1, action_mode="pressure")
    with pytest.raises(ValueError, match="action_mode"):
        load_policy(tiny_run, env)
    with pytest.raises(ValueError, match="not a run directory"):
        load_policy(tiny_run / "nope", env)


@pytest.mark.slow  # trains
def test_agent_runs_in_the_bench_harness(tiny_run):
    from cepam_gym.bench import run_suite

    metrics, tr = run_suite(str(tiny_run), "nominal", episodes=2, max_steps=100)
    assert metrics["episodes"] == 2 and np.isfinite(metrics["score"])
    assert tr["length"].shape == (100, 2)


@pytest.mark.slow  # trains
def test_resume_continues_the_step_count(tiny_run, tmp_path):
    import shutil

    from cepam_gym_agents.train import main

    run = tmp_path / "resumed"
    shutil.copytree(tiny_run, run)
    assert main(["--out", str(run), "--resume", "--total-timesteps", "500", "--quiet"]) == 0
    latest = json.loads((run / "checkpoints" / "latest.json").read_text())
    assert latest["steps"] == 500
    from stable_baselines3 import SAC

    assert SAC.load(str(run / "model.zip")).num_timesteps == 500
    assert (run / "logs" / "progress_300.csv").is_file()
    meta = json.loads((run / "run.json").read_text())
    assert [s["start_step"] for s in meta["sessions"]] == [0, 300]
    assert load_config(run / "config.yaml").total_timesteps == 500
    evals = json.loads((run / "evaluations.json").read_text())
    assert [e["step"] for e in evals][-2:] == [450, 500]
    # a finished run with nothing left to do is not retrained
    assert main(["--out", str(run), "--resume", "--quiet"]) == 0
    # a new run in an existing run directory is refused
    assert main(["--config", str(run / "config.yaml"), "--out", str(run), "--quiet"]) == 2


@pytest.mark.slow  # trains
def test_interrupt_saves_a_usable_checkpoint(tmp_path):
    from stable_baselines3.common.callbacks import BaseCallback

    from cepam_gym_agents.train import EXIT_INTERRUPTED, train

    class CtrlC(BaseCallback):
        def _on_step(self):
            if self.num_timesteps >= 170:
                raise KeyboardInterrupt
            return True

    run = tmp_path / "int"
    cfg = _cfg(total_timesteps=1000, checkpoint={"every_steps": 10_000})  # no periodic checkpoint
    assert train(cfg, run, callbacks=[CtrlC()], quiet=True) == EXIT_INTERRUPTED
    latest = json.loads((run / "checkpoints" / "latest.json").read_text())
    assert latest["interrupted"] and latest["steps"] == 170
    assert (run / latest["model"]).is_file() and (run / latest["replay_buffer"]).is_file()
    assert json.loads((run / "run.json").read_text())["status"] == "interrupted"
    import gymnasium as gym

    from cepam_gym_agents.policy import load_policy

    venv = gym.make_vec("cepam_gym/CEPAM-v0", num_envs=2)
    obs, _ = venv.reset(seed=1)
    assert load_policy(run, venv, which="latest").act(obs).shape == (2, 2)
    # and training goes on from there
    assert train(cfg.replace(total_timesteps=250), run, resume=True, quiet=True) == 0
    from stable_baselines3 import SAC

    assert SAC.load(str(run / "model.zip")).num_timesteps == 250


@pytest.mark.slow  # trains
@pytest.mark.parametrize(
    "algo, hp, agent, n_act",
    [
        (
            "PPO",
            {"n_steps": 32, "batch_size": 32, "n_epochs": 1},
            {"target_shift": True, "residual": True},
            4,
        ),
        (
            "TD3",
            {"learning_starts": 20, "batch_size": 16, "action_noise": {"type": "normal", "sigma": 0.2}},
            {},
            2,
        ),
    ],
)
def test_ppo_and_td3_train_and_act(tmp_path, algo, hp, agent, n_act):
    import gymnasium as gym

    from cepam_gym_agents.policy import load_policy
    from cepam_gym_agents.train import train

    cfg = _cfg(
        algorithm=algo,
        total_timesteps=128,
        hyperparameters=hp,
        agent=agent,
        normalize={"obs": True, "reward": True},
        eval={"every_steps": 1000, "episodes": 1},
        policy_kwargs={"net_arch": [8]},
    )
    assert train(cfg, tmp_path / algo, quiet=True) == 0
    venv = gym.make_vec("cepam_gym/CEPAM-v0", num_envs=2)
    obs, _ = venv.reset(seed=0)
    pol = load_policy(tmp_path / algo, venv)
    assert pol.model.action_space.shape == (n_act,)
    a = pol.act(obs)
    assert a.shape == (2, 2) and a.dtype == np.float32 and np.all(np.abs(a) <= 1)


# --------------------------------------------------------------------------- features
def test_friction_aware_features_peek_rewinds_the_observer():
    import gymnasium as gym

    from cepam_gym.control import make_controller
    from cepam_gym.policies import Features, FeatureSpec

    venv = gym.make_vec("cepam_gym/CEPAM-v1", num_envs=2)
    obs, _ = venv.reset(seed=5)
    cfg = FeatureSpec(setpoint_gaps_in_obs=True, friction_observer=True)
    feats = Features(venv, cfg, venv.unwrapped.core.obs_dim)
    twin = Features(venv, cfg, venv.unwrapped.core.obs_dim)
    ref = make_controller("baseline_friction", venv)
    moved = False
    for _ in range(40):
        f, _ = feats(obs)
        a = ref.act(obs)  # the features' baseline is the registered friction-aware one
        np.testing.assert_array_equal(feats.baseline.last_gap, ref.last_gap)
        feats.peek(obs + 0.01)  # a terminal observation must not move the observer
        np.testing.assert_array_equal(f, twin(obs)[0])
        moved |= bool(np.abs(feats.baseline.friction.z).max() > 0)
        obs, *_ = venv.step(a)
    assert moved


def test_residual_features_terminal_obs_and_peek():
    import gymnasium as gym

    from cepam_gym.control import InverseStaticController
    from cepam_gym.integrations.sb3 import make_sb3_vec_env
    from cepam_gym.policies import Features, FeatureSpec
    from cepam_gym_agents.config.files import AgentConfig
    from cepam_gym_agents.session.envs import make_agent_vec_env

    venv = gym.make_vec("cepam_gym/CEPAM-v0", num_envs=2)
    obs, _ = venv.reset(seed=5)
    feats = Features(
        venv, FeatureSpec(residual=True, baseline_in_obs=True, history=3), venv.unwrapped.core.obs_dim
    )
    ref = InverseStaticController(venv)
    f, base = feats(obs)
    assert f.shape == (2, 3 * 11)
    np.testing.assert_allclose(base, ref.act(obs))
    # a zero policy action sends exactly the baseline's action
    np.testing.assert_allclose(feats.action(np.zeros((2, 2)), base), base)
    before = feats._save()
    feats.peek(obs)
    after = feats._save()
    np.testing.assert_array_equal(before[0], after[0])
    np.testing.assert_array_equal(before[2][0], after[2][0])

    env = make_agent_vec_env(
        make_sb3_vec_env("cepam_gym/CEPAM-v0", num_envs=2, seed=0, max_episode_steps=3),
        AgentConfig(residual=True, baseline_in_obs=True, history=2),
    )
    o = env.reset()
    assert o.shape == (2, 22)
    for _ in range(5):
        o, r, d, infos = env.step(np.zeros((2, 2), dtype=np.float32))
        if d.any():
            assert infos[0]["terminal_observation"].shape == (22,)
            break
    else:
        pytest.fail("episodes of 5 steps did not end")


def test_a_residual_on_the_joint_runs_on_the_joints_baseline():
    """``agent.residual`` on the joint env: the base controller is the joint's baseline (the
    registry's ``baseline`` resolved for the joint), found beneath stable-baselines3's wrappers;
    a zero policy action sends exactly its commands."""
    from cepam_gym.control import make_controller
    from cepam_gym.integrations.sb3 import make_sb3_vec_env
    from cepam_gym_agents.config.files import AgentConfig
    from cepam_gym_agents.session.envs import make_agent_vec_env

    cfg = AgentConfig(residual=True, residual_scale=0.3)
    venv = make_sb3_vec_env("cepam_gym/CEPAMJoint-v2", num_envs=2, seed=0)
    env = make_agent_vec_env(venv, cfg)
    obs = env.reset()
    feats = env.features
    assert type(feats.baseline).__name__ == "JointInverseStaticController"
    ref = make_controller("baseline", venv)
    base = ref.act(obs)
    np.testing.assert_allclose(feats.action(np.zeros((2, 2)), base), base)


def test_agents_import_is_light():
    code = (
        "import sys, cepam_gym_agents, cepam_gym; "
        "print('torch' in sys.modules, 'stable_baselines3' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "False"]


def test_cli_lists_train_and_eval(capsys):
    from cepam_gym.cli import main

    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    assert "train" in out and "eval" in out


@pytest.mark.slow  # trains
def test_time_limit_stops_training_and_saves(tmp_path):
    from cepam_gym_agents.train import train

    cfg = _cfg(total_timesteps=100_000, time_limit_minutes=0)
    assert train(cfg, tmp_path / "limited", quiet=True) == 0
    summary = json.loads((tmp_path / "limited" / "summary.json").read_text())
    assert summary["stopped_by_time_limit"] and 0 < summary["steps"] < 100_000
    assert (tmp_path / "limited" / "model.zip").is_file()


def test_shipped_config_by_name_and_missing_file(tmp_path, monkeypatch):
    from cepam_gym_agents.config.files import resolve_config_path, shipped_configs

    monkeypatch.chdir(tmp_path)  # no configs/ here: the package data answers
    assert set(shipped_configs()) == {p.stem for p in (ROOT / "configs").glob("*.yaml")}
    quick = (ROOT / "configs" / "quick.yaml").read_text()
    for name in ("quick", "quick.yaml", "configs/quick.yaml"):
        assert resolve_config_path(name).read_text() == quick
    assert load_config("quick") == load_config(ROOT / "configs" / "quick.yaml")
    with pytest.raises(ConfigError, match="config file not found: nope.yaml"):
        load_config("nope.yaml")
    with pytest.raises(ConfigError, match="config file not found: elsewhere/quick.yaml"):
        load_config("elsewhere/quick.yaml")  # a path that is not there is not a shipped name


@pytest.mark.parametrize(
    "env_id, residual, n_act",
    [
        ("cepam_gym/CEPAM-v0", False, 2),
        ("cepam_gym/CEPAM-v0", True, 4),
        ("cepam_gym/CEPAMLength-v0", False, 1),
    ],
)
def test_target_shift_moves_the_baselines_targets(env_id, residual, n_act):
    import gymnasium as gym

    from cepam_gym.control import InverseStaticController
    from cepam_gym.policies import Features, FeatureSpec

    venv = gym.make_vec(env_id, num_envs=2)
    obs, _ = venv.reset(seed=2)
    dim = venv.unwrapped.core.obs_dim
    cfg = FeatureSpec(
        target_shift=True, residual=residual, target_shift_length_mm=4.0, target_shift_stiffness=0.5
    )
    feats = Features(venv, cfg, dim)
    assert feats.n_actions == n_act
    f, base = feats(obs)
    assert base is None and f.shape == (2, dim)
    a = np.zeros((2, n_act), dtype=np.float32)
    a[:, 0] = 1.0  # +4 mm
    if n_act > 1:
        a[:, 1] = -1.0  # stiffness x exp(-0.5)
    shifted = obs.astype(np.float64).copy()
    shifted[:, 5] += 4e-3 / 0.0225
    if dim == 9:
        shifted[:, 6] *= np.exp(-0.5)
    ref = InverseStaticController(venv)
    np.testing.assert_allclose(feats.action(a, base), ref.act(shifted), atol=1e-6)
    with pytest.raises(ValueError, match="policy action must have shape"):
        feats.action(np.zeros((2, n_act + 1)), base)


def test_target_shift_moves_the_hinges_angle_target():
    """On the hinge the shift moves the joint angle target (target_shift_angle_deg) and the joint
    stiffness target; the joint baseline then acts on the shifted observation."""
    import gymnasium as gym

    from cepam_gym.control import make_controller
    from cepam_gym.policies import Features, FeatureSpec

    venv = gym.make_vec("cepam_gym/CEPAMJoint-v3", num_envs=2)
    obs, _ = venv.reset(seed=3)
    layout = venv.unwrapped.obs_layout
    dim = obs.shape[1]
    feats = Features(venv, FeatureSpec(target_shift=True, target_shift_angle_deg=3.0), dim)
    assert feats.n_actions == 2
    _, base = feats(obs)
    a = np.array([[1.0, -1.0], [-0.5, 0.0]], dtype=np.float32)
    shifted = obs.astype(np.float64).copy()
    col_a, col_k = layout.column("target_angle"), layout.column("target_stiffness")
    shifted[:, col_a] += a[:, 0] * np.deg2rad(3.0) / layout.scale("target_angle")
    shifted[:, col_k] *= np.exp(0.4 * a[:, 1])
    ref = make_controller("baseline", venv)
    np.testing.assert_allclose(feats.action(a, base), ref.act(shifted), atol=1e-6)
    # no shift: the joint baseline itself
    feats.reset()
    ref.reset()
    _, base = feats(obs)
    np.testing.assert_allclose(feats.action(np.zeros((2, 2), np.float32), base), ref.act(obs), atol=1e-6)


def test_target_shift_excludes_baseline_in_obs():
    with pytest.raises(ConfigError, match="cannot be used with agent.target_shift"):
        _cfg(agent={"target_shift": True, "baseline_in_obs": True})


def test_target_shift_filter_is_first_order_and_observed():
    import gymnasium as gym

    from cepam_gym.policies import Features, FeatureSpec

    venv = gym.make_vec("cepam_gym/CEPAM-v0", num_envs=2)
    obs, _ = venv.reset(seed=2)
    feats = Features(venv, FeatureSpec(target_shift=True, target_shift_filter_s=0.1), 9)
    assert feats.dim == 11  # observation + the two filtered shifts
    alpha = 1 - np.exp(-0.02 / 0.1)
    f, _ = feats(obs)
    np.testing.assert_array_equal(f[:, 9:], 0.0)
    feats.action(
        np.full((2, 2), 0.5, dtype=np.float32), None
    )  # the first action of an episode is taken as is
    feats(obs)
    feats.action(np.full((2, 2), -0.5, dtype=np.float32), None)
    f, _ = feats(obs)
    np.testing.assert_allclose(f[:, 9:], 0.5 - alpha, rtol=1e-6)
    feats.reset([1])
    feats.action(np.full((2, 2), 1.0, dtype=np.float32), None)
    np.testing.assert_allclose(feats._shift[1], 1.0)  # env 1 restarted: no memory of its last episode
    np.testing.assert_allclose(feats._shift[0], 0.5 - alpha + alpha * (1.0 - (0.5 - alpha)), rtol=1e-6)


def test_obs_filters_are_low_passed_observations_restarted_per_episode():
    import gymnasium as gym

    from cepam_gym.policies import Features, FeatureSpec

    venv = gym.make_vec("cepam_gym/CEPAM-v0", num_envs=2)
    feats = Features(venv, FeatureSpec(obs_filters_s=(0.1, 1.0)), 9)
    assert feats.dim == 27 and not feats.trivial
    x0, x1 = np.zeros((2, 9), np.float32), np.ones((2, 9), np.float32)
    f0, _ = feats(x0)
    np.testing.assert_array_equal(f0[:, 9:], 0.0)  # starts at the first observation
    f1, _ = feats(x1)
    a = 1 - np.exp(-0.02 / np.array([0.1, 1.0]))
    np.testing.assert_allclose(f1[:, 9:18], a[0], rtol=1e-6)
    np.testing.assert_allclose(f1[:, 18:], a[1], rtol=1e-6)
    feats.reset([0])
    f2, _ = feats(x1)
    np.testing.assert_allclose(f2[0, 9:], 1.0)  # env 0: new episode, restarted at its observation
    np.testing.assert_allclose(f2[1, 9:18], a[0] + a[0] * (1 - a[0]), rtol=1e-6)
    with pytest.raises(ConfigError, match="obs_filters_s"):
        _cfg(agent={"obs_filters_s": [0.0]})


def test_eval_states_no_goals_of_a_plan():
    """``eval`` compares an agent with the baseline, the MPC and the oracle, never with a plan's
    goals: the training package declares none."""
    from cepam_gym_agents import evaluate

    assert not [n for n in vars(evaluate) if "GOAL" in n.upper()]


def test_the_feature_spec_of_an_agent_section_carries_what_the_features_read():
    """:func:`feature_spec` is the one place the ``agent`` section becomes the library's
    :class:`~cepam_gym.policies.FeatureSpec`: every field by name, ``start_at_base`` (the
    trainer's) left out."""
    from dataclasses import fields

    from cepam_gym.policies import FeatureSpec
    from cepam_gym_agents.config.agent import AgentConfig, feature_spec

    agent = AgentConfig.parse(
        {
            "residual": True,
            "residual_scale": 0.3,
            "setpoint_gaps_in_obs": True,
            "history": 3,
            "obs_filters_s": [0.1, 1.0],
            "privileged_critic": True,
            "friction_observer": True,
            "plant_features": True,
            "start_at_base": True,
        }
    )
    spec = feature_spec(agent)
    assert {f.name for f in fields(AgentConfig)} - {f.name for f in fields(FeatureSpec)} == {"start_at_base"}
    for f in fields(FeatureSpec):
        want = getattr(agent, f.name)
        assert getattr(spec, f.name) == (tuple(want) if isinstance(want, list) else want), f.name
    assert spec.uses_baseline and hash(spec) == hash(feature_spec(agent))
