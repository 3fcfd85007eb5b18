"""The inverse-static-model baseline on the nominal plant."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401
from cepam_gym.control import InverseStaticController
from cepam_gym.physics import api
from cepam_gym.planning.schedules import stiffness_interval
from cepam_gym.tasks import TASKS


def _grid(core):
    Ls = np.array([0.155, 0.165, 0.175, 0.185])
    loads = np.array([0.0, 0.15, 0.3])
    fractions = np.array([0.15, 0.5, 0.85])  # where in the reachable stiffness interval
    L, m, f = (a.ravel() for a in np.meshgrid(Ls, loads, fractions, indexing="ij"))
    w = (core.nominal.end_mass + m) * core.nominal.gravity
    lo, hi = stiffness_interval(L, w, w, core.nominal.to_array(), TASKS["cepam"])
    assert (hi > lo).all(), "every grid point must be reachable"
    return L, lo + f * (hi - lo), m


@pytest.mark.parametrize(
    "mode, tol_mm, tol_pct", [("valve", 0.5, 5.0), ("pressure", 0.5, 5.0), ("pwm", 2.0, 5.0)]
)
def test_baseline_settles_on_grid_of_targets_and_loads(mode, tol_mm, tol_pct):
    # PWM at 50 Hz leaves a small limit cycle: 2 mm is what on/off valves achieve here
    venv = gym.make_vec("cepam_gym/CEPAM-v0", num_envs=36, action_mode=mode)
    L, K, m = _grid(venv.unwrapped.core)
    ctl = InverseStaticController(venv)
    obs, info = venv.reset(seed=0, options={"target_length": L, "target_stiffness": K, "load_mass": m})
    ctl.reset()
    for _ in range(400):
        obs, _, term, _, info = venv.step(ctl.act(obs, info))
        assert not term.any()
    assert np.abs(info["length"] - L).max() < tol_mm * 1e-3
    assert (np.abs(info["stiffness"] - K) / K).max() < tol_pct / 100


def test_setpoints_solve_the_static_model_when_feasible():
    env = gym.make("cepam_gym/CEPAM-v0")
    ctl = InverseStaticController(env)
    p = env.unwrapped.core.nominal
    L, K, w = np.array([0.17]), np.array([900.0]), np.array([2.0])
    pc, pe = ctl.setpoints(L, K, w)
    f, k, _, _ = api.force_terms(L, pc, pe, p)
    assert f[0] == pytest.approx(-w[0], abs=1e-9) and k[0] == pytest.approx(900.0, rel=1e-9)


def test_infeasible_stiffness_is_projected_keeping_force_balance():
    env = gym.make("cepam_gym/CEPAM-v0")
    ctl = InverseStaticController(env)
    p = env.unwrapped.core.nominal
    L, w = np.array([0.17]), np.array([2.0])
    lo, hi = stiffness_interval(L, w, w, p.to_array(), ctl.task)
    for K_asked, K_expected in ((1e5, hi[0]), (1.0, lo[0])):
        pc, pe = ctl.setpoints(L, np.array([K_asked]), w)
        f, k, _, _ = api.force_terms(L, pc, pe, p)
        assert f[0] == pytest.approx(-w[0], abs=1e-6)  # the length is still held
        assert k[0] == pytest.approx(K_expected, rel=1e-6)  # the stiffness is the nearest reachable
        assert 0 <= pc[0] <= ctl.p_cap and 0 <= pe[0] <= ctl.p_cap


def test_baseline_uses_nominal_params_on_randomized_env():
    env = gym.make("cepam_gym/CEPAM-v0", randomize={"end_mass_g": [40, 50]})
    ctl = InverseStaticController(env)
    env.reset(seed=0)
    assert np.array_equal(ctl.params, env.unwrapped.core.nominal.to_array())
    assert not np.array_equal(ctl.params, env.unwrapped.core.params[0])


def test_baseline_accepts_single_and_batched_obs():
    env = gym.make("cepam_gym/CEPAMLength-v0")
    ctl = InverseStaticController(env)
    obs, info = env.reset(seed=1)
    a = ctl.act(obs, info)
    assert a.shape == (2,) and a.dtype == np.float32 and np.all(np.abs(a) <= 1)
    venv = gym.make_vec("cepam_gym/CEPAMLength-v0", num_envs=3)
    ctl_v = InverseStaticController(venv)
    obs, info = venv.reset(seed=1)
    assert ctl_v.act(obs, info).shape == (3, 2)


def test_reset_of_some_envs_before_any_action_is_harmless():
    venv = gym.make_vec("cepam_gym/CEPAM-v0", num_envs=3)
    ctl = InverseStaticController(venv)
    ctl.reset(np.array([1]))  # an autoreset can come before the first act()
    obs, info = venv.reset(seed=0)
    assert ctl.act(obs, info).shape == (3, 2)
    ctl.reset(np.array([0, 2]))  # and after it: those envs restart their load filter
    weight, _integral, _friction = ctl.get_state()
    assert np.isnan(weight[[0, 2]]).all() and not np.isnan(weight[1])
