"""Tests of the static CE-PAM physics against analytic cases, limits, finite differences and the
paper (Eq. 1-45; summary in docs/model.md).

Every reference value here is computed independently in the test (trigonometry from the braid angle,
the paper's equations written out, central finite differences), never copied from the code.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from cepam_gym.physics import api, load, muscle, valve
from cepam_gym.plant.params import FORCE_FORMS, FORCE_MODELS, PlantParams, preset

# The paper's equations as the paper writes them: equal braid angles (Eq. 6-7 and the 0.325 of
# Eq. 24 hold exactly) and no bladder elasticity (the paper has none). The default plant differs in
# both (calibrated: 28.9 / 19.2 deg, 166 N/m); DEFAULT-plant tests below say so.
BASE = preset("balloon_uncalibrated")
DEFAULT = preset("balloon_v0")  # the calibrated v0 plant (plant v1: test_plant_v1.py)
LENGTHS = np.linspace(0.151, 0.194, 7)  # inside the 15-19.5 cm operating range
ALL_LEVELS = [(m, f) for m in FORCE_MODELS for f in FORCE_FORMS]

# ISO 6358 reference state, written from the model notes (section 5), not imported from the code
RHO0 = 1.185
T0 = 293.15


def fd(fun, x, h):
    """Central finite difference of ``fun`` at ``x``."""
    return (fun(x + h) - fun(x - h)) / (2.0 * h)


def braid_trig(L, b, n):
    """Angle, diameter and Chou's dV/dL of one braid by trigonometry (paper Eq. 1-3, 14-20)."""
    theta = math.acos(L / b)
    D = b * math.sin(theta) / (n * math.pi)
    V = math.pi * D * D * L / 4.0
    dV_dL = -b * b * (3.0 * math.cos(theta) ** 2 - 1.0) / (4.0 * math.pi * n * n)
    return theta, D, V, dV_dL


def radial_pr(L, b, n, d_o, kr_hi, kr_lo):
    """Eq. 27-28/32: P_r = K_r (D_o - D sin(theta)), K_r by the paper's D sin(theta) < D_o/2 rule,
    clipped at 0 once the bladder touches the sleeve."""
    theta = math.acos(L / b)
    x = b * math.sin(theta) / (math.pi * n) * math.sin(theta)
    kr = kr_hi if x < d_o / 2 else kr_lo
    return max(kr * (d_o - x), 0.0)


def kr_switch_lengths(p: PlantParams):
    """Lengths where P_r has a step (K_r switch) or a kink (bladder touches the sleeve)."""
    out = []
    for (b, n), d_o in ((p.cpam_braid(), p.cpam_bladder_diameter), (p.epam_braid(), p.epam_bladder_diameter)):
        for x in (d_o / 2, d_o):  # D sin(theta) = (b^2 - L^2)/(pi n b) = x
            L2 = b * b - math.pi * n * b * x
            if L2 > 0:
                out.append(math.sqrt(L2))
    return np.array(out)


# --------------------------------------------------------------------------- 1
@pytest.mark.parametrize("model,form", ALL_LEVELS)
def test_zero_pressure_gives_zero_force(model, form):
    """No gauge pressure, no elasticity: the CE-PAM makes no force and no stiffness at any length."""
    p = BASE.replace(force_model=model, force_form=form, elastic_stiffness=0.0)
    F, K, _, _ = api.force_terms(LENGTHS, 0.0, 0.0, p)
    assert F.shape == LENGTHS.shape
    np.testing.assert_array_equal(np.abs(F) <= 1e-12, True)
    np.testing.assert_array_equal(np.abs(K) <= 1e-9, True)
    # and a pressure does make force (the zero is not a trivially dead model)
    F1 = api.force(LENGTHS, 100e3, 0.0, p)
    assert np.all(np.abs(F1) > 1.0)


# --------------------------------------------------------------------------- 2
@pytest.mark.parametrize("b,n", [(BASE.cpam_braid()), (BASE.epam_braid()), (0.25, 2.0)])
def test_braid_terms_chou_single_muscle(b, n):
    """Chou and Hannaford (Eq. 14-20): dV/dL = -b^2 (3 cos^2 - 1) / (4 pi n^2) with cos = L/b;
    V = pi D^2 L / 4 (Eq. 3) with D = b sin / (n pi) (Eq. 2); also via Eq. 18/19 (d/dtheta)."""
    for L in LENGTHS:
        theta, D, V, dV = braid_trig(L, b, n)
        v_out, v_air, dv_out, dv_air, d2v_out, _ = muscle.braid_terms(L, b, n, 0.0)
        assert v_out == pytest.approx(V, rel=1e-12)
        assert dv_out == pytest.approx(dV, rel=1e-10, abs=1e-15)
        # Eq. 17-19 route: (dV/dtheta) / (dL/dtheta)
        dv_dth = b**3 * math.sin(theta) * (3 * math.cos(theta) ** 2 - 1) / (4 * math.pi * n * n)
        dl_dth = -b * math.sin(theta)
        assert dv_out == pytest.approx(dv_dth / dl_dth, rel=1e-10, abs=1e-15)
        # with no wall the air volume is the braid volume
        assert v_air == v_out and dv_air == dv_out
        # and d2V/dL2 is the derivative of dV/dL
        h = 1e-6
        d2_fd = fd(lambda x: muscle.braid_terms(x, b, n, 0.0)[2], L, h)
        assert d2v_out == pytest.approx(d2_fd, rel=1e-6)


@pytest.mark.parametrize("ta", [0.0002, 0.0005, 0.001])
def test_braid_terms_air_volume_derivatives(ta):
    """Thick wall (Eq. 34-37, 40, 42-45): V_air = pi (D - 2 t_a)^2 L / 4; its dV/dL and d2V/dL2 equal
    central finite differences; dV_air/dL equals the paper's printed Eq. 40 bracket."""
    b, n = BASE.cpam_braid()
    h = 1e-6
    for L in LENGTHS:
        theta, D, _, _ = braid_trig(L, b, n)
        v_out, v_air, dv_out, dv_air, d2v_out, d2v_air = muscle.braid_terms(L, b, n, ta)
        assert v_air == pytest.approx(math.pi * (D - 2 * ta) ** 2 * L / 4, rel=1e-12)
        # Eq. 37 expanded form
        eq37 = (
            math.pi
            * b
            * math.cos(theta)
            / 4
            * (
                b * b * math.sin(theta) ** 2 / (math.pi**2 * n * n)
                - 4 * ta * b * math.sin(theta) / (math.pi * n)
                + 4 * ta * ta
            )
        )
        assert v_air == pytest.approx(eq37, rel=1e-12)
        assert dv_air == pytest.approx(fd(lambda x: muscle.braid_terms(x, b, n, ta)[1], L, h), rel=1e-7)
        assert d2v_air == pytest.approx(fd(lambda x: muscle.braid_terms(x, b, n, ta)[3], L, h), rel=1e-6)
        assert d2v_out == pytest.approx(fd(lambda x: muscle.braid_terms(x, b, n, ta)[2], L, h), rel=1e-6)
        c = math.cos(theta)
        eq40 = (
            b * ta / (n * math.sin(theta)) * (2 * c * c - 1)
            - b * b / (4 * math.pi * n * n) * (3 * c * c - 1)
            + math.pi * ta * ta
        )
        assert dv_air == pytest.approx(eq40, rel=1e-10)
        # a wall makes the air volume smaller than the braid volume
        assert v_air < v_out


# --------------------------------------------------------------------------- 3
def test_eq24_constant_is_0325_for_equal_braid_angles():
    """0.325 = 1.3 (bc/be)^2 (ne/nc)^2 (Eq. 5-7 into Eq. 23 -> Eq. 24) for the uncalibrated
    balloon preset, whose CPAM and EPAM braids have equal angles (the calibrated default's do not)."""
    assert BASE.cpam_rest_angle == BASE.epam_sleeve_free_angle
    bc, nc = BASE.cpam_braid()
    be, ne = BASE.epam_braid()
    assert 1.3 * (bc / be) ** 2 * (ne / nc) ** 2 == pytest.approx(0.325, rel=1e-12)
    # the paper's Eq. 6-7 relations themselves
    assert 2 * bc == pytest.approx(1.3 * be, rel=1e-12)
    assert nc == pytest.approx(1.3 * ne, rel=1e-12)
    # with unequal angles the constant is different (the identity is not vacuous)
    q = BASE.replace(cpam_rest_angle=math.radians(20.0))
    (bc2, nc2), (be2, ne2) = q.cpam_braid(), q.epam_braid()
    assert abs(1.3 * (bc2 / be2) ** 2 * (ne2 / nc2) ** 2 - 0.325) > 1e-3


def _paper_eq24_minus_eq20(L, Pc, Pe, p: PlantParams):
    bc, nc = p.cpam_braid()
    be, ne = p.epam_braid()
    cc = math.cos(math.acos(L / bc))
    ce = math.cos(math.acos(L / be))
    Fe = be**2 * Pe / (4 * math.pi * ne**2) * (0.325 * (3 * cc**2 - 1) - (3 * ce**2 - 1))  # Eq. 24
    Fc = bc**2 * (Pc - Pe) / (4 * math.pi * nc**2) * (3 * cc**2 - 1)  # Eq. 20
    return Fe - Fc  # Eq. 25


@pytest.mark.parametrize("Pc,Pe", [(0.0, 100e3), (150e3, 100e3), (250e3, 250e3), (75e3, 50e3), (20e3, 180e3)])
def test_basic_paper_form_is_eq24_minus_eq20(Pc, Pe):
    p = BASE.replace(force_model="basic", force_form="paper")
    F = api.force(LENGTHS, Pc, Pe, p)
    ref = np.array([_paper_eq24_minus_eq20(L, Pc, Pe, p) for L in LENGTHS])
    np.testing.assert_allclose(F, ref, rtol=1e-10, atol=1e-9)


@pytest.mark.parametrize("model", ["radial", "enhanced"])
@pytest.mark.parametrize("Pc,Pe", [(150e3, 100e3), (250e3, 150e3), (50e3, 250e3)])
def test_paper_form_is_eq41_minus_eq45(model, Pc, Pe):
    """Paper form with P_r (Eq. 27-33) and, at the enhanced level, t_a (Eq. 41 minus Eq. 45),
    written out with trig; the K_r switch rule of Eq. 27 is reimplemented here."""
    p = BASE.replace(force_model=model, force_form="paper")
    bc, nc = p.cpam_braid()
    be, ne = p.epam_braid()
    ta = p.bladder_thickness + p.sleeve_thickness if model == "enhanced" else 0.0
    for L in np.linspace(0.151, 0.194, 23):
        thc, the = math.acos(L / bc), math.acos(L / be)
        cc, ce = math.cos(thc), math.cos(the)
        Pac = max(Pc - radial_pr(L, bc, nc, p.cpam_bladder_diameter, p.kr_high, p.kr_low), 0.0)
        Pae = max(Pe - radial_pr(L, be, ne, p.epam_bladder_diameter, p.kr_high, p.kr_low), 0.0)
        Fe = Pae * (
            be**2 / (4 * math.pi * ne**2) * (0.325 * (3 * cc**2 - 1) - (3 * ce**2 - 1))
            + ta * (be / (ne * math.sin(the)) * (2 * ce**2 - 1) + math.pi * ta)
        )  # Eq. 41
        Fc = -(Pac - Pae) * (
            bc * ta / (nc * math.sin(thc)) * (2 * cc**2 - 1)
            - bc**2 / (4 * math.pi * nc**2) * (3 * cc**2 - 1)
            + math.pi * ta**2
        )  # Eq. 45
        assert float(api.force(L, Pc, Pe, p)) == pytest.approx(Fe - Fc, rel=1e-9, abs=1e-9)


# --------------------------------------------------------------------------- 4
@pytest.mark.parametrize("form", FORCE_FORMS)
@pytest.mark.parametrize("model", ["radial", "enhanced"])
def test_refined_models_reduce_to_basic(model, form):
    """With K_r = 0 (no radial loss) and no wall thickness the refinements are the basic model."""
    basic = BASE.replace(force_model="basic", force_form=form)
    red = BASE.replace(
        force_model=model,
        force_form=form,
        kr_high=0.0,
        kr_low=0.0,
        bladder_thickness=0.0,
        sleeve_thickness=0.0,
    )
    Lg, Pc, Pe = np.meshgrid(LENGTHS, [0.0, 30e3, 120e3, 250e3], [0.0, 40e3, 200e3], indexing="ij")
    for a, b in zip(
        api.force_terms(Lg.ravel(), Pc.ravel(), Pe.ravel(), red),
        api.force_terms(Lg.ravel(), Pc.ravel(), Pe.ravel(), basic),
    ):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)
    # with the default K_r and t_a they do differ (the reduction test is not vacuous)
    full = BASE.replace(force_model=model, force_form=form)
    assert not np.allclose(
        api.force(Lg.ravel(), Pc.ravel(), Pe.ravel(), full),
        api.force(Lg.ravel(), Pc.ravel(), Pe.ravel(), basic),
    )


# --------------------------------------------------------------------------- 5
PRESSURES_FD = [(60e3, 40e3), (150e3, 100e3), (250e3, 200e3), (40e3, 230e3)]  # all >> P_r (< 8 kPa)


@pytest.mark.parametrize("model,form", ALL_LEVELS)
def test_stiffness_is_minus_dF_dL(model, form):
    p = BASE.replace(force_model=model, force_form=form)
    # P_r is at most K_r D_o (= 20 kPa for the EPAM, < 8 kPa in range for the CPAM); all test
    # pressures are well above it so P_a > 0 and no max(., 0) kink is crossed
    grid = np.linspace(0.1505, 0.1945, 31)
    bad = kr_switch_lengths(p) if model != "basic" else np.array([])
    grid = np.array([L for L in grid if np.all(np.abs(L - bad) > 1e-4)])
    assert grid.size > 20
    h = 1e-7
    for Pc, Pe in PRESSURES_FD:
        K = api.stiffness(grid, Pc, Pe, p)
        K_fd = -(api.force(grid + h, Pc, Pe, p) - api.force(grid - h, Pc, Pe, p)) / (2 * h)
        np.testing.assert_allclose(K, K_fd, rtol=2e-6, atol=2e-3)


@pytest.mark.parametrize("model,form", ALL_LEVELS)
def test_pressure_sensitivities_are_dF_dP(model, form):
    p = BASE.replace(force_model=model, force_form=form)
    Lg = np.linspace(0.152, 0.193, 9)
    h = 1.0  # Pa; F is affine in each pressure above P_r
    for Pc, Pe in PRESSURES_FD:
        _, _, dfdpc, dfdpe = api.force_terms(Lg, Pc, Pe, p)
        np.testing.assert_allclose(dfdpc, fd(lambda x: api.force(Lg, x, Pe, p), Pc, h), rtol=1e-6, atol=1e-12)
        np.testing.assert_allclose(dfdpe, fd(lambda x: api.force(Lg, Pc, x, p), Pe, h), rtol=1e-6, atol=1e-12)


@pytest.mark.parametrize("model,form", ALL_LEVELS)
def test_closed_chamber_stiffness_is_isentropic_dF_dL(model, form):
    """Sealed chambers: p_abs V^n const with V from chamber_volumes (dead volumes included); the
    closed-chamber stiffness is -dF/dL along that compression."""
    p = BASE.replace(force_model=model, force_form=form)
    nexp = p.polytropic_exponent
    patm = p.atmospheric_pressure
    grid = np.linspace(0.1505, 0.1945, 17)
    bad = kr_switch_lengths(p) if model != "basic" else np.array([])
    grid = np.array([L for L in grid if np.all(np.abs(L - bad) > 1e-4)])
    h = 1e-7
    for Pc, Pe in PRESSURES_FD:
        Vc0, Ve0, _, _ = api.chamber_volumes(grid, p)

        def F_sealed(L):
            Vc, Ve, _, _ = api.chamber_volumes(L, p)
            pc = (Pc + patm) * (Vc0 / Vc) ** nexp - patm
            pe = (Pe + patm) * (Ve0 / Ve) ** nexp - patm
            return api.force(L, pc, pe, p)

        K_fd = -(F_sealed(grid + h) - F_sealed(grid - h)) / (2 * h)
        K = api.closed_chamber_stiffness(grid, Pc, Pe, p)
        np.testing.assert_allclose(K, K_fd, rtol=2e-6, atol=2e-3)
        # sealed air always stiffens the muscle relative to regulated pressures
        assert np.all(K > api.stiffness(grid, Pc, Pe, p))


def test_chamber_volume_slopes_match_finite_differences():
    for model in FORCE_MODELS:
        p = BASE.replace(force_model=model)
        Vc, Ve, dVc, dVe = api.chamber_volumes(LENGTHS, p)
        h = 1e-6
        np.testing.assert_allclose(dVc, fd(lambda x: api.chamber_volumes(x, p)[0], LENGTHS, h), rtol=1e-7)
        np.testing.assert_allclose(dVe, fd(lambda x: api.chamber_volumes(x, p)[1], LENGTHS, h), rtol=1e-7)
        assert np.all(Vc > p.dead_volume_cpam) and np.all(Ve > p.dead_volume_epam)


# --------------------------------------------------------------------------- 6
@pytest.mark.parametrize("model", ["basic", "enhanced"])
@pytest.mark.parametrize("Pc,Pe", [(150e3, 100e3), (0.0, 250e3), (250e3, 0.0), (80e3, 200e3)])
def test_virtual_work_balance(model, Pc, Pe):
    """force_form='virtual_work': F dL = Pe dV_annulus + Pc dV_cpam (volumes by finite difference).
    The enhanced level is taken without the radial loss (K_r = 0), which is not a pressure-volume
    work term."""
    for base in (BASE, DEFAULT):  # equal braids without elasticity; the calibrated default plant
        p = base.replace(force_model=model, force_form="virtual_work", kr_high=0.0, kr_low=0.0)
        if model == "enhanced":
            assert p.wall_thickness() > 0
        h = 1e-6
        grid = np.linspace(0.1505, 0.1945, 15)
        dVc = fd(lambda x: api.chamber_volumes(x, p)[0], grid, h)
        dVe = fd(lambda x: api.chamber_volumes(x, p)[1], grid, h)
        # the bladder elasticity is a spring, not pressure-volume work: F_el = -k_el (L - L_el0)
        f_el = -p.elastic_stiffness * (grid - p.elastic_rest_length)
        np.testing.assert_allclose(
            api.force(grid, Pc, Pe, p) - f_el, Pe * dVe + Pc * dVc, rtol=1e-7, atol=1e-7
        )
    assert DEFAULT.elastic_stiffness > 0  # the second pass really tested the spring term


def test_paper_form_differs_from_virtual_work():
    """The paper form counts Pe's effect on the CPAM volume 1 + 1.3 times (Eq. 15 and 22): at the basic
    level F_paper - F_vw = -1.3 Pe dV_c/dL exactly. For typical pressures this is as large as the
    force itself: at L = 17.5 cm, Pe = 100 kPa it is about 32 N (paper 62 N vs virtual work 31 N for
    Pc = 0)."""
    paper = BASE.replace(force_model="basic", force_form="paper")
    vw = BASE.replace(force_model="basic", force_form="virtual_work")
    bc, nc = BASE.cpam_braid()
    for Pc, Pe in [(0.0, 100e3), (150e3, 100e3), (250e3, 250e3)]:
        for L in LENGTHS:
            dVc = braid_trig(L, bc, nc)[3]
            diff = float(api.force(L, Pc, Pe, paper) - api.force(L, Pc, Pe, vw))
            assert diff == pytest.approx(-1.3 * Pe * dVc, rel=1e-9)
    L = 0.175
    Fp, Fv = float(api.force(L, 0.0, 100e3, paper)), float(api.force(L, 0.0, 100e3, vw))
    assert 25.0 < Fp - Fv < 40.0  # -1.3 * 1e5 * dVc/dL, dVc/dL = -2.44e-4 m^2 at 17.5 cm
    assert Fp - Fv > 0.5 * abs(Fv)  # not a small correction
    # at the enhanced level the difference is Pae (-(1.3 - 1) dVc/dL - dVac/dL): still tens of N
    pe_ = BASE.replace(force_model="enhanced", force_form="paper")
    ve_ = BASE.replace(force_model="enhanced", force_form="virtual_work")
    d = api.force(LENGTHS, 150e3, 100e3, pe_) - api.force(LENGTHS, 150e3, 100e3, ve_)
    assert np.all(d > 10.0)


# --------------------------------------------------------------------------- 7
C, B, RLAM = 1e-9, 0.3, 0.995


def _iso(p1, p2, t1=T0):
    return float(api.iso6358_flow(p1, p2, t1, C, B, RLAM))


@pytest.mark.parametrize("t1", [T0, 350.0, 250.0])
def test_iso6358_choked_value(t1):
    p1 = 500e3
    ref = C * RHO0 * p1 * math.sqrt(T0 / t1)
    for r in (0.0, 0.1, 0.2, B):
        assert _iso(p1, r * p1, t1) == pytest.approx(ref, rel=1e-12)


def test_iso6358_subsonic_formula_and_continuity():
    p1 = 400e3
    choked = C * RHO0 * p1
    for r in (0.35, 0.5, 0.8, 0.95, 0.99):
        x = (r - B) / (1 - B)
        assert _iso(p1, r * p1) == pytest.approx(choked * math.sqrt(1 - x * x), rel=1e-12)
    eps = 1e-10
    # continuous at the critical ratio b ...
    assert _iso(p1, B * p1 * (1 + eps)) == pytest.approx(_iso(p1, B * p1 * (1 - eps)), rel=1e-8)
    # ... and at the laminar ratio
    lo, hi = _iso(p1, RLAM * p1 * (1 - eps)), _iso(p1, RLAM * p1 * (1 + eps))
    assert lo == pytest.approx(hi, rel=1e-6)
    # zero at equal pressures, linear in the laminar region
    assert _iso(p1, p1) == 0.0
    r1, r2 = 0.996, 0.998
    assert _iso(p1, r1 * p1) / _iso(p1, r2 * p1) == pytest.approx((1 - r1) / (1 - r2), rel=1e-9)


def test_iso6358_monotone_in_downstream_pressure():
    p1 = 300e3
    p2 = np.linspace(0.0, p1, 20001)
    m = api.iso6358_flow(p1, p2, T0, C, B, RLAM)
    assert np.all(np.diff(m) <= 0.0)
    assert np.all(np.diff(m[p2 > B * p1 * 1.001]) < 0.0)  # strictly once unchoked
    assert m[-1] == 0.0 and np.all(m >= 0.0)


def test_signed_flow_antisymmetric():
    rng = np.random.default_rng(1)
    for _ in range(200):
        pa, pb = rng.uniform(50e3, 600e3, 2)
        ta, tb = rng.uniform(250.0, 350.0, 2)
        f_ab = valve.signed_flow(pa, ta, pb, tb, C, B, RLAM)
        f_ba = valve.signed_flow(pb, tb, pa, ta, C, B, RLAM)
        assert f_ab == -f_ba
        assert (f_ab > 0) == (pa > pb)
        # the upstream temperature is the one used
        up_t = ta if pa > pb else tb
        assert abs(f_ab) == pytest.approx(_iso(max(pa, pb), min(pa, pb), up_t), rel=1e-14)
    assert valve.signed_flow(2e5, 300.0, 2e5, 250.0, C, B, RLAM) == 0.0


def test_spool_first_order_exact():
    """Order-1 spool: tau ds/dt = cmd - s integrated exactly, saturating at +-1."""
    tau, dt = 0.005, 1e-3
    decay = math.exp(-dt / tau)  # the caller passes exp(-dt/tau), computed once per control step
    s, r = 0.0, 0.0
    for k in range(1, 20):
        s, r = valve.spool_step(s, r, 0.8, dt, tau, 1, 0.7, decay)
        assert s == pytest.approx(0.8 * (1 - math.exp(-k * dt / tau)), rel=1e-12)
    s, r = valve.spool_step(0.9, 0.0, 5.0, 0.1, tau, 1, 0.7, math.exp(-0.1 / tau))
    assert s == 1.0
    # order 2 settles on the command without leaving [-1, 1]
    s, r = 0.0, 0.0
    for _ in range(2000):
        s, r = valve.spool_step(s, r, -0.6, 1e-4, tau, 2, 0.7, 0.0)
        assert -1.0 <= s <= 1.0
    assert s == pytest.approx(-0.6, abs=1e-4)


def test_first_order_interval_is_the_spool_law_averaged():
    """``first_order_interval`` (the rig's leak check credits the valves with it) is the order-1
    spool of ``spool_step`` over an interval: its end equals stepping the law, its mean equals the
    average of finely stepped openings."""
    tau, dt, n = 0.005, 0.02, 20000
    for s0, cmd in ((0.0, 0.8), (0.6, -0.3), (-0.2, -0.2)):
        mean, end = valve.first_order_interval(s0, cmd, dt, tau)
        h = dt / n
        decay = math.exp(-h / tau)
        s, r, acc = s0, 0.0, 0.0
        for _ in range(n):
            s_next, r = valve.spool_step(s, r, cmd, h, tau, 1, 0.7, decay)
            acc += 0.5 * (s + s_next) * h  # trapezoid: second order in h
            s = s_next
        assert end == pytest.approx(s, abs=1e-12)
        assert mean == pytest.approx(acc / dt, abs=1e-8)
    assert valve.first_order_interval(0.3, 0.3, dt, tau) == (0.3, 0.3)


# --------------------------------------------------------------------------- 12
@pytest.mark.parametrize("model,form", ALL_LEVELS)
def test_static_pressures_round_trip(model, form):
    p = BASE.replace(force_model=model, force_form=form)
    cases = [
        (0.175, 552.542, 0.5),
        (0.175, 863.552, 2.0),
        (0.185, 1084.0, 1.0),
        (0.16, 800.0, 0.2),
        (0.19, 700.0, 3.0),
    ]
    for L, K, w in cases:
        Pc, Pe, ok = api.static_pressures(L, K, w, p)
        assert ok, (L, K, w, Pc, Pe)
        F, Kx, _, _ = api.force_terms(L, Pc, Pe, p)
        assert float(F) == pytest.approx(-w, rel=1e-9, abs=1e-9)
        assert float(Kx) == pytest.approx(K, rel=1e-9)
    # vectorised call agrees with the scalar ones
    Ls = np.array([c[0] for c in cases])
    Ks = np.array([c[1] for c in cases])
    ws = np.array([c[2] for c in cases])
    Pc, Pe, ok = api.static_pressures(Ls, Ks, ws, p)
    F, Kx, _, _ = api.force_terms(Ls, Pc, Pe, p)
    np.testing.assert_allclose(F, -ws, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(Kx, Ks, rtol=1e-9)


def test_static_pressures_flags_unphysical_targets():
    """A negative stiffness target cannot be reached with positive pressures (K rises with both)."""
    p = BASE
    Pc, Pe, ok = api.static_pressures(0.175, -500.0, 1.0, p)
    assert not ok


def test_load_step_terminal_velocity_friction_and_stops():
    """Free end: implicit damping reaches the exact terminal velocity (F + M g - F_coulomb) / c,
    Coulomb friction sticks below its level, and the plastic end stops clamp L and v."""
    m, g, c, fc, dt = 0.2, 9.81, 5.0, 0.3, 5e-4
    L, v = 0.16, 0.0
    for _ in range(4000):
        L, v, stop = load.load_step(L, v, -1.0, m, 0.0, g, c, fc, 0.0, 10.0, dt)
    assert v == pytest.approx((-1.0 + m * g - fc) / c, rel=1e-9)
    # below the friction level the end does not move from rest
    L1, v1, _ = load.load_step(0.17, 0.0, -m * g + 0.5 * fc, m, 0.0, g, c, fc, 0.15, 0.195, dt)
    assert (L1, v1) == (0.17, 0.0)
    # end stops
    L2, v2, s2 = load.load_step(0.1949, 1.0, 0.0, m, 0.0, g, c, 0.0, 0.15, 0.195, dt)
    assert (L2, v2, s2) == (0.195, 0.0, 1.0)
    L3, v3, s3 = load.load_step(0.1501, -1.0, 0.0, m, 0.0, g, c, 0.0, 0.15, 0.195, dt)
    assert (L3, v3, s3) == (0.15, 0.0, -1.0)
