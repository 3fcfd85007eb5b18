"""``cepam_gym/CEPAMJoint-v1``: the hinge on the batched kernel, against the MuJoCo hinge (v0's
mechanics, the reference), Gymnasium and SB3 checks, vector == single envs, input errors.

Agreement (MuJoCo is the reference; same plant v1, no randomization, no noise, same actions):
away from the joint limits the two integrate the same semi-implicit Euler scheme, so angle,
muscle length and pressures agree to round-off (tolerances 1e-9 rad, 1e-11 m, 1e-3 Pa over 6 s).
At a limit MuJoCo's is soft (``solreflimit``: the hinge penetrates a little and springs back)
and the kernel's a perfectly plastic end stop (the rig's); through repeated limit contacts the
two stay within 5 mrad of angle and 0.5 kPa of pressure over 6 s.
"""

from __future__ import annotations

import os

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym.envs.joint import CEPAMJointV1Env, CEPAMJointVectorEnv
from cepam_gym.physics import api
from cepam_gym.plant.params import PlantParams
from cepam_gym.tasks.joint import JointGeometry

if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
    os.environ["MUJOCO_GL"] = "egl"  # headless; must be set before mujoco is imported

ID = "cepam_gym/CEPAMJoint-v1"
MODES = ["valve", "pwm", "pressure"]
_OPTS = dict(
    initial_angle=0.8, initial_stiffness=0.4, external_torque=0.02, target_angle=0.8, target_stiffness=0.4
)
_KEYS = ("angle", "muscle_length", "pressure_c", "pressure_e")


@pytest.fixture
def mujoco():
    return pytest.importorskip("mujoco")


def _pair(mode):
    from cepam_gym.envs.joint_mujoco import CEPAMJointEnv

    v1 = CEPAMJointV1Env(action_mode=mode, preview_steps=10)
    ref = CEPAMJointEnv(plant="balloon", action_mode=mode)  # the same plant (v1) in MuJoCo
    i1, i0 = v1.reset(seed=1, options=_OPTS)[1], ref.reset(seed=1, options=_OPTS)[1]
    return v1, ref, i1, i0


def _setpoint_action(angle, stiffness, torque, p, cap):
    """Pressure-mode action holding ``angle`` [rad] with ``stiffness`` [N m/rad] under
    ``torque`` [N m] (the inverse static model): a smooth drive that stays off the limits."""
    g = JointGeometry()
    L = g.length(angle, p)
    pc, pe, _ = api.static_pressures(L, stiffness / g.lever_arm**2, g.equivalent_weight(angle, torque, p), p)
    return np.clip(2.0 * np.array([float(pc), float(pe)]) / cap - 1.0, -1.0, 1.0)


@pytest.mark.parametrize("mode", MODES)
def test_v1_kernel_agrees_with_the_mujoco_hinge_away_from_the_limits(mujoco, mode):
    v1, ref, i1, i0 = _pair(mode)
    p = PlantParams().to_array()
    cap = PlantParams().pressure_cap
    plan = [0.5, 1.2, 0.7, 1.1, 0.9, 0.6]  # a new angle set-point every second
    worst = dict.fromkeys(_KEYS, 0.0)
    for k in range(300):  # 6 s
        if mode == "pressure":
            a = _setpoint_action(plan[k // 50], 0.4, 0.02, p, cap)
        else:  # proportional feedback on the reference's own pressures: the same actions for both
            want = (_setpoint_action(plan[k // 50], 0.4, 0.02, p, cap) + 1.0) * 0.5 * cap
            a = np.clip(np.array([want[0] - i0["pressure_c"], want[1] - i0["pressure_e"]]) / 2e4, -1, 1)
        a = a.astype(np.float32)
        _, r1, *_, i1 = v1.step(a)
        _, r0, *_, i0 = ref.step(a)
        assert 0.02 < i0["angle"] < 1.78, "the drive was meant to stay off the limits"
        for key in _KEYS:
            worst[key] = max(worst[key], abs(i1[key] - i0[key]))
        assert r1 == pytest.approx(r0, abs=1e-9)
    assert worst["angle"] < 1e-9 and worst["muscle_length"] < 1e-11, worst
    assert worst["pressure_c"] < 1e-3 and worst["pressure_e"] < 1e-3, worst


def test_v1_kernel_agrees_with_the_mujoco_hinge_through_limit_contacts(mujoco):
    v1, ref, i1, i0 = _pair("valve")
    rng = np.random.default_rng(0)
    worst = dict.fromkeys(_KEYS, 0.0)
    at_limit = 0
    for k in range(300):  # 6 s of random held actions
        if k % 15 == 0:
            a = rng.uniform(-0.6, 0.6, 2).astype(np.float32)
        i1 = v1.step(a)[4]
        i0 = ref.step(a)[4]
        at_limit += not 0.01 < i0["angle"] < 1.79
        for key in _KEYS:
            worst[key] = max(worst[key], abs(i1[key] - i0[key]))
    assert at_limit > 10  # the episode does test the limits
    assert worst["angle"] < 5e-3 and worst["muscle_length"] < 1e-4, worst
    assert worst["pressure_c"] < 500 and worst["pressure_e"] < 500, worst


def test_make_vec_gives_the_native_batched_env():
    env = gym.make_vec(ID, num_envs=3)
    assert isinstance(env, CEPAMJointVectorEnv) and env.num_envs == 3
    obs, info = env.reset(seed=0)
    assert obs.shape == (3, 29) and env.observation_space.contains(obs)
    layout = env.obs_layout
    assert layout.names[9] == "target_angle_+1" and layout.names[19] == "target_stiffness_+1"
    # the decoded angle column is the hinge angle of info, to float32 precision
    np.testing.assert_allclose(layout.decode(obs)["angle"], info["angle"], atol=1e-6)
    obs, r, term, trunc, info = env.step(env.action_space.sample())
    assert set(info) >= {"angle", "joint_stiffness", "reward_angle", "termination_reason", "_angle"}
    np.testing.assert_allclose(
        r, sum(info[f"reward_{t}"] for t in ("angle", "stiffness", "effort", "air", "burst"))
    )
    env.close()


@pytest.mark.parametrize("mode", MODES)
def test_gymnasium_check_env(mode):
    from gymnasium.utils.env_checker import check_env

    check_env(gym.make(ID, action_mode=mode).unwrapped, skip_render_check=True)


def test_sb3_check_env():
    sb3_env_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    for mode in MODES:
        sb3_env_checker.check_env(gym.make(ID, action_mode=mode).unwrapped, warn=True)


def test_vector_element_i_is_the_single_env_with_stream_i():
    kw = dict(randomize={"supply_pressure_kpa": [230, 260]}, sensor_noise={"pressure_kpa": 0.5})
    venv = gym.make_vec(ID, num_envs=3, **kw)
    singles = [gym.make(ID, stream=i, **kw) for i in range(3)]
    vo, _ = venv.reset(seed=7)
    so = [e.reset(seed=7)[0] for e in singles]
    np.testing.assert_array_equal(vo, np.stack(so))
    rng = np.random.default_rng(1)
    for _ in range(40):
        a = rng.uniform(-1, 1, (3, 2)).astype(np.float32)
        vo, vr, *_ = venv.step(a)
        steps = [e.step(a[i]) for i, e in enumerate(singles)]
        np.testing.assert_array_equal(vo, np.stack([s[0] for s in steps]))
        np.testing.assert_array_equal(vr, [s[1] for s in steps])
        # the single env's info (Python floats) is the vector env's info arrays, key by key
        vinfo = venv.core.task.info_arrays(venv.core, True)
        for key, value in steps[1][4].items():
            if key != "termination_reason":
                assert value == vinfo[key][1], key


def test_bad_input_errors():
    env = gym.make(ID)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="NaN"):
        env.step(np.array([np.nan, 0.0]))
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(3))
    with pytest.raises(ValueError, match="unknown keys"):
        env.reset(options={"target_length": 0.17})
    with pytest.raises(ValueError, match="radians"):
        env.reset(options={"target_angle": 30.0})
    with pytest.raises(ValueError, match="unknown keys"):
        gym.make(ID, joint={"arm": 0.03})
    with pytest.raises(ValueError, match="task_options"):
        gym.make(ID, task_options={"length_range": (0.15, 0.19)})
    with pytest.raises(ValueError, match="unknown task 'nonsense'"):
        gym.make(ID, task="nonsense")
    with pytest.raises(ValueError, match="joint kwarg applies to the joint tasks"):
        gym.make("cepam_gym/CEPAM-v1", joint={"lever_arm": 0.03})
    with pytest.raises(ValueError, match="angle_range"):
        gym.make(ID, task_options={"angle_range": (0.2, 2.5)})
    with pytest.raises(ValueError, match="renderer"):
        gym.make(ID, renderer="numpy")
    venv = gym.make_vec(ID, num_envs=2)
    venv.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        venv.step(np.zeros((3, 2)))


def test_reset_options_pin_the_episode():
    env = gym.make(ID)
    _, info = env.reset(seed=3, options={"initial_angle": 1.0, "target_angle": 0.6, "external_torque": 0.01})
    assert info["angle"] == pytest.approx(1.0) and info["target_angle"] == 0.6
    for _ in range(5):
        info = env.step(np.zeros(2, np.float32))[4]
        assert info["target_angle"] == 0.6 and info["external_torque"] == 0.01


def test_v1_references_are_planned_and_previewed():
    env = gym.make(ID)
    obs, _ = env.reset(seed=11)
    core = env.unwrapped.core
    ta = core.target_l[0]
    # planned references move smoothly: no set-point jumps of the v0 schedule
    assert np.abs(np.diff(ta)).max() < 0.1
    layout = core.obs_layout
    dec = layout.decode(obs)
    np.testing.assert_allclose([dec[f"target_angle_+{j}"] for j in range(1, 11)], ta[1:11], atol=1e-6)


def test_rgb_frame_follows_the_angle(mujoco):
    env = gym.make(ID, render_mode="rgb_array")
    env.reset(seed=0, options={"initial_angle": 0.3})
    f0 = env.render()
    env.reset(seed=0, options={"initial_angle": 1.5})
    f1 = env.render()
    assert f0.shape == (480, 480, 3) and f0.std() > 5
    assert (np.abs(f0.astype(int) - f1.astype(int)).max(axis=2) > 12).mean() > 0.005
    env.close()


@pytest.mark.parametrize("mode", ["valve", "pressure"])
def test_the_joint_baseline_drives_v1(mode):
    """``make_controller("baseline", env)`` resolves to the joint baseline on v1 as on v0 and
    holds the reference (zero actions do not)."""
    from cepam_gym.control import make_controller
    from cepam_gym.control.joint_baseline import JointInverseStaticController

    errors = {}
    for name in ("zero", "baseline"):
        env = gym.make(ID, action_mode=mode)
        ctl = make_controller(name, env)
        obs, info = env.reset(seed=0)
        ctl.reset()
        err = []
        for _ in range(250):
            obs, r, term, trunc, info = env.step(ctl.act(obs, info))
            err.append(abs(info["angle"] - info["target_angle"]))
        errors[name] = np.degrees(np.mean(err))
        if name == "baseline":
            assert isinstance(ctl, JointInverseStaticController)
    assert errors["baseline"] < 2.0 and errors["zero"] > 3.0, errors


def test_step_set_points_are_reachable_through_the_mechanism_map():
    """The joint's set-points come from the rig's batched sampler through the mechanism map:
    at every step the inverse static model holds the target angle and joint stiffness under that
    step's external torque (and the link's weight at the target angle) with pressures inside the
    task's margin."""
    from cepam_gym.plant.params import pressure_cap_of

    env = gym.make_vec(ID, num_envs=6, task="joint", randomize={"end_mass_g": [15, 25]})
    env.reset(seed=4)
    core, g = env.core, env.geometry
    for i in range(core.num_envs):
        p = core.params[i]
        ta, kj, tau = core.target_l[i], core.target_k[i], core.load[i]
        assert len(np.unique(ta)) >= 2  # set-points change over the episode
        pc, pe, _ = api.static_pressures(
            g.length(ta, p), kj / g.lever_arm**2, g.equivalent_weight(ta, tau, p), p
        )
        top = core.task.spec.pressure_margin * pressure_cap_of(p)
        assert (pc >= 0).all() and (pe >= 0).all() and (pc <= top).all() and (pe <= top).all()


def test_a_randomize_range_outside_the_joint_is_refused_at_build():
    with pytest.raises(ValueError, match="cpam_rest_length_cm"):
        gym.make(ID, randomize={"cpam_rest_length_cm": [18.0, 19.5]})


@pytest.mark.parametrize("name", ["mpc"])
def test_rig_only_controllers_refuse_the_joint_clearly(name):
    from cepam_gym.control import make_controller

    with pytest.raises(TypeError, match="rig envs only"):
        make_controller(name, gym.make(ID))
