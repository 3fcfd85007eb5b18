"""Commands and envs that do the obvious thing: an option error is one line, ``train --check``
runs the checks ``train`` runs, ``bench`` on a trained agent scores its own id's headline suites,
a wrong action shape is refused naming the expected one (single and vector), and the README's
first ``train`` example trains on the recommended id."""

from __future__ import annotations

import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym import versions
from cepam_gym.cli import main
from cepam_gym.errors import InputError

ROOT = Path(__file__).resolve().parents[2]


def _exit_code_and_stderr(capsys, argv) -> tuple[int, list[str]]:
    try:
        code = main(argv)
    except SystemExit as e:  # argparse exits
        code = e.code
    return code, capsys.readouterr().err.strip().splitlines()


@pytest.mark.parametrize(
    "argv",
    [
        ["bench", "--suite", "nope"],
        ["bench", "--episodes", "many"],
        ["bench", "--bogus"],
        ["train", "--bogus"],
        ["eval"],
        ["dataset", "--bogus"],
        ["identify", "--bogus"],
        ["validate", "--bogus"],
        ["rollout", "--seed", "x"],
    ],
)
def test_an_option_error_is_one_line(capsys, argv):
    if argv[0] in ("train", "eval"):
        pytest.importorskip("stable_baselines3")
    code, err = _exit_code_and_stderr(capsys, argv)
    assert code == 2, err
    assert len(err) == 1, err
    assert err[0].startswith(f"cepam-gym {argv[0]}: error: ") and "(--help shows the options)" in err[0]


def test_bench_unknown_suite_names_the_suite(capsys):
    _, err = _exit_code_and_stderr(capsys, ["bench", "--suite", "nope"])
    assert "unknown suite(s) ['nope']" in err[0] and "nominal-v2" in err[0]


def _config(tmp_path: Path, plant: str) -> Path:
    import yaml

    base = yaml.safe_load((ROOT / "configs" / "fast_ppo.yaml").read_text())
    base["env"].update(num_envs=4, kwargs={"plant": plant})
    path = tmp_path / "cfg.yaml"
    path.write_text(yaml.safe_dump(base))
    return path


@pytest.mark.parametrize(
    "plant_yaml, needle",
    [
        (None, "No such file or directory"),  # the plant file is missing
        ("preset: balloon_v2\ncpam_rest_length_cm: -19.5\n", "cpam_rest_length must be > 0"),
    ],
)
def test_train_check_runs_the_env_checks_of_train(capsys, tmp_path, plant_yaml, needle):
    pytest.importorskip("stable_baselines3")
    plant = tmp_path / "plant.yaml"
    if plant_yaml is not None:
        plant.write_text(plant_yaml)
    code, err = _exit_code_and_stderr(
        capsys, ["train", "--config", str(_config(tmp_path, str(plant))), "--check"]
    )
    assert code == 2 and len(err) == 1 and needle in err[0], err
    assert not (tmp_path / "runs").exists()


def test_train_check_passes_a_good_config_and_writes_nothing(capsys, tmp_path, monkeypatch):
    pytest.importorskip("stable_baselines3")
    monkeypatch.chdir(tmp_path)
    plant = tmp_path / "plant.yaml"
    plant.write_text("preset: balloon_v2\n")
    code, err = _exit_code_and_stderr(
        capsys, ["train", "--config", str(_config(tmp_path, str(plant))), "--check"]
    )
    assert code == 0, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cfg.yaml", "plant.yaml"]


def test_bench_scores_a_trained_agent_on_its_own_ids_headline_suites(tmp_path):
    pytest.importorskip("stable_baselines3")
    import yaml

    from cepam_gym.bench.cli import default_suites
    from cepam_gym.bench.suites import headline_suites

    run = tmp_path / "run"
    run.mkdir()
    (run / "model.zip").write_bytes(b"")  # found, never loaded: the record alone names the id
    config = yaml.safe_load((ROOT / "configs" / "fast_ppo.yaml").read_text())
    for env_id in ("cepam_gym/CEPAM-v1", "cepam_gym/CEPAMJoint-v2"):
        config["env"] = {"id": env_id, "num_envs": 4}
        config["eval"].pop("suite", None)
        (run / "config.yaml").write_text(yaml.safe_dump(config))
        assert default_suites([str(run)], None) == headline_suites(env_id)
        assert default_suites(["baseline", str(run)], None) == headline_suites(env_id)
    assert default_suites(["baseline"], None) == ["all"]
    assert set(headline_suites("cepam_gym/CEPAM-v2")) <= set(
        default_suites(["baseline"], "cepam_gym/CEPAM-v2")
    )
    with pytest.raises(InputError, match="no suite runs it"):
        default_suites(["baseline"], "cepam_gym/CEPAMLength-v0")


@pytest.mark.parametrize("shape", [(1, 2), (2, 1), (1, 1, 2), (3,), (4,), ()])
def test_a_single_env_refuses_a_wrong_action_shape(shape):
    env = gym.make(versions.RECOMMENDED_ID)
    env.reset(seed=0)
    with pytest.raises(
        InputError, match=re.escape(f"must have shape (2,) (one command per chamber), got {shape}")
    ):
        env.step(np.zeros(shape))
    env.step(np.zeros(2))  # the right one still steps
    env.close()


@pytest.mark.parametrize(
    "num_envs, shape", [(3, (3,)), (3, (2, 2)), (3, (3, 2, 1)), (3, (1, 3, 2)), (1, (2,))]
)
def test_a_vector_env_refuses_a_wrong_action_shape(num_envs, shape):
    venv = gym.make_vec(versions.RECOMMENDED_ID, num_envs=num_envs)
    venv.reset(seed=0)
    expected = f"must have shape ({num_envs}, 2) (one command per chamber), got {shape}"
    with pytest.raises(InputError, match=re.escape(expected)):
        venv.step(np.zeros(shape))
    venv.step(np.zeros((num_envs, 2)))
    venv.close()


def test_the_readmes_first_train_example_trains_on_the_recommended_id():
    from cepam_gym_agents.config.files import load_config

    readme = (ROOT / "README.md").read_text()
    name = re.search(r"cepam-gym train --config (\w+)", readme).group(1)
    cfg = load_config(name)
    assert cfg.env.id == versions.RECOMMENDED_ID, name
    assert cfg.eval.suite in versions.get(cfg.env.id).suites
    started = (ROOT / "docs" / "getting-started.md").read_text()
    assert re.search(r"cepam-gym train --config (\w+)", started).group(1) == name
