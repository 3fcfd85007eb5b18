"""The README's code examples run as written (in a fresh interpreter, from the repository); the
README stays a front door: at most 15 KB, the two commands first, every link resolving."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from cepam_gym import RECOMMENDED_ID

ROOT = Path(__file__).resolve().parents[2]


def python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)


def test_readme_has_the_quick_example_first():
    blocks = python_blocks()
    assert blocks and f'gym.make("{RECOMMENDED_ID}")' in blocks[0]  # the recommended id first
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


def test_readme_is_a_front_door():
    text = (ROOT / "README.md").read_text()
    assert len(text.encode()) <= 15_000, f"README.md is {len(text.encode())} bytes, at most 15 KB"
    first_block = re.search(r"```bash\n(.*?)```", text, flags=re.S).group(1).splitlines()
    assert first_block[0].startswith("make run") and first_block[1].startswith("make test")
    assert text.index("```bash") < text.index("## ")  # the commands come before any section


def test_readme_links_resolve():
    text = (ROOT / "README.md").read_text()
    links = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", text)
    local = [link for link in links if "://" not in link]
    assert local, "the README links to the docs"
    missing = [link for link in local if not (ROOT / link).exists()]
    # pages the docs build generates (envs/, configs.md, changelog.md) have no file in docs/
    generated = [link for link in missing if link.startswith("docs/envs/")]
    assert missing == generated, f"README links to missing files: {sorted(set(missing) - set(generated))}"
