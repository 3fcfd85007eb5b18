"""A grid's trials as Ray tasks (``compare --ray``, agents/grid/trials.py): each trial's run is the same
seed's run trained here as a plain process. Runs where Ray is installed (``.venv-ray``; the main
venv skips it)."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest
import yaml

ray = pytest.importorskip("ray")
pytest.importorskip("stable_baselines3")
pytestmark = pytest.mark.train

CONFIG = {
    "algorithm": "PPO",
    "learner": "native",
    "total_timesteps": 2048,
    "seed": 0,
    "torch_threads": 1,
    "env": {"id": "cepam_gym/CEPAMLength-v3", "num_envs": 8, "kwargs": {"max_episode_steps": 40}},
    "normalize": {"obs": True, "reward": True},
    "hyperparameters": {"n_steps": 64, "batch_size": 256, "n_epochs": 2},
    "policy_kwargs": {"net_arch": [16, 16]},
    "eval": {"every_steps": 100000, "episodes": 2},
    "checkpoint": {"every_steps": 100000},
}


def test_a_ray_trial_is_the_same_seeds_local_run(tmp_path):
    from cepam_gym_agents.grid.trials import Trial, run_local, run_ray

    config = tmp_path / "tiny.yaml"
    config.write_text(yaml.safe_dump(CONFIG))
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        run_ray([Trial(str(config), s, tmp_path / f"ray-s{s}") for s in (0, 1)], None, 1)
    finally:
        ray.shutdown()
    run_local([Trial(str(config), 1, tmp_path / "local-s1")], jobs=1)
    import torch

    def params(run):
        with zipfile.ZipFile(run / "model.zip") as z, z.open("policy.pth") as f:
            return torch.load(f, map_location="cpu", weights_only=True)

    a, b, other = params(tmp_path / "ray-s1"), params(tmp_path / "local-s1"), params(tmp_path / "ray-s0")
    assert a.keys() == b.keys()
    for k in a:
        np.testing.assert_array_equal(a[k].numpy(), b[k].numpy(), err_msg=k)
    assert any(not np.array_equal(a[k].numpy(), other[k].numpy()) for k in a)  # the seed matters
    assert (tmp_path / "ray-s0.log").is_file() and (tmp_path / "ray-s1" / "summary.json").is_file()


def test_time_to_score_trains_its_seeds_as_ray_tasks(tmp_path):
    """``benchmarks/time_to_score.py --ray local``: each seed a Ray task on the whole node, its
    evaluations read back into the same report as a local run's."""
    import importlib.util
    import json
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    spec = importlib.util.spec_from_file_location("time_to_score", root / "benchmarks" / "time_to_score.py")
    tts = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tts)
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        tts.main(
            ["--ids", "CEPAMLength-v3", "--seeds", "2", "--config", "fast_ppo_v3", "--budget-s", "4"]
            + [
                "--eval-every",
                "16384",
                "--out",
                str(tmp_path),
                "--json",
                str(tmp_path / "r.json"),
                "--ray",
                "local",
            ]
        )
    finally:
        ray.shutdown()
    (r,) = json.loads((tmp_path / "r.json").read_text()).values()
    assert r["config"] == "fast_ppo_v3" and len(r["runs"]) == 2 and all(run for run in r["runs"])
    for seed in (0, 1):
        run = tmp_path / "CEPAMLength-v3" / f"seed{seed}"
        assert json.loads((run / "run.json").read_text())["seed"] == seed
        assert json.loads((run / "evaluations.json").read_text()) == r["runs"][seed]
    assert tts.report({"CEPAMLength-v3": r}).count("CEPAMLength-v3") == 1
