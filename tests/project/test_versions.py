"""The version table (cepam_gym.versions): it covers exactly the registered ids, registers them,
and is what every version-dependent setting reads: scoring, oracle settings, joint variants,
suites, eval's defaults, the recommended id and the docs."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import gymnasium as gym
import pytest

import cepam_gym
from cepam_gym import plant as pl
from cepam_gym import versions
from cepam_gym.bench.cli import expand_version
from cepam_gym.bench.metrics import JOINT, JOINT_V1, RIG, RIG_V1
from cepam_gym.bench.suites import SUITES, version_suites
from cepam_gym.control.objective import spec_of_core, version_of_core
from cepam_gym.control.oracle import ORACLE_CONFIGS, oracle_config
from cepam_gym.control.registry import is_joint_env
from cepam_gym.envs.joint import CEPAMJointKernelEnv
from cepam_gym.plant.params import PlantParams, preset

ROOT = Path(__file__).resolve().parents[2]
IDS = list(versions.VERSIONS)


def _quiet_make(env_id, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # the older ids' "out of date" notice
        return gym.make(env_id, **kwargs)


def test_the_table_covers_exactly_the_registered_ids():
    registered = sorted(k for k in gym.registry if k.startswith("cepam_gym/"))
    assert sorted(IDS) == registered
    for env_id, row in versions.VERSIONS.items():
        spec = gym.spec(env_id)
        assert spec.entry_point == row.entry_point and spec.vector_entry_point == row.vector_entry_point
        assert spec.kwargs == row.kwargs and spec.max_episode_steps == versions.MAX_EPISODE_STEPS
        assert row.status in versions.STATUSES
        assert spec.version == row.version


def test_registration_names_are_views_of_the_table():
    from cepam_gym.registration import ENV_IDS, JOINT_ENV_IDS, MUJOCO_ENV_IDS

    assert set(ENV_IDS) | set(JOINT_ENV_IDS) | set(MUJOCO_ENV_IDS) == set(IDS)
    assert ENV_IDS["cepam_gym/CEPAM-v2"] == {"task": "cepam_v1", "preview_steps": 10, "plant": "balloon_v2"}
    assert JOINT_ENV_IDS["cepam_gym/CEPAMJoint-v2"][2]["plant"] == "balloon_v2"
    assert list(MUJOCO_ENV_IDS) == ["cepam_gym/CEPAMJoint-v0"]


@pytest.mark.parametrize("env_id", [i for i in IDS if not versions.VERSIONS[i].extra])
def test_each_row_is_what_its_env_runs(env_id):
    """The task, plant and preview of a row are the env's (the row's kwargs build them)."""
    row = versions.VERSIONS[env_id]
    core = _quiet_make(env_id).unwrapped.core
    assert core.preview_steps == row.preview_steps
    assert core.nominal == preset(row.plant_preset)
    assert version_of_core(core) is row
    assert versions.task_version(row.task) == row.task_version
    assert (core.mech == pl.HINGE) == (row.mechanism == "hinge")


def test_the_default_plant_is_plant_v1():
    assert PlantParams() == preset(versions.DEFAULT_PRESET) == preset(versions.PLANT_PRESETS[1])


def _obs_space(env_id, **kwargs):
    env = _quiet_make(env_id, **kwargs)
    if not versions.VERSIONS[env_id].extra:
        return env.observation_space, env.unwrapped.core.obs_layout.names
    return env.observation_space, None


@pytest.mark.parametrize("env_id", IDS)
def test_each_ids_suites_observe_what_the_id_observes(env_id):
    """An agent trained on an id acts on its headline suites and on every suite ``eval --suite all``
    gives it; ids whose rows name the same observation observe the same columns."""
    row = versions.VERSIONS[env_id]
    if row.extra:
        pytest.importorskip(row.extra)
    mine = _obs_space(env_id)
    names = set(row.suites) | set(version_suites(env_id))
    assert set(row.suites) <= set(version_suites(env_id))
    for name in names:
        s = SUITES[name]
        assert _obs_space(s.env_id, **s.env_kwargs) == mine, name
    for other, r in versions.VERSIONS.items():
        if r.observation == row.observation and not r.extra and not row.extra:
            assert _obs_space(other) == mine, (env_id, other)


def test_every_suite_runs_on_a_listed_id_and_is_scored_as_its_task_version():
    for name, s in SUITES.items():
        row = versions.get(s.env_id)
        want = {("rig", 0): RIG, ("hinge", 0): JOINT}
        want.update({("rig", v): RIG_V1 for v in (1, 2)} | {("hinge", v): JOINT_V1 for v in (1, 2)})
        assert s.traces == want[row.mechanism, row.task_version], name
        assert s.extra == row.extra, name
    headline = [n for row in versions.VERSIONS.values() for n in row.suites]
    assert len(headline) == len(set(headline)) and set(headline) <= set(SUITES)
    for row in versions.VERSIONS.values():
        assert all(SUITES[n].env_id == row.env_id for n in row.suites), row.env_id


@pytest.mark.parametrize("env_id", [i for i in IDS if versions.VERSIONS[i].oracle])
def test_scoring_and_oracle_settings_come_from_the_table(env_id):
    row = versions.VERSIONS[env_id]
    core = gym.make_vec(env_id, num_envs=1).unwrapped.core
    assert oracle_config(core) == ORACLE_CONFIGS[row.oracle]
    assert spec_of_core(core).allowance_s == (0.5 if row.task_version else 0.0)


def test_version_follows_the_task_and_plant_not_the_preview_or_friction_law():
    # the v1 task without preview is still scored as v1 (not a v0 guess from preview_steps == 0)
    core = _quiet_make("cepam_gym/CEPAM-v1", preview_steps=0).unwrapped.core
    assert spec_of_core(core) == RIG_V1 and version_of_core(core).env_id == "cepam_gym/CEPAM-v1"
    # a v1 task given plant v2 by its parameters is the v2 id; by name too
    for plant in (preset("balloon_v2"), "balloon_v2"):
        core = gym.make_vec("cepam_gym/CEPAM-v1", num_envs=1, plant=plant).unwrapped.core
        assert version_of_core(core).env_id == "cepam_gym/CEPAM-v2"
        assert oracle_config(core) == ORACLE_CONFIGS["v2"]
    # a plant of one's own: no id; the setting of how its task is scored
    own = preset("balloon_v2").replace(end_mass=0.021)
    core = gym.make_vec("cepam_gym/CEPAM-v1", num_envs=1, plant=own).unwrapped.core
    assert version_of_core(core) is None and oracle_config(core) == ORACLE_CONFIGS["v1"]
    core = _quiet_make("cepam_gym/CEPAM-v0", plant=own).unwrapped.core
    assert oracle_config(core) == ORACLE_CONFIGS["v0"] and spec_of_core(core) == RIG


def test_joint_envs_are_known_by_the_tables_entry_points():
    from cepam_gym.envs.joint import CEPAMJointV1Env

    class MyJoint(CEPAMJointKernelEnv):
        pass

    assert CEPAMJointV1Env is CEPAMJointKernelEnv  # the former name, an alias
    assert is_joint_env(CEPAMJointV1Env())
    assert is_joint_env(MyJoint()) and is_joint_env(gym.make("cepam_gym/CEPAMJoint-v2"))
    assert is_joint_env(gym.make_vec("cepam_gym/CEPAMJoint-v1", num_envs=2))
    assert not is_joint_env(gym.make_vec("cepam_gym/CEPAM-v2", num_envs=2))
    assert not is_joint_env(gym.make("cepam_gym/CEPAM-v2"))


def test_bench_version_names_the_suites_of_its_ids():
    for n in (0, 1, 2):
        want = [s for s in SUITES if versions.get(SUITES[s].env_id).version == n]
        assert expand_version(f"v{n}") == want and want
    assert "nominal" in expand_version("v0") and "joint" in expand_version("v0")
    assert expand_version("v9") == ["v9"]


def test_eval_default_suites_follow_the_agents_id(tmp_path):
    """A v2 agent is scored on v2 suites by default, a joint-v2 agent on joint-v2, a v1 length
    agent on its own length suite (18 columns, not nominal-v1's 29)."""
    evaluate = pytest.importorskip("cepam_gym_agents.evaluate")
    assert evaluate.default_suites("cepam_gym/CEPAM-v2") == ["nominal-v2", "randomized-v2"]
    assert evaluate.default_suites("cepam_gym/CEPAMJoint-v2") == ["joint-v2"]
    assert evaluate.default_suites("cepam_gym/CEPAMLength-v1") == ["length-v1"]
    assert evaluate.default_suites("cepam_gym/CEPAM-v0") == ["nominal", "randomized"]
    assert evaluate.default_suites("cepam_gym/CEPAM-v2", ["stress-v2"]) == ["stress-v2"]
    every = evaluate.default_suites("cepam_gym/CEPAM-v2", ["all"])
    assert every == [s for s in SUITES if s.endswith("-v2") and s not in ("length-v2", "joint-v2")]
    with pytest.raises(ValueError, match="CEPAMLength-v0 has no benchmark suite"):
        evaluate.default_suites("cepam_gym/CEPAMLength-v0")
    with pytest.raises(ValueError, match="not a cepam_gym id"):
        evaluate.default_suites("Pendulum-v1")
    # through a run's config, as `cepam-gym eval --run` reads it
    from cepam_gym_agents.policy import load_run_config

    for env_id, want in (("cepam_gym/CEPAM-v2", "nominal-v2"), ("cepam_gym/CEPAMJoint-v2", "joint-v2")):
        run = tmp_path / env_id.split("/")[1]
        run.mkdir()
        (run / "config.yaml").write_text(f"algorithm: PPO\nenv:\n  id: {env_id}\n")
        assert evaluate.default_suites(load_run_config(run).env.id)[0] == want


def test_recommended_is_the_newest_version_and_gymnasiums_notice_names_it():
    rec = versions.VERSIONS[versions.RECOMMENDED_ID]
    assert rec.status == "recommended" and cepam_gym.RECOMMENDED_ID == versions.RECOMMENDED_ID
    newest = max(r.version for r in versions.VERSIONS.values())
    for row in versions.VERSIONS.values():
        assert (row.status == "recommended") == (row.version == newest), row.env_id
        assert (row.status == "legacy") == (row.version == 0), row.env_id
    with pytest.warns(DeprecationWarning, match=r"CEPAM-v1 is out of date.*`v3`"):
        gym.make("cepam_gym/CEPAM-v1")
    with pytest.warns(DeprecationWarning, match=r"CEPAM-v0 is out of date.*`v3`"):
        gym.make("cepam_gym/CEPAM-v0")
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        gym.make(versions.RECOMMENDED_ID)
    from gymnasium.envs.registration import find_highest_version

    for row in versions.VERSIONS.values():  # what an unversioned make picks, and the notice names
        assert find_highest_version("cepam_gym", row.family) == rec.version


def test_docs_hold_the_table_and_the_package_doc_counts_the_ids():
    doc = (ROOT / "docs" / "versions.md").read_text()
    assert versions.markdown_table() in doc, "docs/versions.md: paste versions.markdown_table() again"
    words = {12: "twelve", 16: "sixteen"}
    assert f"registers {words[len(IDS)]} ids" in " ".join(cepam_gym.__doc__.split())
    for word in ("promises", "recommended", "supported", "legacy"):
        assert word in versions.__doc__


# what a version guess looks like: an id's suffix, the plant's friction law outside the plant, a
# preview count as a version test, finding env classes through sys.modules
GUESSES = {
    "an id's suffix": re.compile(r"""endswith\(\s*f?["']-v"""),
    "'Joint' in an id": re.compile(r"""["']Joint["']\s+in\s+\w*id"""),
    "the plant's friction law": re.compile(r"friction_law\s*=="),
    "a preview count": re.compile(r"preview_steps\W[^\n]*>\s*0"),
    "sys.modules": re.compile(r"sys\.modules\.get"),
}


def test_nothing_guesses_a_version():
    bad = []
    for top in ("src", "agents", "benchmarks"):
        for path in (ROOT / top).rglob("*.py"):
            rel = path.relative_to(ROOT).as_posix()
            for n, line in enumerate(path.read_text().splitlines(), 1):
                for what, pattern in GUESSES.items():
                    if not pattern.search(line):
                        continue
                    if what == "the plant's friction law" and rel.startswith("src/cepam_gym/plant/"):
                        continue
                    if what == "sys.modules" and not rel.startswith("src/cepam_gym/control/"):
                        continue
                    bad.append(f"{rel}:{n}: {what}: {line.strip()}")
    assert not bad, "\n".join(bad)


def test_a_guess_is_caught():
    """The patterns above match the guesses they are for (so the test above can fail)."""
    assert GUESSES["an id's suffix"].search('v1 = env_id.endswith("-v1")')
    assert GUESSES["the plant's friction law"].search('nominal.friction_law == "contact_area"')
    assert GUESSES["a preview count"].search('if getattr(core, "preview_steps", 0) > 0:')
    assert GUESSES["'Joint' in an id"].search('if "Joint" in env_id:')


# what parsing an id (or a suite's name) looks like: splitting off its version or namespace,
# replacing or testing its suffix, a version pattern. Versions and suites come from the table
# (cepam_gym.versions: each row's version, family, name and suites) and a suite's stem.
ID_PARSING = {
    "a suffix split off": re.compile(r"""\.r?(partition|split)\(\s*["']-(v\d*)?["']"""),
    "a namespace split off": re.compile(r"""id\w*(\.\w+)*\.r?(partition|split)\(\s*["']/["']"""),
    "a version replaced": re.compile(r"""\.(replace|removesuffix|removeprefix)\(\s*f?["'][^"']*(-v|_v\d)"""),
    "a suffix tested": re.compile(r"""(ends|starts)with\(\s*\(?\s*f?["'][^"']*-v"""),
    "a suffix searched": re.compile(r"""["']-v\d*["']\s+(not\s+)?in\b"""),
    "a version pattern": re.compile(r"""-v\\d"""),
}
# a dataset name the user gives must not end as a version (Minari appends its own): not an id
ID_PARSING_ALLOWED = {("src/cepam_gym/offline/naming.py", "a version pattern")}


def test_no_id_string_is_parsed():
    bad = []
    for top in ("src", "agents"):
        for path in (ROOT / top).rglob("*.py"):
            rel = path.relative_to(ROOT).as_posix()
            for n, line in enumerate(path.read_text().splitlines(), 1):
                for what, pattern in ID_PARSING.items():
                    if pattern.search(line) and (rel, what) not in ID_PARSING_ALLOWED:
                        bad.append(f"{rel}:{n}: {what}: {line.strip()}")
    assert not bad, "\n".join(bad)


def test_an_id_parse_is_caught():
    """Each pattern above matches the parse it is for (so the test above can fail)."""
    caught = {
        "a suffix split off": ('stem, _, version = suite.name.rpartition("-")', 'env_id.split("-v")'),
        "a namespace split off": ('suite.env_id.rpartition("/")[2]', 'env_id.split("/")'),
        "a version replaced": (
            'v1.env_id.replace("-v1", "-v2")',
            "name.replace(f'-v{n}', '')",
            'v1.name.removesuffix("_v1") + "_v3"',
        ),
        "a suffix tested": ('env_id.endswith("-v1")', 'name.endswith(("-v1", "-v2"))'),
        "a suffix searched": ('if "-v2" in env_id:',),
        "a version pattern": (r're.search(r"-v\d+$", env_id)',),
    }
    for what, lines in caught.items():
        for line in lines:
            assert ID_PARSING[what].search(line), (what, line)
    assert not any(p.search('f"cepam_gym/{self.family}-v{self.version}"') for p in ID_PARSING.values())


def test_the_suites_are_made_from_the_rows_that_name_them():
    """Each suite is named by one row (headline or other) and runs on that row's id; a name no
    scenario makes is refused; a suite keeps its scenario's stem on every version."""
    import dataclasses

    from cepam_gym.bench import suites

    named = [n for row in versions.VERSIONS.values() for n in (*row.suites, *row.other_suites)]
    assert sorted(named) == sorted(SUITES)
    for row in versions.VERSIONS.values():
        assert all(SUITES[n].env_id == row.env_id for n in (*row.suites, *row.other_suites)), row.env_id
    typo = dataclasses.replace(versions.get("cepam_gym/CEPAM-v2"), other_suites=("tracking-v3",))
    with pytest.raises(ImportError, match="tracking-v3"):
        suites._suites_of_version([typo])
    assert {SUITES[n].stem for n in ("nominal", "nominal-v1", "nominal-v3")} == {"nominal"}
    assert suites.with_id_window(SUITES["randomized-v2"], 5.0).name == "randomized-id-v2"
