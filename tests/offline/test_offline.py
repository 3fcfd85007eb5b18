"""Offline-RL datasets (``cepam-gym dataset``, :mod:`cepam_gym.offline`): the episodes recorded are
the benchmark's, Minari's normalized score reads episode returns between the zero controller's and
the oracle's, bad input is one line."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

from cepam_gym.bench import cli as bench_cli
from cepam_gym.bench import references
from cepam_gym.bench.harness import run_suite
from cepam_gym.bench.suites import SUITES
from cepam_gym.cli import main as cli_main
from cepam_gym.errors import InputError
from cepam_gym.offline import dataset_id, record_dataset
from cepam_gym.offline.episodes import EpisodeRecorder

NOMINAL = "nominal-v1"


# --------------------------------------------------------------------------- without Minari
def test_ids_live_in_the_cepam_namespace_under_the_env():
    s = SUITES
    assert dataset_id(s["randomized-v1"], "oracle") == "cepam/CEPAM-v1/randomized-oracle-v0"
    assert dataset_id(s[NOMINAL], "baseline", version=2) == "cepam/CEPAM-v1/nominal-baseline-v2"
    assert (
        dataset_id(s["stiffness-at-fixed-length-v1"], "random")
        == "cepam/CEPAMStiffness-v1/stiffness-at-fixed-length-random-v0"
    )
    assert dataset_id(s["nominal"], "zero") == "cepam/CEPAM-v0/nominal-zero-v0"  # a v0 suite
    # a trained run directory by its folder, characters Minari refuses replaced
    assert dataset_id(s["joint-v1"], "runs/my run.2/") == "cepam/CEPAMJoint-v1/joint-my_run_2-v0"
    assert dataset_id(s[NOMINAL], "agent:runs/bc") == "cepam/CEPAM-v1/nominal-bc-v0"
    assert dataset_id(s[NOMINAL], "oracle", name="expert") == "cepam/CEPAM-v1/expert-v0"
    for bad in ("a b", "x-v3", "a/b"):
        with pytest.raises(InputError, match="dataset name"):
            dataset_id(s[NOMINAL], "oracle", name=bad)


def test_episodes_end_at_their_first_termination_and_drop_the_autoreset_steps():
    rec = EpisodeRecorder(2)
    info0 = {"length": np.array([0.17, 0.18]), "_length": np.array([True, True])}
    rec.start(np.zeros((2, 3)), info0)
    for t in range(3):
        term = np.array([False, t == 1])
        info = {
            "length": np.array([0.2 + t, 0.3 + t]),
            "reward_length": np.array([-1.0, -2.0]),
            "termination_reason": np.array([0, int(t == 1)]),
            "final_obs": np.zeros((2, 3)),  # a per-env vector: not an info column
        }
        rec.step(
            np.array([[2.0, -0.5], [0.25, -3.0]]),
            np.full((2, 3), t + 1.0),
            np.array([1.0, 2.0]),
            term,
            term & False,
            info,
        )
    ep0, ep1 = rec.episodes()
    assert ep0["observations"].shape == (4, 3) and ep0["actions"].shape == (3, 2)
    assert ep0["truncations"].tolist() == [False, False, True] and not ep0["terminations"].any()
    # env 1 failed at step 1: its episode ends there (the step after is the autoreset's)
    assert ep1["terminations"].tolist() == [False, True] and not ep1["truncations"].any()
    assert ep1["observations"].shape == (3, 3) and ep1["rewards"].tolist() == [2.0, 2.0]
    # what the plant received: commands clipped into [-1, 1]
    assert ep0["actions"][0].tolist() == [1.0, -0.5] and ep1["actions"][0].tolist() == [0.25, -1.0]
    # infos: the reset row first (no reward yet: 0), no masks, no per-env vectors
    assert sorted(ep0["infos"]) == ["length", "reward_length", "termination_reason"]
    assert ep0["infos"]["length"].tolist() == [0.17, 0.2, 1.2, 2.2]
    assert ep1["infos"]["reward_length"].tolist() == [0.0, -2.0, -2.0]
    assert ep1["infos"]["termination_reason"].tolist() == [0, 0, 1]


def test_without_minari_the_command_names_the_extra(monkeypatch, capsys):
    import sys

    monkeypatch.setitem(sys.modules, "minari", None)  # import minari raises ImportError
    code = cli_main(["dataset", "--suite", NOMINAL, "--controller", "zero"])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert "pip install 'cepam-gym[offline]'" in err and len(err.splitlines()) == 1


# --------------------------------------------------------------------------- with Minari
@pytest.fixture
def minari_home(tmp_path, monkeypatch):
    pytest.importorskip("minari", reason="the [offline] extra (minari) is not installed")
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "datasets"))
    return tmp_path / "datasets"


def _dataset(cli_args, capsys):
    import minari

    assert cli_main(["dataset", *cli_args]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    return out, minari.load_dataset(out[-1])


def test_a_dataset_holds_the_episodes_the_benchmark_scores(minari_home, capsys):
    """Two short episodes of the baseline: transitions, infos and score are those of the bench's
    run on the same episodes, and each episode replays from its seed and stream."""
    out, ds = _dataset(
        ["--suite", NOMINAL, "--controller", "baseline", "--episodes", "2", "--max-steps", "40"], capsys
    )
    assert out[-1] == "cepam/CEPAM-v1/nominal-baseline-v0"
    assert (minari_home / "cepam" / "CEPAM-v1" / "nominal-baseline-v0").is_dir()  # under MINARI_DATASETS_PATH
    assert (ds.total_episodes, ds.total_steps) == (2, 80)
    metrics, tr = run_suite("baseline", NOMINAL, episodes=2, max_steps=40)
    meta = ds.storage.metadata
    assert meta["cepam_score"] == metrics["score"] and meta["cepam_suite_episodes"] is False
    suite = SUITES[NOMINAL]
    for i, ep in enumerate(ds.iterate_episodes()):
        assert ep.observations.shape == (41, ds.observation_space.shape[0]) and ep.actions.shape == (40, 2)
        assert ep.truncations[-1] and not ep.terminations.any()
        np.testing.assert_array_equal(ep.rewards, tr["reward"][:, i])
        np.testing.assert_array_equal(ep.infos["length"][1:], tr["length"][:, i])
        np.testing.assert_array_equal(ep.infos["target_stiffness"][1:], tr["target_stiffness"][:, i])
        assert {"reward_length", "reward_stiffness", "reward_effort", "reward_air"} <= set(ep.infos)
        # the named reward terms add up to the reward
        terms = sum(v[1:] for k, v in ep.infos.items() if k.startswith("reward_"))
        np.testing.assert_allclose(terms, ep.rewards, rtol=1e-9, atol=1e-12)
        # episode i is stream i of the suite's seed: a single env replays it
        epmeta = ds.storage.get_episode_metadata([i])
        (epmeta,) = list(epmeta)
        env = gym.make(suite.env_id, stream=int(epmeta["stream"]), **suite.env_kwargs)
        obs, _ = env.reset(seed=int(epmeta["seed"]))
        np.testing.assert_array_equal(obs, ep.observations[0])
        np.testing.assert_array_equal(env.step(ep.actions[0])[0], ep.observations[1])
        env.close()
    # the eval env is the suite's, at full length; the collection env says the episodes were cut
    env = ds.recover_environment(eval_env=True)
    assert env.spec.id == suite.env_id and env.spec.max_episode_steps == 500
    assert env.unwrapped.core.task.spec == gym.make(suite.env_id, **suite.env_kwargs).unwrapped.core.task.spec
    assert ds.spec.env_spec.max_episode_steps == 40


def test_a_window_dataset_holds_the_windows_and_each_episodes_true_plant(minari_home, capsys):
    """Offline identification: on the window suite the dataset keeps the unscored identification
    window (``infos["window"]``) before the tracking, and each episode's metadata holds its
    plant's parameter row (``plant_<NAME>``), the truth a fit of the window is scored against: the
    row a single env of the episode's stream runs."""
    from cepam_gym.envs.model import model_of
    from cepam_gym.physics.layout import NAMES

    suite = SUITES["randomized-id-v2"]
    _out, ds = _dataset(
        ["--suite", suite.name, "--controller", "baseline", "--episodes", "2", "--max-steps", "5"], capsys
    )
    n_window = int(suite.env_kwargs["task_options"]["id_window_s"] / 0.02)
    rows = []
    for i, ep in enumerate(ds.iterate_episodes()):
        assert ep.actions.shape == (n_window + 5, 2)
        window = np.asarray(ep.infos["window"][1:], dtype=bool)
        assert window[:n_window].all() and not window[n_window:].any()
        (meta,) = list(ds.storage.get_episode_metadata([i]))
        row = np.array([meta[f"plant_{name}"] for name in NAMES])
        env = gym.make(suite.env_id, stream=int(meta["stream"]), **suite.env_kwargs)
        env.reset(seed=int(meta["seed"]))
        np.testing.assert_array_equal(row, model_of(env).params[0])
        env.close()
        rows.append(row)
    assert not np.array_equal(rows[0], rows[1])  # randomized: each episode its own plant


def test_minaris_normalized_score_puts_a_baseline_episode_between_the_zero_controller_and_the_oracle(
    minari_home, capsys
):
    """ref_min_score / ref_max_score are the mean episode returns of the zero controller and of the
    oracle on the suite's episodes (the stored references), as Minari expects: the zero
    controller's mean return reads 0, the oracle's 1, the baseline's in between; the benchmark's
    own scores of the recorded episodes are the dataset's cepam_* metadata."""
    import minari

    _, ds = _dataset(["--suite", NOMINAL, "--controller", "baseline"], capsys)
    entry = references.load()[NOMINAL]
    meta = ds.storage.metadata
    assert (meta["ref_min_score"], meta["ref_max_score"]) == (entry["zero_return"], entry["oracle_return"])
    returns = np.array([ep.rewards.sum() for ep in ds.iterate_episodes()])
    assert returns.shape == (SUITES[NOMINAL].episodes,)
    # the baseline's mean episode return, on the scale its ends are (means over the same episodes)
    mean = float(minari.get_normalized_score(ds, returns.mean()))
    assert 0 < mean < 1, mean
    assert meta["cepam_mean_return"] == pytest.approx(returns.mean(), rel=1e-12)
    # single episodes spread around it (some are easier than the oracle's average), none near valves shut
    assert np.all(np.asarray(minari.get_normalized_score(ds, returns)) > 0.5)
    zero, _ = run_suite("zero", NOMINAL)  # measured now: the stored end is current
    assert float(minari.get_normalized_score(ds, zero["mean_return"])) == pytest.approx(0.0, abs=1e-9)
    assert float(minari.get_normalized_score(ds, entry["oracle_return"])) == pytest.approx(1.0)
    # the benchmark's figures of the same episodes, as cepam-gym bench gives them
    assert bench_cli.main(["--controller", "baseline", "--suite", NOMINAL, "--json"]) == 0
    base = json.loads(capsys.readouterr().out.strip().splitlines()[0])
    assert meta["cepam_suite_episodes"] is True and meta["cepam_score"] == base["score"]
    assert meta["cepam_headline"] == pytest.approx(base["headline"], abs=1e-9)
    assert meta["cepam_normalized"] == pytest.approx(base["normalized"], rel=1e-12)


def test_without_stored_reference_returns_the_dataset_has_no_minari_ends_and_says_how_to_get_them(
    minari_home, capsys, monkeypatch
):
    import minari

    table = references.load()
    entry = {k: v for k, v in table[NOMINAL].items() if not k.endswith("_return")}
    # the suites' table without the returns; the unseen seed's table empty
    tables = {"suite": {**table, NOMINAL: entry}}
    monkeypatch.setattr(references, "load", lambda name="suite": tables.get(name, {}))
    assert (
        cli_main(
            ["dataset", "--suite", NOMINAL, "--controller", "zero", "--episodes", "1", "--max-steps", "3"]
        )
        == 0
    )
    out, err = capsys.readouterr()
    assert f"no reference returns stored for {NOMINAL}" in err
    assert f"cepam-gym bench --update-references --suite {NOMINAL}" in err
    ds = minari.load_dataset(out.strip().splitlines()[-1])
    assert ds.storage.metadata.get("ref_min_score") is None


@pytest.mark.parametrize(
    "args, message",
    [
        (["--suite", "nope", "--controller", "zero"], "unknown suite 'nope'"),
        (["--suite", NOMINAL, "--controller", "nope"], "unknown controller 'nope'"),
        (["--suite", NOMINAL, "--controller", "zero", "--episodes", "0"], "--episodes must be >= 1, got 0"),
        (["--suite", NOMINAL, "--controller", "zero", "--episodes", "-3"], "--episodes must be >= 1, got -3"),
        (["--suite", NOMINAL, "--controller", "zero", "--max-steps", "501"], "--max-steps must be in 1..500"),
        (["--suite", NOMINAL, "--controller", "zero", "--name", "a.b"], "dataset name must be"),
        (
            ["--suite", NOMINAL, "--controller", "zero", "--dataset-version", "-1"],
            "dataset version must be >= 0",
        ),
    ],
)
def test_bad_input_is_one_line(tmp_path, monkeypatch, capsys, args, message):
    """Checked before anything runs, Minari installed or not."""
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "datasets"))
    assert cli_main(["dataset", *args]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and message in captured.err and len(captured.err.strip().splitlines()) == 1
    assert not (tmp_path / "datasets").exists()


def test_a_controller_for_another_env_is_bad_input(minari_home, capsys):
    """The rig's MPC cannot drive the joint: the benchmark skips the pair, the command refuses it."""
    assert cli_main(["dataset", "--suite", "joint-v1", "--controller", "mpc", "--episodes", "1"]) == 2
    err = capsys.readouterr().err
    assert "controller 'mpc' cannot drive suite joint-v1" in err and len(err.strip().splitlines()) == 1
    assert not any(minari_home.rglob("*.hdf5"))


def test_an_existing_id_needs_overwrite(minari_home, capsys):
    args = ["--suite", NOMINAL, "--controller", "zero", "--episodes", "1", "--max-steps", "5"]
    out, ds = _dataset(args, capsys)
    assert ds.total_steps == 5
    assert cli_main(["dataset", *args[:-1], "7"]) == 2
    err = capsys.readouterr().err
    assert (
        f"dataset {out[-1]} already exists" in err
        and "--overwrite" in err
        and len(err.strip().splitlines()) == 1
    )
    with pytest.raises(InputError, match="already exists"):
        record_dataset(NOMINAL, "zero", 1, max_steps=7)
    out, ds = _dataset([*args[:-1], "7", "--overwrite"], capsys)
    assert ds.total_steps == 7  # replaced
