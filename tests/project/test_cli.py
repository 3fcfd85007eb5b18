"""The command line's own logic (the commands themselves are tested with their modules)."""

from __future__ import annotations

import importlib.metadata
import subprocess
import sys

import pytest

from cepam_gym import cli


def test_help_lists_commands_and_unknown_command_fails():
    ok = subprocess.run([sys.executable, "-m", "cepam_gym.cli", "--help"], capture_output=True, text=True)
    assert ok.returncode == 0
    for cmd in ("run", "bench", "train", "eval", "validate", "calibrate", "identify", "excite", "video"):
        assert cmd in ok.stdout
    bad = subprocess.run([sys.executable, "-m", "cepam_gym.cli", "fly"], capture_output=True, text=True)
    assert bad.returncode == 2 and "fly" in bad.stderr


class _EntryPoint:
    """An installed plug-in as ``importlib.metadata`` gives it: ``load()`` returns its function."""

    def __init__(self, load):
        self.load = load


@pytest.mark.parametrize("cmd", ["run", "train", "eval", "export"])
def test_the_training_packages_commands_are_dispatched_to_its_entry_points(cmd, monkeypatch):
    calls = []
    found = {}

    def entry_points(group, name):
        found[name] = group
        return [_EntryPoint(lambda: lambda argv: calls.append(argv) or 7)]

    monkeypatch.setattr(importlib.metadata, "entry_points", entry_points)
    assert cli.main([cmd, "--out-dir", "x"]) == 7
    assert calls == [["--out-dir", "x"]] and found == {cmd: cli.PLUGIN_GROUP}


def test_a_plugin_that_cannot_be_loaded_names_the_extra_in_one_line(monkeypatch, capsys):
    def load():
        raise ModuleNotFoundError("No module named 'stable_baselines3'")

    monkeypatch.setattr(importlib.metadata, "entry_points", lambda group, name: [_EntryPoint(load)])
    assert cli.main(["run"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cepam-gym run: the command 'run' cannot be loaded")
    assert "stable_baselines3" in err and "pip install 'cepam-gym[train]'" in err
    assert err.strip().count("\n") == 0
