"""Gymnasium / SB3 API conformance and behaviour of the CE-PAM environments."""

from __future__ import annotations

import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

import cepam_gym
from cepam_gym.envs import CEPAMEnv
from cepam_gym.tasks.contract import RIG

IDS = list(cepam_gym.ENV_IDS)
MODES = ["valve", "pwm", "pressure"]


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("mode", MODES)
def test_gymnasium_check_env(env_id, mode):
    env = gym.make(env_id, action_mode=mode)
    gym_check_env(env.unwrapped, skip_render_check=True)


@pytest.mark.parametrize("env_id", IDS)
def test_sb3_check_env(env_id):
    sb3_env_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    for mode in MODES:
        sb3_env_checker.check_env(gym.make(env_id, action_mode=mode).unwrapped, warn=True)


def test_spaces_and_dtypes():
    env = gym.make("cepam_gym/CEPAM-v0")
    assert env.action_space == gym.spaces.Box(-1, 1, (2,), np.float32)
    obs, _ = env.reset(seed=1)
    assert obs.dtype == np.float32 and obs.shape == (9,)
    assert env.observation_space.contains(obs)
    length_env = gym.make("cepam_gym/CEPAMLength-v0")
    assert length_env.observation_space.shape == (8,)  # no stiffness target


def test_seeding_is_deterministic_bit_for_bit():
    def run(seed):
        env = gym.make(
            "cepam_gym/CEPAM-v0",
            sensor_noise={"length_mm": 0.5, "pressure_kpa": 2.0},
            randomize={"valve_conductance_dm3_per_s_bar": [0.05, 0.15]},
        )
        obs, _ = env.reset(seed=seed)
        rng = np.random.default_rng(99)
        out = [obs]
        for _ in range(60):
            obs, r, *_ = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
            out.append(np.append(obs, r))
        return np.concatenate(out)

    a, b, c = run(3), run(3), run(4)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_sensor_noise_reaches_observations_only():
    def run(noise):
        env = gym.make("cepam_gym/CEPAM-v0", sensor_noise=noise)
        obs, info = env.reset(seed=3)
        obs2, _, _, _, info2 = env.step(np.zeros(2))
        return obs, obs2, info2

    o0, o1, i_clean = run(None)
    n0, n1, i_noisy = run({"length_mm": 1.0, "pressure_kpa": 5.0})
    assert i_clean["length"] == i_noisy["length"]  # the plant is untouched
    layout = gym.make("cepam_gym/CEPAM-v0").unwrapped.core.obs_layout
    col = layout.column
    d_len = layout.value(n1, "length") - layout.value(o1, "length")  # measured minus true length [m]
    assert 1e-6 < abs(d_len) < 5e-3
    assert n1[col("pressure_c")] != o1[col("pressure_c")] and n1[col("pressure_e")] != o1[col("pressure_e")]
    assert n1[col("target_length")] == o1[col("target_length")]  # targets are not measured: no noise


def test_info_keys_and_reward_terms_sum_to_reward():
    env = gym.make("cepam_gym/CEPAM-v0")
    _, info0 = env.reset(seed=0)
    for key in ("length", "stiffness", "load_mass", "target_length", "target_stiffness", "pressure_c"):
        assert key in info0
    rng = np.random.default_rng(0)
    for _ in range(50):
        _, r, term, trunc, info = env.step(rng.uniform(-1, 1, 2))
        terms = [info[f"reward_{t}"] for t in RIG.reward_terms]
        assert all(t <= 0 for t in terms)
        assert r == pytest.approx(sum(terms), rel=1e-12, abs=1e-12)
        assert info["termination_reason"] == 0
    # the length term is exactly the scored error
    assert info["reward_length"] == pytest.approx(-abs(info["length"] - info["target_length"]) / 0.01)


def test_single_env_fast_path_equals_general_path():
    """A (2,) array action takes the single env's one-call fast path; a list takes the general
    path (action checks, CEPAMBatch.step, info from the arrays). Both give the same bits."""
    envs = [gym.make("cepam_gym/CEPAM-v0", sensor_noise={"pressure_kpa": 1.0}) for _ in range(2)]
    assert envs[0].unwrapped.core.fast_single
    for e in envs:
        e.reset(seed=4)
    rng = np.random.default_rng(1)
    for _ in range(40):
        a = rng.uniform(-1.3, 1.3, 2)
        fast = envs[0].step(a)
        general = envs[1].step([float(a[0]), float(a[1])])
        assert np.array_equal(fast[0], general[0]) and fast[1:4] == general[1:4]
        assert list(fast[4].items()) == list(general[4].items())  # same keys, order and values
    assert not gym.make("cepam_gym/CEPAM-v0", action_latency_steps=1).unwrapped.core.fast_single


def test_true_stiffness_in_info_matches_physics():
    from cepam_gym.physics import api

    env = gym.make("cepam_gym/CEPAM-v0")
    _, info = env.reset(seed=5)
    for _ in range(10):
        _, _, _, _, info = env.step(np.zeros(2))
    k = api.stiffness(info["length"], info["pressure_c"], info["pressure_e"], env.unwrapped.core.nominal)
    assert info["stiffness"] == pytest.approx(float(k), rel=1e-9)


def test_terminates_on_burst_with_reason_and_penalty():
    env = gym.make("cepam_gym/CEPAM-v0", plant={"supply_pressure_kpa": 400.0, "burst_pressure_kpa": 300.0})
    env.reset(seed=0)
    for step in range(200):
        _, r, term, trunc, info = env.step(np.array([1.0, 1.0]))
        if term:
            break
    assert term and not trunc
    assert env.unwrapped.metadata["termination_reasons"][info["termination_reason"]] == "burst"
    assert info["reward_burst"] == -100.0
    assert max(info["pressure_c"], info["pressure_e"]) > 0.95 * 300e3


def test_actions_out_of_range_are_clipped():
    def last_obs(action):
        env = gym.make("cepam_gym/CEPAM-v0")
        env.reset(seed=2)
        for _ in range(5):
            obs, *_ = env.step(action)
        return obs

    assert np.array_equal(last_obs(np.array([5.0, -7.0])), last_obs(np.array([1.0, -1.0])))


@pytest.mark.parametrize("bad", [np.array([np.nan, 0.0]), np.array([0.0, np.inf]), np.zeros(3)])
def test_bad_actions_raise_clear_error(bad):
    env = gym.make("cepam_gym/CEPAM-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="NaN|inf|shape"):
        env.unwrapped.step(bad)


def test_batched_equals_single_bit_for_bit():
    n, seed = 3, 11
    venv = gym.make_vec("cepam_gym/CEPAM-v0", num_envs=n)
    obs_v, _ = venv.reset(seed=seed)
    singles = [gym.make("cepam_gym/CEPAM-v0", stream=i) for i in range(n)]
    obs_s = [e.reset(seed=seed)[0] for e in singles]
    assert np.array_equal(obs_v, np.stack(obs_s))
    rng = np.random.default_rng(0)
    for _ in range(100):
        a = rng.uniform(-1, 1, (n, 2))
        obs_v, r_v, *_ = venv.step(a)
        for i, e in enumerate(singles):
            o, r, *_ = e.step(a[i])
            assert np.array_equal(o, obs_v[i]) and r == r_v[i]


def test_vector_env_autoresets_same_step_with_final_obs():
    venv = gym.make_vec(
        "cepam_gym/CEPAMLength-v0", num_envs=4, max_episode_steps=20, autoreset_mode="same_step"
    )
    venv.reset(seed=0)
    for t in range(20):
        obs, r, term, trunc, infos = venv.step(np.zeros((4, 2)))
    assert trunc.all() and not term.any()
    assert infos["_final_obs"].all() and infos["final_obs"].shape == (4, 8)
    assert not np.array_equal(infos["final_obs"], obs)  # obs is already the next episode's first
    assert (venv.unwrapped.core.t_idx == 0).all()


def test_control_period_must_divide():
    with pytest.raises(ValueError, match="divide"):
        gym.make("cepam_gym/CEPAM-v0", control_dt=0.02, sub_dt=0.0003)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"action_mode": "torque"}, "action_mode"),
        ({"plant": {"supply_kpa": 3}}, "supply_kpa"),
        ({"randomize": {"not_a_param": [0, 1]}}, "not_a_param"),
        ({"reward_weights": {"speed": 1.0}}, "speed"),
        ({"sensor_noise": {"length_cm": 1.0}}, "length_cm"),
        ({"action_latency_steps": -1}, "action_latency_steps"),
    ],
)
def test_bad_kwargs_name_the_problem(kwargs, match):
    with pytest.raises(ValueError, match=match):
        gym.make("cepam_gym/CEPAM-v0", **kwargs)


def test_targets_are_reachable_and_change():
    from cepam_gym.physics import api

    env = gym.make("cepam_gym/CEPAM-v0")
    env.reset(seed=7)
    core = env.unwrapped.core
    tl, tk_, load = core.target_l[0], core.target_k[0], core.load[0]
    assert len(np.unique(tl)) >= 2 and len(np.unique(tk_)) >= 2
    p = core.params[0]
    pc, pe, ok = api.static_pressures(tl, tk_, (core.nominal.end_mass + load) * core.nominal.gravity, p)
    cap = min(core.nominal.supply_pressure, core.nominal.burst_pressure)
    assert ok.all() and (pc < cap).all() and (pe < cap).all() and (pc > 0).all() and (pe > 0).all()


def test_stiffness_task_holds_fixed_length():
    env = gym.make("cepam_gym/CEPAMStiffness-v0")
    env.reset(seed=0)
    assert np.all(env.unwrapped.core.target_l == 0.175)


def test_domain_randomization_varies_params_per_episode():
    env = gym.make("cepam_gym/CEPAM-v0", randomize={"end_mass_g": [10, 40], "damping_ns_per_m": [2, 8]})
    env.reset(seed=0)
    a = env.unwrapped.core.params[0].copy()
    env.reset()
    b = env.unwrapped.core.params[0].copy()
    assert not np.array_equal(a, b)
    from cepam_gym.physics import layout as ix

    for p in (a, b):
        assert 0.010 <= p[ix.M_END] <= 0.040 and 2 <= p[ix.DAMP] <= 8


def test_action_latency_delays_the_valves():
    def pressures(latency):
        env = gym.make("cepam_gym/CEPAM-v0", action_latency_steps=latency)
        env.reset(seed=0)
        out = []
        for _ in range(4):
            _, _, _, _, info = env.step(np.array([1.0, 1.0]))
            out.append(info["pressure_e"])
        return np.array(out)

    p0, p2 = pressures(0), pressures(2)
    assert p0[0] > p2[0] + 100  # without latency the annulus already fills in step 1
    # with 2 steps of latency the same fill happens 2 steps later (up to the slow leak meanwhile)
    assert np.allclose(p2[2:], p0[:2], rtol=1e-3)
    assert abs(p2[1] - p2[0]) < 1e-3 * p2[0]  # nothing filled before the command arrived


def test_render_rgb_array_not_blank_and_follows_state():
    env = gym.make("cepam_gym/CEPAM-v0", render_mode="rgb_array")
    env.reset(seed=0)
    f0 = env.render()
    assert f0.shape == (400, 320, 3) and f0.dtype == np.uint8
    assert f0.std() > 10
    for _ in range(30):
        env.step(np.array([-1.0, 1.0]))
    f1 = env.render()
    assert np.mean(f0 != f1) > 0.001


def test_ezpickle_rebuilds_same_env():
    import pickle

    env = CEPAMEnv(task="length", action_mode="pwm", reward_weights={"effort": 0.2})
    clone = pickle.loads(pickle.dumps(env))
    assert clone.core.action_mode == "pwm" and clone.core.task.spec.weights.effort == 0.2
    o1, _ = env.reset(seed=4)
    o2, _ = clone.reset(seed=4)
    assert np.array_equal(o1, o2)


def test_import_does_not_import_torch():
    code = (
        "import sys, cepam_gym, gymnasium as gym; gym.make('cepam_gym/CEPAM-v0'); "
        "print('torch' in sys.modules, 'stable_baselines3' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]


def test_sb3_vec_env_adapter_steps_and_reports_terminal_obs():
    pytest.importorskip("stable_baselines3")
    from cepam_gym.integrations.sb3 import make_sb3_vec_env

    venv = make_sb3_vec_env("cepam_gym/CEPAMLength-v0", num_envs=4, seed=0, max_episode_steps=10)
    obs = venv.reset()
    assert obs.shape == (4, 8)
    for t in range(10):
        obs, rewards, dones, infos = venv.step(np.zeros((4, 2)))
    assert dones.all()
    assert all("terminal_observation" in i and i["TimeLimit.truncated"] for i in infos)
    assert all("episode" in i for i in infos)  # VecMonitor episode statistics
    assert "reward_length" in infos[0]
