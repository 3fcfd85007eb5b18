"""Reference trajectories of tracking tasks: shapes, reachability, followability."""

from __future__ import annotations

import numpy as np
import pytest

from cepam_gym.planning.episodes import episode_schedules
from cepam_gym.planning.references import (
    min_jerk,
    periodic_length,
    pressure_rate_ratio,
    project,
    smooth_reference,
    smooth_steps,
    stiffness_ramp,
)
from cepam_gym.planning.schedules import stiffness_interval
from cepam_gym.plant.params import PlantParams
from cepam_gym.tasks import TASKS

DT = 0.02
P = PlantParams().to_array()
SPEC = TASKS["cepam"]


def test_min_jerk_has_zero_rate_and_acceleration_at_both_ends():
    s = np.linspace(0, 1, 2001)
    x = min_jerk(s)
    v = np.gradient(x, s)
    acc = np.gradient(v, s)
    assert x[0] == 0 and x[-1] == 1
    assert abs(v[0]) < 1e-5 and abs(v[-1]) < 1e-5
    # peak acceleration 10/sqrt(3) = 5.77; at the ends it vanishes (0.03 one grid step in)
    assert abs(acc[1]) < 0.05 and abs(acc[-2]) < 0.05 and acc.max() == pytest.approx(5.7735, rel=1e-3)
    assert np.all(np.diff(x) >= 0)
    assert v.max() == pytest.approx(1.875, rel=1e-4)  # 15/8, the classic peak rate


def test_smooth_steps_joins_set_points_without_jumps():
    v = np.r_[np.full(50, 0.16), np.full(50, 0.18), np.full(50, 0.17)]
    out = smooth_steps(v, DT, 0.4)
    assert out[0] == 0.16 and out[70] == pytest.approx(0.18) and out[-1] == pytest.approx(0.17)
    assert np.abs(np.diff(out)).max() < 0.02 * 1.875 * DT / 0.4 * 1.01 + 1e-12
    # a change that comes before the move ends starts from where the move had got to
    w = np.r_[np.full(10, 0.0), np.full(5, 1.0), np.full(30, 0.0)]
    out = smooth_steps(w, DT, 0.4)
    assert 0 < out[14] < 1 and np.abs(np.diff(out)).max() < 1.875 * DT / 0.4 + 1e-12


def _schedule(seed=0):
    rng = np.random.default_rng(seed)
    tl, tk, load, _ = episode_schedules([rng], SPEC, P, 500, DT)
    return tl[0], tk[0], load[0]


@pytest.mark.parametrize("seed", range(4))
def test_smooth_reference_is_reachable_and_followable(seed):
    tl, tk, load = _schedule(seed)
    L, K = smooth_reference(tl, tk, load, P, SPEC, DT)
    from cepam_gym.physics import layout as ix

    w = (P[ix.M_END] + load) * P[ix.GRAV]
    k_lo, k_hi = stiffness_interval(L, w, w, P, SPEC)
    assert np.all((K >= k_lo) & (K <= k_hi))
    assert np.all((L >= SPEC.length_range[0]) & (L <= SPEC.length_range[1]))
    # followable: no step asks more than a fully open valve gives (the generator aims at half of
    # it, which a move ending near the pressure cap, where the fill rate vanishes, cannot always keep)
    assert pressure_rate_ratio(L, K, load, P, DT).max() <= 1.0
    assert np.median(pressure_rate_ratio(L, K, load, P, DT)[pressure_rate_ratio(L, K, load, P, DT) > 0]) < 0.5
    # the steps themselves are not followable: that is what the smoothing is for
    assert pressure_rate_ratio(tl, tk, load, P, DT).max() > 1.0


@pytest.mark.parametrize("kind", ["sine", "chirp"])
def test_periodic_length_at_constant_reachable_stiffness(kind):
    rng = np.random.default_rng(3)
    load = np.full(500, 0.1)
    L, K = periodic_length(rng, SPEC, load, P, 500, DT, kind=kind)
    assert np.ptp(K) == 0.0 and np.ptp(L) > 1e-3
    L2, K2 = project(L, K, load, P, SPEC)
    np.testing.assert_allclose(K2, K)
    assert pressure_rate_ratio(L, K, load, P, DT).max() <= 0.5


def test_stiffness_ramp_holds_the_length():
    tl, tk, load = _schedule(1)
    L, K = stiffness_ramp(tk, np.minimum(load, 0.15), P, TASKS["stiffness"], DT, 0.175)
    assert np.all(L == 0.175)
    assert np.abs(np.diff(K)).max() < np.abs(np.diff(tk)).max()


def test_project_names_an_impossible_load():
    with pytest.raises(ValueError, match="no reachable stiffness"):
        project(np.full(3, 0.17), np.full(3, 800.0), np.full(3, 50.0), P, SPEC)


def test_reachable_targets_are_met_by_the_plants_own_force_model():
    """Inside the reachable interval the inverse static model's pressures give the target on the
    plant's force model, slack switch included: the CPAM of plant v1 stays taut there (a slack
    one would add no force, and the inverse model would promise a stiffness the plant lacks)."""
    from cepam_gym.physics import api
    from cepam_gym.physics import layout as ix

    rng = np.random.default_rng(0)
    L = rng.uniform(*SPEC.length_range, 400)
    w = (P[ix.M_END] + rng.uniform(*SPEC.load_range, 400)) * P[ix.GRAV]
    k_lo, k_hi = stiffness_interval(L, w, w, P, SPEC)
    ok = k_hi > k_lo
    assert ok.mean() > 0.5
    K = k_lo + rng.uniform(0.01, 0.99, 400) * (k_hi - k_lo)
    pc, pe, _ = api.static_pressures(L[ok], K[ok], w[ok], P)
    f, k, _, _ = api.force_terms(L[ok], pc, pe, P)
    np.testing.assert_allclose(f + w[ok], 0.0, atol=1e-9)
    np.testing.assert_allclose(k, K[ok], rtol=1e-9)
    c, c_taut = api.cpam_tension(L[ok], pc, pe, P)
    assert np.all(c <= c_taut + 1e-12)
