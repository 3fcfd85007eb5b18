"""The generated page of what each shipped config is for (docs/gen_config_page.py): an entry per
config in configs/, each saying which plants it was trained for, read from the config's own
training suites, and the nominal-only ones warning where they fail."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import yaml

from cepam_gym.bench.suites import SUITES

ROOT = Path(__file__).resolve().parents[2]


def _module():
    spec = importlib.util.spec_from_file_location("gen_config_page", ROOT / "docs" / "gen_config_page.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _sections(page: str) -> dict[str, str]:
    parts = re.split(r"^## `([^`]+)`$", page, flags=re.M)
    return dict(zip(parts[1::2], parts[2::2]))


def test_every_shipped_config_has_an_entry_saying_which_plants_it_was_trained_for():
    page = _module().page()
    sections = _sections(page)
    shipped = sorted(p.stem for p in (ROOT / "configs").glob("*.yaml"))
    assert shipped and sorted(sections) == shipped
    for name, text in sections.items():
        cfg = yaml.safe_load((ROOT / "configs" / f"{name}.yaml").read_text())
        trained = re.search(r"^- \*\*Trained for:\*\* (.+)$", text, flags=re.M)
        assert trained, f"{name}: no 'Trained for' line"
        suites = list((cfg.get("student") or {}).get("suites") or [cfg["env"]["suite"]])
        for s in suites:  # each training suite named, as randomized or nominal as it is
            kind = "randomized plants" if SUITES[s].env_kwargs.get("randomize") else "the nominal plant"
            assert f"`{s}`: {kind}" in trained[1], (name, s)
        assert f"`{cfg['env']['id']}`" in text


def test_the_nominal_only_configs_say_where_they_fail():
    sections = _sections(_module().page())
    trained = {n: re.search(r"^- \*\*Trained for:\*\* (.+)$", t, flags=re.M)[1] for n, t in sections.items()}
    nominal_only = [n for n, line in trained.items() if "randomized plants" not in line]
    assert "fast_ppo" in nominal_only and "student_v3" not in nominal_only
    for name in nominal_only:
        assert "**-477** on `randomized-v2`" in sections[name], name
    assert not any("-477" in sections[n] for n in sections if n not in nominal_only)
