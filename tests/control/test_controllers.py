"""The controller registry: names, the joint variants, trained agents through entry points."""

from __future__ import annotations

import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym.control import (
    Controller,
    InverseStaticController,
    RandomController,
    ZeroController,
    controller_names,
    is_joint_env,
    make_controller,
    register_controller,
    registry,
)


@pytest.fixture
def venv():
    v = gym.make_vec("cepam_gym/CEPAM-v0", num_envs=3)
    yield v
    v.close()


@pytest.fixture
def clean_registry(monkeypatch):
    monkeypatch.setattr(registry, "CONTROLLERS", dict(registry.CONTROLLERS))
    monkeypatch.setattr(registry, "JOINT_VARIANTS", dict(registry.JOINT_VARIANTS))


def test_registered_names():
    assert {"zero", "random", "baseline", "joint_baseline"} <= set(controller_names())
    assert controller_names() == sorted(controller_names())


@pytest.mark.parametrize(
    "name, cls",
    [("zero", ZeroController), ("random", RandomController), ("baseline", InverseStaticController)],
)
def test_names_build_their_controller_on_the_rig(venv, name, cls):
    ctl = make_controller(name, venv)
    assert type(ctl) is cls and isinstance(ctl, Controller)
    obs, info = venv.reset(seed=0)
    ctl.reset()
    a = ctl.act(obs, info)
    assert a.shape == (3, 2) and a.dtype == np.float32 and np.all(np.abs(a) <= 1)
    ctl.reset(np.array([1]))  # one episode restarts
    assert ctl.act(obs, info).shape == (3, 2)
    ctl.reset()
    assert ctl.act(obs[0]).shape == (2,)  # a single env's observation


def test_zero_sends_zeros_and_random_is_seeded(venv):
    obs, _ = venv.reset(seed=0)
    assert not make_controller("zero", venv).act(obs).any()
    a, b = make_controller("random", venv).act(obs), make_controller("random", venv).act(obs)
    np.testing.assert_array_equal(a, b)  # seed 0 by default
    assert not np.array_equal(a, make_controller("random", venv, seed=1).act(obs))


def test_action_size_follows_the_env():
    class Env:  # any env with a Box action space of size 3
        action_space = gym.spaces.Box(-1, 1, (3,))

    assert ZeroController(Env()).act(np.zeros((4, 7))).shape == (4, 3)
    assert RandomController(Env()).act(np.zeros(7)).shape == (3,)


def test_unknown_name_lists_the_registered_ones(venv):
    with pytest.raises(ValueError, match="unknown controller 'pid-from-mars'") as e:
        make_controller("pid-from-mars", venv)
    for name in ("zero", "random", "baseline", "joint_baseline"):
        assert name in str(e.value)


def test_joint_variant_refused_on_the_rig(venv):
    with pytest.raises(ValueError, match="joint env .* only; on this env use 'baseline'"):
        make_controller("joint_baseline", venv)


def test_register_a_controller(clean_registry, venv):
    built = []

    def factory(env, gain=1.0):
        built.append(gain)
        return ZeroController(env)

    register_controller("mine", factory)
    assert "mine" in controller_names()
    make_controller("mine", venv, gain=2.0)
    assert built == [2.0]
    register_controller("lazy", "cepam_gym.control.trivial:RandomController")
    assert type(make_controller("lazy", venv)) is RandomController
    with pytest.raises(ValueError, match="already registered"):
        register_controller("mine", factory)
    with pytest.raises(ValueError, match="without ':'"):
        register_controller("a:b", factory)
    with pytest.raises(TypeError, match="module:attr"):
        register_controller("other", "not a path")


class _EntryPoint:
    def __init__(self, fn):
        self.fn = fn

    def load(self):
        return self.fn


def test_trained_agents_go_to_the_installed_loader(monkeypatch, venv, tmp_path):
    calls = []

    def loader(spec, env):
        calls.append(spec)
        return ZeroController(env)

    monkeypatch.setattr(registry, "agent_loaders", lambda: {"agent": _EntryPoint(loader)})
    run = tmp_path / "run"
    run.mkdir()
    assert isinstance(make_controller(str(run), venv), ZeroController)
    assert isinstance(make_controller(run, venv), ZeroController)  # a Path works too
    assert isinstance(make_controller("agent:hub-id/model", venv), ZeroController)  # LOADER:SPEC
    assert calls == [str(run), str(run), "hub-id/model"]
    with pytest.raises(ValueError, match="not an existing path"):
        make_controller(str(tmp_path / "missing"), venv)


def test_without_a_loader_the_error_says_what_to_install(monkeypatch, venv, tmp_path):
    monkeypatch.setattr(registry, "agent_loaders", lambda: {})
    with pytest.raises(ValueError, match=r"cepam-gym\[train\]"):
        make_controller(str(tmp_path), venv)


def test_the_installed_distribution_declares_the_agent_loader():
    """The training package's loader is found through the package metadata (pyproject.toml's
    entry points), not through an import in cepam_gym."""
    eps = registry.agent_loaders()
    if "agent" not in eps:
        pytest.skip("cepam-gym is not installed with its current metadata (pip install -e .)")
    assert eps["agent"].value == "cepam_gym_agents.policy:load_policy"


def test_rig_envs_are_told_apart_without_importing_mujoco():
    code = (
        "import sys; sys.modules['mujoco'] = None  # as if not installed\n"
        "import gymnasium as gym, cepam_gym\n"
        "from cepam_gym.control import make_controller, InverseStaticController\n"
        "env = gym.make('cepam_gym/CEPAM-v0')\n"
        "assert type(make_controller('baseline', env)) is InverseStaticController\n"
        "assert 'cepam_gym.envs.joint_mujoco' not in sys.modules\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr


def test_joint_env_gets_the_joint_variants(monkeypatch, tmp_path):
    pytest.importorskip("mujoco")
    from cepam_gym.control.joint_baseline import JointInverseStaticController

    env = gym.make("cepam_gym/CEPAMJoint-v0")
    venv = gym.make_vec("cepam_gym/CEPAMJoint-v0", num_envs=2)
    try:
        for e in (env, venv, env.unwrapped):
            assert is_joint_env(e)
            assert type(make_controller("baseline", e)) is JointInverseStaticController
        assert type(make_controller("zero", venv)) is ZeroController  # no variant: the same one
        obs, info = venv.reset(seed=0)
        ctl = make_controller("baseline", venv)
        ctl.reset()
        assert ctl.act(obs, info).shape == (2, 2)
        monkeypatch.setattr(registry, "agent_loaders", lambda: {"agent": _EntryPoint(lambda spec, e: None)})
        with pytest.raises(ValueError, match="cannot drive the MuJoCo joint env"):
            make_controller(str(tmp_path), env)
    finally:
        env.close()
        venv.close()


def test_commands_check_the_controller_before_any_work(monkeypatch, tmp_path, capsys):
    from cepam_gym.bench import cli as bench_cli
    from cepam_gym.control import check_controller_spec

    monkeypatch.setattr(registry, "agent_loaders", lambda: {"agent": _EntryPoint(lambda spec, e: None)})
    check_controller_spec("baseline")
    check_controller_spec(tmp_path)  # an existing run directory goes to the loader
    with pytest.raises(ValueError, match="unknown controller 'pid'"):
        check_controller_spec("pid")
    with pytest.raises(ValueError, match="unknown controller 'pid'.*baseline"):
        bench_cli.main(["--controller", "pid", "--suite", "nominal", "--out-dir", str(tmp_path / "b")])
    assert not (tmp_path / "b").exists()  # refused before any work (the CLI prints it as one line)
