"""``agent.load_estimate_in_obs`` (:mod:`cepam_gym.policies.load_estimate`): the columns are the
adaptive MPC's own filtered load and the nominal model's set-point gaps at it, from the sensors
only; they keep per-env state through peeks and resets like every other feature."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401
from cepam_gym.control import make_controller
from cepam_gym.policies import Features, FeatureSpec

SPEC = FeatureSpec(load_estimate_in_obs=True)
CONSTANT = {"task_options": {"load_kinds": ["constant"]}}


def _columns(f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return f[:, -3], f[:, -2:]


def test_the_columns_are_the_adaptive_mpcs_load_and_the_gaps_at_it():
    """Beside ``adaptive_mpc`` driving the same episodes, the load column is its filter's
    estimate every step, and the gaps are the nominal inverse model's set-points at that load
    minus the measured pressures; under a constant load the estimate settles near the true one."""
    from cepam_gym.physics import layout as ix

    venv = gym.make_vec("cepam_gym/CEPAM-v3", num_envs=3, **CONSTANT)
    obs, info = venv.reset(seed=4)
    ctrl = make_controller("adaptive_mpc", venv, population=8, iterations=1)
    ctrl.reset()
    feats = Features(venv, SPEC, obs.shape[1])
    for _ in range(100):
        f, _ = feats(obs)
        a = ctrl.act(obs, info)
        load, gaps = _columns(f)
        np.testing.assert_array_equal(load, ctrl._x[:, 0].astype(np.float32))
        L, pc, pe, L_t, K_t = ctrl._decode(np.asarray(obs, dtype=float))
        p = ctrl.params
        pc_set, pe_set = feats.baseline.setpoints(L_t, K_t, (p[ix.M_END] + ctrl._x[:, 0]) * p[ix.GRAV])
        np.testing.assert_allclose(gaps, np.stack([pc_set - pc, pe_set - pe], 1) / 1e5, rtol=1e-5, atol=1e-6)
        obs, _r, _te, _tr, info = venv.step(a)
    core = venv.unwrapped.core
    true = core.load[np.arange(3), core.t_idx]
    assert np.abs(load - true).max() < 0.05, (load, true)  # kg, against loads of 0-0.5 kg
    assert load.std() > 0.01  # the three envs' loads differ, and so do their estimates
    venv.close()


def test_a_peek_changes_nothing_and_a_reset_restarts_only_its_envs():
    venv = gym.make_vec("cepam_gym/CEPAM-v3", num_envs=3, **CONSTANT)
    obs, _ = venv.reset(seed=5)
    feats = Features(venv, SPEC, obs.shape[1])
    for _ in range(30):
        feats(obs)
        obs, *_ = venv.step(np.full((3, 2), 0.05, dtype=np.float32))
    first = feats.peek(obs)
    np.testing.assert_array_equal(feats.peek(obs), first)
    np.testing.assert_array_equal(feats(obs)[0], first)
    before = feats.load_estimate.filter._x.copy()
    feats.reset([1])
    after, _ = feats(obs)
    fresh = make_controller("adaptive_mpc", venv)  # a filter started on this observation alone
    fresh.estimate(*fresh._decode(np.asarray(obs, dtype=float))[:3], fresh.layout.value(obs, "velocity"))
    assert after[1, -3] == np.float32(fresh._x[1, 0])  # env 1 starts from the prior again
    assert np.abs(after[[0, 2], -3] - before[[0, 2], 0]).max() < 0.02  # the others go on filtering
    venv.close()


def test_a_config_that_cannot_have_it_is_refused_and_export_names_it(tmp_path):
    pytest.importorskip("stable_baselines3")
    from cepam_gym_agents.config.files import ConfigError, TrainConfig

    def cfg(agent):
        return TrainConfig.from_dict(
            {"algorithm": "PPO", "env": {"id": "cepam_gym/CEPAM-v3", "num_envs": 2}, "agent": agent}
        )

    with pytest.raises(ConfigError, match="load_estimate_in_obs"):
        cfg({"load_estimate_in_obs": True, "residual": True, "base_controller": "mpc_friction"})
    from cepam_gym_agents.export import _refusal

    assert "load_estimate_in_obs" in _refusal(cfg({"load_estimate_in_obs": True}), "PPO")
