"""Every user error of the command line is one line on stderr naming the problem, exit code 2,
no traceback; ``--debug`` shows the traceback. Corrupted files are made here: truncated and random
zips, a garbage pickle, broken YAML and JSON."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from cepam_gym.cli import main

ROOT = Path(__file__).resolve().parents[2]


def _one_line_error(capsys, argv, *needles):
    code = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2, err
    assert len(err) == 1 and "Traceback" not in err[0], err
    assert err[0].startswith(f"cepam-gym {argv[0]}: error: "), err
    for n in needles:
        assert str(n) in err[0], (n, err)
    return err[0]


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """A run directory with a real (untrained) model, its normalizer and a checkpoint index."""
    pytest.importorskip("stable_baselines3")
    import yaml
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    from cepam_gym_agents.config.files import dump_config, load_config
    from cepam_gym_agents.train import make_train_env

    run = tmp_path_factory.mktemp("run")
    cfg = load_config(str(ROOT / "configs" / "quick.yaml"))
    cfg = cfg.replace(env=cfg.env.__class__(**{**cfg.env.__dict__, "num_envs": 2}))
    dump_config(cfg, run / "config.yaml")
    env = VecNormalize(make_train_env(cfg, 0))
    model = PPO("MlpPolicy", env, n_steps=8, batch_size=8, device="cpu")
    model.save(str(run / "best_model.zip"))
    env.save(str(run / "best_vecnormalize.pkl"))
    (run / "checkpoints").mkdir()
    model.save(str(run / "checkpoints" / "model_8.zip"))
    env.save(str(run / "checkpoints" / "vecnormalize_8.pkl"))
    (run / "checkpoints" / "latest.json").write_text(
        json.dumps(
            {"steps": 8, "model": "checkpoints/model_8.zip", "vecnormalize": "checkpoints/vecnormalize_8.pkl"}
        )
    )
    assert yaml.safe_load((run / "config.yaml").read_text())["algorithm"] == "PPO"
    return run


def _copy(run: Path, tmp_path: Path) -> Path:
    import shutil

    dst = tmp_path / "copy"
    shutil.copytree(run, dst)
    return dst


def test_version(capsys):
    assert main(["--version"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("cepam-gym ") and len(out.split()) >= 2


@pytest.mark.parametrize("corrupt", ["truncated_zip", "random_zip", "garbage_pickle", "broken_yaml"])
def test_eval_on_corrupted_run_files(capsys, run_dir, tmp_path, corrupt):
    run = _copy(run_dir, tmp_path)
    if corrupt == "truncated_zip":
        data = (run / "best_model.zip").read_bytes()
        (run / "best_model.zip").write_bytes(data[: len(data) // 2])
        needles = ("best_model.zip", "cannot load the PPO model")
    elif corrupt == "random_zip":
        (run / "best_model.zip").write_bytes(bytes(range(256)) * 8)
        needles = ("best_model.zip",)
    elif corrupt == "garbage_pickle":
        (run / "best_vecnormalize.pkl").write_bytes(b"\x80\x04garbage not a pickle")
        needles = ("best_vecnormalize.pkl", "observation normalizer")
    else:
        (run / "config.yaml").write_text("algorithm: [PPO\n")
        needles = ("config.yaml",)
    _one_line_error(
        capsys,
        ["eval", "--run", str(run), "--suite", "nominal", "--episodes", "1", "--no-baseline"],
        *needles,
    )
    # the benchmark reads the same files
    _one_line_error(
        capsys, ["bench", "--controller", str(run), "--suite", "nominal", "--episodes", "1"], *needles
    )


def test_resume_on_broken_checkpoint_index(capsys, run_dir, tmp_path):
    run = _copy(run_dir, tmp_path)
    (run / "checkpoints" / "latest.json").write_text('{"steps": 8, "model": ')
    _one_line_error(capsys, ["train", "--out", str(run), "--resume", "--quiet"], "latest.json")


def test_train_bad_config_env_kwargs_and_hyperparameters(capsys, tmp_path):
    import yaml

    base = yaml.safe_load((ROOT / "configs" / "quick.yaml").read_text())

    def cfg(name, **changes):
        d = json.loads(json.dumps(base))
        for path, value in changes.items():
            node = d
            *head, last = path.split(".")
            for k in head:
                node = node.setdefault(k, {})
            node[last] = value
        p = tmp_path / f"{name}.yaml"
        p.write_text(yaml.safe_dump(d))
        return p

    broken = tmp_path / "broken.yaml"
    broken.write_text("algorithm: [\n")
    _one_line_error(capsys, ["train", "--config", str(broken), "--out", str(tmp_path / "a")], "broken.yaml")
    _one_line_error(
        capsys,
        [
            "train",
            "--config",
            str(cfg("k", **{"env.kwargs.control_dt": 20})),
            "--out",
            str(tmp_path / "b"),
            "--quiet",
        ],
        "control_dt is in seconds",
    )
    _one_line_error(
        capsys,
        [
            "train",
            "--config",
            str(cfg("r", **{"env.kwargs.randomize": {"nope_kpa": [1, 2]}})),
            "--out",
            str(tmp_path / "c"),
            "--quiet",
        ],
        "nope_kpa",
    )
    _one_line_error(
        capsys,
        [
            "train",
            "--config",
            str(cfg("h", **{"hyperparameters.batch_size": 0})),
            "--out",
            str(tmp_path / "d"),
            "--quiet",
        ],
        "batch_size",
    )
    _one_line_error(
        capsys,
        [
            "train",
            "--config",
            str(cfg("u", **{"hyperparameters.bogus": 1})),
            "--out",
            str(tmp_path / "e"),
            "--quiet",
        ],
        "bogus",
    )
    _one_line_error(capsys, ["train", "--config", str(tmp_path / "missing.yaml")], "missing.yaml")


def test_unknown_controller_and_missing_files(capsys, tmp_path):
    _one_line_error(
        capsys,
        ["bench", "--controller", "nosuch", "--suite", "nominal", "--episodes", "1"],
        "unknown controller 'nosuch'",
    )
    _one_line_error(
        capsys, ["calibrate", "--data", str(tmp_path / "gone.csv"), "--out", str(tmp_path / "o")], "gone.csv"
    )


def test_calibrate_value_errors_are_one_line(capsys, tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("nonsense_column\n1\n")
    _one_line_error(capsys, ["calibrate", "--data", str(bad), "--out", str(tmp_path / "o")], "bad.csv")


def test_debug_shows_the_traceback(tmp_path):
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "cepam_gym.cli",
            "bench",
            "--controller",
            "nosuch",
            "--suite",
            "nominal",
            "--episodes",
            "1",
            "--debug",
        ],
        capture_output=True,
        text=True,
    )
    assert r.returncode != 0 and "Traceback" in r.stderr and "unknown controller" in r.stderr
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "cepam_gym.cli",
            "bench",
            "--controller",
            "nosuch",
            "--suite",
            "nominal",
            "--episodes",
            "1",
        ],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
