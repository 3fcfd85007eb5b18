"""Every fenced command of the README and the docs, read by Sybil: each Python block runs (in its
page's namespace, from a scratch directory), unless a ``<!-- skip: next "why, and how long" -->``
above it says why not; each shell block carries a mark on the line above it, either
``<!-- shell: runs as "COMMANDS" -->`` (the test runs COMMANDS, the block in a shortened form, with
the venv's commands first on the PATH) or ``<!-- shell: not run: WHY, measured TIME -->``."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import unittest
from pathlib import Path

import pytest
from sybil import Sybil
from sybil.parsers.markdown import CodeBlockParser, PythonCodeBlockParser, SkipParser

ROOT = Path(__file__).resolve().parents[2]
# pages whose shell blocks need not all be marked (read for their Python blocks only): none
SHELL_UNMARKED: set[str] = set()
PAGES = sorted(
    str(p.relative_to(ROOT)) for p in [ROOT / "README.md", *(ROOT / "docs").rglob("*.md")] if p.is_file()
)
MARK = re.compile(r"<!-- shell: (runs as \"(?P<run>.+?)\"|not run: (?P<why>.+?)) -->[ \t]*$", re.M)
SHELL = "shell"


def _mark(example) -> re.Match | None:
    before = example.document.text[: example.start].rstrip("\n").rsplit("\n", 1)[-1]
    return MARK.search(before)


def _shell(example):
    """The shell block's mark; the block is not run here (its shortened form is, below)."""
    example.namespace.setdefault(SHELL, []).append((example.line, _mark(example)))


SYBIL = Sybil(
    parsers=[
        PythonCodeBlockParser(),
        SkipParser(),
        CodeBlockParser(language="bash", evaluator=_shell),
    ],
    path=str(ROOT),
)


def _examples(page: str) -> list:
    return list(SYBIL.parse(ROOT / page))


@pytest.mark.parametrize("page", [p for p in PAGES if any(True for _ in _examples(p))])
def test_the_pages_python_blocks_run_and_shell_blocks_are_marked(page, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    skipped, shells = [], []
    for example in _examples(page):
        try:
            example.evaluate()
        except unittest.SkipTest as e:
            skipped.append(f"line {example.line}: {e}")
        shells = example.namespace.get(SHELL, shells)
    for reason in skipped:  # a skipped block says why, and how long it takes or where it runs
        assert re.search(r"\d+ (s|min)\b| runs it\b", reason), f"{page} {reason}: state the measured time"
    if page not in SHELL_UNMARKED:
        unmarked = [line for line, mark in shells if mark is None]
        assert not unmarked, f"{page}: shell blocks at lines {unmarked} carry no <!-- shell: ... --> mark"
        for _, mark in shells:
            if mark["why"] is not None:
                assert re.search(r"measured .*\d+ (s|min)\b", mark["why"]), mark["why"]


def _shortened_forms() -> list:
    out = []
    for page in PAGES:
        text = (ROOT / page).read_text()
        out += [pytest.param(m["run"], id=f"{page}:{m['run'][:40]}") for m in MARK.finditer(text) if m["run"]]
    return out


@pytest.mark.parametrize("commands", _shortened_forms())
def test_a_shell_blocks_shortened_form_runs(commands, tmp_path):
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    out = subprocess.run(
        ["bash", "-euo", "pipefail", "-c", commands],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stderr[-3000:]
