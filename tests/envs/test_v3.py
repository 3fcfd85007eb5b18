"""The v3 ids: the reward is the score's per-step form, the observation a rig's sensors."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401
from cepam_gym import versions
from cepam_gym.bench.suites import SUITES
from cepam_gym.control import make_controller
from cepam_gym.control.objective import STIFFNESS_NORM, scored_steps
from cepam_gym.rig.emulator import RigImperfections
from cepam_gym.rig.observation import RigObserver
from cepam_gym.rig.protocol import Reading
from cepam_gym.tasks.contract import CONTRACTS

STEPS = 499  # the last step of an episode is the vector env's autoreset boundary


def _run(suite_name: str, controller: str, episodes: int = 3, steps: int = STEPS, **kwargs) -> dict:
    suite = SUITES[suite_name]
    venv = gym.make_vec(suite.env_id, num_envs=episodes, **{**suite.env_kwargs, **kwargs})
    model = venv.unwrapped.env_model
    contract = CONTRACTS["joint" if model.mech != 0 else "rig"]
    keys = dict(contract.score_keys)
    pos, tpos = keys["length"], keys["target_length"]
    k, tk = keys["stiffness"], keys["target_stiffness"]
    terms = contract.term_keys
    policy = make_controller(controller, venv)
    obs, info = venv.reset(seed=suite.seed)
    policy.reset()
    out = {name: np.zeros((steps, episodes)) for name in (pos, tpos, k, tk, "reward", *terms)}
    for t in range(steps):
        obs, r, term, trunc, info = venv.step(policy.act(obs, info))
        assert not (term | trunc).any(), "an episode of the check ended early"
        for name in (pos, tpos, k, tk, *terms):
            out[name][t] = info[name]
        out["reward"][t] = r
    venv.close()
    return {"trace": out, "keys": (pos, tpos, k, tk), "contract": contract, "model": model, "suite": suite}


@pytest.mark.parametrize(
    ("suite", "controller"),
    [("nominal-v3", "baseline"), ("length-v3", "baseline"), ("joint-v3", "joint_baseline")],
)
def test_reward_is_minus_the_scores_squared_error_on_the_steps_it_counts(suite, controller):
    run = _run(suite, controller)
    tr, (pos, tpos, k, tk), contract = run["trace"], run["keys"], run["contract"]
    model, spec = run["model"], run["suite"].traces
    track_k = model.track_stiffness
    mask = scored_steps(tr[tpos], tr[tk], track_k, spec, model.control_dt)
    assert mask.any() and not mask.all(), "the episodes must hold both scored and allowance steps"
    want = ((tr[pos] - tr[tpos]) / contract.trade.position_norm) ** 2
    if track_k:
        want += ((tr[k] / tr[tk] - 1.0) / STIFFNESS_NORM) ** 2
    got = -(tr[contract.term_keys[0]] + tr[contract.term_keys[1]])
    np.testing.assert_allclose(got, np.where(mask, want, 0.0), rtol=1e-9, atol=1e-15)
    # the reward is the sum of its terms, and the effort and air terms are small beside tracking
    np.testing.assert_allclose(tr["reward"], sum(tr[t] for t in contract.term_keys), rtol=1e-12)
    side = -(tr[contract.term_keys[2]] + tr[contract.term_keys[3]]).sum()
    assert 0 < side < 0.05 * got.sum()


def test_a_burst_is_charged_as_an_episode_scoring_the_failure_weight_at_every_step():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # supply above burst: the point of the test
        plant = {"supply_pressure_kpa": 400.0, "burst_pressure_kpa": 300.0}
        env = gym.make("cepam_gym/CEPAM-v3", plant=plant)
    env.reset(seed=0)
    for _ in range(200):
        _, r, term, _, info = env.step(np.array([1.0, 1.0]))
        if term:
            break
    assert term and env.unwrapped.metadata["termination_reasons"][info["termination_reason"]] == "burst"
    trade = CONTRACTS["rig"].trade
    assert info["reward_burst"] == -(trade.failure_weight**2) * versions.MAX_EPISODE_STEPS


def test_the_earlier_ids_keep_their_reward():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # v2's "out of date" notice
        env = gym.make("cepam_gym/CEPAM-v2")
    env.reset(seed=3)
    for _ in range(30):
        _, _, _, _, info = env.step(np.array([0.3, -0.2]))
    # the absolute form: 1 cm of length error is one unit of the (unsquared) length term
    want = -min(abs(info["length"] - info["target_length"]) / 0.01, 5.0)
    assert info["reward_length"] == pytest.approx(want, rel=1e-12)


def test_v3_observes_through_a_rigs_sensors_and_ideal_sensors_are_a_kwarg_away():
    def spread(**kwargs):
        env = gym.make("cepam_gym/CEPAM-v3", **kwargs)
        obs = []
        for seed in range(2):
            o, _ = env.reset(seed=seed)
            for _ in range(5):
                o, *_ = env.step(np.zeros(2))
            obs.append(o)
        # same seed twice: the noise is seeded, so a repeat reproduces
        o1, _ = env.reset(seed=7)
        o2, _ = env.reset(seed=7)
        np.testing.assert_array_equal(o1, o2)
        return env.unwrapped.core.noise_sd

    sd = spread()
    assert sd[0] == pytest.approx(3e-5) and sd[2] == pytest.approx(200.0)
    assert not spread(sensor_noise=None).any()


def test_the_rate_noise_is_the_deploy_loops_estimate_of_the_rigs_length_noise():
    """The v3 velocity noise is what the deploy loop's filtered difference makes of the emulated
    rig's length noise and quantisation at 50 Hz, at rest."""
    imp = RigImperfections()
    env = gym.make("cepam_gym/CEPAM-v3")
    model = env.unwrapped.env_model
    observer = RigObserver(model, np.full(10, 0.17), np.full(10, 800.0))
    rng = np.random.default_rng(0)
    dt, velocities = 0.02, []
    for k in range(20000):
        length = 0.17 + imp.noise_length * rng.standard_normal()
        length = round(length / imp.quant_length) * imp.quant_length
        v = observer.velocity(Reading(k * dt, 1e5, 1e5, length, 4e5))
        if k > 10:
            velocities.append(v)
    measured_mm_s = 1e3 * float(np.std(velocities))
    noise = dict(versions.RIG_SENSOR_NOISE)
    assert noise["velocity_mm_s"] == pytest.approx(measured_mm_s, rel=0.1)
    assert noise["length_mm"] == pytest.approx(imp.noise_length * 1e3)
    assert noise["pressure_kpa"] == pytest.approx(imp.noise_pressure / 1e3)
    # the hinge reads its angle through its lever arm from the same sensor
    joint = dict(versions.JOINT_SENSOR_NOISE)
    r = gym.make("cepam_gym/CEPAMJoint-v3").unwrapped.core.task.geometry.lever_arm
    assert joint["angle_mrad"] == pytest.approx(noise["length_mm"] / (r * 1e3) * 1e3)
    assert joint["angular_velocity_mrad_s"] == pytest.approx(noise["velocity_mm_s"] / (r * 1e3) * 1e3)
    assert math.isclose(joint["pressure_kpa"], noise["pressure_kpa"])
