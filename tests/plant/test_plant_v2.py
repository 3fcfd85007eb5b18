"""Plant v2: the slack contractor's seal term, the contact-area friction law, the two stiffnesses
(tangent and protocol secant) and the paper's protocols on the dynamic plant."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401 (registers the ids)
from cepam_gym.physics import api, friction, muscle, secant
from cepam_gym.physics import layout as ix
from cepam_gym.plant.params import preset
from cepam_gym.registration import ENV_IDS, JOINT_ENV_IDS
from cepam_gym.validation import protocols
from cepam_gym.validation.calibrate_v2 import experiment_group_v2, v2_experiments
from cepam_gym.validation.equilibrium import simulate
from cepam_gym.validation.experiments import Experiment


@pytest.fixture(scope="module")
def v2():
    return preset("balloon_v2")


def test_v1_rows_leave_the_v2_columns_zero():
    row = preset("balloon").to_array()
    assert row[ix.COL_A] == row[ix.FR_MU] == row[ix.FR_CC] == 0.0
    assert row[ix.FR_C] == preset("balloon").friction_coefficient  # the v1 law's own coefficient


def test_seal_term_of_a_slack_cpam_is_pressure_difference_times_seal_area(v2):
    """Pc = 0 at 17.5 cm: the CPAM is slack (gate 0), so the seal adds exactly (Pc - Pe) pi d^2/4
    and nothing to -dF/dL."""
    without = v2.replace(collapse_seal_diameter=0.0).to_array()
    row = v2.to_array()
    L, pe = 0.175, 60e3
    c, _ = muscle.cpam_tension(L, 0.0, pe, row)
    assert c >= 0.0  # slack
    f0, k0, _, dpe0 = muscle.cepam_force(L, 0.0, pe, without)
    f1, k1, _, dpe1 = muscle.cepam_force(L, 0.0, pe, row)
    area = math.pi * v2.collapse_seal_diameter**2 / 4
    assert f1 - f0 == pytest.approx(-pe * area, rel=1e-9)
    assert k1 == pytest.approx(k0, rel=1e-12)
    assert dpe1 - dpe0 == pytest.approx(-area, rel=1e-9)


@pytest.mark.parametrize("pc_kpa, pe_kpa", [(0, 60), (60, 50), (75, 50), (125, 75), (250, 125)])
def test_force_derivatives_match_finite_differences_through_the_gate(v2, pc_kpa, pe_kpa):
    """K = -dF/dL, dF/dPc and dF/dPe of the v2 force (seal term faded by the slack gate) against
    central differences, at lengths that cross the gate's transition."""
    row = v2.to_array()
    pc, pe = pc_kpa * 1e3, pe_kpa * 1e3
    for L in np.linspace(0.16, 0.19, 13):
        f, k, dpc, dpe = muscle.cepam_force(L, pc, pe, row)
        h, hp = 1e-7, 1.0
        k_fd = -(muscle.cepam_force(L + h, pc, pe, row)[0] - muscle.cepam_force(L - h, pc, pe, row)[0]) / (
            2 * h
        )
        dpc_fd = (muscle.cepam_force(L, pc + hp, pe, row)[0] - muscle.cepam_force(L, pc - hp, pe, row)[0]) / (
            2 * hp
        )
        dpe_fd = (muscle.cepam_force(L, pc, pe + hp, row)[0] - muscle.cepam_force(L, pc, pe - hp, row)[0]) / (
            2 * hp
        )
        assert k == pytest.approx(k_fd, rel=2e-4, abs=0.05), L
        assert dpc == pytest.approx(dpc_fd, rel=2e-4, abs=1e-9), L
        assert dpe == pytest.approx(dpe_fd, rel=2e-4, abs=1e-9), L


def test_contact_area_friction_is_mu_times_pressure_times_braid_surface(v2):
    """F_b = mu (Pc S_c + Pe S_e), S = pi D L of each braid at mid-stroke (Eq. 2 for D)."""
    row = v2.to_array()
    lm = 0.5 * (v2.min_length + v2.max_length)
    surfaces = []
    for b, n in (v2.cpam_braid(), v2.epam_braid()):
        diameter = b * math.sqrt(1 - (lm / b) ** 2) / (n * math.pi)
        surfaces.append(math.pi * diameter * lm)
    pc, pe = 150e3, 80e3
    expect = v2.friction_mu * (pc * surfaces[0] + pe * surfaces[1])
    assert friction.breakaway_force(row, pc, pe) == pytest.approx(expect, rel=1e-12)
    assert friction.breakaway_force(row, -5e3, 0.0) == 0.0  # suction presses nothing


def test_secant_equals_tangent_for_a_linear_frictionless_muscle():
    """The v0 spring alone (no pressure, no friction): F = -k (L - L_el), so every weight reads k."""
    p = preset("balloon_v0").replace(elastic_stiffness=300.0)
    row = p.to_array()
    weights = np.array([0.5, 1.0, 2.0])
    assert secant.secant_stiffness(0.16, 0.0, 0.0, row, weights) == pytest.approx(300.0, rel=1e-9)


def test_secant_with_friction_matches_the_hand_solution():
    """Linear spring plus relaxed Maxwell-slip elements: a weight W above the break-away force F_b
    that moves past every presliding displacement rests at x = (W - F_b) / k."""
    k = 300.0
    p = preset("balloon_v0").replace(elastic_stiffness=k, friction_coefficient=5e-6, friction_presliding=1e-4)
    row = p.to_array()
    pc = 40e3  # F_b = 5e-6 * 40e3 = 0.2 N (only the pressure's friction matters: the spring is linear)
    f_lin = -api.stiffness(0.16, pc, 0.0, row)  # the pressure adds a slope too: use the exact tangent
    assert abs(api.stiffness(0.17, pc, 0.0, row) + f_lin) < 5.0  # nearly linear over the range
    fb = friction.breakaway_force(row, pc, 0.0)
    for w in (0.8, 1.6, 2.4):
        x = secant.loaded_length(0.16, pc, 0.0, row, w) - 0.16
        force_change = api.force(0.16 + x, pc, 0.0, row) - api.force(0.16, pc, 0.0, row)
        assert force_change + w == pytest.approx(fb, rel=1e-6)  # the elements slide at F_b
        assert w / x > -f_lin  # friction holds part of the weight: the reading is stiffer


def test_protocol_without_friction_reproduces_the_static_solution(v2):
    """Friction 0: the dynamic plant settles where the static validation's equilibrium is (lengths
    within 0.05 mm, hanging-weight stiffness within 1 %), for the CE-PAM and both single muscles."""
    p = v2.replace(friction_mu=0.0)
    exps = [e for e in v2_experiments() if e.id in _SAMPLE]
    assert len(exps) == len(_SAMPLE)
    for e, r in zip(exps, protocols.run(exps, p)):
        s = simulate(e, p).value
        if e.measured == "length":
            assert r.value == pytest.approx(s, abs=0.005), e.id
        else:
            assert r.value == pytest.approx(s, rel=0.01), e.id


_SAMPLE = (
    "cpam_balloon_length_250",
    "cpam_balloon_stiffness_250",
    "epam_balloon_length_50",
    "epam_balloon_stiffness_250",
    "cepam_length_pe50_pc0",
    "cepam_stiffness_pe100_pc175",
)


def test_friction_stiffens_the_protocol_reading_and_history_matters(v2):
    """With friction a hung weight moves less (part of it is held): the protocol's stiffness rises
    with the friction coefficient; and the reading depends on the order of pressurising."""
    exps = [e for e in v2_experiments() if e.id == "cepam_stiffness_pe100_pc175"]
    ks = [protocols.run(exps, v2.replace(friction_mu=mu))[0].value for mu in (0.0, 1e-4, 2e-4)]
    assert ks[0] < ks[1] < ks[2]
    e = exps[0]
    swapped = Experiment(**{**e.__dict__, "pc_kpa": e.pe_kpa, "pe_kpa": e.pc_kpa, "id": "swapped"})
    a, b = protocols.run([e, swapped], v2)
    assert a.length0 != pytest.approx(b.length0, abs=1e-4)


def test_protocol_refuses_bad_timing():
    with pytest.raises(ValueError, match="hang_s"):
        protocols.Protocol(hang_s=0.0)


def test_v2_groups_are_the_papers_experiments():
    fig26 = {e.id for e in v2_experiments() if protocols.is_fixed_stiffness_sequence(e)}
    assert fig26 == {"cepam_length_pe125_pc200", "cepam_stiffness_pe125_pc200"}
    groups = {experiment_group_v2(e) for e in v2_experiments()}
    assert groups == {
        "cpam_balloon",
        "cpam_tube",
        "epam_balloon",
        "epam_tube",
        "cepam_extension",
        "cepam_extensor_only",
        "cepam_fixed_length",
        "cepam_fixed_stiffness",
    }


def test_v2_ids_run_on_the_v2_plant():
    for env_id in ("cepam_gym/CEPAM-v2", "cepam_gym/CEPAMLength-v2", "cepam_gym/CEPAMStiffness-v2"):
        assert ENV_IDS[env_id]["plant"] == "balloon_v2"
        v1 = ENV_IDS[env_id.replace("-v2", "-v1")]
        assert {k: v for k, v in ENV_IDS[env_id].items() if k != "plant"} == v1
    assert JOINT_ENV_IDS["cepam_gym/CEPAMJoint-v2"][2]["plant"] == "balloon_v2"
    env = gym.make("cepam_gym/CEPAM-v2")
    obs, _ = env.reset(seed=0)
    obs, r, *_ = env.step(env.action_space.sample())
    assert np.all(np.isfinite(obs)) and math.isfinite(r)
    assert env.unwrapped.core.nominal == preset("balloon_v2")


def test_protocol_stiffness_info_is_the_secant_at_the_steps_state():
    from cepam_gym.envs.protocol_info import ProtocolStiffnessInfo

    env = ProtocolStiffnessInfo(gym.make("cepam_gym/CEPAMStiffness-v2"))
    # seeded actions: on the refitted plant about 1 random state in 60 has no protocol reading
    # (a weight pulls the stretching braids past an equilibrium: the secant is NaN there)
    env.action_space.seed(0)
    _, info = env.reset(seed=3)
    for _ in range(5):
        *_, info = env.step(env.action_space.sample())
    row = env.unwrapped.core.params[0]
    weights = np.array([50.0, 100, 150, 200, 250, 300]) * 1e-3 * row[ix.GRAV]
    expect = secant.secant_stiffness(info["length"], info["pressure_c"], info["pressure_e"], row, weights)
    assert info["stiffness_protocol"] == pytest.approx(expect, rel=1e-12)
    assert math.isfinite(info["stiffness"])  # the tangent stays beside it
    with pytest.raises(ValueError, match="loads_g"):
        ProtocolStiffnessInfo(gym.make("cepam_gym/CEPAM-v2"), loads_g=[])


def test_joint_v2_runs_on_the_v2_plant():
    env = gym.make("cepam_gym/CEPAMJoint-v2")
    obs, _ = env.reset(seed=0)
    obs, r, *_ = env.step(env.action_space.sample())
    assert np.all(np.isfinite(obs)) and math.isfinite(r)


def test_v2_preset_is_the_protocol_fits_optimum_along_its_interior_parameters(v2):
    """The shipped balloon_v2 is what `calibrate --v2` found: moving any interior fitted parameter
    by 2 % or 5 % of its range raises the sum of squared relative errors through the protocols."""
    from cepam_gym.validation.calibrate_v2 import V2_BOUNDS
    from cepam_gym.validation.fit import FIT_PARAMS, apply, relative_errors

    exps = v2_experiments()

    def cost(p):
        r = relative_errors(protocols.protocol_values(exps, p), exps)
        return float(r @ r)

    c0 = cost(v2)
    assert np.sqrt(c0 / len(exps)) < 0.1
    for name in (
        "cpam_rest_angle",
        "epam_sleeve_free_angle",
        "bladder_thickness",
        "friction_mu",
        "thread_compliance",
    ):
        lo, hi = V2_BOUNDS[name]
        x = FIT_PARAMS[name].get(v2)
        for step in (-0.05, -0.02, 0.02, 0.05):
            assert cost(apply(v2, (name,), np.array([x + step * (hi - lo)]))) > c0, (name, step)


def test_calibrate_v2_refuses_incomplete_commands(capsys):
    from cepam_gym.validation.cli import calibrate_main

    for argv, msg in ((["--v2"], "--out is required"), (["--v1", "--v2", "--out", "x.yaml"], "one of --v1")):
        with pytest.raises(SystemExit):
            calibrate_main(argv)
        assert msg in capsys.readouterr().err


def test_protocol_readings_are_converged_in_time_and_step(v2):
    """The 3 s settles and hangs are long enough and the 0.5 ms sub-step small enough: doubling the
    times or halving the step moves no reading by more than 1 %."""
    exps = v2_experiments()
    ref = protocols.protocol_values(exps, v2)
    for proto in (protocols.Protocol(settle_s=6.0, hang_s=6.0), protocols.Protocol(dt=2.5e-4)):
        np.testing.assert_allclose(protocols.protocol_values(exps, v2, proto), ref, rtol=0.01)


def test_cumulative_loading_shares_the_first_weight_and_then_reads_differently(v2):
    """Hung on top of each other, the first weight sees exactly the history it sees alone (same
    state, same load, same time: the same length bit for bit); the later ones do not."""
    exps = [e for e in v2_experiments() if e.measured == "stiffness"]
    alone = protocols.run(exps, v2)
    stacked = protocols.run(exps, v2, protocols.Protocol(cumulative=True))
    for a, b in zip(alone, stacked):
        assert a.lengths[0] == b.lengths[0]
        assert a.length0 == b.length0
    assert any(abs(a.stiffness - b.stiffness) > 0.01 * a.stiffness for a, b in zip(alone, stacked))
