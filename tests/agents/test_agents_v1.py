"""Agents on the v1 ids: every variant trains and loads back, the privileged critic never reaches
the actor, recurrent policies keep and reset their memory, the reference-curve runner and the goals
of the comparison table."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytestmark = pytest.mark.train

from cepam_gym_agents.config.files import ConfigError, TrainConfig  # noqa: E402

V1 = "cepam_gym/CEPAM-v1"
SMALL_ON_POLICY = {"n_steps": 64, "batch_size": 64, "n_epochs": 1}
SMALL_OFF_POLICY = {"learning_starts": 64, "batch_size": 32, "buffer_size": 2000}

VARIANTS = {
    "ppo": ("PPO", SMALL_ON_POLICY, {}, {}),
    "ppo-residual-history": (
        "PPO",
        SMALL_ON_POLICY,
        {"target_shift": True, "residual": True, "history": 3},
        {},
    ),
    "ppo-privileged-critic": ("PPO", SMALL_ON_POLICY, {"privileged_critic": True, "residual": True}, {}),
    "recurrent-ppo": ("RecurrentPPO", SMALL_ON_POLICY, {}, {"lstm_hidden_size": 8}),
    "sac": ("SAC", SMALL_OFF_POLICY, {}, {}),
    "td3": ("TD3", {**SMALL_OFF_POLICY, "action_noise": {"type": "normal", "sigma": 0.1}}, {}, {}),
}


def _cfg(algo, hp, agent, pk, **env) -> TrainConfig:
    return TrainConfig.from_dict(
        {
            "algorithm": algo,
            "total_timesteps": 256,
            "seed": 2,
            "env": {"id": V1, "num_envs": 2, "kwargs": {"episode_seconds": 2.0, **env}},
            "agent": agent,
            "normalize": {"obs": True, "reward": True},
            "hyperparameters": hp,
            "policy_kwargs": {"net_arch": [8], **pk},
            "eval": {"every_steps": 10_000, "episodes": 1},
            "checkpoint": {"every_steps": 10_000, "replay_buffer": False},
            "log_every_steps": 100,
        }
    )


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """Each variant trained for 256 steps (once per module)."""
    from cepam_gym_agents.train import train

    root = tmp_path_factory.mktemp("v1agents")
    for name, spec in VARIANTS.items():
        assert train(_cfg(*spec), root / name, quiet=True) == 0, name
    return root


@pytest.mark.slow  # trains six agents
@pytest.mark.parametrize("name", list(VARIANTS))
def test_each_variant_trains_loads_back_and_acts(trained, name):
    import gymnasium as gym

    from cepam_gym_agents.policy import load_policy

    venv = gym.make_vec(V1, num_envs=3, episode_seconds=2.0)
    obs, _ = venv.reset(seed=5)
    pol = load_policy(trained / name, venv)
    assert pol.recurrent == (VARIANTS[name][0] == "RecurrentPPO")
    for _ in range(10):
        a = pol.act(obs)
        assert a.shape == (3, 2) and a.dtype == np.float32
        assert np.all(np.isfinite(a)) and np.all(np.abs(a) <= 1)
        obs, *_ = venv.step(a)
    summary = json.loads((trained / name / "summary.json").read_text())
    assert summary["steps"] >= 256


@pytest.mark.slow
def test_privileged_columns_never_reach_the_saved_actor(trained):
    """The saved model's actions do not change whatever the privileged columns hold, NaN
    included, while the critic's values do; the deployed policy fills them with NaN."""
    import gymnasium as gym
    import torch

    from cepam_gym_agents.policy import load_policy

    venv = gym.make_vec(V1, num_envs=4, episode_seconds=2.0)
    obs, _ = venv.reset(seed=1)
    pol = load_policy(trained / "ppo-privileged-critic", venv)
    f = pol.features
    assert f.priv_dim > 0 and f.dim == f.actor_dim + f.priv_dim
    model = pol.model
    rng = np.random.default_rng(0)
    x = rng.normal(size=(4, f.dim)).astype(np.float32)
    actions = []
    for fill in (0.0, 1e3, np.nan, None):
        y = x.copy()
        y[:, f.actor_dim :] = rng.normal(size=(4, f.priv_dim)) if fill is None else fill
        actions.append(model.predict(y, deterministic=True)[0])
    for a in actions[1:]:
        np.testing.assert_array_equal(a, actions[0])
    with torch.no_grad():
        t = torch.as_tensor(x)
        t2 = t.clone()
        t2[:, f.actor_dim :] += 3.0
        v1, v2 = model.policy.predict_values(t), model.policy.predict_values(t2)
    assert not torch.allclose(v1, v2), "the critic ignores the privileged columns"
    # deployed: the privileged part of the features is NaN, and the actions are finite
    feats, _ = pol.features(obs)
    assert np.isnan(feats[:, f.actor_dim :]).all() and np.isfinite(feats[:, : f.actor_dim]).all()
    assert np.isfinite(pol.act(obs)).all()


@pytest.mark.slow
def test_a_privileged_critic_model_saved_under_the_old_class_path_loads(trained, tmp_path, monkeypatch):
    """An SB3 zip pickles its policy class by module and name: models of privileged-critic runs
    saved before the policy moved to ``learners.asymmetric`` name ``cepam_gym_agents.asymmetric``."""
    import shutil
    import zipfile

    import gymnasium as gym

    from cepam_gym_agents.learners.asymmetric import AsymmetricActorCriticPolicy
    from cepam_gym_agents.policy import load_policy

    venv = gym.make_vec(V1, num_envs=2, episode_seconds=2.0)
    obs, _ = venv.reset(seed=5)
    now = load_policy(trained / "ppo-privileged-critic", venv)
    old = tmp_path / "old"
    shutil.copytree(trained / "ppo-privileged-critic", old)
    monkeypatch.setattr(AsymmetricActorCriticPolicy, "__module__", "cepam_gym_agents.asymmetric")
    for name in ("best_model.zip", "model.zip"):
        if (old / name).is_file():
            now.model.save(old / name)
            assert b"cepam_gym_agents.asymmetric" in zipfile.ZipFile(old / name).read("data")
    monkeypatch.undo()
    then = load_policy(old, venv)
    assert isinstance(then.model.policy, AsymmetricActorCriticPolicy)
    now.reset()
    np.testing.assert_array_equal(then.act(obs), now.act(obs))


def test_privileged_view_holds_the_true_errors_load_and_plant():
    import gymnasium as gym

    from cepam_gym import plant as pl
    from cepam_gym.envs.model import model_of
    from cepam_gym.policies.privileged import PrivilegedView

    venv = gym.make_vec(V1, num_envs=3, randomize={"end_mass_g": [15.0, 25.0]})
    venv.reset(seed=3)
    core = venv.unwrapped.core
    for _ in range(20):
        venv.step(np.full((3, 2), 0.3, dtype=np.float32))
    view = PrivilegedView(model_of(venv))  # the env's plant model; the core checks it below
    rows = view.view()
    assert rows.shape == (3, view.dim) and np.isfinite(rows).all()
    tl, tk, load = core.current_targets()
    n = len(view._cols)
    np.testing.assert_allclose(rows[:, n], load / 0.1, rtol=1e-6)
    np.testing.assert_allclose(rows[:, n + 1], (core.state[:, pl.S_L] - tl) / 5e-3, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(rows[:, n + 2], np.log(core.aux[:, pl.A_STIFF] / tk), rtol=1e-5, atol=1e-5)
    # the randomized end mass shows as log(value / nominal), the untouched columns as 0
    from cepam_gym.physics import layout as ix

    j = list(view._cols).index(ix.M_END)
    nominal = core.nominal.to_array()[ix.M_END]
    np.testing.assert_allclose(rows[:, j], np.log(core.params[:, ix.M_END] / nominal), rtol=1e-5)
    assert np.any(np.abs(rows[:, j]) > 1e-3)
    other = [k for k, c in enumerate(view._cols) if c not in (ix.M_END, ix.P_SUP)]
    assert np.allclose(rows[:, other], 0.0, atol=1e-6)


@pytest.mark.slow
def test_recurrent_policy_remembers_and_forgets_per_env(trained):
    import gymnasium as gym

    from cepam_gym_agents.policy import load_policy

    venv = gym.make_vec(V1, num_envs=2, episode_seconds=2.0)
    obs, _ = venv.reset(seed=4)
    pol = load_policy(trained / "recurrent-ppo", venv)
    same = np.repeat(obs[:1], 2, axis=0)
    first = pol.act(same)
    np.testing.assert_array_equal(first[0], first[1])
    later = pol.act(same)  # the same observation again: the memory has changed the action
    assert not np.array_equal(later[0], first[0])
    pol.reset([1])  # env 1 starts a new episode: it acts as on its first step, env 0 does not
    again = pol.act(same)
    np.testing.assert_allclose(again[1], first[1], rtol=1e-6)
    assert not np.allclose(again[0], first[0])


# --------------------------------------------------------------------------- configs
def test_recurrent_ppo_name_is_case_insensitive_and_checks_lstm_kwargs():
    cfg = _cfg("recurrentppo", SMALL_ON_POLICY, {}, {"lstm_hidden_size": 8})
    assert cfg.algorithm == "RecurrentPPO"
    with pytest.raises(ConfigError, match="lstm_hidden_sise"):
        _cfg("RecurrentPPO", SMALL_ON_POLICY, {}, {"lstm_hidden_sise": 8})
    with pytest.raises(ConfigError, match="action_noise.*RecurrentPPO"):
        _cfg("RecurrentPPO", {"action_noise": {"sigma": 0.1}}, {}, {})


def test_privileged_critic_is_for_ppo_only():
    with pytest.raises(ConfigError, match="privileged_critic.*SAC"):
        _cfg("SAC", SMALL_OFF_POLICY, {"privileged_critic": True}, {})


def test_v1_configs_are_shipped_and_the_curve_runner_sets_id_suite_seed():
    from cepam_gym_agents.config.files import shipped_configs
    from cepam_gym_agents.curves import CONFIG_OF, SUITE_OF, run_config

    assert set(CONFIG_OF.values()) <= set(shipped_configs())
    cfg = run_config("SAC", "cepam_gym/CEPAMStiffness-v1", 7, 2.5)
    assert cfg.env.id == "cepam_gym/CEPAMStiffness-v1" and cfg.seed == 7
    assert cfg.env.suite == cfg.eval.suite == SUITE_OF[cfg.env.id] == "stiffness-at-fixed-length-v1"
    assert cfg.time_limit_minutes == 2.5 and cfg.env.kwargs["num_threads"] == 1
    with pytest.raises(ConfigError, match="unknown env id"):
        run_config("PPO", "cepam_gym/CEPAM-v0", 0, 1.0)


def test_curves_are_normalized_on_the_evaluations_own_episodes_and_plotted(tmp_path):
    """A periodic evaluation (16 episodes from seed 12345, say) is normalized between the zero
    controller and the oracle on those same episodes, not the suite's stored 20-episode ends."""
    from cepam_gym_agents.curves import plot_curves, read_curves, write_csv

    zero, oracle = 2.0, 0.01  # the ends on the evaluation's episodes (cached, as a run measures)
    runs = tmp_path / "runs"
    for seed, scores in ((0, [zero, oracle]), (1, [zero, (zero + oracle) / 2])):
        d = runs / "PPO" / "CEPAM-v1" / f"seed{seed}"
        d.mkdir(parents=True)
        ev = [{"step": 1000 * (i + 1), "wall_s": 10.0 * (i + 1), "score": s} for i, s in enumerate(scores)]
        (d / "evaluations.json").write_text(json.dumps(ev))
        (d / "config.yaml").write_text("eval: {episodes: 16, seed: 12345}\n")
    (runs / "eval_references.json").write_text(json.dumps({"nominal-v1|16|12345": [zero, oracle]}))
    rows = read_curves(runs)
    assert [round(r["normalized"], 6) for r in rows] == [0.0, 100.0, 0.0, 50.0]
    write_csv(rows, tmp_path / "curves.csv")
    lines = (tmp_path / "curves.csv").read_text().splitlines()
    assert lines[0].startswith("algorithm,env_id,seed,steps") and len(lines) == 5
    (png,) = plot_curves(rows, tmp_path)
    assert png.name == "CEPAM-v1.png" and png.stat().st_size > 10_000


@pytest.mark.slow  # runs the oracle on an episode
def test_eval_references_are_measured_on_the_evaluation_episodes(tmp_path):
    from cepam_gym.bench.harness import run_suite
    from cepam_gym.bench.suites import REFERENCE_SCORES, SUITES, Suite
    from cepam_gym_agents.curves import eval_references

    zero, oracle = eval_references(tmp_path, "nominal-v1", 1, 777)
    s = SUITES["nominal-v1"]
    other = Suite(s.name, s.env_id, s.env_kwargs, seed=777, traces=s.traces)
    want, _ = run_suite("zero", other, episodes=1)
    assert zero == pytest.approx(want["score"], rel=1e-12)
    assert 0 < oracle < 0.1 * zero
    assert (zero, oracle) != REFERENCE_SCORES["nominal-v1"]
    assert json.loads((tmp_path / "eval_references.json").read_text())["nominal-v1|1|777"] == [zero, oracle]


def row(suite, controller, score):
    """A benchmark row as ``cepam-gym eval`` collects it, with what the comparisons read."""
    return {"suite": suite, "controller": controller, "score": score, "failure_rate": 0.0}


def test_comparison_gives_ratios_to_every_reference_and_no_goals():
    from cepam_gym_agents.evaluate import compare

    rows = [
        row("randomized-v1", "agent", 0.5),
        row("randomized-v1", "baseline", 0.8),
        row("randomized-v1", "mpc", 0.45),
        row("nominal-v1", "agent", 0.094),
        row("nominal-v1", "oracle", 0.086),
        row("nominal-v1", "zero", 2.7),
    ]
    got = {(c["suite"], c["reference"]): c for c in compare(rows)}
    assert set(got) == {
        ("randomized-v1", "baseline"),
        ("randomized-v1", "mpc"),
        ("nominal-v1", "oracle"),
        ("nominal-v1", "zero"),
    }
    assert got[("randomized-v1", "baseline")]["ratio"] == pytest.approx(0.625)
    assert got[("randomized-v1", "mpc")]["ratio"] == pytest.approx(0.5 / 0.45)
    assert got[("nominal-v1", "zero")]["reference_score"] == 2.7
    assert not any(k.startswith("goal") for c in got.values() for k in c)


def test_the_agents_headline_beside_the_baseline_the_mpc_and_the_oracle():
    from cepam_gym_agents.evaluate import compare, comparison_markdown, gaps_closed

    rows = [
        row("nominal-v1", "agent", 0.06),
        row("nominal-v1", "baseline", 0.31),
        row("nominal-v1", "oracle", 0.01),
        row("nominal-v1", "mpc", 0.08),
        row("randomized-v1", "agent", 0.4),
        row("randomized-v1", "baseline", 0.8),
        row("randomized-v1", "oracle", 0.0),
        row("stress", "agent", 1.0),  # no oracle ran and no stored headline: no gap
        row("stress", "baseline", 2.0),
    ]
    got = {g["suite"]: g for g in gaps_closed(rows)}
    assert set(got) == {"nominal-v1", "randomized-v1"}
    assert got["nominal-v1"]["headline"] == pytest.approx(100 * 0.25 / 0.30)  # (0.31 - 0.06) / (0.31 - 0.01)
    assert got["nominal-v1"]["mpc_headline"] == pytest.approx(100 * 0.23 / 0.30)
    assert got["nominal-v1"]["mpc_ratio"] == pytest.approx(0.75)  # 0.06 / 0.08
    assert got["randomized-v1"]["headline"] == pytest.approx(50.0)
    assert got["randomized-v1"]["mpc_headline"] is None and got["randomized-v1"]["mpc_ratio"] is None
    md = comparison_markdown(compare(rows), Path("run"), "final", gaps_closed(rows))
    assert "| nominal-v1 | **83** | 0 | 77 | 100 | 0.75 | this run |" in md
    assert "| randomized-v1 | **50** | 0 | not run (--against mpc) | 100 | - | this run |" in md
    assert "goal" not in md and "| met |" not in md
    assert "No headline on stress: no stored reference scores" in md


def test_the_headline_from_the_stored_references_when_the_oracle_did_not_run():
    """eval's default (the baseline only): the agent's and the MPC's headlines are the ones
    ``add_scores`` put in their rows from the stored references of the same episodes."""
    from cepam_gym_agents.evaluate import gaps_closed

    stored = {"headline": 40.0, "headline_from": "reference scores"}
    rows = [
        {**row("nominal-v2", "agent", 0.2), **stored},
        {**row("nominal-v2", "baseline", 0.3), "headline": 0.0, "headline_from": "reference scores"},
        {**row("nominal-v2", "mpc", 0.25), "headline": 20.0, "headline_from": "reference scores"},
    ]
    (got,) = gaps_closed(rows)
    assert (got["headline"], got["mpc_headline"], got["headline_from"]) == (40.0, 20.0, "reference scores")
    assert got["mpc_ratio"] == pytest.approx(0.8)


@pytest.mark.slow  # trains
def test_an_agent_trains_on_the_batched_joint_and_drives_it_through_the_registry(tmp_path):
    """CEPAMJoint-v1 runs on the batched kernel: agents train on it and the bench loads them
    (the MuJoCo joint, v0, still refuses agents: tests/control/test_controllers.py)."""
    from cepam_gym.bench.harness import run_suite
    from cepam_gym_agents.train import train

    cfg = _cfg("PPO", SMALL_ON_POLICY, {}, {})
    cfg = cfg.replace(env=cfg.env.__class__("cepam_gym/CEPAMJoint-v1", 2, None, {"episode_seconds": 2.0}))
    assert train(cfg, tmp_path / "joint", quiet=True) == 0
    m, _ = run_suite(str(tmp_path / "joint"), "joint-v1", episodes=2)
    assert np.isfinite(m["score"]) and m["score"] > 0 and "angle_rmse_deg" in m
