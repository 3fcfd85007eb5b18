"""A deployment's score from its log: the benchmark's metrics of the steps it logged, aligned by
their times; and the same controller on a simulated rig."""

from __future__ import annotations

import numpy as np
import pytest

from cepam_gym.control import make_controller
from cepam_gym.errors import InputError
from cepam_gym.rig.cli import DEFAULT_ENV, _episode
from cepam_gym.rig.score import APPROACH_S, log_score, simulate


@pytest.fixture(scope="module")
def episode():
    return _episode(DEFAULT_ENV, {}, 1000, 0, 1)


def test_a_log_scores_each_step_against_its_own_target_also_when_steps_were_skipped(episode):
    _env, model, tl, tk = episode
    n = 200
    steps = np.arange(n - 1)
    error = 1e-3 * (1 + steps / n)  # step k ends 1 to 2 mm long, each step its own error
    measured = np.zeros((n, 3))
    measured[1:, 2] = tl[: n - 1] + error
    measured[1:, :2] = 100e3, 50e3
    first = int(round(APPROACH_S / model.control_dt))

    def rmse_mm(scored):
        return 1e3 * np.sqrt(np.mean(error[scored] ** 2))

    full = log_score(measured, model, tl, tk, model.nominal, False)
    assert full["length_rmse_mm"] == pytest.approx(rmse_mm(steps >= first), rel=1e-9)
    times = np.arange(n) * model.control_dt + 0.003  # stamped 3 ms after each release
    keep = np.ones(n, dtype=bool)
    keep[[140, 141, 150]] = False  # skipped steps (the target moving): no rows, the steps before no end
    gapped = log_score(measured[keep], model, tl, tk, model.nominal, False, times[keep])
    scored = (steps >= first) & ~np.isin(steps + 1, [140, 141, 150])
    assert gapped["length_rmse_mm"] == pytest.approx(rmse_mm(scored), rel=1e-9)
    shifted = log_score(measured[keep], model, tl, tk, model.nominal, False)  # rows taken as steps
    assert shifted["length_rmse_mm"] != pytest.approx(rmse_mm(scored), rel=1e-3)
    tripped = log_score(measured, model, tl, tk, model.nominal, True)
    assert tripped["score"] > full["score"]  # a trip is a failed episode
    with pytest.raises(InputError, match="nothing to score"):
        log_score(measured[:first], model, tl, tk, model.nominal, False)


def test_the_simulated_deployment_tracks_like_the_benchmarks_baseline(episode):
    env, model, tl, tk = episode
    measured, tripped = simulate(model.nominal, make_controller("baseline", env), model, tl, tk, 0.1, 150, 0)
    assert not tripped and measured.shape == (150, 3) and np.isfinite(measured).all()
    score = log_score(measured, model, tl, tk, model.nominal, tripped)
    assert score["length_rmse_mm"] < 2.0 and score["score"] < 1.0
    again, _ = simulate(model.nominal, make_controller("baseline", env), model, tl, tk, 0.1, 150, 0)
    np.testing.assert_array_equal(again, measured)  # a seed is one run
