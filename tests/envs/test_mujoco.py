"""MuJoCo: the 3-D rig view, MuJoCo-backed load mechanics, the CE-PAM joint env, videos.

The tests that need MuJoCo skip cleanly without it (``pip install 'cepam-gym[mujoco]'``);
the import hygiene tests run everywhere.
"""

from __future__ import annotations

import os
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym
from cepam_gym import plant as pl
from cepam_gym.control.joint_baseline import JointInverseStaticController
from cepam_gym.envs.joint_mujoco import CEPAMJointEnv
from cepam_gym.mujoco.rig import RigRenderer, RigSimulator
from cepam_gym.physics import api
from cepam_gym.physics import layout as ix

if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
    os.environ["MUJOCO_GL"] = "egl"  # headless; must be set before mujoco is imported


def _run(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)


# ------------------------------------------------------------------ import hygiene (no mujoco)
def test_import_and_default_render_do_not_import_mujoco():
    r = _run(
        "import sys, gymnasium as gym, cepam_gym, cepam_gym.mujoco\n"
        "env = gym.make('cepam_gym/CEPAM-v0', render_mode='rgb_array'); env.reset(seed=0)\n"
        "frame = env.render(); assert frame.shape == (400, 320, 3), frame.shape\n"
        "assert 'cepam_gym/CEPAMJoint-v0' in gym.registry\n"
        "assert 'mujoco' not in sys.modules, 'mujoco imported'\n"
    )
    assert r.returncode == 0, r.stderr


def test_missing_mujoco_gives_the_install_hint():
    r = _run(
        "import sys; sys.modules['mujoco'] = None  # as if not installed\n"
        "import gymnasium as gym, cepam_gym\n"
        "for make in (lambda: gym.make('cepam_gym/CEPAMJoint-v0'),\n"
        "             lambda: gym.make('cepam_gym/CEPAM-v0', render_mode='rgb_array', renderer='mujoco')):\n"
        "    try:\n"
        "        make()\n"
        "    except ImportError as e:\n"
        "        assert \"pip install 'cepam-gym[mujoco]'\" in str(e), str(e)\n"
        "    else:\n"
        "        raise SystemExit('no ImportError')\n"
    )
    assert r.returncode == 0, r.stderr


def test_unknown_renderer_is_refused():
    with pytest.raises(ValueError, match="renderer must be one of"):
        gym.make("cepam_gym/CEPAM-v0", renderer="opengl")


# ------------------------------------------------------------------------------ rig view
@pytest.fixture(scope="module")
def mujoco():
    """The tests below need MuJoCo; they skip without it (the ones above run everywhere)."""
    return pytest.importorskip("mujoco")


def _changed_fraction(a, b, tol=12):
    return float((np.abs(a.astype(int) - b.astype(int)).max(axis=2) > tol).mean())


def test_rig_frame_is_not_blank_and_follows_the_state(mujoco):
    env = gym.make("cepam_gym/CEPAM-v0", render_mode="rgb_array", renderer="mujoco")
    env.reset(seed=0, options={"target_length": 0.17, "load_mass": 0.1})
    core = env.unwrapped.core
    core.state[0, pl.S_L] = 0.155
    core.aux[0, pl.A_PC] = core.aux[0, pl.A_PE] = 20e3
    a = env.render()
    assert a.shape == (480, 480, 3) and a.dtype == np.uint8
    assert a.std() > 20 and len(np.unique(a.reshape(-1, 3), axis=0)) > 200  # not blank
    core.state[0, pl.S_L] = 0.19  # longer muscle: end cap and load lower
    b = env.render()
    assert _changed_fraction(a, b) > 0.01
    core.aux[0, pl.A_PC] = core.aux[0, pl.A_PE] = 230e3  # colours only
    c = env.render()
    assert _changed_fraction(b, c) > 0.01
    core.load[0] = 0.45  # bigger block
    d = env.render()
    assert _changed_fraction(c, d) > 0.0005
    env.close()


def test_rig_renderer_diameters_follow_the_braids(mujoco):
    """The drawn EPAM is wider at 15 cm than at 19.5 cm, as braid_diameter says (Eq. 2)."""
    r = RigRenderer(width=160, height=160)
    p = cepam_gym.PlantParams().to_array()
    r.render(p, 0.15, 0.0, 0.0)
    wide = r.model.geom_size[r.ids["epam"], 0]
    r.render(p, 0.195, 0.0, 0.0)
    narrow = r.model.geom_size[r.ids["epam"], 0]
    assert wide > narrow > r.model.geom_size[r.ids["cpam"], 0] > 0
    r.close()


def test_mujoco_load_mechanics_agree_with_the_numpy_plant(mujoco):
    """Free end on a MuJoCo slider, force from the plant each sub-step, vs plant.step: same
    integration scheme, so the trajectories agree to round-off (stated tolerance: 1 nm, 1 Pa)."""
    params = cepam_gym.PlantParams()
    p = params.to_array()
    L0, load = 0.172, 0.12
    pc, pe, _ = api.static_pressures(L0, 800.0, (params.end_mass + load) * params.gravity, p)
    x = pl.initial_state(p, L0, pc, pe)
    sim = RigSimulator(params)
    sim.reset(x[0])
    rng = np.random.default_rng(0)
    lengths, worst_l, worst_p = [], 0.0, 0.0
    for k in range(50):  # 1 s; load and valve commands vary (load on a step at 0.5 s)
        u = np.array([[*rng.uniform(-0.4, 0.4, 2), load if k < 25 else 0.25, 0.0]])
        x, aux = pl.step(x, u, p[None])
        xs, auxs = sim.step(u[0])
        assert aux[0, pl.A_STOP] == 0.0  # away from the end stops (where MuJoCo's are soft)
        worst_l = max(worst_l, abs(xs[pl.S_L] - x[0, pl.S_L]))
        worst_p = max(worst_p, abs(auxs[pl.A_PC] - aux[0, pl.A_PC]), abs(auxs[pl.A_PE] - aux[0, pl.A_PE]))
        lengths.append(x[0, pl.S_L])
        # the end-of-step bookkeeping is the plant's own (plant.end_of_step): same flows, air, peak
        for col in (pl.A_MDOT_C, pl.A_MDOT_E, pl.A_AIR, pl.A_PMAX):
            assert auxs[col] == pytest.approx(aux[0, col], rel=1e-6, abs=1e-15), pl.AUX_FIELDS[col]
        assert auxs[pl.A_STOP] == aux[0, pl.A_STOP] and auxs[pl.A_BURST] == aux[0, pl.A_BURST]
    assert np.ptp(lengths) > 2e-3  # the test moves the muscle
    assert worst_l < 1e-9 and worst_p < 1.0


# ----------------------------------------------------------------------------- joint env
def test_joint_env_passes_gymnasium_check_env(mujoco):
    from gymnasium.utils.env_checker import check_env

    for mode in ("valve", "pressure"):
        check_env(CEPAMJointEnv(action_mode=mode), skip_render_check=True)
    env = gym.make("cepam_gym/CEPAMJoint-v0")
    assert env.spec.max_episode_steps == 500
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    obs, r, term, trunc, info = env.step(env.action_space.sample())
    terms = [v for k, v in info.items() if k.startswith("reward_")]
    assert len(terms) == 5 and r == pytest.approx(sum(terms))
    assert info["termination_reason"] == 0 and env.unwrapped.metadata["termination_reasons"][0] == "none"
    with pytest.raises(ValueError, match="NaN"):
        env.step(np.array([np.nan, 0.0]))
    with pytest.raises(ValueError, match="unknown keys"):
        gym.make("cepam_gym/CEPAMJoint-v0", joint={"arm": 0.03})


def test_joint_env_pickles_and_is_deterministic(mujoco):
    import pickle

    env = CEPAMJointEnv(
        action_mode="pwm", joint={"lever_arm": 0.03}, task_options={"angle_range": [0.2, 1.4]}
    )
    twin = pickle.loads(pickle.dumps(env))
    assert twin.geometry.lever_arm == 0.03 and twin.action_mode == "pwm"
    a, _ = env.reset(seed=5)
    b, _ = twin.reset(seed=5)
    assert np.array_equal(a, b)
    for u in ([0.3, -0.2], [-1.0, 0.5]):
        assert np.array_equal(env.step(np.array(u))[0], twin.step(np.array(u))[0])
    c, _ = twin.reset(seed=6)
    assert not np.array_equal(a, c)


def _sealed_energy(mujoco, env):
    """Hinge kinetic + gravity energy (MuJoCo), end-cap gravity, chamber air internal energy, the
    work against the atmosphere ``p_atm (Vc + Ve)`` and the bladder spring: constant for sealed,
    undamped motion."""
    u = env.unwrapped
    mujoco.mj_forward(u.model, u.data)
    p, x, aux = u.params, u.link.x, u.aux
    mech = u.data.energy[0] + u.data.energy[1] - p[ix.M_END] * p[ix.GRAV] * x[pl.S_L]
    air = x[pl.S_UC] + x[pl.S_UE] + p[ix.P_ATM] * (aux[pl.A_VC] + aux[pl.A_VE])
    spring = 0.5 * p[ix.K_EL] * (x[pl.S_L] - p[ix.L_EL0]) ** 2  # the bladder elasticity
    return mech + air + spring, u.data.energy[1]


def _sealed_oscillation(mujoco, sub_dt: float):
    """Worst energy error and the kinetic energies over 1 s (about 4 oscillations) after a kick."""
    env = CEPAMJointEnv(
        sub_dt=sub_dt,
        plant={
            "preset": "balloon_v0",
            "force_model": "basic",
            "heat_transfer_w_per_k": 0.0,
            "leak_conductance_dm3_per_s_bar": 0.0,
            "damping_ns_per_m": 0.0,
        },
        joint={"joint_damping": 0.0},
    )
    env.reset(
        seed=0,
        options={
            "initial_angle": 0.9,
            "initial_stiffness": 0.5,
            "external_torque": 0.0,
            "target_angle": 0.9,
            "target_stiffness": 0.5,
        },
    )
    env.data.qvel[0] = 1.0  # kick: 0.5 mJ of kinetic energy
    e0, ke0 = _sealed_energy(mujoco, env)
    errors, kinetic, angles = [], [], []
    for _ in range(50):
        _, _, term, _, info = env.step(np.zeros(2))
        assert not term
        e, ke = _sealed_energy(mujoco, env)
        errors.append(abs(e - e0))
        kinetic.append(ke)
        angles.append(info["angle"])
    assert min(kinetic) < 0.1 * ke0 and max(kinetic) > 0.8 * ke0  # the energy goes into the air and back
    assert 0.85 < min(angles) and max(angles) < 0.95  # away from the hinge limits
    return max(errors) / ke0


def test_joint_coupling_conserves_energy_with_sealed_chambers(mujoco):
    """Valves closed, no heat transfer, no leak, no damping, no radial pressure (basic force
    model, so F dL = Pc dVc + Pe dVe exactly): hinge + air energy is conserved up to the sub-step
    scheme's error, which is first order (the plant updates the air with the velocity at the
    start of a sub-step and the length with the new one), so it halves with the sub-step. A wrong
    coupling (lever arm, sign, units) would leave an error that does not vanish."""
    e1 = _sealed_oscillation(mujoco, 5e-4)
    e2 = _sealed_oscillation(mujoco, 2.5e-4)
    assert 1.7 < e1 / e2 < 2.3
    assert e2 < 0.5


def test_joint_static_stiffness_is_muscle_stiffness_times_arm_squared(mujoco):
    """Held pressures (set-point mode), a small external torque step: the angle moves by
    dtau / (K r^2 + m g l_c cos theta)."""
    env = CEPAMJointEnv(action_mode="pressure", plant="balloon_v0")  # the v0 id's plant
    opts = {
        "initial_angle": 0.9,
        "initial_stiffness": 0.5,
        "external_torque": 0.02,
        "target_angle": 0.9,
        "target_stiffness": 0.5,
    }
    _, info = env.reset(seed=0, options=opts)
    cap = env.setpoint_max
    a = np.array([2 * info["pressure_c"] / cap - 1, 2 * info["pressure_e"] / cap - 1])
    for _ in range(60):
        _, _, _, _, info = env.step(a)
    th1, k1 = info["angle"], info["joint_stiffness_total"]
    assert abs(th1 - 0.9) < 0.01 and abs(info["angular_velocity"]) < 1e-3  # at rest where it started
    dtau = 0.004
    env.external_torque[:] += dtau
    for _ in range(60):
        _, _, _, _, info = env.step(a)
    th2, k2 = info["angle"], info["joint_stiffness_total"]
    predicted = -dtau / (0.5 * (k1 + k2))
    assert (th2 - th1) == pytest.approx(predicted, rel=0.03)
    g = env.geometry
    assert info["joint_stiffness"] == pytest.approx(info["stiffness"] * g.lever_arm**2)


@pytest.mark.parametrize("mode", ["valve", "pressure"])
def test_joint_baseline_settles_on_the_nominal_plant(mujoco, mode):
    env = gym.make("cepam_gym/CEPAMJoint-v0", action_mode=mode)
    ctl = JointInverseStaticController(env)
    obs, info = env.reset(
        seed=3,
        options={
            "target_angle": 1.1,
            "target_stiffness": 0.45,
            "external_torque": 0.03,
            "initial_angle": 0.5,
            "initial_stiffness": 0.3,
        },
    )
    ctl.reset()
    assert abs(info["angle"] - 1.1) > 0.5
    for _ in range(150):  # 3 s
        obs, r, term, trunc, info = env.step(ctl.act(obs, info))
        assert not term
    assert info["angle"] == pytest.approx(1.1, abs=0.02)  # about 1 degree
    assert info["joint_stiffness"] == pytest.approx(0.45, rel=0.05)
    assert abs(info["angular_velocity"]) < 0.01


def test_joint_reward_terms_are_the_rig_terms_over_the_mechanism_map(mujoco):
    """The joint scores with the rig's reward function (envs.step.reward_terms) on the angle
    and the joint stiffness, and its terms are the documented ones."""
    import math

    from cepam_gym.envs.step import reward_terms
    from cepam_gym.tasks.reward import MAX_TERMS

    env = CEPAMJointEnv(action_mode="pressure", reward_weights={"air": 0.3})
    assert env.terms.shape == (MAX_TERMS,)
    env.reset(seed=2)
    rng = np.random.default_rng(0)
    for _ in range(5):
        a = rng.uniform(-1, 1, 2)
        _, r, _, _, info = env.step(a)
        got = [info[f"reward_{t}"] for t in ("angle", "stiffness", "effort", "air", "burst")]
        terms = np.zeros(MAX_TERMS)
        total = reward_terms(
            info["angle"],
            info["target_angle"],
            info["angular_velocity"],
            info["joint_stiffness"],
            info["target_stiffness"],
            a[0],
            a[1],
            info["air_used"],
            False,
            True,
            env.task_params,
            terms,
        )
        assert terms[:5].tolist() == got and total == r
        w = env.weights
        expect = [
            -w.angle * min(abs(info["angle"] - info["target_angle"]) / math.radians(10), 5.0),
            -w.stiffness
            * min(abs(info["joint_stiffness"] - info["target_stiffness"]) / info["target_stiffness"], 2.0),
            -w.effort * 0.5 * (a[0] ** 2 + a[1] ** 2),
            -0.3 * info["air_used"] / 1e-5,
            0.0,
        ]
        assert got == pytest.approx(expect, rel=1e-12, abs=1e-15)
    # the observation is the layout's encoding of the measured quantities, by name
    obs = env._obs()
    decoded = env.obs_layout.decode(obs)
    assert decoded["angle"] == pytest.approx(info["angle"], abs=1e-6)
    assert decoded["pressure_c"] == pytest.approx(info["pressure_c"], rel=1e-6, abs=1.0)


def test_joint_frame_is_not_blank_and_follows_the_angle(mujoco):
    env = CEPAMJointEnv(render_mode="rgb_array", width=240, height=240)
    env.reset(seed=0, options={"initial_angle": 0.3, "initial_stiffness": 0.4, "target_angle": 0.3})
    a = env.render()
    assert a.shape == (240, 240, 3) and a.std() > 20
    env.data.qpos[0] = 1.5
    b = env.render()
    assert _changed_fraction(a, b) > 0.02
    env.close()


# --------------------------------------------------------------------------------- video
@pytest.mark.slow  # renders and encodes a video (~15 s)
def test_video_command_writes_an_episode(mujoco, tmp_path):
    from cepam_gym.cli import main

    out = tmp_path / "joint.gif"
    assert (
        main(
            [
                "video",
                "--controller",
                "zero",
                "--env-id",
                "cepam_gym/CEPAMJoint-v0",
                "--seconds",
                "0.3",
                "--fps",
                "10",
                "--size",
                "160",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    import imageio.v3 as iio

    frames = iio.imread(out, index=None)
    assert frames.shape[0] >= 3 and frames.shape[1] == 160 and frames.shape[2] > 300  # view + traces
    out = tmp_path / "rig.mp4"  # MP4 with ffmpeg, else a GIF beside it
    assert main(["video", "--controller", "baseline", "--seconds", "0.2", "--out", str(out)]) == 0
    assert out.exists() or out.with_suffix(".gif").exists()


# ------------------------------------------------------------------------- benchmark harness
def test_joint_bench_suite_baseline_beats_zero(mujoco):
    from cepam_gym.bench import run_suite

    m = {c: run_suite(c, "joint", episodes=4)[0] for c in ("baseline", "zero")}
    for r in m.values():
        assert r["suite"] == "joint" and r["episodes"] == 4 and "length_rmse_mm" not in r
        assert np.isfinite(r["angle_rmse_deg"]) and np.isfinite(r["stiffness_rmse_pct"])
    assert m["baseline"]["failure_rate"] == 0
    assert m["baseline"]["angle_rmse_deg"] < 10.0
    assert m["baseline"]["angle_rmse_deg"] < 0.5 * m["zero"]["angle_rmse_deg"]
    assert m["baseline"]["score"] < 0.5 * m["zero"]["score"]


@pytest.mark.slow  # a subprocess running the joint suite (~10 s)
def test_joint_bench_cli_json_and_table(mujoco, tmp_path):
    import json

    from cepam_gym.bench.cli import main

    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "cepam_gym.cli",
            "bench",
            "--controller",
            "baseline",
            "--suite",
            "joint",
            "--episodes",
            "2",
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
    )
    (row,) = [json.loads(line) for line in out.stdout.splitlines()]
    assert row["suite"] == "joint" and np.isfinite(row["angle_rmse_deg"]) and np.isfinite(row["score"])
    assert (
        main(["--controller", "zero", "--suite", "joint", "--episodes", "1", "--out-dir", str(tmp_path)]) == 0
    )
    assert "ang RMS deg" in (tmp_path / "table.txt").read_text()
    assert (tmp_path / "traces_joint_zero.png").stat().st_size > 0
