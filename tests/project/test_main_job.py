"""The main job (``cepam-gym run``, declared by the training package): its default config, its run
directories and ``summary.md`` (what ran, versions, where every output is, the scores)."""

from __future__ import annotations

import json
import re
from datetime import UTC, datetime

import pytest

from cepam_gym.bench.suites import SUITES
from cepam_gym.cli import main
from cepam_gym_agents import main_job
from cepam_gym_agents.config.files import load_config
from cepam_gym_agents.main_job import fresh_dir
from cepam_gym_agents.main_summary import write_summary


def test_main_job_never_reuses_a_run_directory(tmp_path):
    first = fresh_dir(tmp_path / "agent")
    assert first == tmp_path / "agent"
    first.mkdir()
    second = fresh_dir(tmp_path / "agent")
    assert second == tmp_path / "agent-2"
    second.mkdir()
    assert fresh_dir(tmp_path / "agent") == tmp_path / "agent-3"


def test_the_main_jobs_default_config_is_a_shipped_student_on_the_recommended_id(capsys):
    from cepam_gym import versions

    cfg = load_config(main_job.MAIN_CONFIG)
    assert cfg.student is not None
    assert cfg.env.id == versions.RECOMMENDED_ID
    assert all(SUITES[s].env_id == versions.RECOMMENDED_ID for s in cfg.student.suites)
    with pytest.raises(SystemExit) as done:  # argparse's --help, through the command line's hook
        main(["run", "--help"])
    assert done.value.code == 0
    assert f"the shipped ``{main_job.MAIN_CONFIG}`` config" in " ".join(capsys.readouterr().out.split())


def test_main_job_without_the_train_extra_fails_in_one_line_before_any_step(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(main_job, "TRAINING_MODULES", ("stable_baselines3", "no_such_module_of_the_extra"))
    out = tmp_path / "main"
    assert main(["run", "--out-dir", str(out)]) == 2
    err = capsys.readouterr().err
    assert "no_such_module_of_the_extra not installed" in err and "pip install 'cepam-gym[train]'" in err
    assert "stable_baselines3" not in err  # installed: only the missing module is named
    assert err.strip().count("\n") == 0
    assert not (out / "step_response.png").exists()  # nothing ran
    assert "| plant step response" not in (out / "summary.md").read_text()


@pytest.mark.slow
def test_main_job_without_training_writes_the_summary(tmp_path, capsys, recwarn):
    from cepam_gym import versions

    out = tmp_path / "main"
    assert main(["run", "--out-dir", str(out), "--no-train", "--episodes", "2"]) == 0
    assert not [w for w in recwarn if "out of date" in str(w.message)]  # only the recommended id runs
    text = (out / "summary.md").read_text()
    assert f"preset {versions.get(versions.RECOMMENDED_ID).plant_preset}" in text
    assert "cepam-gym run --out-dir" in text and "numba" in text and "gymnasium" in text
    for what in ("`step_response.png`", "`validate`", "`bench`", "| done |"):
        assert what in text, what
    timed = re.findall(r"^\| .+ \| done \| [\d.]+ (s|min) \| .+ \|$", text, flags=re.M)
    assert len(timed) == 3  # every step with its elapsed time
    printed = capsys.readouterr().out
    assert all(f"[{k}/3] done in " in printed for k in (1, 2, 3))
    table = (out / "bench" / "table.txt").read_text().strip()
    assert table in text and "baseline" in text
    assert (out / "step_response.png").is_file()


def test_summary_names_a_time_limit_stop_and_the_run_files(tmp_path):
    run = tmp_path / "agent"
    run.mkdir()
    (run / "run.json").write_text(
        json.dumps(
            {
                "seed": 3,
                "status": "stopped_by_time_limit",
                "sessions": [{"end_step": 721_000, "total_timesteps": 1_000_000, "wall_s": 360.0}],
            }
        )
    )
    (tmp_path / "t.txt").write_text("suite controller score\nnominal agent 1.2\n")
    path = write_summary(
        tmp_path,
        ["--config", "configs/quick.yaml"],
        datetime.now(UTC),
        [("train an agent", "done", run, 150.0), ("score", "exit code 2", None)],
        run,
        tmp_path / "t.txt",
    )
    text = path.read_text()
    assert "**stopped_by_time_limit** at step 721000 of 1000000" in text
    assert "time limit" in text and "--resume" in text and "`agent`" in text
    assert "| score | exit code 2 | - | - |" in text and "nominal agent 1.2" in text
    assert "| train an agent | done | 2.5 min | `agent` |" in text


def test_summary_of_a_student_names_its_rounds_and_only_the_files_it_has(tmp_path):
    run = tmp_path / "agent"
    run.mkdir()
    rounds = [{"round": k, "labels": 32000 * (k + 1)} for k in range(4)]
    session = {"rounds": rounds, "steps": 128000, "wall_s": 468.0}
    (run / "run.json").write_text(json.dumps({"seed": 0, "status": "finished", "sessions": [session]}))
    for name in ("config.yaml", "model.zip"):
        (run / name).write_text("")
    text = write_summary(tmp_path, [], datetime.now(UTC), [], run, None).read_text()
    assert "**finished** after 4 DAgger rounds, 128000 labels (468.0 s of training)" in text
    assert "`model.zip` (final)" in text and "`config.yaml`" in text
    assert "best_model" not in text and "checkpoints" not in text and "time limit" not in text


def test_summary_of_a_student_stopped_by_its_time_limit_says_it_cannot_resume(tmp_path):
    run = tmp_path / "agent"
    run.mkdir()
    session = {"rounds": [{"round": 0}, {"round": 1}], "steps": 64000, "wall_s": 910.0}
    (run / "run.json").write_text(
        json.dumps({"seed": 0, "status": "stopped_by_time_limit", "sessions": [session]})
    )
    text = write_summary(tmp_path, [], datetime.now(UTC), [], run, None).read_text()
    assert "after 2 DAgger rounds" in text and "cannot be resumed" in text and "--resume" not in text
