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
    for cmd in ("run", "bench", "train", "eval", "validate", "calibrate", "identify", "excite", "video"):
        assert cmd in ok.stdout
    bad = subprocess.run([sys.executable, "-m", "cepam_gym.cli", "fly"], capture_output=True, text=True)
    assert bad.returncode == 2 and "fly" in bad.stderr
