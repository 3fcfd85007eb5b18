"""Plant v1 statics: tension-only CPAM braid and neo-Hookean bladder walls (docs/physics.md,
"Plant v1"). Reference values are computed here independently (the neo-Hookean energy written
out from the stretches, central finite differences), never copied from the code."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cepam_gym import plant
from cepam_gym.physics import api
from cepam_gym.physics import layout as ix
from cepam_gym.plant.params import FORCE_FORMS, FORCE_MODELS, PlantParams

# a v1 parameter set written out here (independent of the shipped presets' fitted values)
V1 = PlantParams().replace(
    braid_tension="tension_only",
    bladder_model="neo_hookean",
    bladder_shear_modulus=600e3,
    tube_shear_modulus=400e3,
    bladder_thickness=0.2e-3,
    sleeve_thickness=0.1e-3,
    elastic_stiffness=0.0,
    cpam_rest_angle=math.radians(26.0),
    epam_sleeve_free_angle=math.radians(40.0),
)
V0_LIKE = V1.replace(braid_tension="bidirectional", bladder_model="spring", elastic_stiffness=0.0)
LENGTHS = np.linspace(0.151, 0.194, 9)


def fd(fun, x, h):
    return (fun(x + h) - fun(x - h)) / (2.0 * h)


def neo_hookean_energy(L, p: PlantParams):
    """Both walls' energy from the stretches (thin-wall incompressible neo-Hookean cylinders):
    lam1 = L / L_ref, lam2 = D(L) / D(L_ref), U = mu V_r (lam1^2 + lam2^2 + (lam1 lam2)^-2 - 3) / 2."""
    total = 0.0
    for b_n, l_ref, d_o in (
        (p.cpam_braid(), p.cpam_rest_length, p.cpam_bladder_diameter),
        (p.epam_braid(), p.epam_bladder_length, p.epam_bladder_diameter),
    ):
        b, n = b_n

        def diameter(x):
            return b * math.sin(math.acos(x / b)) / (n * math.pi)

        l1 = L / l_ref
        l2 = diameter(L) / diameter(l_ref)
        v_rubber = math.pi * (d_o - p.bladder_thickness) * p.bladder_thickness * l_ref
        total += p.bladder_shear_modulus * v_rubber * 0.5 * (l1**2 + l2**2 + (l1 * l2) ** -2 - 3.0)
    return total


def test_bladder_energy_matches_the_stretches_and_its_derivatives():
    for L in LENGTHS:
        u, du, d2u = (float(v) for v in api.bladder_energy(L, V1))
        assert u == pytest.approx(neo_hookean_energy(L, V1), rel=1e-10)
        assert du == pytest.approx(fd(lambda x: neo_hookean_energy(x, V1), L, 1e-6), rel=1e-6, abs=1e-9)
        assert d2u == pytest.approx(
            fd(lambda x: float(api.bladder_energy(x, V1)[1]), L, 1e-6), rel=1e-6, abs=1e-6
        )
    # stress free at each bladder's rest configuration, positive elsewhere
    assert neo_hookean_energy(V1.cpam_rest_length, V1.replace(bladder_shear_modulus=0.0)) == 0.0
    assert float(api.bladder_energy(0.17, V1)[0]) > 0.0


def test_v0_rows_store_no_bladder_energy():
    u, du, d2u = api.bladder_energy(LENGTHS, V0_LIKE)
    assert np.all(u == 0.0) and np.all(du == 0.0) and np.all(d2u == 0.0)


def test_slack_cpam_adds_no_force():
    """Pe >= Pc: the CPAM is squeezed from outside, its braid slack. The CE-PAM then makes exactly
    the force of the EPAM alone, P_e dV_ae/dL - dU_e/dL (no CPAM braid term, no CPAM wall)."""
    row = V1.to_array()
    alone = row.copy()  # the EPAM alone: no CPAM term, no CPAM wall
    alone[ix.KAPPA] = alone[ix.LAMBDA] = 0.0
    alone[ix.EL_C] = 0.0
    for pc, pe in ((0.0, 100e3), (50e3, 100e3), (120e3, 120e3), (0.0, 250e3)):
        f = api.force(LENGTHS, pc, pe, row)
        f_epam = api.force(LENGTHS, 0.0, pe, alone)
        np.testing.assert_allclose(f, f_epam, rtol=1e-12, atol=1e-12)
    # the bidirectional (v0) braid pushes there: the difference is the push the braid cannot make
    f_v0 = api.force(LENGTHS, 0.0, 250e3, V1.replace(braid_tension="bidirectional"))
    assert np.all(f_v0 > api.force(LENGTHS, 0.0, 250e3, V1) + 1.0)


def test_taut_cpam_is_unchanged_by_the_switch():
    """Well in tension (Pc >> Pe) the tension-only braid is the bidirectional one."""
    for pc, pe in ((200e3, 50e3), (250e3, 125e3)):
        f1 = api.force(LENGTHS, pc, pe, V1)
        f2 = api.force(LENGTHS, pc, pe, V1.replace(braid_tension="bidirectional"))
        np.testing.assert_allclose(f1, f2, rtol=1e-12)


@pytest.mark.parametrize("L", [0.16, 0.175, 0.19])
def test_force_and_stiffness_continuous_at_the_switch(L):
    """Sweep Pc through the slack-taut transition at fixed Pe: neighbouring samples of force and
    stiffness differ in proportion to the sample spacing (halving the spacing halves the largest
    step), i.e. neither jumps; a jump of the braid term would be ~0.06 N (w |dV_c/dL|)."""
    pe = 80e3
    f_coarse = api.force(np.full(31, L), np.linspace(0.0, 300e3, 31), pe, V1)
    assert np.ptp(f_coarse) > 0.5  # the CPAM takes hold inside the sweep
    slack = np.abs(f_coarse - f_coarse[0]) < 1e-9
    i = int(np.argmin(slack))  # first taut sample
    lo, hi = (i - 1) * 10e3, (i + 1) * 10e3

    def steps(n):
        pcs = np.linspace(lo, hi, n)
        f, k, _, _ = api.force_terms(np.full(n, L), pcs, pe, V1)
        return np.abs(np.diff(f)).max(), np.abs(np.diff(k)).max(), f

    sf1, sk1, f = steps(20001)  # 1 Pa
    sf2, sk2, _ = steps(40001)  # 0.5 Pa
    assert np.ptp(f) > 0.1
    assert sf1 < 1e-3 and sf2 < 0.6 * sf1
    assert sk2 < 0.6 * sk1


@pytest.mark.parametrize(
    "pc,pe", [(0.0, 150e3), (75e3, 50e3), (81e3, 80e3), (80.5e3, 80e3), (250e3, 125e3), (175e3, 100e3)]
)
def test_stiffness_and_pressure_sensitivities_are_exact_derivatives(pc, pe):
    """K = -dF/dL at constant pressures and dF/dP by central differences, the switch included
    (80.5 and 81 kPa against 80: inside the 1 kPa switch at some lengths)."""
    for L in LENGTHS:
        f, k, dpc, dpe = (float(v) for v in api.force_terms(L, pc, pe, V1))
        num_k = -fd(lambda x: float(api.force(x, pc, pe, V1)), L, 1e-7)
        assert k == pytest.approx(num_k, rel=2e-5, abs=2e-3)
        assert dpc == pytest.approx(fd(lambda x: float(api.force(L, x, pe, V1)), pc, 0.5), rel=1e-4, abs=1e-9)
        assert dpe == pytest.approx(fd(lambda x: float(api.force(L, pc, x, V1)), pe, 0.5), rel=1e-4, abs=1e-9)


def test_paper_levels_unchanged_by_the_v1_fields():
    """The reproduction table's named levels (basic Eq. 25, radial Eq. 30-33, enhanced Eq. 41/45,
    paper and virtual-work forms) evaluate the same with the v1 fields at their v0 values, whatever
    v1 values the plant carries otherwise (bladder modulus, tube modulus, slack width)."""
    other = V0_LIKE.replace(bladder_shear_modulus=900e3, tube_shear_modulus=50e3, slack_width=5e3)
    for fm in FORCE_MODELS:
        for ff in FORCE_FORMS:
            a = V0_LIKE.replace(force_model=fm, force_form=ff)
            b = other.replace(force_model=fm, force_form=ff)
            for pc, pe in ((0.0, 150e3), (175e3, 100e3)):
                np.testing.assert_array_equal(
                    api.force_terms(LENGTHS, pc, pe, a), api.force_terms(LENGTHS, pc, pe, b)
                )


def test_thicker_walls_contract_less():
    """Section X: the same CPAM with a thicker tube wall contracts less at the same pressure."""
    from cepam_gym.validation import Experiment, simulate

    out = []
    for t_mm in (1.0, 1.5, 2.0):
        e = Experiment(
            "c",
            "c",
            "contraction",
            "%",
            1.0,
            device="cpam",
            bladder="tube",
            bladder_thickness_mm=t_mm,
            pc_kpa=500.0,
        )
        out.append(simulate(e, V1).value)
    assert out[0] > out[1] > out[2]


def test_single_muscle_free_length_depends_on_pressure():
    """With elastic walls a lone CPAM shortens and a lone EPAM lengthens as the pressure rises
    (a bare braid is force free at one length whatever the pressure)."""
    from cepam_gym.validation import Experiment, simulate

    def length(device, kpa):
        e = Experiment("l", "l", "length", "cm", 1.0, device=device, pc_kpa=kpa, pe_kpa=kpa)
        return simulate(e, V1).value

    c = [length("cpam", k) for k in (100.0, 175.0, 250.0)]
    e = [length("epam", k) for k in (50.0, 150.0, 300.0)]
    assert c[0] > c[1] > c[2]
    assert e[0] < e[1] < e[2]


def test_inverse_statics_includes_the_walls():
    """The 2x2 inverse (physics.statics) holds length and stiffness on the v1 plant (CPAM taut)."""
    w = (V1.end_mass + 0.1) * V1.gravity
    for L, K in ((0.165, 900.0), (0.18, 1200.0)):
        pc, pe, ok = api.static_pressures(L, K, w, V1)
        assert ok and pc > pe + 5e3
        f, k, _, _ = api.force_terms(L, pc, pe, V1)
        assert float(f) + w == pytest.approx(0.0, abs=1e-8)
        assert float(k) == pytest.approx(K, rel=1e-9)


def test_sealed_v1_plant_conserves_energy_with_the_walls():
    """Sealed chambers, no heat, no damping, no radial loss, CPAM taut all the way: air + load +
    atmosphere + wall strain energy is conserved up to the integration error, which halves with
    the sub-step (the walls are a conservative force)."""

    def drift(dt, n_sub=10, t_end=0.2):
        p = V1.replace(
            heat_transfer=0.0,
            heat_transfer_coefficient=0.0,
            leak_conductance=0.0,
            damping=0.0,
            kr_high=0.0,
            kr_low=0.0,
            friction_coefficient=0.0,
        )
        P = p.to_array()[None]
        load = 0.1
        M, patm = p.end_mass + load, p.atmospheric_pressure

        def energy(x, a):
            return (
                x[0, plant.S_UC]
                + x[0, plant.S_UE]
                + 0.5 * M * x[0, plant.S_V] ** 2
                - M * p.gravity * x[0, plant.S_L]
                + patm * (a[plant.A_VC] + a[plant.A_VE])
                + float(api.bladder_energy(x[0, plant.S_L], p)[0])
            )

        x = plant.initial_state(P, 0.17, 200e3, 60e3)
        a = plant.measure(x, P)[0]
        e0 = energy(x, a)
        dE, Ls = [], []
        for _ in range(int(round(t_end / dt / n_sub))):
            x, aux = plant.step(x, np.array([[0.0, 0.0, load, 0.0]]), P, dt=dt, n_sub=n_sub)
            dE.append(energy(x, aux[0]) - e0)
            Ls.append(x[0, plant.S_L])
            assert aux[0, plant.A_PC] > aux[0, plant.A_PE] + 20e3  # taut throughout
        return np.abs(dE).max(), np.ptp(Ls)

    e1, travel = drift(1e-4)
    e2, _ = drift(5e-5)
    u_wall = float(api.bladder_energy(0.17, V1)[0])
    assert travel > 5e-4
    assert u_wall > 1e-3  # the walls hold energy comparable to the oscillation's
    assert e1 < 5e-4
    assert e2 < 0.6 * e1


# ------------------------------------------------------------------ air and valves of plant v1
def test_each_chamber_exchanges_heat_through_its_own_wall_area():
    """hA of each chamber = h times its wall area at mid-stroke (CPAM: its bladder's inside;
    annulus: the EPAM bladder's inside and the CPAM's outside), written out here; a warm sealed
    chamber then cools at hA (T_amb - T) / (m c_v)."""
    p = V1.replace(heat_transfer_coefficient=10.0, leak_conductance=0.0)
    row = p.to_array()
    lm = 0.5 * (p.min_length + p.max_length)
    (bc, nc), (be, ne) = p.cpam_braid(), p.epam_braid()
    d_c = bc * math.sin(math.acos(lm / bc)) / (math.pi * nc)
    d_e = be * math.sin(math.acos(lm / be)) / (math.pi * ne)
    ta = p.wall_thickness()
    ha_c = 10.0 * math.pi * (d_c - 2 * ta) * lm
    ha_e = 10.0 * math.pi * (d_e - 2 * ta + d_c) * lm
    assert row[ix.HA_C] == pytest.approx(ha_c, rel=1e-12) and row[ix.HA_E] == pytest.approx(ha_e, rel=1e-12)
    assert ha_e > 2.5 * ha_c  # the annulus has the larger wall
    v0 = V0_LIKE.replace(heat_transfer_coefficient=0.0).to_array()
    assert v0[ix.HA_C] == v0[ix.HA_E] == V0_LIKE.heat_transfer

    # the same run without wall heat cancels the compression's share of the temperature change
    adiabatic = row.copy()
    adiabatic[ix.HA_C] = adiabatic[ix.HA_E] = 0.0
    inp = np.array([[0.0, 0.0, 0.2, 0.0]])
    x = plant.initial_state(row[None], 0.17, 150e3, 60e3, temperature=313.15)
    _, aux = plant.step(x, inp, row[None], dt=5e-5, n_sub=40)  # 2 ms
    _, aux0 = plant.step(x, inp, adiabatic[None], dt=5e-5, n_sub=40)
    cv = 287.0 / 0.4
    for s_m, a_t, ha in ((plant.S_MC, plant.A_TC, ha_c), (plant.S_ME, plant.A_TE, ha_e)):
        rate = (aux[0, a_t] - aux0[0, a_t]) / 2e-3
        expected = ha * (p.ambient_temperature - 313.15) / (x[0, s_m] * cv)
        assert rate == pytest.approx(expected, rel=0.05)


def _pwm_mass_gain(p, duty, n_periods=3):
    P = p.to_array()[None]
    x = plant.initial_state(P, 0.17, 50e3, 50e3)
    m0 = x[0, plant.S_MC]
    n_sub = int(round(n_periods / p.pwm_frequency / 5e-5))
    x, _ = plant.step(x, np.array([[duty, 0.0, 0.1, 0.0]]), P, mode=plant.ONOFF, dt=5e-5, n_sub=n_sub)
    return x[0, plant.S_MC] - m0


def test_onoff_dead_time_swallows_short_pulses():
    """On/off valves open d_on after the PWM's rising edge and close d_off after its falling edge:
    a pulse shorter than d_on - d_off (here 1 ms against 4 - 2 ms) passes no air; a v0 valve (no
    dead time) passes it; a long pulse passes air either way."""
    p = V1.replace(leak_conductance=0.0, onoff_open_delay=4e-3, onoff_close_delay=2e-3, pwm_frequency=50.0)
    short = 1e-3 * p.pwm_frequency  # duty of a 1 ms pulse
    assert _pwm_mass_gain(p, short) == 0.0
    assert _pwm_mass_gain(p.replace(onoff_open_delay=0.0, onoff_close_delay=0.0), short) > 0.0
    long_v1 = _pwm_mass_gain(p, 0.3)
    long_v0 = _pwm_mass_gain(p.replace(onoff_open_delay=0.0, onoff_close_delay=0.0), 0.3)
    # open 0.3 T - (d_on - d_off) = 4 ms instead of 6 ms per 20 ms period: about 2/3 of the air
    assert 0.5 * long_v0 < long_v1 < 0.85 * long_v0
    assert _pwm_mass_gain(p, 1.0) == pytest.approx(
        _pwm_mass_gain(p.replace(onoff_open_delay=0.0, onoff_close_delay=0.0), 1.0), rel=1e-12
    )  # full duty: no switching


# ------------------------------------------------------------------ friction (Maxwell-slip)
def _friction_cycle(row, pc, pe, amplitude=2e-3, n=2000, cycles=2):
    """Impose L = 0.17 + A sin(t) on the friction elements alone; return (L, F_friction)."""
    from cepam_gym.physics.friction import friction_force, friction_slip

    ls = 0.17 + amplitude * np.sin(np.linspace(0.0, 2 * np.pi * cycles, n * cycles + 1))
    z = (0.0, 0.0, 0.0)
    forces = [friction_force(row, pc, pe, *z)]
    for k in range(1, ls.size):
        z = friction_slip(row, ls[k] - ls[k - 1], *z)
        forces.append(friction_force(row, pc, pe, *z))
    return ls, np.array(forces)


def test_friction_hysteresis_loop_area_is_the_slid_work_and_grows_with_pressure():
    """One cycle of +-2 mm: element i slides 4 (A - delta_i) per cycle at its break-away force
    w_i c (Pc + Pe), so the loop encloses sum 4 w_i F_b (A - delta_i) (the sticking part returns
    what it stores); the friction force opposes the motion and never exceeds F_b."""
    from cepam_gym.physics.friction import DELTA_FRACTIONS, WEIGHTS

    p = V1.replace(friction_coefficient=2e-6, friction_presliding=0.5e-3)  # 0.002 N/kPa
    row = p.to_array()
    areas = []
    for pc, pe in ((100e3, 50e3), (200e3, 100e3)):
        L, F = _friction_cycle(row, pc, pe)
        half = (L.size - 1) // 2  # the second cycle
        work_on_load = float(np.sum(0.5 * (F[half + 1 :] + F[half:-1]) * np.diff(L[half:])))
        fb = p.friction_coefficient * (pc + pe)
        expected = sum(
            4 * w * fb * (2e-3 - r * p.friction_presliding) for w, r in zip(WEIGHTS, DELTA_FRACTIONS)
        )
        assert -work_on_load == pytest.approx(expected, rel=2e-3)
        assert np.abs(F).max() <= fb * (1 + 1e-12)
        areas.append(-work_on_load)
    assert areas[0] > 0.0 and areas[1] == pytest.approx(2.0 * areas[0], rel=1e-9)


def test_no_friction_in_a_v0_row():
    _, F = _friction_cycle(V0_LIKE.replace(friction_coefficient=0.0).to_array(), 200e3, 100e3)
    assert np.all(F == 0.0)


def test_friction_only_dissipates_in_the_plant():
    """Sealed chambers, no heat, no damping: with friction the total energy (air, load, walls and
    the elements' stored spring energy sum f_i z_i^2 / (2 delta_i)) never rises beyond the
    integration error, and falls clearly: the oscillation decays."""
    from cepam_gym.physics.friction import DELTA_FRACTIONS, WEIGHTS

    p = V1.replace(
        heat_transfer=0.0,
        heat_transfer_coefficient=0.0,
        leak_conductance=0.0,
        damping=0.0,
        kr_high=0.0,
        kr_low=0.0,
        friction_coefficient=2e-6,
    )  # 0.002 N/kPa
    P = p.to_array()[None]
    load = 0.1
    M, patm = p.end_mass + load, p.atmospheric_pressure

    def energy(x, a):
        fb = p.friction_coefficient * (max(a[plant.A_PC], 0) + max(a[plant.A_PE], 0))
        stored = sum(
            0.5 * w * fb * x[0, s] ** 2 / (r * p.friction_presliding)
            for w, r, s in zip(WEIGHTS, DELTA_FRACTIONS, (plant.S_Z1, plant.S_Z2, plant.S_Z3))
        )
        return (
            x[0, plant.S_UC]
            + x[0, plant.S_UE]
            + 0.5 * M * x[0, plant.S_V] ** 2
            - M * p.gravity * x[0, plant.S_L]
            + patm * (a[plant.A_VC] + a[plant.A_VE])
            + float(api.bladder_energy(x[0, plant.S_L], p)[0])
            + stored
        )

    x = plant.initial_state(P, 0.17, 200e3, 60e3)
    e0 = energy(x, plant.measure(x, P)[0])
    dE, Ls = [], []
    for _ in range(40):
        x, aux = plant.step(x, np.array([[0.0, 0.0, load, 0.0]]), P, dt=5e-5, n_sub=100)
        dE.append(energy(x, aux[0]) - e0)
        Ls.append(x[0, plant.S_L])
    dE = np.array(dE)
    assert np.all(np.diff(dE) < 2e-4)  # no gain beyond the integration error (J)
    assert dE[-1] < -2e-3  # the friction took a clear share of the energy exchanged
    # the swing decays (what is left oscillates inside the presliding range, nearly elastic)
    assert np.ptp(Ls[-10:]) < 0.3 * np.ptp(Ls[:10])


# ------------------------------------------------------------------ versions
def test_v0_ids_keep_the_v0_plant_and_an_explicit_plant_wins():
    """PlantParams() is plant v1; the -v0 env ids default to the v0 plant (preset balloon_v0), so
    their published results reproduce; a user's plant= replaces it."""
    import gymnasium as gym

    import cepam_gym  # noqa: F401
    from cepam_gym.plant.params import preset

    v0 = preset("balloon_v0")
    assert (v0.braid_tension, v0.bladder_model, v0.friction_coefficient) == ("bidirectional", "spring", 0.0)
    assert PlantParams().braid_tension == "tension_only"
    for env_id in ("cepam_gym/CEPAM-v0", "cepam_gym/CEPAMStiffness-v0"):
        env = gym.make(env_id)
        assert env.unwrapped.core.nominal == v0
        env = gym.make(env_id, plant="balloon")
        assert env.unwrapped.core.nominal == PlantParams()
        venv = gym.make_vec(env_id, num_envs=2)
        assert venv.unwrapped.core.nominal == v0  # the vector entry point gets the same default


def test_a_layout_change_drops_the_numba_caches(tmp_path, monkeypatch):
    """Kernels in other files inline the layouts' constants; numba's cache does not see a layout
    change, so the package drops its cached kernels when the layouts' text changes."""
    import shutil

    from cepam_gym import _jit

    pkg = tmp_path / "pkg"
    (pkg / "physics").mkdir(parents=True)
    (pkg / "plant").mkdir()
    (pkg / "__pycache__").mkdir()
    shutil.copy(_jit._PKG / "plant" / "layout.py", pkg / "plant" / "layout.py")
    shutil.copy(_jit._PKG / "physics" / "layout.py", pkg / "physics" / "layout.py")
    monkeypatch.setattr(_jit, "_PKG", pkg)
    _jit._drop_stale_caches()  # first stamp
    cached = pkg / "__pycache__" / "kernel.f-1.py311.nbi"
    cached.write_text("x")
    _jit._drop_stale_caches()
    assert cached.exists()  # same layouts: the cache stays
    with (pkg / "physics" / "layout.py").open("a") as fh:
        fh.write("\nNEW_COLUMN = 999\n")
    _jit._drop_stale_caches()
    assert not cached.exists()  # a new parameter layout: cached kernels dropped
    cached.write_text("x")
    _jit._drop_stale_caches()
    assert cached.exists()
    with (pkg / "plant" / "layout.py").open("a") as fh:
        fh.write("\nS_NEW = 99\n")
    _jit._drop_stale_caches()
    assert not cached.exists()  # a new state layout: dropped too
    cached.write_text("x")
    (pkg / "physics" / "muscle.py").write_text("# an edit of an inlined physics kernel\n")
    _jit._drop_stale_caches()
    assert not cached.exists()  # inlined physics changed: dropped too


@pytest.mark.parametrize("name", ["balloon_v0", "balloon", "balloon_v2"])
def test_the_pwm_open_fraction_is_the_period_average_of_the_valve_opening(name):
    """``pwm_open_fraction`` (what the rig's leak check credits a PWM valve with) is the average of
    ``valve_command`` over a PWM period, dead times included: short pulses that never open the
    valve, and long ones that overlap the next period."""
    from cepam_gym.plant.layout import ONOFF
    from cepam_gym.plant.params import preset
    from cepam_gym.plant.substep import pwm_open_fraction, valve_command

    p = preset(name).to_array()
    period = p[ix.PWM_PERIOD]
    ts = (np.arange(20000) + 0.5) * period / 20000 + 3 * period  # one period, away from t = 0
    dead = (p[ix.D_ON] - p[ix.D_OFF]) / period
    for duty in (0.0, 0.5 * max(dead, 0.0), 0.05, 0.3, 0.5, 0.97, 0.999, 1.0):
        mean = np.mean([valve_command(ONOFF, duty, 0.0, t, p) for t in ts])
        assert pwm_open_fraction(duty, p) == pytest.approx(mean, abs=2e-4), (name, duty)
        # a negative command opens the exhaust valve for the same share of the period
        assert np.mean([valve_command(ONOFF, -duty, 0.0, t, p) for t in ts]) == pytest.approx(
            -mean, abs=1e-12
        )
