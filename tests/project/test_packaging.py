"""What a pip user gets: the package list, the wheel's contents, and the wheel installed in a
fresh venv, run from a directory that is not a checkout."""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

import cepam_gym

ROOT = Path(__file__).resolve().parents[2]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_every_package_of_the_tree_is_listed_in_pyproject():
    """The packages are listed by hand (the training folder is mapped to another name): a new
    subpackage of src/cepam_gym, or a new folder of data, must be added there."""
    st = PYPROJECT["tool"]["setuptools"]

    def folders(root: Path, name: str) -> set[str]:
        subs = [p.relative_to(root).parts for p in root.rglob("*") if p.is_dir() and p.name != "__pycache__"]
        return {name} | {".".join((name, *parts)) for parts in subs}

    tree = folders(ROOT / "src" / "cepam_gym", "cepam_gym") | folders(ROOT / "agents", "cepam_gym_agents")
    assert set(st["packages"]) == tree | {"cepam_gym_agents.configs"}
    assert st["package-dir"] == {
        "": "src",
        "cepam_gym_agents": "agents",
        "cepam_gym_agents.configs": "configs",
    }


def test_entry_points_name_existing_functions():
    """The plug-ins the library finds by name: each ``module:function`` exists in the source."""
    eps = PYPROJECT["project"]["entry-points"]
    assert set(eps) == {"cepam_gym.controllers", "cepam_gym.commands", "cepam_gym.registered_controllers"}
    assert set(eps["cepam_gym.commands"]) == {"run", "train", "eval", "export"}
    for group in eps.values():
        for target in group.values():
            module, _, func = target.partition(":")
            top, rest = module.split(".", 1)
            root = {"cepam_gym_agents": ROOT / "agents", "cepam_gym": ROOT / "src" / "cepam_gym"}[top]
            path = root / (rest.replace(".", "/") + ".py")
            assert f"def {func}(" in path.read_text() or f"class {func}" in path.read_text(), target


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "--no-build-isolation",
            "-q",
            "-w",
            str(out),
            str(ROOT),
        ],
        check=True,
        capture_output=True,
    )
    (whl,) = out.glob("cepam_gym-*.whl")
    return whl


@pytest.mark.slow
def test_wheel_has_no_top_level_agents_and_ships_data(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/")[0] for n in names}
    dist_info = f"cepam_gym-{cepam_gym.__version__}.dist-info"
    assert tops == {"cepam_gym", "cepam_gym_agents", dist_info}, tops
    for src in (ROOT / "agents").rglob("*.py"):
        assert f"cepam_gym_agents/{src.relative_to(ROOT / 'agents').as_posix()}" in names
    for cfg in (ROOT / "configs").glob("*.yaml"):
        assert f"cepam_gym_agents/configs/{cfg.name}" in names
    for shipped in (
        "cepam_gym/presets/balloon.yaml",
        "cepam_gym/data/reported.yaml",
        "cepam_gym/integrations/sb3.py",
        "cepam_gym/control/registry.py",
    ):
        assert shipped in names
    assert not [n for n in names if ".data/" in n]  # no data-files outside the packages
    eps = zipfile.ZipFile(wheel).read(f"{dist_info}/entry_points.txt").decode()
    assert "agent = cepam_gym_agents.policy:load_policy" in eps
    assert "train = cepam_gym_agents.train:main" in eps


def _venv_with_wheel(wheel: Path, where: Path) -> Path:
    """A fresh venv with the wheel installed; the dependencies (numpy, gymnasium, ...) come from this
    interpreter's site-packages through a .pth file (plain paths: their own .pth files, such as an
    editable install's import hooks, are not run, so the checkout stays invisible)."""
    venv = where / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    py = venv / "bin" / "python"
    site = subprocess.run(
        [str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    deps = [p for p in sys.path if p.endswith("site-packages") and Path(p).is_dir()]
    Path(site, "_deps.pth").write_text("\n".join(deps) + "\n")
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "--python",
            str(py),
            "install",
            "--no-deps",
            "--no-index",
            "-q",
            str(wheel),
        ],
        check=True,
        capture_output=True,
    )
    return venv


@pytest.mark.slow
def test_installed_wheel_runs_from_any_directory(wheel, tmp_path):
    """``pip install cepam-gym[train]`` and then, outside any checkout: the CLI, the plug-in
    commands, the packaged configs by name, the trained-agent loader; no ``agents`` package."""
    venv = _venv_with_wheel(wheel, tmp_path)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}

    def run(*args):
        return subprocess.run(list(args), cwd=elsewhere, env=env, capture_output=True, text=True, timeout=300)

    r = run(str(venv / "bin" / "cepam-gym"), "run", "--help")
    assert r.returncode == 0, r.stderr
    assert "quick" in r.stdout
    code = (
        "import importlib.util, sys, cepam_gym\n"
        f"assert cepam_gym.__file__.startswith({str(venv)!r}), cepam_gym.__file__\n"
        "assert importlib.util.find_spec('agents') is None\n"
        "from cepam_gym_agents.config.files import load_config\n"
        "cfg = load_config('quick')\n"
        "assert cfg.algorithm == 'PPO' and cfg.total_timesteps > 0\n"
        "from cepam_gym.control.registry import agent_loaders\n"
        "assert list(agent_loaders()) == ['agent']\n"
        "print('ok')\n"
    )
    r = run(str(venv / "bin" / "python"), "-c", code)
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stderr
    # the train command comes through its entry point and finds the packaged configs
    r = run(str(venv / "bin" / "cepam-gym"), "train", "--config", "no-such-config")
    assert r.returncode == 2
    assert "shipped configs" in r.stderr and "'quick'" in r.stderr


def test_cli_reaches_run_train_and_eval_only_through_entry_points(monkeypatch, capsys):
    import importlib.metadata

    from cepam_gym import cli

    monkeypatch.setattr(importlib.metadata, "entry_points", lambda **kw: [])  # no training package
    for cmd in ("run", "train", "eval", "export"):
        assert cli.main([cmd, "--help"]) == 2
        err = capsys.readouterr().err
        assert f"cepam-gym {cmd}: no package provides the command '{cmd}'" in err
        assert "pip install 'cepam-gym[train]'" in err
