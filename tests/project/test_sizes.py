"""Small files and short functions: no module of the library or of the training code over 400
lines, no function over 80, but the command lines' entry functions (``main``, ``*_main``: an
argument parser and its dispatch, read top to bottom)."""

from __future__ import annotations

import ast
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FOLDERS = (ROOT / "src" / "cepam_gym", ROOT / "agents")
MAX_FILE_LINES = 400
MAX_FUNCTION_LINES = 80
# generated code (envs/step_source writes it), held to its generator instead
GENERATED = {"_reward_builtin.py"}


def _modules():
    for folder in FOLDERS:
        yield from (p for p in sorted(folder.rglob("*.py")) if p.name not in GENERATED)


def _is_command_line_entry(name: str) -> bool:
    return name == "main" or name.endswith("_main")


def test_no_module_is_over_400_lines():
    long = {
        str(p.relative_to(ROOT)): n for p in _modules() if (n := p.read_text().count("\n")) > MAX_FILE_LINES
    }
    assert not long, f"split these modules (lines): {long}"


def _long_functions(text: str) -> dict[str, int]:
    """The functions of module text ``text`` over the limit (command-line entries excepted)."""
    out = {}
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            n = node.end_lineno - node.lineno + 1
            if n > MAX_FUNCTION_LINES and not _is_command_line_entry(node.name):
                out[node.name] = n
    return out


def test_no_function_is_over_80_lines_but_the_command_line_entries():
    long = {
        f"{p.relative_to(ROOT)}:{name}": n
        for p in _modules()
        for name, n in _long_functions(p.read_text()).items()
    }
    assert not long, f"split these functions (lines): {long}"


def test_the_scan_finds_a_long_function_and_spares_an_entry():
    body = "".join(f"    x{i} = {i}\n" for i in range(MAX_FUNCTION_LINES))
    method = textwrap.indent(body, "    ")
    text = f"def helper():\n{body}\n\ndef main():\n{body}\n\nclass A:\n    def method(self):\n{method}"
    assert _long_functions(text) == {"helper": MAX_FUNCTION_LINES + 1, "method": MAX_FUNCTION_LINES + 1}
    short = "".join(f"    x{i} = {i}\n" for i in range(MAX_FUNCTION_LINES - 1))  # 80 lines with its def
    assert _long_functions(f"def short():\n{short}") == {}
