"""Plant v2's extensible braid threads (Chambers and Wereley 2022): the analytic limits, the
stretch law, the exact slopes (finite differences) and what the stretch does to the single EPAM."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cepam_gym.physics import layout as ix
from cepam_gym.physics import muscle, statics, stretch
from cepam_gym.plant.params import preset
from cepam_gym.validation.calibrate_v2 import v2_experiments
from cepam_gym.validation.equilibrium import simulate


@pytest.fixture(scope="module")
def v2():
    return preset("balloon_v2")


def _inextensible(p):
    return p.replace(epam_thread_compliance=0.0, cpam_thread_compliance=0.0)


def test_v0_and_v1_rows_leave_the_thread_columns_zero():
    for name in ("balloon", "balloon_v0"):
        row = preset(name).to_array()
        assert row[ix.THR_E] == row[ix.THR_AE] == row[ix.THR_C] == row[ix.THR_AC] == 0.0


def test_zero_compliance_is_the_inextensible_braid(v2):
    """Compliance 0: the rest threads exactly; a vanishing compliance converges to that force."""
    row0 = _inextensible(v2).to_array()
    assert muscle.thread_lengths(0.175, 200e3, 100e3, row0) == (row0[ix.BC], row0[ix.BE])
    tiny = v2.replace(epam_thread_compliance=1e-12, cpam_thread_compliance=1e-12).to_array()
    for L in (0.16, 0.175, 0.19):
        for pc, pe in ((0.0, 60e3), (250e3, 125e3)):
            f0, k0, c0, e0 = muscle.cepam_force(L, pc, pe, row0)
            f1, k1, c1, e1 = muscle.cepam_force(L, pc, pe, tiny)
            assert f1 == pytest.approx(f0, rel=1e-8, abs=1e-10)
            assert k1 == pytest.approx(k0, rel=1e-8)
            assert (c1, e1) == pytest.approx((c0, e0), rel=1e-8, abs=1e-15)


def test_stretched_slopes_without_stretch_are_the_braid_terms(v2):
    """a = 0 in the (L, b) form of the slopes gives :func:`braid_terms` of the rest braid."""
    row = v2.to_array()
    for L in (0.15, 0.17, 0.195):
        _, _, dvc, dvac, d2vc, d2vac = muscle.cpam_terms(L, row)
        got = stretch.stretched_slopes.py_func(
            L, 1e5, 0.0, 0.0, row[ix.BC], row[ix.QC], row[ix.TAN_C], row[ix.PTA2]
        )
        np.testing.assert_allclose(got[:4], (dvc, dvac, d2vc, d2vac), rtol=1e-10)


def test_thread_stretch_is_linear_in_the_ideal_braid_tension_and_grows_with_pressure(v2):
    """b = b0 (1 + C T), T = P b L / (2 pi n^2), with P the EPAM's pressure (its bladder lies on
    the sleeve: no contact pressure) and the CPAM's P_c - P_e; a squeezed CPAM does not stretch."""
    row = v2.to_array()
    L = 0.175
    assert muscle.contact_pressures(L, row)[2] == 0.0
    prev = row[ix.BE]
    for pe in (25e3, 100e3, 250e3, 500e3):
        _, b = muscle.thread_lengths(L, 0.0, pe, row)
        tension = pe * b * L / (2 * math.pi * row[ix.NE] ** 2)
        assert b == pytest.approx(row[ix.BE] * (1 + v2.epam_thread_compliance * tension), rel=1e-12)
        assert b > prev
        prev = b
    bc, _ = muscle.thread_lengths(L, 250e3, 100e3, row)
    pac = 250e3 - muscle.contact_pressures(L, row)[0]
    tension = (pac - 100e3) * bc * L / (2 * math.pi * row[ix.NC] ** 2)
    assert bc == pytest.approx(row[ix.BC] * (1 + v2.cpam_thread_compliance * tension), rel=1e-12)
    assert muscle.thread_lengths(L, 50e3, 100e3, row)[0] == row[ix.BC]  # squeezed: slack threads


@pytest.mark.parametrize("pc_kpa, pe_kpa", [(0, 60), (60, 50), (75, 50), (125, 75), (250, 125), (300, 20)])
def test_force_derivatives_through_the_stretch_match_finite_differences(v2, pc_kpa, pe_kpa):
    """-dF/dL, dF/dPc, dF/dPe with both braids stretching (compliances raised to make the stretch
    large) against central differences, across the slack gate."""
    row = v2.replace(epam_thread_compliance=1.5e-3, cpam_thread_compliance=1.5e-3).to_array()
    pc, pe = pc_kpa * 1e3, pe_kpa * 1e3

    def f(L, a, b):
        return muscle.cepam_force(L, a, b, row)[0]

    for L in np.linspace(0.155, 0.19, 11):
        _, k, dpc, dpe = muscle.cepam_force(L, pc, pe, row)
        h, hp = 1e-7, 1.0
        assert k == pytest.approx(-(f(L + h, pc, pe) - f(L - h, pc, pe)) / (2 * h), rel=2e-4, abs=0.05), L
        assert dpc == pytest.approx((f(L, pc + hp, pe) - f(L, pc - hp, pe)) / (2 * hp), rel=2e-4, abs=1e-9)
        assert dpe == pytest.approx((f(L, pc, pe + hp) - f(L, pc, pe - hp)) / (2 * hp), rel=2e-4, abs=1e-9)


def test_static_inverse_holds_the_stretched_plant_exactly(v2):
    """The fixed-point inverse: F + W = 0 and -dF/dL = K at the returned pressures; for an
    inextensible plant it is the one affine solve."""
    row0 = _inextensible(v2).to_array()
    affine = statics.static_pressures(0.17, 900.0, 0.3, row0)
    assert statics.static_pressures_exact(0.17, 900.0, 0.3, row0) == affine
    row = v2.to_array()
    for L, K, w in ((0.16, 600.0, 0.2), (0.175, 800.0, 0.2), (0.185, 1000.0, 0.5)):
        pc, pe, ok = statics.static_pressures_exact(L, K, w, row)
        f, k, _, _ = muscle.cepam_force(L, pc, pe, row)
        assert ok == 1.0
        assert f + w == pytest.approx(0.0, abs=1e-9)
        assert k == pytest.approx(K, rel=1e-9)


def test_stretch_lengthens_the_single_epam_towards_the_papers_23_cm(v2):
    """Section III: 23 cm at 300 kPa (balloon), 23.3 cm at 500 kPa (tube). An inextensible braid
    stops below b / sqrt(3); the stretched one reaches both within 10 %."""
    exps = {e.id: e for e in v2_experiments()}
    for eid, paper in (("epam_balloon_length_300", 23.0), ("epam_tube_length_500", 23.3)):
        stretched = simulate(exps[eid], v2).value
        rigid = simulate(exps[eid], _inextensible(v2)).value
        assert rigid < stretched
        assert stretched == pytest.approx(paper, rel=0.1)
        assert rigid < 0.9 * paper


def test_the_baseline_sets_pressures_that_hold_the_stretching_plant_at_its_target():
    """The baseline's inverse is exact on plant v2 (threads stretched at the solution): at its
    set-points the plant's own force balances the weight and its tangent stiffness is the target;
    the affine solve at rest threads would miss the stiffness by several per cent."""
    import gymnasium as gym

    from cepam_gym.control import make_controller
    from cepam_gym.physics import api

    env = gym.make_vec("cepam_gym/CEPAM-v2", num_envs=1)
    try:
        base = make_controller("baseline", env)
        row = base.params
        from cepam_gym.planning.schedules import stiffness_interval

        L = np.array([0.170, 0.175, 0.180])
        W = np.full(3, 0.1 * 9.81)
        k_lo, k_hi = stiffness_interval(L, W, W, row, base.task)
        assert np.all(k_hi > k_lo + 50.0)
        K = k_lo + np.array([0.3, 0.5, 0.7]) * (k_hi - k_lo)  # reachable targets
        pc, pe = base.setpoints(L, K, W)
        np.testing.assert_allclose(api.force(L, pc, pe, row), -W, rtol=1e-4)
        np.testing.assert_allclose(api.stiffness(L, pc, pe, row), K, rtol=1e-3)
        pc0, pe0, _ = api.static_pressures(L, K, W, row)
        assert np.max(np.abs(api.stiffness(L, pc0, pe0, row) / K - 1)) > 0.01
    finally:
        env.close()
