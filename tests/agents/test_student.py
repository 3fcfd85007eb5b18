"""The student (agents/learners/student.py): its config is checked, it is saved in the format every run
loader reads, and (slow) it learns: a short DAgger run must beat the baseline on a fixed suite."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

from cepam_gym_agents.config.files import ConfigError, TrainConfig  # noqa: E402


def _cfg(suite: str = "nominal-v1", env_id: str = "cepam_gym/CEPAM-v1", **student) -> TrainConfig:
    return TrainConfig.from_dict(
        {
            "algorithm": "PPO",
            "env": {"id": env_id, "num_envs": 2, "suite": suite},
            "normalize": {"obs": True},
            "agent": {"history": 4},
            "student": {"suites": {suite: 2}, "iterations": 1, "gradient_steps": 20, **student},
            "eval": {"episodes": 2, "suite": suite, "seed": 5},
        }
    )


@pytest.mark.parametrize(
    "student, words",
    [
        ({"suites": {"nope": 4}}, "unknown suite 'nope'"),
        ({"suites": {}}, "at least one suite"),
        ({"beta": 1.5}, "student.beta"),
        ({"iterations": 0}, "student.iterations"),
        ({"net_arch": "big"}, "student.net_arch"),
        ({"teachr": "oracle"}, "teachr"),
        ({"teacher_options": [24]}, "student.teacher_options"),
    ],
)
def test_bad_student_config_is_named(student, words):
    with pytest.raises(ConfigError, match=words):
        _cfg(**student)


def test_student_needs_ppo_and_normalized_inputs():
    with pytest.raises(ConfigError, match="must be PPO"):
        TrainConfig.from_dict({"algorithm": "SAC", "student": {}})
    from cepam_gym_agents.learners.student import check_student

    with pytest.raises(ConfigError, match="normalize.obs"):
        check_student(_cfg().replace(normalize=_cfg().normalize.__class__(obs=False)))
    with pytest.raises(ConfigError, match="must run env.id"):
        check_student(_cfg(suites={"length-v1": 4}))
    with pytest.raises(ConfigError, match="'orcale' is not a registered controller"):
        check_student(_cfg(teacher="orcale"))
    # a misspelt search setting of an MPC teacher fails before the first round
    with pytest.raises(ConfigError, match="teacher_options do not fit teacher 'mpc_known_params'.*populaton"):
        check_student(_cfg(teacher="mpc_known_params", teacher_options={"populaton": 24}))
    check_student(_cfg(teacher="mpc_known_params", teacher_options={"population": 24, "iterations": 3}))


def test_every_shipped_student_config_passes_its_check():
    """The shipped students (the main job's two-minute one, the full-teacher one, ...) build their
    teacher with their search settings before any round runs: a setting the planner refuses fails
    here, not after the first round's labels."""
    from cepam_gym_agents.config.files import load_config, shipped_configs
    from cepam_gym_agents.learners.student import check_student

    students = [load_config(n) for n in sorted(shipped_configs())]
    students = [c for c in students if c.student is not None]
    assert len(students) >= 3  # student, student_fast, student_residual
    for cfg in students:
        check_student(cfg)
    fast = load_config("student_fast").student.teacher_options
    assert fast["population"] * fast["iterations"] * 9 == 48 * 6  # a ninth of the default search


def test_teacher_options_reach_the_teachers_search():
    from cepam_gym_agents.learners.student import collect

    cfg = _cfg(teacher="mpc_known_params", teacher_options={"population": 8, "iterations": 1})
    x, y = collect(cfg, "nominal-v1", 2, seed=3)
    assert x.shape[0] == y.shape[0] > 0 and np.isfinite(y).all()


def test_a_teacher_that_reads_the_schedule_plans_the_settling_allowance():
    """The oracle and its variants are built for a student with ``allowance_weight`` 1 unless the
    options set it (an MPC has no such setting to change); and that teacher chases a jump of the
    target inside the allowance, where the scored oracle plans nothing: on the first two episodes
    of joint-v3 its angle error over every step is a fraction of the one at weight 0 (16 plans x 4
    iterations on 8 episodes: 0.31 deg against 14 deg)."""
    import gymnasium as gym

    from cepam_gym.bench.harness import run_suite
    from cepam_gym.bench.suites import SUITES
    from cepam_gym_agents.learners.student import TEACHER_ALLOWANCE_WEIGHT, make_teacher, teacher_options

    search = {"population": 16, "iterations": 4, "elites": 4}
    for name in ("oracle", "oracle_causal"):
        assert teacher_options(_cfg(teacher=name, teacher_options=search))["allowance_weight"] == 1.0
        assert teacher_options(_cfg(teacher=name, teacher_options={"allowance_weight": 0.0})) == {
            "allowance_weight": 0.0
        }
    assert "allowance_weight" not in teacher_options(_cfg(teacher="mpc_known_params", teacher_options=search))
    s = SUITES["joint-v3"]
    cfg = _cfg("joint-v3", s.env_id, teacher="oracle_causal", teacher_options=search)
    venv = gym.make_vec(s.env_id, num_envs=1, **s.env_kwargs)
    assert make_teacher(cfg, venv).cfg.allowance_weight == TEACHER_ALLOWANCE_WEIGHT
    venv.close()
    chased, _ = run_suite("oracle_causal", "joint-v3", episodes=2, **search, allowance_weight=1.0)
    scored_only, _ = run_suite("oracle_causal", "joint-v3", episodes=2, **search)
    assert chased["angle_rmse_deg_raw"] < 0.2 * scored_only["angle_rmse_deg_raw"], (chased, scored_only)
    # chasing costs little on the steps the score counts (these two episodes: 0.043 against 0.025)
    assert chased["score"] < 3 * scored_only["score"]


def test_the_time_limit_holds_inside_a_round(tmp_path):
    """A round's episodes stop at the run's time limit: the round is fitted on the labels so far
    and the run ends there, stopped by the limit (so a grid's cells keep one budget on any
    machine, and a config's minutes bound its run)."""
    import json
    import time

    from cepam_gym_agents.config.files import dump_config
    from cepam_gym_agents.learners.student import collect, train_student

    cfg = _cfg(teacher="baseline", iterations=3)
    x, _ = collect(cfg, "nominal-v1", 2, seed=3, deadline=time.perf_counter())
    assert len(x) == 2  # one step of each env: the first step past the deadline is the last
    full, _ = collect(cfg, "nominal-v1", 2, seed=3)
    assert len(full) > 100 * 2
    cfg = cfg.replace(time_limit_minutes=1e-6)
    dump_config(cfg, tmp_path / "config.yaml")
    assert train_student(cfg, tmp_path, quiet=True) == 0
    (only,) = json.loads((tmp_path / "summary.json").read_text())["rounds"]
    assert only["labels"] == 2 and only["past_time_limit"]
    assert json.loads((tmp_path / "run.json").read_text())["status"] == "stopped_by_time_limit"


def test_saved_student_acts_as_the_fitted_actor(tmp_path):
    """The PPO model written for the student reproduces the fitted actor's actions exactly
    (layers copied, the action scale folded into the head, VecNormalize's statistics)."""
    import gymnasium as gym
    import torch

    from cepam_gym_agents.config.files import dump_config
    from cepam_gym_agents.learners.student import Student, _Actor, as_ppo
    from cepam_gym_agents.policy import load_policy
    from cepam_gym_agents.session.checkpoints import save_model

    cfg = _cfg()
    venv = gym.make_vec("cepam_gym/CEPAM-v1", num_envs=3)
    obs, _ = venv.reset(seed=1)
    dim = 4 * obs.shape[1]
    rng = np.random.default_rng(0)
    actor = _Actor(dim, [16, 16], seed=0)
    with torch.no_grad():
        for p in actor.params:
            p.add_(torch.as_tensor(rng.normal(0, 0.3, tuple(p.shape)), dtype=torch.float32))
    mean, std, scale = rng.normal(0, 1, dim), rng.uniform(0.5, 2, dim), np.array([0.05, 0.08])
    cfg = cfg.replace(student=cfg.student.__class__(net_arch=[16, 16]))
    model, vecnorm = as_ppo(cfg, actor, mean, std, scale, seed=0)
    save_model(tmp_path, "final", model, vecnorm)
    dump_config(cfg, tmp_path / "config.yaml")
    policy = load_policy(tmp_path, venv, "final")
    policy.reset()
    got = policy.act(obs)
    x = np.tile(obs, 4)  # a new episode's history is its first frame repeated
    want = Student(actor, mean, std, scale)(x.astype(np.float32))
    np.testing.assert_allclose(got, want, atol=1e-5)
    assert np.abs(want).max() > 1e-3  # not a trivially zero policy
    venv.close()


@pytest.mark.slow
def test_student_learns_to_beat_the_baseline(tmp_path):
    """Learning works: two DAgger rounds with the MPC as teacher (a cheap search, 8 length-v1
    plants; about a minute on 2 cores) give a student that beats the baseline on the first 4
    episodes of length-v1, the benchmark's own (never trained on). A regression in the env, the
    features, the teacher or the fit shows here."""
    from cepam_gym.bench.harness import run_suite
    from cepam_gym_agents.config.files import dump_config
    from cepam_gym_agents.learners.student import train_student

    cfg = _cfg("length-v1", "cepam_gym/CEPAMLength-v1", suites={"length-v1": 8}, iterations=2)
    search = {"population": 16, "iterations": 2}
    cfg = cfg.replace(  # the schema's fit (2500 steps per round)
        student=cfg.student.__class__(
            teacher="mpc", suites={"length-v1": 8}, iterations=2, teacher_options=search
        )
    )
    dump_config(cfg, tmp_path / "config.yaml")
    assert train_student(cfg, tmp_path, quiet=True) == 0
    import json

    rounds = json.loads((tmp_path / "summary.json").read_text())["rounds"]
    # each round's time splits into the teacher's labels and the fit
    assert len(rounds) == 2 and all(0 < r["labels_s"] <= r["seconds"] for r in rounds), rounds
    student, _ = run_suite(str(tmp_path), "length-v1", episodes=4)
    baseline, _ = run_suite("baseline", "length-v1", episodes=4)
    # measured on a busy 2-core machine: student 0.086, baseline 0.253
    assert student["failure_rate"] == 0.0
    assert student["score"] < baseline["score"], (student["score"], baseline["score"])


def test_setpoint_gaps_are_the_nominal_models_pressure_gaps():
    """The feature is the baseline's set-point minus the measured pressure (100 kPa units): near
    zero where an episode starts at rest on its reference (nominal plant, pressures set by the
    inverse model), and it follows a pressure the env is pushed away from."""
    import gymnasium as gym

    from cepam_gym.control import InverseStaticController
    from cepam_gym.policies import Features, FeatureSpec

    venv = gym.make_vec("cepam_gym/CEPAM-v1", num_envs=3)
    obs, _ = venv.reset(seed=3)
    feats = Features(venv, FeatureSpec(setpoint_gaps_in_obs=True), obs.shape[1])
    f, _ = feats(obs)
    assert f.shape == (3, obs.shape[1] + 2)
    ref = InverseStaticController(venv)
    ref.act(obs)
    np.testing.assert_allclose(f[:, -2:], ref.last_gap / 1e5, rtol=1e-5, atol=1e-7)
    assert np.abs(f[:, -2:]).max() < 0.05  # < 5 kPa at rest on the reference
    for _ in range(10):  # exhaust the contractor: its gap opens, positive (it needs air back)
        obs, *_ = venv.step(np.tile(np.array([-1.0, 0.0], np.float32), (3, 1)))
    f, _ = feats(obs)
    assert (f[:, -2] > 0.2).all(), f[:, -2]
    venv.close()


@pytest.mark.slow
def test_comparison_table_gives_iqm_and_the_gap_closed():
    from cepam_gym_agents.compare import CONTROLLERS, SUITES, UNSEEN_CONTROLLERS, table

    cache = {}
    for suite in SUITES:
        for where, names in (("suite", CONTROLLERS), ("unseen", UNSEEN_CONTROLLERS)):
            cache.update({f"{suite}|{where}|{n}": 0.5 for n in names})
            cache[f"{suite}|{where}|baseline"], cache[f"{suite}|{where}|oracle"] = 1.0, 0.0
            for s, v in enumerate([0.2, 0.2, 0.2, 0.2, 0.9]):  # IQM of five: the middle three
                cache[f"{suite}|{where}|student-s{s}"] = v
    md = table(["student"], range(5), cache)
    rows = [r for r in md.splitlines() if "student" in r]
    assert len(rows) == 4 and all("**0.2" in r and "| 80 |" in r for r in rows), rows
    one = table(["student"], [4], cache)
    assert "no IQM under 5 seeds" in one and "| 10 |" in one


def test_comparison_on_chosen_suites_scores_the_chosen_controllers_on_both_episode_sets(tmp_path, capsys):
    """``--suite``/``--controller``: the controllers (with the baseline and the oracle) are scored
    on the suite's and the unseen seed's episodes; the cache is kept between calls."""
    from cepam_gym_agents import compare

    cache = {}
    for where in ("suite", "unseen"):
        cache[f"randomized-id-v2|{where}|baseline"], cache[f"randomized-id-v2|{where}|oracle"] = 1.0, 0.0
        cache[f"randomized-id-v2|{where}|identify_mpc"] = 0.25
    got = compare.measure([], [], tmp_path, 99000, dict(cache), ("randomized-id-v2",), ["identify_mpc"])
    assert got == cache  # nothing left to score: the cache answered every key
    md = compare.table([], [], cache, ("randomized-id-v2",), ["identify_mpc"])
    rows = [r for r in md.splitlines() if "identify_mpc" in r]
    assert len(rows) == 2 and all("0.2500 | 75 |" in r for r in rows), rows
    for bad, words in (
        (["--suite", "moon"], "unknown suite 'moon'"),
        (["--controller", "pid"], "unknown controller 'pid'"),
    ):
        with pytest.raises(SystemExit):
            compare.main(["--config", "student", "--report-only", "--out", str(tmp_path), *bad])
        assert words in capsys.readouterr().err


def test_comparison_on_more_unseen_episodes_keeps_them_apart_from_the_twenty(tmp_path, monkeypatch, capsys):
    """``--unseen-episodes N``: the unseen seed's N episodes are scored under their own name, so a
    cache of the usual 20 is neither reused for them nor overwritten; a count below 1 is refused."""
    from cepam_gym_agents import compare

    calls = []

    def fake_score(spec, suite, seed, episodes=20):
        calls.append((spec, seed, episodes))
        return {"baseline": 0.8, "oracle": 0.2}[spec]

    monkeypatch.setattr(compare, "score", fake_score)
    cache = {
        f"nominal-v1|{w}|{n}": v for w in ("suite", "unseen") for n, v in (("baseline", 1.0), ("oracle", 0.0))
    }
    got = compare.measure([], [], tmp_path, 99000, dict(cache), ("nominal-v1",), [], unseen_episodes=100)
    assert sorted(calls) == [("baseline", 99000, 100), ("oracle", 99000, 100)]
    assert got["nominal-v1|unseen|baseline"] == 1.0 and got["nominal-v1|unseen-100|baseline"] == 0.8
    assert compare.unseen_set() == "unseen" and compare.unseen_set(100) == "unseen-100"
    md = compare.table([], [], got, ("nominal-v1",), [], unseen_episodes=100)
    assert "| nominal-v1 | unseen-100 | baseline | 0.8000 |" in md
    with pytest.raises(SystemExit):
        compare.main(
            ["--config", "student", "--report-only", "--out", str(tmp_path), "--unseen-episodes", "0"]
        )
    assert "--unseen-episodes must be >= 1" in capsys.readouterr().err


def test_base_controller_config_is_checked():
    with pytest.raises(ConfigError, match="agent.base_controller must be a registered controller"):
        TrainConfig.from_dict(
            {"algorithm": "PPO", "agent": {"residual": True, "base_controller": "mpc_frictoin"}}
        )
    with pytest.raises(ConfigError, match="need the baseline's set-points"):
        TrainConfig.from_dict(
            {"algorithm": "PPO", "agent": {"setpoint_gaps_in_obs": True, "base_controller": "mpc"}}
        )
    from cepam_gym_agents.learners.student import check_student

    cfg = _cfg()
    bad = cfg.replace(agent=cfg.agent.__class__(residual=True, residual_scale=0.0))
    with pytest.raises(ConfigError, match="residual_scale > 0"):
        check_student(bad)


def test_a_residual_student_is_fitted_to_what_the_teacher_adds_to_its_base():
    """Labels of a residual student are (teacher - base) / residual_scale: zero where the teacher
    is the base controller itself, the teacher's difference otherwise; and a zero residual sends
    the base controller's own action (here the registered mpc_friction)."""
    import gymnasium as gym

    from cepam_gym.control import make_controller
    from cepam_gym.policies import Features, FeatureSpec
    from cepam_gym_agents.config.files import AgentConfig
    from cepam_gym_agents.learners.student import collect

    cfg = _cfg()
    cfg = cfg.replace(agent=AgentConfig(residual=True, residual_scale=0.5, baseline_in_obs=True))
    _x, y = collect(cfg.replace(student=cfg.student.__class__(teacher="baseline")), "nominal-v1", 2, seed=4)
    assert y.shape == (1000, 2) and np.abs(y).max() == 0.0
    _x, y = collect(cfg.replace(student=cfg.student.__class__(teacher="zero")), "nominal-v1", 2, seed=4)
    assert np.abs(y).max() > 0.1  # the zero controller's commands minus the baseline's, over 0.5

    venv = gym.make_vec("cepam_gym/CEPAM-v1", num_envs=2)
    obs, _ = venv.reset(seed=2)
    feats = Features(venv, FeatureSpec(residual=True, base_controller="mpc_friction"), obs.shape[1])
    ref = make_controller("mpc_friction", venv)
    for _ in range(5):
        _f, base = feats(obs)
        a = feats.action(np.zeros((2, 2), np.float32), base)
        np.testing.assert_array_equal(a, ref.act(obs))
        obs, *_ = venv.step(a)
    venv.close()


def test_a_bias_in_a_residual_moves_the_pressures_a_bounded_amount_where_a_direct_command_vents():
    """Why the main job's student is a residual on the baseline: a student whose output is a
    little off (here -0.05 on both valves, all along) vents both chambers within a second when it
    drives the valves itself (0 holds them shut), while the baseline's pressure feedback under a
    residual holds them within a few kPa of the baseline's own run, the offset shrinking."""
    import gymnasium as gym

    from cepam_gym.policies import Features, FeatureSpec

    def pressures(residual: bool, bias: float):
        venv = gym.make_vec("cepam_gym/CEPAM-v3", num_envs=2)
        obs, _ = venv.reset(seed=3)
        feats = Features(venv, FeatureSpec(residual=True, residual_scale=0.5), obs.shape[1])
        out = []
        for _ in range(150):  # 3 s
            a = np.full((2, 2), bias, np.float32)
            if residual:
                a = feats.action(a, feats(obs)[1])
            obs, _r, _te, _tr, info = venv.step(a)
            out.append([info["pressure_c"], info["pressure_e"]])
        venv.close()
        return np.array(out)

    direct = np.abs(pressures(False, -0.05) - pressures(False, 0.0)).max(axis=(1, 2))
    residual = np.abs(pressures(True, -0.05) - pressures(True, 0.0)).max(axis=(1, 2))
    assert direct[49] > 50e3, direct[49]  # Pa, after 1 s: vented, not held
    assert residual.max() < 5e3, residual.max()  # measured: 2.6 kPa at 1 s, 1.4 kPa at 3 s
    assert residual[149] < residual[49]


def test_comparison_reads_stored_references_and_can_leave_the_unseen_oracle_out(tmp_path, monkeypatch):
    """The baseline's and the oracle's scores come from the stored references where measured on
    the same episodes (never re-run); ``unseen_oracle=False`` scores no oracle on unseen episodes
    without a stored reference, and the table then gives those rows no headline."""
    from cepam_gym.bench import harness
    from cepam_gym.bench.references import stored_entry
    from cepam_gym_agents import compare

    ran = []

    def fake_run_suite(spec, suite, episodes):
        ran.append((spec, suite.seed, episodes))
        return [{"score": 0.5}]

    monkeypatch.setattr(harness, "run_suite", fake_run_suite)
    entry = stored_entry("nominal-v3", 20, harness.seeded("nominal-v3").seed)
    assert compare.score("oracle", "nominal-v3", None, 20) == entry["oracle"]
    assert compare.score("baseline", "nominal-v3", None, 20) == entry["baseline"]
    assert ran == []
    got = compare.measure([], [], tmp_path, 12345, {}, ("nominal-v3",), ["mpc"], 7, unseen_oracle=False)
    assert sorted(ran) == [
        ("baseline", 12345, 7),
        ("mpc", 12345, 7),
        ("mpc", harness.SUITES["nominal-v3"].seed, 20),
    ]
    assert "nominal-v3|unseen-7|oracle" not in got and got["nominal-v3|suite|oracle"] == entry["oracle"]
    md = compare.table([], [], got, ("nominal-v3",), ["mpc"], unseen_episodes=7)
    assert "| nominal-v3 | unseen-7 | mpc | 0.5000 | - |" in md
    assert "| nominal-v3 | unseen-7 | oracle |" not in md and "| nominal-v3 | suite | oracle |" in md
