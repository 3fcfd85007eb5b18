"""The README's code examples run as written (in a fresh interpreter, from the repository)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)


def test_readme_has_the_quick_example_first():
    blocks = python_blocks()
    assert blocks and 'gym.make("cepam_gym/CEPAM-v1")' in blocks[0]  # the current id first
    assert len(blocks[0].strip().splitlines()) <= 12  # "a ten-line example"


@pytest.mark.parametrize(
    "index",
    [
        pytest.param(i, marks=pytest.mark.slow) if ".learn(" in block else i
        for i, block in enumerate(python_blocks())
    ],
)  # training: slow
def test_readme_python_block_runs(index):
    code = python_blocks()[index]
    if "stable_baselines3" in code:
        pytest.importorskip("stable_baselines3")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert out.returncode == 0, out.stderr[-3000:]
    if index == 0:
        assert "'length'" in out.stdout and "'reward_length'" in out.stdout  # it printed the info
