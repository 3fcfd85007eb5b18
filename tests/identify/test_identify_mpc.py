"""``identify_mpc``: sensor-only, it fits each episode's plant to its identification window and
plans through the fit (:mod:`cepam_gym.identify.identify_mpc`)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym.bench.harness import run_suite
from cepam_gym.bench.suites import RANDOMIZE_V2, SUITES, with_id_window
from cepam_gym.control import make_controller
from cepam_gym.control.baseline import UnsupportedEnvError
from cepam_gym.envs import EnvModel
from cepam_gym.physics import layout as ix

PRIVILEGED = ("params", "state", "aux", "target_l", "target_k", "load", "t_idx", "current_targets")


def _window_env(n: int, seconds: float, **kwargs):
    options = {"id_window_s": seconds}
    env_id = "cepam_gym/CEPAM-v2"
    return gym.make_vec(env_id, num_envs=n, task_options=options, randomize=RANDOMIZE_V2, **kwargs)


def test_it_reads_no_privileged_fact_of_the_env(monkeypatch):
    venv = _window_env(2, 1.5, sensor_noise={"length_mm": 0.2, "pressure_kpa": 1.0}, supply_drift_kpa=5.0)
    ctrl = make_controller("identify_mpc", venv, max_nfev=3)
    obs, info = venv.reset(seed=1)
    read = []

    def refuse(name):
        def get(self):
            read.append(name)
            raise AssertionError(f"identify_mpc read the privileged EnvModel.{name}")

        return property(get)

    for name in PRIVILEGED:
        monkeypatch.setattr(EnvModel, name, refuse(name))
    window = ctrl.window
    assert window == 75
    for _ in range(window + 3):
        a = ctrl.act(obs, info)
        assert a.shape == (2, 2) and np.isfinite(a).all() and (np.abs(a) <= 1).all()
        obs, _, term, _, info = venv.step(a)
        assert not term.any()
    assert read == [] and len(ctrl.fits) == 2
    assert all(f.cost < f.start_cost for f in ctrl.fits)  # the fit moved off the nominal plant
    venv.close()


def test_its_fit_has_no_time_budget_unless_given_one():
    """By default a fit is bounded by its evaluations only (the score then does not depend on the
    machine); a time budget of 0 s stops each fit at once, on its starting point."""
    venv = _window_env(2, 1.5)
    assert make_controller("identify_mpc", venv).identifier.budget_s is None
    ctrl = make_controller("identify_mpc", venv, max_nfev=3, budget_s=0.0)
    obs, info = venv.reset(seed=1)
    for _ in range(ctrl.window + 1):
        obs, *_ = venv.step(ctrl.act(obs, info))
    assert len(ctrl.fits) == 2
    assert all(f.evaluations == 0 and f.cost == f.start_cost for f in ctrl.fits)
    venv.close()


def test_it_needs_a_window():
    venv = gym.make_vec("cepam_gym/CEPAM-v2", num_envs=1)
    with pytest.raises(UnsupportedEnvError, match="id_window_s"):
        make_controller("identify_mpc", venv)
    venv.close()


def _braid_angles_deg(row: np.ndarray, nominal) -> np.ndarray:
    """The CPAM's rest and the EPAM sleeve's free braid angles of a parameter row: ``L = b cos
    theta`` at their (not randomized) rest lengths."""
    return np.degrees(
        np.arccos([nominal.cpam_rest_length / row[ix.BC], nominal.epam_sleeve_free_length / row[ix.BE]])
    )


@pytest.mark.slow
def test_the_fitted_braid_angles_are_closer_to_the_truth_than_the_prior():
    """On the first two episodes of the window suite the fitted angles are nearer the plants' true
    angles than the nominal plant's are: the CPAM's on each plant, both angles together in RMS.
    The EPAM sleeve's angle alone is not always nearer: on one load it trades against the
    compliance of the sleeve's threads (the pair predicts the force as well; with the compliances
    held nominal both angles end further off, docs/identify_then_control.md)."""
    suite = SUITES["randomized-id-v2"]
    venv = gym.make_vec(suite.env_id, num_envs=2, **suite.env_kwargs)
    ctrl = make_controller("identify_mpc", venv)
    obs, info = venv.reset(seed=suite.seed)
    model = venv.unwrapped.env_model
    nominal = model.nominal
    assert np.allclose(_braid_angles_deg(nominal.to_array(), nominal), [22.1832, 29.8466], atol=1e-3)
    truth = np.array([_braid_angles_deg(r, nominal) for r in model.params])
    for _ in range(ctrl.window + 1):
        obs, *_ = venv.step(ctrl.act(obs, info))
    assert len(ctrl.fits) == 2
    fitted = np.array([_braid_angles_deg(f.params.to_array(), nominal) for f in ctrl.fits])
    prior = _braid_angles_deg(nominal.to_array(), nominal)
    err, err0 = np.abs(fitted - truth), np.abs(prior - truth)
    assert (err[:, 0] < err0[:, 0]).all(), (fitted, truth, prior)
    assert np.sqrt(np.mean(err**2)) < 0.5 * np.sqrt(np.mean(err0**2)), (fitted, truth, prior)
    venv.close()


@pytest.mark.slow
def test_it_beats_the_mpc_on_the_window_suite():
    """Two episodes of a short version of the window suite (a 5 s window, 4 s of tracking)."""
    suite = with_id_window(SUITES["randomized-v2"], 5.0)
    ident, _ = run_suite("identify_mpc", suite, episodes=2, max_steps=200)
    mpc, _ = run_suite("mpc", suite, episodes=2, max_steps=200)
    assert ident["failure_rate"] == 0.0
    assert ident["score"] < 0.7 * mpc["score"], (ident["score"], mpc["score"])


def _window_logs(suite, episodes: int, seed: int) -> list:
    """The windows' logs ``(commands, measured, supply)`` of a suite's first episodes as
    identify_mpc records them (its fits replaced by taking the log)."""
    venv = gym.make_vec(suite.env_id, num_envs=episodes, **suite.env_kwargs)
    ident = make_controller("identify_mpc", venv).identifier
    logs = {}
    ident._fit = lambda i: logs.setdefault(
        i, (ident._cmd[i].copy(), ident._meas[i].copy(), ident._supply[i].copy())
    )
    obs, _ = venv.reset(seed=seed)
    for _ in range(ident.window + 1):
        obs, *_ = venv.step(ident.step(obs)[0])
    venv.close()
    return [logs[i] for i in range(episodes)], ident


@pytest.mark.slow
def test_the_staged_fit_leaves_the_corner_where_friction_stands_in_for_the_braid_angles():
    """On one plant of twenty (an unseen seed's 12th episode) the direct fit settles at twice the
    noise floor's cost: the friction doubled, the braid angles off by up to 8 %, the stiffness
    tracked 10 % off. Fitting the dynamics first with the statics held lands at the floor; the
    staged fit keeps the better of the two."""
    import dataclasses

    from cepam_gym.identify.window_fit import fit_window, fit_window_staged, window_recording

    suite = dataclasses.replace(SUITES["randomized-id-v2"], seed=99000)
    logs, ident = _window_logs(suite, 12, suite.seed)
    cmd, meas, supply = logs[11]
    rec = window_recording(cmd, meas, supply, ident.dt)
    start = ident.start_of(meas[0])
    direct = fit_window(rec, start, ident.action_mode, ident.sub_dt, max_nfev=100)
    staged = fit_window_staged(rec, start, ident.action_mode, ident.sub_dt, max_nfev=100)
    # measured: direct 0.72, staged 0.34 (the true plant's cost on this log: 0.34)
    assert staged.cost < 0.6 * direct.cost, (direct.cost, staged.cost)
    assert staged.evaluations > direct.evaluations  # it ran the direct fit too, and counts it


def test_the_staged_fit_is_the_cheaper_of_a_direct_and_a_dynamics_first_fit():
    """Its result is the lower-cost one of the direct fit and the staged one (the dynamics fitted
    with the statics held, then everything from there, bounds around the start throughout); its
    evaluations count all three fits."""
    from cepam_gym.identify.window_fit import (
        DYNAMICS_FIRST_NFEV,
        FREE,
        STATICS,
        fit_window,
        fit_window_staged,
        window_recording,
    )

    logs, ident = _window_logs(SUITES["randomized-id-v2"], 2, 7)
    dynamics = tuple(n for n in FREE if n not in STATICS)
    for cmd, meas, supply in logs:
        rec = window_recording(cmd[:150], meas[:150], supply[:150], ident.dt)
        start, mode, sub_dt = ident.start_of(meas[0]), ident.action_mode, ident.sub_dt
        direct = fit_window(rec, start, mode, sub_dt, max_nfev=8)
        first = fit_window(rec, start, mode, sub_dt, dynamics, None, DYNAMICS_FIRST_NFEV, around=start)
        second = fit_window(rec, first.params, mode, sub_dt, FREE, None, 8, around=start)
        staged = fit_window_staged(rec, start, mode, sub_dt, max_nfev=8)
        best = second if second.cost < direct.cost else direct
        assert staged.cost == best.cost and staged.params == best.params
        assert staged.evaluations == direct.evaluations + first.evaluations + second.evaluations
        assert staged.start_cost == direct.start_cost and second.cost != direct.cost  # two fits differ
