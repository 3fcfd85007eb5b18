"""Each generated spec page (docs/gen_env_pages.py) against the env it describes: every argument
it lists is taken by ``gym.make``, and the task kwargs it leaves out are refused; every task field
it lists is overridable through ``task_options`` and no other is; the starting state it states is
what ``reset`` gives over 20 seeds; its spaces are the env's."""

from __future__ import annotations

import dataclasses
import importlib.util
import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
SEEDS = range(20)


def _generator():
    spec = importlib.util.spec_from_file_location("gen_env_pages", ROOT / "docs" / "gen_env_pages.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


GEN = _generator()


def _ids() -> list:
    out = []
    for env_id in GEN.registered_ids():
        needs = cepam_gym.versions.get(env_id).extra
        mark = pytest.mark.skipif(
            bool(needs) and importlib.util.find_spec(needs) is None, reason=f"needs the [{needs}] extra"
        )
        out.append(pytest.param(env_id, marks=mark))
    return out


def _table(page: str, section: str) -> list[str]:
    """The first column (without backticks) of the tables of ``## section``."""
    body = page.split(f"## {section}\n", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"^\| `([^`]+)` \|", body, flags=re.M)


@pytest.fixture(scope="module", params=_ids())
def page(request):
    facts = GEN.env_facts(request.param)
    return request.param, facts, GEN.spec_page(facts)


def test_the_arguments_are_the_ones_the_env_takes(page):
    env_id, facts, text = page
    listed = _table(text, "Arguments")
    assert listed == list(facts["kwargs"])
    for k in listed:  # each at its listed default
        gym.make(env_id, **{k: facts["kwargs"][k]}).close()
    if "joint" not in listed:  # the hinge's geometry: refused by a rig
        with pytest.raises(InputError, match="joint"):
            gym.make(env_id, joint={"lever_arm": 0.02})


def test_the_task_fields_are_all_the_task_options(page):
    env_id, facts, text = page
    fields = _table(text, "Starting state")
    task = facts["task"]
    assert fields == list(facts["task_fields"])
    every = [f.name for f in dataclasses.fields(task)]
    for name in every:
        kwargs = {"task_options": {name: getattr(task, name)}}
        if name in fields:
            gym.make(env_id, **kwargs).close()
        else:
            with pytest.raises((InputError, TypeError)):
                gym.make(env_id, **kwargs)


def test_the_starting_state_is_what_reset_gives(page):
    env_id, facts, text = page
    (position, target), (stiffness, target_k) = facts["start_keys"]
    env = gym.make(env_id)
    on_target = 0
    for seed in SEEDS:
        _, info = env.reset(seed=seed)
        same_position = np.isclose(info[position], info[target], rtol=0, atol=1e-9)
        close_k = abs(info[stiffness] - info[target_k]) <= GEN.START_STIFFNESS_TOL * info[target_k]
        on_target += bool(same_position and close_k)
    env.close()
    stated = text.split("## Starting state\n", 1)[1].strip().split("\n\n")[0]
    if facts["starts_on_reference"]:
        assert on_target == len(SEEDS) and f"`{position}` equals `{target}`" in stated
    else:
        assert on_target == 0 and f"is not (`{target}`, `{target_k}`)" in stated


def test_the_spaces_and_status_are_the_envs(page):
    env_id, facts, text = page
    env = gym.make(env_id)
    assert f"| action space | `{env.action_space}` |" in text
    assert f"| observation space | `{env.observation_space}` |" in text
    assert f"| status | {cepam_gym.versions.get(env_id).status} |" in text
    env.close()
