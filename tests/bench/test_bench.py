"""Benchmark metrics on hand-made traces, and the harness end to end."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from cepam_gym.bench.metrics import score_traces


def _traces(T=100, N=2, dt=0.1):
    tl = np.full((T, N), 0.17)
    tl[50:] = 0.18  # a 1 cm step at t = 5 s
    tr = {
        "length": tl.copy(),
        "target_length": tl,
        "stiffness": np.full((T, N), 800.0),
        "target_stiffness": np.full((T, N), 800.0),
        "air_used": np.full((T, N), 1e-6),
        "reward": np.full((T, N), -1.0),
        "alive": np.ones((T, N), dtype=bool),
        "failed": np.zeros(N, dtype=bool),
        "dt": dt,
    }
    return tr


def test_perfect_tracking_scores_zero_error():
    m = score_traces(_traces())
    assert m["length_rmse_mm"] == 0 and m["stiffness_rmse_pct"] == 0
    assert m["settling_time_s"] == 0 and m["overshoot_pct"] == 0
    assert m["score"] == 0 and m["failure_rate"] == 0
    assert m["air_g_per_episode"] == pytest.approx(100 * 1e-6 * 1000)
    assert m["mean_return"] == -100 and m["cvar10_return"] == -100


def test_constant_offset_rmse_and_score():
    tr = _traces()
    tr["length"] = tr["length"] + 0.002  # 2 mm everywhere
    tr["stiffness"] = tr["stiffness"] * 1.1  # 10 % everywhere
    m = score_traces(tr)
    assert m["length_rmse_mm"] == pytest.approx(2.0)
    assert m["stiffness_rmse_pct"] == pytest.approx(10.0)
    assert m["score"] == pytest.approx(2.0 / 5 + 10.0 / 20)
    assert np.isclose(m["settling_time_s"], 5.0)  # never inside the 1 mm band: whole segment


def test_settling_time_and_overshoot_of_a_step_response():
    tr = _traces(N=1)
    L = tr["length"]
    # after the step at index 50: 3 samples at the old value, overshoot to 0.182, then on target
    L[50:53] = 0.17
    L[53] = 0.182
    L[54:] = 0.18
    m = score_traces(tr, track_stiffness=False)
    assert m["stiffness_rmse_pct"] is None
    assert m["overshoot_pct"] == pytest.approx(20.0)  # 2 mm beyond a 10 mm step
    # segments: [0, 50) settled at once, [50, 100) settled from index 54: 0.4 s
    assert m["settling_time_s"] == pytest.approx((0.0 + 0.4) / 2)


def test_failures_and_cvar():
    tr = _traces(N=10)
    tr["reward"][:, 0] = -10.0  # one bad episode
    tr["failed"][3] = True
    tr["alive"][60:, 3] = False
    m = score_traces(tr)
    assert m["failure_rate"] == pytest.approx(0.1)
    assert m["cvar10_return"] == pytest.approx(-1000.0)  # worst 10 % = the one bad episode
    assert m["score"] == pytest.approx(2 * 0.1)


@pytest.mark.slow  # a subprocess: interpreter, numba cache and two suites (~10 s)
def test_bench_cli_json_one_object_per_suite():
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "cepam_gym.cli",
            "bench",
            "--controller",
            "baseline",
            "--suite",
            "nominal",
            "--suite",
            "stiffness-at-fixed-length",
            "--episodes",
            "3",
            "--json",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    rows = [json.loads(line) for line in out.stdout.splitlines()]
    assert [r["suite"] for r in rows] == ["nominal", "stiffness-at-fixed-length"]
    for r in rows:
        for key in (
            "length_rmse_mm",
            "stiffness_rmse_pct",
            "settling_time_s",
            "overshoot_pct",
            "cvar10_return",
            "failure_rate",
            "air_g_per_episode",
            "score",
        ):
            assert np.isfinite(r[key])


def test_baseline_beats_zero_and_random_on_nominal():
    from cepam_gym.bench import run_suite

    scores = {c: run_suite(c, "nominal", episodes=4)[0]["score"] for c in ("baseline", "zero", "random")}
    assert scores["baseline"] < 0.5 * scores["zero"] and scores["baseline"] < 0.5 * scores["random"]


def test_run_suite_passes_controller_options_to_the_controller():
    from cepam_gym.bench import run_suite

    full, _ = run_suite("mpc", "nominal", episodes=2, max_steps=30)
    again, _ = run_suite("mpc", "nominal", episodes=2, max_steps=30)
    one_plan, _ = run_suite("mpc", "nominal", episodes=2, max_steps=30, population=4, elites=2, iterations=1)
    assert full["score"] == again["score"]  # the planner is seeded: only the options differ
    assert one_plan["score"] != full["score"]


def test_a_trained_agent_refuses_controller_options(tmp_path):
    import gymnasium as gym

    from cepam_gym.control import make_controller

    env = gym.make_vec("cepam_gym/CEPAM-v1", num_envs=1)
    with pytest.raises(ValueError, match="takes no options"):
        make_controller(str(tmp_path), env, population=4)  # any existing path goes to the loader
    env.close()


def test_unknown_controller_and_suite_are_rejected():
    from cepam_gym.bench import run_suite

    with pytest.raises(ValueError, match="controller"):
        run_suite("pid-from-mars", "nominal", episodes=1)
    bad = subprocess.run(
        [sys.executable, "-m", "cepam_gym.cli", "bench", "--suite", "moon"], capture_output=True, text=True
    )
    assert bad.returncode != 0 and "moon" in bad.stderr


def test_joint_trace_spec_scores_the_angle_in_degrees():
    from cepam_gym.bench.metrics import JOINT

    tr = _traces(N=1)
    tr["target_length"] = np.full_like(tr["target_length"], 0.8)  # rad
    tr["length"] = tr["target_length"] + np.deg2rad(1.0)  # 1 deg off: inside the 2 deg band
    tr["target_stiffness"] = tr["stiffness"] = np.full_like(tr["stiffness"], 0.4)  # N m/rad
    m = score_traces(tr, True, JOINT)
    assert "length_rmse_mm" not in m
    assert m["angle_rmse_deg"] == pytest.approx(1.0)
    assert m["score"] == pytest.approx(1.0 / JOINT.score_norm)
    assert m["settling_time_s"] == 0


def test_joint_suite_needs_mujoco_only_when_used():
    r = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; sys.modules['mujoco'] = None  # as if not installed\n"
            "from cepam_gym.bench import harness, cli, report\n"
            "from cepam_gym.bench.suites import SUITES, available\n"
            "assert 'joint' in SUITES and not available('joint') and available('nominal')\n"
            "assert 'cepam_gym.envs.joint_mujoco' not in sys.modules\n",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 0, r.stderr


def test_env_reward_weighs_length_and_stiffness_like_the_score():
    """The env's default reward trades 5 mm of length error against 20 % of stiffness error, as
    the benchmark score does: an agent maximising the default reward is ranked by the same trade."""
    from cepam_gym.tasks import RewardWeights

    T, N = 10, 1
    base = {
        "length": np.full((T, N), 0.17),
        "target_length": np.full((T, N), 0.17),
        "stiffness": np.full((T, N), 800.0),
        "target_stiffness": np.full((T, N), 800.0),
        "air_used": np.zeros((T, N)),
        "reward": np.zeros((T, N)),
        "alive": np.ones((T, N), dtype=bool),
        "failed": np.zeros(N, dtype=bool),
        "dt": 0.02,
    }
    off_5mm = dict(base, length=base["length"] + 5e-3)
    off_20pct = dict(base, stiffness=base["stiffness"] * 1.2)
    s_len, s_k = score_traces(off_5mm)["score"], score_traces(off_20pct)["score"]
    assert s_len == pytest.approx(1.0) and s_k == pytest.approx(1.0)
    from cepam_gym.tasks import TASKS

    # every rig task of the absolute form uses them (the score form's are the score's own: test_v3)
    assert all(t.weights == RewardWeights() for t in TASKS.values() if t.reward_form == "abs")
    w = RewardWeights()
    reward_len = w.length * 0.5  # per cm of length error
    reward_k = w.stiffness * 0.2  # per unit relative stiffness error
    assert reward_len == pytest.approx(reward_k * s_len / s_k)


def test_joint_reward_weighs_angle_and_stiffness_like_its_score():
    """The joint env's default reward trades 10 deg against 20 % of joint stiffness, as the
    joint suite's score (TraceSpec JOINT) does."""
    pytest.importorskip("mujoco")
    import math

    from cepam_gym.bench.metrics import JOINT
    from cepam_gym.tasks.joint import JointRewardWeights, JointTask

    w = JointRewardWeights()
    per_score_unit_angle = w.angle * math.radians(JOINT.score_norm) / JointTask().scales.tracking_unit
    per_score_unit_stiffness = w.stiffness * 0.20  # the score's 20 %
    assert per_score_unit_angle == pytest.approx(per_score_unit_stiffness)


def test_settling_allowance_leaves_out_the_transient_after_a_jump_only():
    """With a 1 s allowance, an error in the second after the jump does not count in the
    headline error, an error later does; the raw error counts both."""
    import dataclasses

    from cepam_gym.bench.metrics import RIG, tracking_mask

    spec = dataclasses.replace(RIG, allowance_s=1.0)
    tr = _traces(N=1)  # dt 0.1 s, jump at index 50
    tr["length"][50:60] += 0.004  # 4 mm off during the allowance
    m = score_traces(tr, spec=spec)
    assert m["length_rmse_mm"] == 0.0
    assert m["length_rmse_mm_raw"] == pytest.approx(4.0 * np.sqrt(10 / 100))
    assert m["tracked_fraction"] == pytest.approx(0.9)
    tr["length"][60] += 0.004  # one step after the allowance: counted
    m = score_traces(tr, spec=spec)
    assert m["length_rmse_mm"] == pytest.approx(4.0 * np.sqrt(1 / 90))
    # a smooth ramp of the target is no jump: nothing left out
    ramp = _traces(N=1)
    ramp["target_length"][:, 0] = np.linspace(0.16, 0.18, 100)  # 0.2 mm per step
    assert tracking_mask(ramp, True, spec).all()
    # without an allowance (v0 suites) headline = raw, no raw keys
    assert "length_rmse_mm_raw" not in score_traces(tr)


def test_rise_time_of_a_hand_made_response():
    import dataclasses

    from cepam_gym.bench.metrics import RIG

    spec = dataclasses.replace(RIG, allowance_s=0.5)
    tr = _traces(N=1)
    L = tr["length"]
    L[50:] = 0.18
    L[50:55, 0] = 0.17 + 0.01 * np.array([0.0, 0.05, 0.3, 0.7, 0.95])  # 10 % at 52, 90 % at 54
    assert score_traces(tr, spec=spec)["rise_time_s"] == pytest.approx(0.2)


def test_normalized_score_is_zero_for_zero_and_hundred_for_the_oracle():
    from cepam_gym.bench.metrics import normalized_score

    assert normalized_score(6.0, 6.0, 1.0) == 0.0
    assert normalized_score(1.0, 6.0, 1.0) == 100.0
    assert normalized_score(3.5, 6.0, 1.0) == pytest.approx(50.0)
    with pytest.raises(ValueError, match="zero controller"):
        normalized_score(1.0, 1.0, 2.0)


@pytest.mark.slow
def test_reference_scores_are_what_the_zero_controller_scores_now():
    """The stored ends of the normalized score are current: the zero controller's score of every
    suite with a reference, recomputed at the suite's default episodes (cheap: valves shut)."""
    from cepam_gym.bench.harness import run_suite
    from cepam_gym.bench.suites import REFERENCE_SCORES, SUITES

    assert {"nominal-v1", "randomized-v1"} <= set(REFERENCE_SCORES)
    for name, (zero, oracle) in REFERENCE_SCORES.items():
        assert oracle < zero, name
        m, _ = run_suite("zero", SUITES[name])
        assert m["score"] == pytest.approx(zero, rel=1e-9), name


def test_bench_skips_a_controller_the_env_does_not_take_and_says_so(capsys):
    """The rig's MPC cannot drive the joint: the pair is skipped with a note, the rest runs."""
    import json

    from cepam_gym.bench.cli import main

    assert (
        main(
            [
                "--controller",
                "zero",
                "--controller",
                "mpc",
                "--suite",
                "joint-v1",
                "--episodes",
                "1",
                "--json",
            ]
        )
        == 0
    )
    out, err = capsys.readouterr()
    rows = [json.loads(line) for line in out.splitlines() if line.startswith("{")]
    assert [r["controller"] for r in rows] == ["zero"] and rows[0]["suite"] == "joint-v1"
    assert "skipped mpc on joint-v1" in err


def test_a_failing_suite_is_named_and_the_finished_ones_are_kept(tmp_path, monkeypatch):
    """A multi-suite run writes each suite's results as it finishes; the one that fails is named
    in one line (a user error) or in a note on the traceback (a bug), and the run exits non-zero."""
    from cepam_gym.bench import cli
    from cepam_gym.errors import InputError

    real = cli.run_suite

    def failing_on(name, exc):
        def run(controller, suite, episodes=None):
            if suite == name:
                raise exc
            return real(controller, suite, episodes=episodes)

        return run

    args = ["--controller", "zero", "--suite", "nominal-v2", "--suite", "randomized-v2", "--episodes", "1"]
    monkeypatch.setattr(
        cli, "run_suite", failing_on("randomized-v2", InputError("observation must have shape"))
    )
    with pytest.raises(InputError, match=r"suite randomized-v2 failed: observation must.*nominal-v2") as e:
        cli.main([*args, "--out-dir", str(tmp_path / "a")])
    assert "\n" not in str(e.value)
    rows = json.loads((tmp_path / "a" / "results.json").read_text())
    assert [r["suite"] for r in rows] == ["nominal-v2"] and np.isfinite(rows[0]["score"])
    assert "nominal-v2" in (tmp_path / "a" / "table.txt").read_text()

    monkeypatch.setattr(cli, "run_suite", failing_on("randomized-v2", RuntimeError("a bug")))
    with pytest.raises(RuntimeError, match="a bug") as e:
        cli.main([*args, "--out-dir", str(tmp_path / "b")])
    assert any("suite randomized-v2 failed" in n for n in e.value.__notes__)
    assert [r["suite"] for r in json.loads((tmp_path / "b" / "results.json").read_text())] == ["nominal-v2"]


def test_an_agent_that_does_not_fit_a_suite_is_refused_before_any_suite_runs(tmp_path, monkeypatch):
    """A v2 rig agent on --suite v2: the length suite's observations differ; said before running."""
    pytest.importorskip("stable_baselines3")
    import gymnasium as gym
    from stable_baselines3 import PPO

    from cepam_gym.bench import cli
    from cepam_gym.errors import InputError

    PPO("MlpPolicy", gym.make("cepam_gym/CEPAM-v2"), n_steps=8, batch_size=8).save(str(tmp_path / "agent"))
    ran = []
    monkeypatch.setattr(cli, "run_suite", lambda *a, **k: ran.append(a))
    with pytest.raises(InputError, match=r"does not fit suite length-v2 \(cepam_gym/CEPAMLength-v2") as e:
        cli.main(["--controller", str(tmp_path / "agent.zip"), "--suite", "v2", "--out-dir", str(tmp_path)])
    assert "--suite nominal-v2" in str(e.value) and "--suite length-v2" not in str(e.value)
    assert ran == []


def test_bench_env_id_picks_that_ids_suites(monkeypatch):
    from cepam_gym.bench import cli

    asked = []

    def stop(controllers, suites):
        asked.extend(suites)
        raise SystemExit(0)

    monkeypatch.setattr(cli, "check_agents_fit", stop)
    with pytest.raises(SystemExit):
        cli.main(["--env-id", "cepam_gym/CEPAMLength-v2"])
    assert asked == ["length-v2"]
    from cepam_gym.errors import InputError

    with pytest.raises(InputError, match="no suite runs it"):  # the command line: one line, exit 2
        cli.main(["--env-id", "cepam_gym/Nope-v9"])
