"""The documentation: a generated spec page per registered id, the reference tables from the stored
scores, the strict site build, the release's version, and no issue or session numbers anywhere
but the changelog."""

from __future__ import annotations

import importlib.util
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

import cepam_gym
from cepam_gym.cli import main

ROOT = Path(__file__).resolve().parents[2]


def _generator():
    spec = importlib.util.spec_from_file_location("gen_env_pages", ROOT / "docs" / "gen_env_pages.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_registered_id_has_a_generated_spec_page():
    import gymnasium as gym

    gen = _generator()
    ids = gen.registered_ids()
    assert sorted(ids) == sorted(i for i in gym.registry if i.startswith("cepam_gym/"))
    from cepam_gym import versions

    newest = max(row.version for row in versions.VERSIONS.values())
    assert [versions.get(i).version for i in ids[:4]] == [newest] * 4  # newest first
    for env_id in ("cepam_gym/CEPAM-v2", "cepam_gym/CEPAMLength-v0", "cepam_gym/CEPAMJoint-v1"):
        facts = gen.env_facts(env_id)
        page = gen.spec_page(facts)
        sections = re.findall(r"^## (.+)$", page, flags=re.M)
        assert sections == [
            "Description",
            "Action space",
            "Observation space",
            "Rewards",
            "Starting state",
            "Episode end",
            "Arguments",
            "Version history",
        ]
        # every observation column is in the table (preview columns folded into one row per quantity)
        n_obs = gym.spec(env_id).kwargs.get("preview_steps", 0)
        rows = re.findall(r"^\| (\d+)(?:-(\d+))? \| `", page, flags=re.M)
        covered = sum(int(b or a) - int(a) + 1 for a, b in rows)
        assert covered == facts["observation_space"].shape[0], (env_id, n_obs, rows)
        for term in facts["weights"]:
            assert f"\n| {term} | `-w" in page
    index = gen.index_page(ids)
    assert all(f"({i.split('/')[-1]}.md)" in index for i in ids)


def test_reference_tables_follow_the_stored_scores():
    import json

    refs = json.loads((ROOT / "src/cepam_gym/data/reference_scores.json").read_text())
    table = _generator().reference_tables()
    for suite, r in refs.items():
        ends = f"{r['zero']:.4f} | {r['baseline']:.4f} | {r['oracle']:.4f}"
        assert f"| `{suite}` | {r['seed']} | {r['episodes']} | {ends} |" in table


@pytest.mark.slow
def test_docs_build_strictly(tmp_path):
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings")
    out = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(tmp_path / "site")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=900,
        env={**__import__("os").environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    assert out.returncode == 0, out.stderr[-3000:]
    assert (tmp_path / "site" / "envs" / "CEPAM-v2" / "index.html").exists()
    api = (tmp_path / "site" / "api" / "index.html").read_text()
    assert "EnvModel" in api or "make_controller" in api
    # the docstrings' Sphinx roles are shown as code, never as ":func:" text (docs/sphinx_roles.py)
    assert not re.search(r":(mod|func|class|meth|attr|data|obj|exc):<code>", api)
    assert re.search(r"<code>[\w.]+</code>", api)


def test_docs_build_fails_on_a_broken_link(tmp_path):
    """The site's own settings (strict, the link validation) make a broken link fail the build;
    checked on a one-page copy (the API pages and the generated ones are not what is tested)."""
    pytest.importorskip("mkdocs")
    import yaml

    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    kept = {k: config[k] for k in ("site_name", "docs_dir", "strict", "validation")}
    copy = tmp_path / "repo"
    (copy / "docs").mkdir(parents=True)
    (copy / "mkdocs.yml").write_text(yaml.safe_dump(kept))
    (copy / "docs" / "index.md").write_text("# Home\n\n[nowhere](no-such-page.md)\n")
    out = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "-d", str(tmp_path / "site")],
        cwd=copy,
        capture_output=True,
        text=True,
        timeout=300,
        env={**__import__("os").environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    assert kept["strict"] is True
    assert out.returncode != 0 and "no-such-page.md" in out.stderr, out.stderr[-2000:]


def test_version_is_one_and_printed(capsys):
    assert re.fullmatch(r"\d+\.\d+\.\d+", cepam_gym.__version__)
    assert cepam_gym.__version__ == "1.0.0"
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "version" in project["project"]["dynamic"]  # read from cepam_gym.__version__, not written twice
    assert project["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "cepam_gym.__version__"}
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"cepam-gym {cepam_gym.__version__}"
    changelog = (ROOT / "CHANGELOG.md").read_text()
    assert f"## [{cepam_gym.__version__}]" in changelog


def _tracked_text_files() -> list[Path]:
    if shutil.which("git") and (ROOT / ".git").exists():
        out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True)
        paths = [ROOT / p for p in out.stdout.splitlines()]
    else:  # a source tree without git: every file but the venvs and caches
        paths = [
            p for p in ROOT.rglob("*") if not any(part.startswith(".") for part in p.parts[len(ROOT.parts) :])
        ]
    return [
        p for p in paths if p.is_file() and p.suffix not in (".png", ".gif", ".mp4", ".zip", ".pkl", ".npz")
    ]


def test_no_issue_or_session_numbers_outside_the_changelog():
    pattern = re.compile(r"issue[ -]#?[0-9]|session [0-9]", re.I)
    hits = []
    for path in _tracked_text_files():
        if path.name == "CHANGELOG.md":
            continue
        try:
            text = path.read_text()
        except (UnicodeDecodeError, OSError):
            continue
        for n, line in enumerate(text.splitlines(), 1):
            if pattern.search(line):
                hits.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()[:80]}")
    assert not hits, "cite no issue or session; history goes to CHANGELOG.md:\n" + "\n".join(hits)
