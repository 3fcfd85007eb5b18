"""Behaviour cloning from a dataset of ``cepam-gym dataset`` (agents/bc.py): it fits, it is scored
with the dataset's normalization, and its run directory is a controller like any trained agent."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("minari", reason="the [offline] extra (minari) is not installed")
pytestmark = pytest.mark.train

from cepam_gym.bench import references  # noqa: E402
from cepam_gym.bench.harness import run_suite  # noqa: E402
from cepam_gym.bench.headline import headline_score  # noqa: E402
from cepam_gym.bench.metrics import normalized_score  # noqa: E402
from cepam_gym.bench.suites import SUITES  # noqa: E402
from cepam_gym.control import make_controller  # noqa: E402
from cepam_gym.errors import InputError  # noqa: E402
from cepam_gym.offline import record_dataset  # noqa: E402
from cepam_gym_agents import bc  # noqa: E402
from cepam_gym_agents.learners.bc_policy import BCPolicy, load_bc_policy  # noqa: E402

NOMINAL = "nominal-v1"


@pytest.fixture
def baseline_dataset(tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "datasets"))
    return record_dataset(NOMINAL, "baseline", 4, max_steps=60)["dataset_id"]


def test_bc_trains_scores_and_loads_as_a_controller(baseline_dataset, tmp_path, capsys):
    out = tmp_path / "bc-base"
    assert (
        bc.main(["--dataset", baseline_dataset, "--out", str(out), "--epochs", "15", "--hidden", "32", "32"])
        == 0
    )
    printed = capsys.readouterr().out.strip().splitlines()
    assert printed[-1].startswith(f"wrote {out}")
    info = json.loads((out / "bc.json").read_text())
    # 4 episodes: 3 to train on, 1 to pick the epoch on; the fit improves
    assert (info["train_episodes"], info["val_episodes"], info["train_samples"]) == (3, 1, 180)
    assert info["train_loss"][-1] < 0.5 * info["train_loss"][0]
    assert 1 <= info["best_epoch"] <= 15 and info["val_loss"][info["best_epoch"] - 1] == min(info["val_loss"])
    # scored on the suite's 20 episodes, its headline and normalized scores as the benchmark's
    zero, oracle = SUITES[NOMINAL].reference
    assert info["normalized"] == pytest.approx(normalized_score(info["score"], zero, oracle), rel=1e-12)
    baseline = references.load()[NOMINAL]["baseline"]
    assert info["headline"] == pytest.approx(headline_score(info["score"], baseline, oracle), rel=1e-12)
    # the run directory is a controller: the bench (entry-point loader) scores it the same
    venv = gym.make_vec(SUITES[NOMINAL].env_id, num_envs=3, **SUITES[NOMINAL].env_kwargs)
    policy = make_controller(str(out), venv)
    assert isinstance(policy, BCPolicy)
    obs, _ = venv.reset(seed=0)
    a = policy.act(obs)
    assert a.shape == (3, 2) and np.all(np.abs(a) <= 1) and policy.act(obs[0]).shape == (2,)
    metrics, _ = run_suite(str(out), NOMINAL)
    assert metrics["score"] == info["score"]
    # and a trained run records a dataset of its own, named by its folder
    rec = record_dataset(NOMINAL, str(out), 1, max_steps=3)
    assert rec["dataset_id"] == "cepam/CEPAM-v1/nominal-bc-base-v0" and rec["steps"] == 3


def test_bc_refuses_a_wrong_env_and_an_unknown_dataset(baseline_dataset, tmp_path):
    out = tmp_path / "bc"
    assert bc.main(["--dataset", baseline_dataset, "--out", str(out), "--epochs", "1", "--no-score"]) == 0
    assert "score" not in json.loads((out / "bc.json").read_text())
    other = gym.make("cepam_gym/CEPAMLength-v1")  # fewer observation columns than CEPAM-v1
    with pytest.raises(InputError, match="wrong env for this policy"):
        load_bc_policy(out, other)
    with pytest.raises(InputError, match="cannot load dataset 'cepam/CEPAM-v1/nope-v0'"):
        bc.main(["--dataset", "cepam/CEPAM-v1/nope-v0", "--out", str(tmp_path / "x")])
    with pytest.raises(InputError, match="--val-fraction"):
        bc.main(["--dataset", baseline_dataset, "--out", str(tmp_path / "x"), "--val-fraction", "1"])
