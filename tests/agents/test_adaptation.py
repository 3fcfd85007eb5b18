"""The adaptation module (``student.adaptation``, RMA's second phase): a network from the sensors'
history to the plant's columns, told to a student where no identification window runs
(:mod:`cepam_gym.policies.plant_estimate`, ``agents/learners/adaptation.py``)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

import cepam_gym  # noqa: E402, F401  (registers the ids)
from cepam_gym.bench.suites import SUITES  # noqa: E402
from cepam_gym.control.baseline import UnsupportedEnvError, rig_model_of  # noqa: E402
from cepam_gym.errors import InputError  # noqa: E402
from cepam_gym.identify.window_identifier import plant_columns, rows_of_columns  # noqa: E402
from cepam_gym.physics import layout as ix  # noqa: E402
from cepam_gym.policies.plant_estimate import (  # noqa: E402
    INPUTS,
    EstimatedPlant,
    InputFrames,
    PlantEstimator,
)
from cepam_gym_agents.config.files import ConfigError, TrainConfig  # noqa: E402

RANDOMIZED = SUITES["randomized-v3"]


def _venv(n: int, window_s: float = 0.0):
    kwargs = dict(RANDOMIZED.env_kwargs)
    if window_s:
        kwargs["task_options"] = {"id_window_s": window_s}
    return gym.make_vec(RANDOMIZED.env_id, num_envs=n, **kwargs)


def _config(adaptation=None) -> TrainConfig:
    student = {"suites": {"nominal-v3": 2, "randomized-v3": 6}, "net_arch": [16, 16]}
    if adaptation is not None:
        student["adaptation"] = adaptation
    return TrainConfig.from_dict(
        {
            "algorithm": "PPO",
            "env": {"id": "cepam_gym/CEPAM-v3", "num_envs": 2, "suite": "randomized-v3"},
            "normalize": {"obs": True},
            "agent": {"history": 2, "setpoint_gaps_in_obs": True, "plant_features": True},
            "student": student,
            "eval": {"suite": "randomized-id-v3"},
        }
    )


def _student(run, venv, adaptation=None):
    """A saved student with small random weights, told the plant (the format a run loads)."""
    import torch

    from cepam_gym.policies import Features
    from cepam_gym_agents.config.agent import feature_spec
    from cepam_gym_agents.config.files import dump_config
    from cepam_gym_agents.learners.student import _Actor, as_ppo
    from cepam_gym_agents.session.checkpoints import save_model

    cfg = _config(adaptation)
    dim = Features(venv, feature_spec(cfg.agent), venv.observation_space.shape[1]).actor_dim
    actor = _Actor(dim, [16, 16], seed=0)
    with torch.no_grad():
        for p in actor.params:
            p.mul_(0.1)
    model, vecnorm = as_ppo(cfg, actor, np.zeros(dim), np.ones(dim), np.array([0.05, 0.05]), seed=0)
    save_model(run, "final", model, vecnorm)
    dump_config(cfg, run / "config.yaml")
    return cfg


def _estimator(k: int, history=6, stride=2, seed=0) -> PlantEstimator:
    rng = np.random.default_rng(seed)
    d = len(range(history - 1, -1, -stride)) * len(INPUTS)
    shapes = [(8, d), (k, 8)]
    return PlantEstimator(
        history,
        stride,
        tuple(rng.normal(0, 0.3, s).astype(np.float32) for s in shapes),
        tuple(rng.normal(0, 0.1, s[0]).astype(np.float32) for s in shapes),
        rng.normal(0, 1, d).astype(np.float32),
        rng.uniform(0.5, 2, d).astype(np.float32),
        np.full(k, -0.2, np.float32),
        np.full(k, 0.2, np.float32),
    )


def test_the_told_rows_of_a_plants_columns_give_back_its_columns():
    venv = _venv(6)
    venv.reset(seed=1)
    model = rig_model_of(venv)
    cols = plant_columns(model.params, model.nominal)
    rows = rows_of_columns(cols, model.nominal)
    np.testing.assert_allclose(plant_columns(rows, model.nominal), cols, atol=1e-6)
    base = model.nominal.to_array()
    assert (rows[:, ix.M_END] == base[ix.M_END]).all() and (rows[:, ix.P_SUP] == base[ix.P_SUP]).all()
    np.testing.assert_array_equal(
        rows_of_columns(np.zeros_like(cols), model.nominal), np.repeat(base[None], 6, 0)
    )
    venv.close()


def test_the_estimator_is_the_torch_network_saved_clipped_and_loaded(tmp_path):
    """The deployed numpy network computes what the fitted torch network does, inside the fitted
    plants' range, and survives its file."""
    import torch

    from cepam_gym_agents.learners.adaptation import _Net

    net = _Net(18, 5, [12, 12], seed=3)
    mean, std = np.linspace(-1, 1, 18), np.linspace(0.5, 2, 18)
    wide = net.frozen(mean, std, np.full(5, -1e9), np.full(5, 1e9), history=4, stride=2)
    x = np.random.default_rng(0).normal(0, 2, (7, 18)).astype(np.float32)
    with torch.no_grad():
        want = net.net(torch.as_tensor((x - mean) / std, dtype=torch.float32)).numpy()
    np.testing.assert_allclose(wide(x), want, rtol=1e-5, atol=1e-5)
    tight = net.frozen(mean, std, np.full(5, -0.01), np.full(5, 0.01), history=4, stride=2)
    assert np.abs(tight(x)).max() <= 0.01 + 1e-7
    tight.save(tmp_path / "e.npz")
    again = PlantEstimator.load(tmp_path / "e.npz")
    np.testing.assert_array_equal(again(x), tight(x))
    assert (again.history, again.stride, again.inputs, again.frames) == (4, 2, INPUTS, 2)
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(InputError, match="bad.npz: not a plant estimator file"):
        PlantEstimator.load(tmp_path / "bad.npz")


def test_the_input_frames_are_the_strided_history_oldest_first():
    venv = _venv(2)
    layout = rig_model_of(venv).obs_layout
    frames = InputFrames(layout, ("length", "pressure_c"), history=5, stride=2)
    i, j = layout.names.index("length"), layout.names.index("pressure_c")
    obs = np.zeros((2, len(layout.names)), dtype=np.float32)
    seen = []
    for t in range(7):
        obs[:, i], obs[:, j] = t, 10 * t
        seen.append(frames.push(obs))
    # steps 2, 4 and 6 of the last 5 (2..6), the first observation filling the history before it
    np.testing.assert_array_equal(seen[-1][0], [2, 20, 4, 40, 6, 60])
    np.testing.assert_array_equal(seen[0][0], [0, 0, 0, 0, 0, 0])
    frames.reset([1])  # env 1's episode ended: its next frame fills its history, env 0's goes on
    obs[:, i], obs[:, j] = 9, 90
    x = frames.push(obs)
    np.testing.assert_array_equal(x[0], [3, 30, 5, 50, 9, 90])  # its history 3..9: 3, 5, 9
    np.testing.assert_array_equal(x[1], [9, 90, 9, 90, 9, 90])
    with pytest.raises(InputError, match="does not observe"):
        InputFrames(layout, ("length", "hinge_angle"))
    venv.close()


def test_deployed_without_a_window_it_is_told_the_estimate_and_behind_one_the_fit(tmp_path):
    from cepam_gym_agents.policy import load_policy

    venv = _venv(3)
    _student(tmp_path, venv)
    policy = load_policy(tmp_path, venv)
    obs, _ = venv.reset(seed=0)
    with pytest.raises(UnsupportedEnvError, match="no plant estimator.*id_window_s"):
        policy.act(obs)  # no adaptation module and no window: nothing to tell it
    model = rig_model_of(venv)
    k = plant_columns(model.params, model.nominal).shape[1]
    est = _estimator(k)
    est.save(tmp_path / PlantEstimator.FILE)
    policy = load_policy(tmp_path, venv)
    policy.reset()
    for _ in range(3):
        a = policy.act(obs)
        assert np.isfinite(a).all()
        obs, *_ = venv.step(a)
    ident = policy.features.identifier
    assert isinstance(ident, EstimatedPlant)
    np.testing.assert_allclose(ident.rows, rows_of_columns(est(ident.frames.inputs()), model.nominal))
    assert np.abs(plant_columns(ident.rows, model.nominal)).max() > 1e-3  # told the estimate, not nominal
    behind = _venv(2, window_s=1.5)
    policy = load_policy(tmp_path, behind)
    obs, _ = behind.reset(seed=0)
    policy.act(obs)
    assert not isinstance(policy.features.identifier, EstimatedPlant)  # the window's fit rules
    venv.close()
    behind.close()


def test_the_adaptation_section_is_checked():
    cfg = _config({"history_s": 2.0, "stride": 4})
    assert cfg.student.adaptation.history_s == 2.0 and cfg.student.adaptation.stride == 4
    assert TrainConfig.from_dict(cfg.to_dict()) == cfg  # the run directory's round trip
    with pytest.raises(ConfigError, match="history_seconds.*student.adaptation"):
        _config({"history_seconds": 2.0})
    with pytest.raises(ConfigError, match="history_s must be > 0"):
        _config({"history_s": 0})
    bare = _config().to_dict()
    bare["agent"]["plant_features"] = False
    bare["student"]["adaptation"] = {}
    bare["eval"] = {}
    with pytest.raises(ConfigError, match="needs agent.plant_features"):
        TrainConfig.from_dict(bare)


@pytest.mark.slow
def test_the_module_learns_the_plant_from_the_history(tmp_path):
    """Fitted on rollouts of a student (random weights, told the true plant), the module tells
    other plants nearer their true columns than the nominal plant would (at least 20 % less
    squared error on 24 plants it never saw), and the run's file is what a loaded run reads."""
    from cepam_gym_agents.learners.adaptation import fit_adaptation, rollout

    venv = _venv(1)
    adaptation = {"history_s": 0.5, "stride": 5, "envs": 128, "rounds": 1, "gradient_steps": 400}
    cfg = _student(tmp_path, venv, adaptation)
    venv.close()
    record = fit_adaptation(cfg, tmp_path, cfg.student.adaptation, say=lambda _: None)
    assert [r["round"] for r in record["rounds"]] == [0] and record["history_steps"] == 25
    est = PlantEstimator.load(tmp_path / PlantEstimator.FILE)
    x, y = rollout(tmp_path, "randomized-v3", 24, 777, None, est.history, est.stride)
    err, nominal = ((est(x) - y) ** 2).sum(), (y**2).sum()
    assert err < 0.8 * nominal, (err, nominal)
