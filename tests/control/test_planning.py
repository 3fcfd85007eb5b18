"""The receding-horizon controllers: the privileged oracle (the benchmark's headroom yardstick)
and the practical MPC on the nominal model (observations only)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401
from cepam_gym import plant as pl
from cepam_gym.bench.harness import make_controller, record
from cepam_gym.bench.metrics import score_traces
from cepam_gym.bench.suites import SUITES
from cepam_gym.control.mpc import ModelPredictiveController
from cepam_gym.control.oracle import OracleController
from cepam_gym.control.planner import CEMConfig, CEMPlanner


def _score(make, episodes=2, steps=150):
    s = SUITES["nominal"]
    tr, track_k = record(make, s.env_id, s.env_kwargs, episodes, s.seed, steps)
    return score_traces(tr, track_k)["score"]


@pytest.mark.slow
def test_oracle_beats_the_baseline_on_a_short_fixed_episode():
    baseline = _score(lambda v: make_controller("baseline", v))
    oracle = _score(lambda v: OracleController(v))
    assert oracle < 0.85 * baseline, (oracle, baseline)


def test_planner_cost_is_the_benchmark_error_along_the_simulated_trajectory():
    env = gym.make("cepam_gym/CEPAM-v0")
    env.reset(seed=3)
    core = env.unwrapped.core
    planner = CEMPlanner(CEMConfig(effort_weight=0.0), core.mode, core.sub_dt, core.n_sub, 250e3)
    h = 4
    actions = np.tile(np.array([[0.3, -0.2]]), (1, h, 1))
    tl = np.full((1, h), 0.17)
    tk = np.full((1, h), 800.0)
    load = np.full((1, h), 0.1)
    got = planner.rollout_cost(core.state.copy(), core.params, actions, tl, tk, load)
    # the same trajectory stepped by hand, errors written out
    x = core.state.copy()
    want = 0.0
    for t in range(h):
        inp = np.array([[0.3, -0.2, 0.1, 0.0]])
        x, aux = pl.step(x, inp, core.params, core.mode, core.sub_dt, core.n_sub)
        want += ((x[0, pl.S_L] - 0.17) / 5e-3) ** 2 + ((aux[0, pl.A_STIFF] - 800.0) / 160.0) ** 2
    assert got.shape == (1,)
    assert got[0] == pytest.approx(want, rel=1e-12)


def test_planner_holds_still_when_the_target_is_where_the_plant_rests():
    """At rest on its target, closed valves cost nothing but the error they keep: the plan
    chosen is (near) zero commands."""
    env = gym.make("cepam_gym/CEPAM-v0")
    env.reset(seed=5)
    core = env.unwrapped.core
    aux = pl.measure(core.state, core.params)
    cfg = CEMConfig(horizon_steps=6, population=16, iterations=2)
    planner = CEMPlanner(cfg, core.mode, core.sub_dt, core.n_sub, 250e3)
    x, aux2 = pl.step(
        core.state.copy(),
        np.array([[0.0, 0.0, core.load[0, 0], 0.0]]),
        core.params,
        core.mode,
        core.sub_dt,
        core.n_sub,
    )
    h = cfg.horizon_steps
    a = planner.plan(
        x,
        core.params,
        np.full((1, h), x[0, pl.S_L]),
        np.full((1, h), aux2[0, pl.A_STIFF]),
        np.full((1, h), core.load[0, 0]),
    )
    assert aux.shape[0] == 1
    assert np.abs(a).max() < 0.2, a


def test_mpc_acts_on_observations_only():
    """The MPC never reads the env's true state: with the state poisoned, its actions are the
    same; on single and batched observations."""
    venv = gym.make_vec("cepam_gym/CEPAM-v0", num_envs=3)
    obs, _ = venv.reset(seed=1)
    mpc = ModelPredictiveController(venv, horizon_steps=5, population=12, iterations=2)
    a1 = mpc.act(obs)
    core = venv.unwrapped.core
    saved = core.state.copy()
    core.state[:] = np.nan
    mpc.reset()
    mpc.planner.rng = np.random.default_rng(mpc.cfg.seed)
    a2 = mpc.act(obs)
    core.state[:] = saved
    assert a1.shape == (3, 2) and a1.dtype == np.float32
    np.testing.assert_array_equal(a1, a2)
    assert mpc.act(obs[0]).shape == (2,)


@pytest.mark.parametrize(
    "bad",
    [
        {"horizon_steps": 0},
        {"elites": 99},
        {"min_std": 0.0},
        {"iterations": 1.5},
        {"noise_beta": -1.0},
        {"plan_substeps": 0},
        {"plan_substeps": 2.5},
        {"send": "median"},
    ],
)
def test_cem_config_rejects_bad_settings_by_name(bad):
    with pytest.raises(ValueError, match=next(iter(bad))):
        CEMConfig(**bad)


def test_mpc_reference_is_the_preview_then_held():
    venv = gym.make_vec("cepam_gym/CEPAM-v1", num_envs=2, preview_steps=4)
    obs, _ = venv.reset(seed=0)
    mpc = ModelPredictiveController(venv, horizon_steps=7)
    core = venv.unwrapped.core
    d = core.obs_layout.decode(obs)
    ref_l, ref_k = mpc.reference(obs, d["target_length"], d["target_stiffness"])
    assert ref_l.shape == (2, 7)
    np.testing.assert_allclose(ref_l[:, :5], core.target_l[:, :5], rtol=1e-6)  # target, then 4 previews
    np.testing.assert_allclose(ref_k[:, :5], core.target_k[:, :5], rtol=1e-6)
    np.testing.assert_array_equal(ref_l[:, 5:], ref_l[:, 4:5].repeat(2, axis=1))  # the last one held


@pytest.mark.parametrize("beta", [2.0, 1.3, 0.0])
@pytest.mark.parametrize("shape", [(2, 48, 2, 8), (3, 16, 2, 5), (1, 4, 2, 1)])
def test_drawing_every_iterations_noise_at_once_gives_the_same_numbers(beta, shape):
    """The planner draws all its iterations' noise in one call (``draws=K``): the same numbers as
    K calls in a row, and the generator left where those calls leave it (the plans depend on it)."""
    from cepam_gym.control.planner import coloured_noise

    r1, r2 = np.random.default_rng(5), np.random.default_rng(5)
    one_by_one = np.stack([coloured_noise(r1, shape, beta) for _ in range(7)])
    at_once = coloured_noise(r2, shape, beta, draws=7)
    np.testing.assert_array_equal(at_once, one_by_one)
    assert r1.standard_normal() == r2.standard_normal()
    if beta > 0 and shape[-1] > 1:  # coloured: unit variance over the samples
        assert abs(at_once.std() - 1.0) < 0.15


def test_coarser_planning_integration_keeps_the_control_period_and_the_plant():
    """``plan_substeps`` re-divides the same 20 ms control period; at half the env's sub-steps
    a plan's cost stays within 2 % of the fine one's, and a sub-step past the explicit
    integration's stability limit is refused with the fix named, for the rows the planner is
    built with and for rows it is given later."""
    from cepam_gym.control.planner import planner_for
    from cepam_gym.envs.model import model_of

    venv = gym.make_vec("cepam_gym/CEPAM-v1", num_envs=1)
    venv.reset(seed=4)
    model = model_of(venv)
    fine = planner_for(model)
    coarse = planner_for(model, plan_substeps=model.n_sub // 2)
    assert (fine.n_sub, coarse.n_sub) == (model.n_sub, model.n_sub // 2)
    assert coarse.sub_dt * coarse.n_sub == pytest.approx(fine.sub_dt * fine.n_sub, rel=1e-12)
    core = venv.unwrapped.core
    h = 10
    rng = np.random.default_rng(0)
    actions = np.clip(rng.normal(0.0, 0.4, (8, h, 2)), -1, 1)
    x = np.repeat(core.state, 8, axis=0)
    args = (np.full((8, h), 0.17), np.full((8, h), 800.0), np.full((8, h), 0.1))
    c_fine = fine.rollout_cost(x, np.asarray(model.params), actions, *args)
    c_coarse = coarse.rollout_cost(x, np.asarray(model.params), actions, *args)
    np.testing.assert_allclose(c_coarse, c_fine, rtol=0.02)  # measured: 0.3 %
    assert not np.array_equal(c_coarse, c_fine)  # a different integration, not the same one
    with pytest.raises(ValueError, match="plan_substeps=5: sub-step .* too long.*use sub_dt"):
        planner_for(model, plan_substeps=5)
    # rows that arrive after the build (a randomized plant at reset) are checked too: a setting
    # stable on the nominal plant is refused for a plant with faster valves
    from cepam_gym.physics import layout as ix

    edge = planner_for(model, plan_substeps=14)  # 1.43 ms: stable on the nominal plant
    fast = np.repeat(np.asarray(model.params, dtype=float), 8, axis=0)
    fast[:, ix.C_PROP] *= 2.0
    with pytest.raises(ValueError, match="plan_substeps=14: sub-step"):
        edge.rollout_cost(x, fast, actions, *args)
    assert np.isfinite(edge.rollout_cost(x, np.asarray(model.params), actions, *args)).all()
    venv.close()


def _sent(cfg: CEMConfig, steps: int) -> np.ndarray:
    """The commands (steps, 2) a planner of ``cfg`` sends while driving a nominal-v1 plant along
    a 1 Hz, 5 mm sine about its target length."""
    from cepam_gym.control.planner import planner_for
    from cepam_gym.envs.model import model_of

    venv = gym.make_vec("cepam_gym/CEPAM-v1", num_envs=1)
    venv.reset(seed=7)
    core, model = venv.unwrapped.core, model_of(venv)
    planner = planner_for(model, cfg)
    h = cfg.horizon_steps
    sent = []
    l0, k0 = core.target_l[:, :1].copy(), core.target_k[:, :1].repeat(h, 1)
    for i in range(steps):
        tl = l0 + 5e-3 * np.sin(2 * np.pi * 0.02 * (i + np.arange(h)))[None]
        tk = k0
        a = planner.plan(core.state.copy(), np.asarray(model.params), tl, tk, np.full((1, h), 0.1))
        sent.append(a[0])
        venv.step(a.astype(np.float32))
    venv.close()
    return np.array(sent)


def test_sending_the_refined_mean_smooths_the_commands_and_keeps_the_search():
    """``send="mean"``: with one elite, no momentum and one iteration the refitted mean is the best
    plan, so the commands are the same bit for bit; with the student's cheap search (16 x 2) they
    move less from one step to the next than the best plan's first commands."""
    one = {"population": 8, "elites": 1, "iterations": 1, "momentum": 0.0}
    np.testing.assert_array_equal(_sent(CEMConfig(**one), 15), _sent(CEMConfig(**one, send="mean"), 15))
    cheap = {"population": 16, "elites": 4, "iterations": 2}
    best, mean = _sent(CEMConfig(**cheap), 60), _sent(CEMConfig(**cheap, send="mean"), 60)
    assert np.abs(mean).max() <= 1.0
    jitter = lambda a: np.abs(np.diff(a, axis=0)).mean()  # noqa: E731
    assert jitter(mean) < 0.9 * jitter(best), (jitter(mean), jitter(best))  # measured: 0.79
