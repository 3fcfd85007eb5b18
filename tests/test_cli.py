"""The command line's own logic (the commands themselves are tested with their modules)."""

from __future__ import annotations

import subprocess
import sys

from cepam_gym.cli import fresh_dir


def test_main_job_never_reuses_a_run_directory(tmp_path):
    first = fresh_dir(tmp_path / "agent")
    assert first == tmp_path / "agent"
    first.mkdir()
    second = fresh_dir(tmp_path / "agent")
    assert second == tmp_path / "agent-2"
    second.mkdir()
    assert fresh_dir(tmp_path / "agent") == tmp_path / "agent-3"


def test_help_lists_commands_and_unknown_command_fails():
    ok = subprocess.run([sys.executable, "-m", "cepam_gym.cli", "--help"], capture_output=True, text=True)
    assert ok.returncode == 0
    for cmd in ("run", "bench", "train", "eval", "validate", "calibrate", "video"):
        assert cmd in ok.stdout
    bad = subprocess.run([sys.executable, "-m", "cepam_gym.cli", "fly"], capture_output=True, text=True)
    assert bad.returncode == 2 and "fly" in bad.stderr


def test_wheel_ships_presets_paper_data_and_training_configs(tmp_path):
    """A pip-installed user (no source tree) still has the presets, the paper's numbers and the
    training configs (`cepam-gym train --config quick`): they are in the wheel."""
    import zipfile
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                    "-w", str(tmp_path), str(root)], check=True, capture_output=True)
    (wheel,) = tmp_path.glob("cepam_gym-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    for cfg in (root / "configs").glob("*.yaml"):
        assert any(n.endswith(f".data/data/share/cepam-gym/configs/{cfg.name}") for n in names), cfg.name
    for shipped in ("cepam_gym/presets/balloon.yaml", "cepam_gym/data/reported.yaml", "agents/config.py"):
        assert shipped in names


def test_config_dir_falls_back_to_the_installed_data_files(monkeypatch, tmp_path):
    import agents.config as c

    monkeypatch.setattr(c, "__file__", str(tmp_path / "site-packages" / "agents" / "config.py"))
    monkeypatch.setattr(sys, "prefix", str(tmp_path / "venv"))
    assert c._shipped_config_dir() == tmp_path / "venv" / "share" / "cepam-gym" / "configs"
