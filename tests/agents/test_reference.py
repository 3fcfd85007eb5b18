"""The reference grid of the recommended version (agents/reference.py): its cells, their configs,
and one tiny grid trained, scored and reported end to end."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytestmark = pytest.mark.train


def test_the_grid_covers_every_recommended_id_and_skips_only_what_it_says():
    from cepam_gym import versions
    from cepam_gym_agents.grid.cells import LEARNERS, cells, recommended_ids, skipped

    ids = recommended_ids()
    recommended = versions.get(versions.RECOMMENDED_ID).version
    assert versions.RECOMMENDED_ID in ids and {versions.get(i).version for i in ids} == {recommended}
    assert len(ids) == len(versions.ids(version=recommended))  # every one of them has a suite
    grid = cells(list(LEARNERS), ids)
    for learner in LEARNERS:
        for i in ids:
            assert ((learner, i) in grid) == (skipped(learner, i) is None)
    joint = [i for i in ids if versions.get(i).mechanism == "hinge"]
    assert joint and all(("student", i) not in grid for i in joint)
    assert all(("PPO", i) in grid for i in ids)


@pytest.mark.parametrize("learner", ["student", "TD3"])
def test_a_cell_config_is_the_shipped_one_on_its_ids_suite(learner):
    from cepam_gym_agents.config.files import load_config
    from cepam_gym_agents.grid.cells import LEARNERS, cell_config, suite_of

    shipped = load_config(LEARNERS[learner])
    cfg = cell_config(learner, "cepam_gym/CEPAMLength-v3", 0.5)
    suite = suite_of("cepam_gym/CEPAMLength-v3")
    assert suite == "length-v3"
    assert (cfg.env.id, cfg.env.suite, cfg.eval.suite, cfg.time_limit_minutes) == (
        "cepam_gym/CEPAMLength-v3",
        suite,
        suite,
        0.5,
    )
    assert cfg.hyperparameters == shipped.hyperparameters and cfg.env.num_envs == shipped.env.num_envs
    if learner == "student":  # as many DAgger envs per round as the shipped config, on this suite
        assert cfg.student.suites == {suite: sum(shipped.student.suites.values())}
    assert (
        cell_config(learner, "cepam_gym/CEPAMLength-v3", None).time_limit_minutes
        == shipped.time_limit_minutes
    )


@pytest.mark.slow
def test_a_tiny_grid_is_trained_scored_and_reported(tmp_path, monkeypatch, capsys):
    from cepam_gym.bench import references
    from cepam_gym_agents.grid import report as reference_report
    from cepam_gym_agents.grid.report import _score
    from cepam_gym_agents.reference import main

    # the MPCs' planning would be most of the test's time; the headline needs these two, read
    # from the stored references on the grid's own episodes (the suite's 20, the unseen seed's 50)
    monkeypatch.setitem(reference_report.CONTROLLERS, "rig", ("baseline", "oracle"))

    out, docs = tmp_path / "runs", tmp_path / "docs"
    args = ["--learners", "PPO", "--ids", "CEPAMLength-v3", "--seeds", "1", "--minutes", "0.03"]
    args += ["--jobs", "2", "--out", str(out), "--docs", str(docs)]  # scored by 2 processes
    assert main(args) == 0
    results = json.loads((docs / "reference" / "reference.json").read_text())
    (row,) = results["runs"]
    assert (row["learner"], row["env_id"], row["suite"], row["seed"]) == (
        "PPO",
        "cepam_gym/CEPAMLength-v3",
        "length-v3",
        0,
    )
    assert row["env_steps"] > 0 and row["wall_s"] > 0 and row["curve"]
    assert all(np.isfinite(v) and v > 0 for v in row["scores"].values())
    assert row["cepam_gym"] and "commit" in row and row["resolved_config"]["env"]["id"] == row["env_id"]
    # the run's score is what the benchmark gives its directory on the same episodes
    run = out / "PPO" / "CEPAMLength-v3" / "seed0"
    assert row["scores"]["unseen"] == pytest.approx(_score(str(run), "length-v3", 99000, 50), rel=1e-9)
    marks = results["controllers"]["length-v3"]
    assert set(marks) == {"suite", "unseen"} and set(marks["suite"]) == {"baseline", "oracle"}
    for where, table in (("suite", "suite"), ("unseen", "unseen")):
        for controller in ("baseline", "oracle"):
            stored = references.load(table)["length-v3"][controller]
            assert marks[where][controller] == pytest.approx(stored, rel=1e-12), (where, controller)
    assert marks["suite"]["oracle"] < marks["suite"]["baseline"]
    page = (docs / "reference.md").read_text()
    assert "| CEPAMLength-v3 (length-v3) | PPO | 1 |" in page and "*oracle*" in page
    assert "](reference/CEPAMLength-v3.png)" in page and "--minutes 0.03" in page
    assert (docs / "reference" / "CEPAMLength-v3.png").stat().st_size > 0
    times = json.loads((out / "grid_time.json").read_text())
    assert times["train"] > 0 and times["score"] > 0
    # a second call trains only what is missing (nothing here) and reports the same numbers
    stamp = (run / "summary.json").stat().st_mtime_ns
    assert main(args) == 0 and (run / "summary.json").stat().st_mtime_ns == stamp
    assert main([*args, "--report-only"]) == 0
    again = json.loads((docs / "reference" / "reference.json").read_text())
    assert again["runs"][0]["scores"] == row["scores"] and again["command"] == results["command"]
    assert "--out" not in results["command"] and "--minutes 0.03" in results["command"]
    cached = json.loads((out / "reference_scores.json").read_text())
    assert len(cached) == 2  # the run on each set, once; the controllers' scores are the stored ones
    # runs of another budget are not mixed into a cell, and nothing is written
    config = (out / "configs" / "PPO-CEPAMLength-v3.yaml").read_text()
    with pytest.raises(SystemExit) as e:
        main([*args, "--minutes", "0.05"])
    assert e.value.code == 2 and "trained for 0.03 min" in capsys.readouterr().err
    assert (out / "configs" / "PPO-CEPAMLength-v3.yaml").read_text() == config


@pytest.mark.parametrize(
    "argv", [["--ids", "CEPAM-v2"], ["--seeds", "0"], ["--minutes", "-1"], ["--suite-episodes", "0"]]
)
def test_bad_input_is_named(argv, capsys):
    from cepam_gym_agents.reference import main

    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert argv[0] in err or argv[1] in err  # the option or the value named


def test_the_grid_reads_the_stored_references_on_their_own_episodes_only(tmp_path):
    """The baseline's and the oracle's scores on the suite's episodes and on the unseen seed's are
    stored once per release (``cepam-gym bench --update-references [--unseen]``) for every cell
    whose oracle the grid runs; the grid reads them there and measures everything else."""
    from cepam_gym.bench import references
    from cepam_gym_agents.grid.cells import recommended_ids, suite_of
    from cepam_gym_agents.grid.report import Scores, controllers_of, stored

    unseen = (references.UNSEEN_SEED, references.UNSEEN_EPISODES)
    rig = [suite_of(i) for i in recommended_ids() if "oracle" in controllers_of(i, "unseen")]
    assert rig and set(rig) <= set(references.load("unseen"))
    for suite in rig:
        own, other = references.load()[suite], references.load("unseen")[suite]
        assert (other["seed"], other["episodes"]) == unseen
        for c in ("baseline", "oracle"):
            assert stored(c, suite, None, None) == own[c] and stored(c, suite, *unseen) == other[c]
        assert stored("oracle", suite, unseen[0], 2) is None  # other episodes: measured
        assert stored("mpc", suite, None, None) is None  # only the stored controllers
    scores = Scores(tmp_path, {"suite": (None, None), "unseen": unseen})
    assert scores.get("oracle", rig[0], "unseen") == references.load("unseen")[rig[0]]["oracle"]
    assert not (tmp_path / "reference_scores.json").exists()  # read, not measured
