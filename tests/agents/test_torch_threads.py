"""torch's thread count in training (``torch_threads``: an integer or ``auto``): the config reads
it, the gradient steps run on the chosen count, the numbers do not depend on it, and a model of a
class with the chooser mixed in saves and loads as the plain algorithm's."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
torch = pytest.importorskip("torch")

from cepam_gym_agents.config.files import ConfigError, TrainConfig, load_config  # noqa: E402
from cepam_gym_agents.session.torch_threads import (  # noqa: E402
    ChosenThreadsTrain,
    TorchThreads,
    inference_threads,
    with_chosen_threads,
)

BASE = {"algorithm": "PPO", "env": {"id": "cepam_gym/CEPAMLength-v2", "num_envs": 2}}


@pytest.mark.parametrize("value, expected", [("auto", "auto"), (2, 2), ("1", 1)])
def test_the_config_reads_an_integer_or_auto(value, expected):
    assert TrainConfig.from_dict({**BASE, "torch_threads": value}).torch_threads == expected


@pytest.mark.parametrize("value", [0, "many", 1.5, True])
def test_a_bad_thread_count_is_one_line_naming_the_key(value):
    with pytest.raises(ConfigError, match=r"torch_threads must be .*'auto'"):
        TrainConfig.from_dict({**BASE, "torch_threads": value})


def test_fixed_threads_are_applied_and_auto_starts_serial():
    before = torch.get_num_threads()
    try:
        t = TorchThreads(2)
        assert torch.get_num_threads() == 2 and t.run(lambda: 7) == 7 and t.now() == 2
        auto = TorchThreads("auto")
        assert torch.get_num_threads() == 1 == auto.now()  # serial first (the env's rule)
        seen = []
        for _ in range(40):
            auto.run(lambda: seen.append(torch.get_num_threads()))
            assert torch.get_num_threads() == auto.now()  # between calls: the best count so far
        assert set(seen) <= {1, 2} and auto.choice.trials >= 1
    finally:
        torch.set_num_threads(before)
    assert inference_threads("auto") == 1 and inference_threads(3) == 3


def test_the_chooser_keeps_the_class_name_and_is_not_saved(tmp_path):
    from stable_baselines3 import PPO

    from cepam_gym_agents.learners.algorithm import training_class

    cls = training_class("PPO")
    assert issubclass(cls, ChosenThreadsTrain) and issubclass(cls, PPO) and cls.__name__ == "PPO"
    assert with_chosen_threads(cls) is cls
    import gymnasium as gym

    model = cls("MlpPolicy", gym.make("cepam_gym/CEPAMLength-v2"), n_steps=16, batch_size=16, device="cpu")
    model.torch_threads = TorchThreads("auto")
    model.learn(32)  # two train() calls through the chooser
    model.save(tmp_path / "m")
    loaded = PPO.load(tmp_path / "m", device="cpu")  # loads as the plain algorithm
    assert not hasattr(loaded, "torch_threads")
    for a, b in zip(model.policy.parameters(), loaded.policy.parameters(), strict=True):
        assert torch.equal(a, b)


@pytest.mark.parametrize("config", ["fast_ppo_v3", "student_v3"])
def test_the_shipped_networks_compute_the_same_numbers_on_one_and_two_threads(config):
    """What lets ``auto`` switch counts mid-run without changing a run's numbers beyond float32
    rounding: the forward and backward passes of the config's network (a minibatch of its size)
    agree to 1e-4 relative (bit for bit on the AMD CPUs measured; on an Intel Emerald Rapids
    fast_ppo_v3's differ by up to 2e-5 relative, a few units of float32's last place)."""
    cfg = load_config(config)
    arch = cfg.student.net_arch if cfg.student is not None else cfg.policy_kwargs["net_arch"]
    width = [24, *arch, 2]
    torch.manual_seed(0)
    layers = []
    for i, o in zip(width[:-1], width[1:], strict=True):
        layers += [torch.nn.Linear(i, o), torch.nn.ReLU()]
    net = torch.nn.Sequential(*layers[:-1])
    batch = int(cfg.student.batch_size if cfg.student is not None else cfg.hyperparameters["batch_size"])
    x = torch.randn(batch, width[0])
    before, out = torch.get_num_threads(), []
    try:
        for count in (1, 2):
            torch.set_num_threads(count)
            net.zero_grad()
            y = net(x)
            (y**2).mean().backward()
            out.append([y.detach().clone(), *(p.grad.clone() for p in net.parameters())])
    finally:
        torch.set_num_threads(before)
    for a, b in zip(*out, strict=True):
        np.testing.assert_allclose(a.numpy(), b.numpy(), rtol=1e-4, atol=1e-9)


def test_configs_on_two_threads_choose_them():
    """A shipped config either fixes one thread (two runs share the cores) or chooses: a fixed
    2 is what collapses beside a second busy process."""
    from pathlib import Path

    import yaml

    for path in sorted((Path(__file__).resolve().parents[2] / "configs").glob("*.yaml")):
        value = yaml.safe_load(path.read_text()).get("torch_threads", 1)
        assert value in (1, "auto"), f"{path.name}: torch_threads {json.dumps(value)}"
