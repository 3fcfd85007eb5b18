"""The page ``config-guide.md`` (a MkDocs hook): one entry per shipped training config
(``configs/*.yaml``), read from the config itself: its header comment (what it is), its
algorithm, env id and that id's status in the version table, the plants it trains on (from its
training suites: ``env.suite``, a student's ``student.suites``; a suite that draws plant
parameters is "randomized", one that does not is the version's nominal plant), where it is
evaluated, its budget, and where it is not the config to use."""

from __future__ import annotations

from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]

# an agent trained on nominal plants only, scored where the plant varies: an agent trained on
# nominal-v2, scored on randomized-v2 (the headline score: baseline 0, oracle 100)
NOMINAL_ONLY_WARNING = (
    "trained on the nominal plant only: expect it to fail where the plant differs (a rig, the "
    "randomized suites). An agent trained on `nominal-v2` only scored a headline of **-477** on "
    "`randomized-v2` (the baseline 0, the oracle 100): far worse than the baseline it beat on the "
    "nominal plant."
)


# what the ids of each family ask of the controller
TASKS = {
    "CEPAM": "track a length and a stiffness reference",
    "CEPAMLength": "track a length reference (stiffness free)",
    "CEPAMStiffness": "track a stiffness reference at a fixed length",
    "CEPAMJoint": "track a hinge's angle and joint stiffness",
}


def header(path: Path) -> str:
    """The config's leading comment block, as one paragraph."""
    lines = []
    for line in path.read_text().splitlines():
        if not line.startswith("#"):
            break
        lines.append(line.lstrip("#").strip())
    return " ".join(lines)


def _plants(suite_name: str) -> tuple[str, str]:
    """``("randomized" | "nominal", description)`` of a benchmark suite's plants."""
    from cepam_gym import versions
    from cepam_gym.bench.suites import SUITES

    suite = SUITES[suite_name]
    preset = versions.get(suite.env_id).plant_preset
    drawn = suite.env_kwargs.get("randomize") or {}
    if drawn:
        return (
            "randomized",
            f"`{suite_name}`: randomized plants ({len(drawn)} parameters of `{preset}` drawn per episode)",
        )
    return "nominal", f"`{suite_name}`: the nominal plant (`{preset}`)"


def entry(path: Path) -> dict:
    """What the guide says of one config, read from the YAML."""
    from cepam_gym import versions

    cfg = yaml.safe_load(path.read_text())
    env = cfg.get("env", {})
    env_id = env["id"]
    student = cfg.get("student") or {}
    suites = list(student.get("suites") or ([env["suite"]] if env.get("suite") else []))
    kinds, plants = zip(*(_plants(s) for s in suites)) if suites else ((), ())
    if env.get("kwargs", {}).get("randomize"):
        kinds, plants = (
            (*kinds, "randomized"),
            (*plants, "plant parameters drawn per episode (`env.kwargs.randomize`)"),
        )
    version = versions.get(env_id)
    if not plants:
        kinds, plants = ("nominal",), (f"the id's nominal plant (`{version.plant_preset}`)",)
    algorithm = "a DAgger student" if student else cfg.get("algorithm", "PPO")
    return {
        "name": path.stem,
        "about": header(path),
        "algorithm": algorithm + (f" ({cfg['learner']} learner)" if cfg.get("learner") else ""),
        "env_id": env_id,
        "status": version.status,
        "task": TASKS[env_id.split("/")[-1].rsplit("-", 1)[0]],
        "suites": suites,
        "plants": list(plants),
        "nominal_only": set(kinds) == {"nominal"},
        "eval_suite": (cfg.get("eval") or {}).get("suite"),
        "budget": _budget(cfg, student),
    }


def _budget(cfg: dict, student: dict) -> str:
    parts = []
    if student:
        parts.append(f"{student.get('iterations', '?')} DAgger rounds")
    elif cfg.get("total_timesteps"):
        parts.append(f"at most {int(cfg['total_timesteps']):,} steps".replace(",", " "))
    if cfg.get("time_limit_minutes"):
        parts.append(f"stopped at {cfg['time_limit_minutes']} min")
    return ", ".join(parts) or "-"


def _not_for(e: dict) -> list[str]:
    from cepam_gym import versions

    out = []
    if e["nominal_only"]:
        out.append(NOMINAL_ONLY_WARNING)
    if e["status"] != "recommended":
        out.append(
            f"`{e['env_id'].split('/')[-1]}` is a {e['status']} id: for new work the recommended "
            f"`{versions.RECOMMENDED_ID.split('/')[-1]}` (set `env.id` and the suites to its version)."
        )
    return out


def entries() -> list[dict]:
    return [entry(p) for p in sorted((ROOT / "configs").glob("*.yaml"))]


def page() -> str:
    lines = [
        "# What each config is for",
        "",
        "One entry per shipped config (`configs/*.yaml`), generated from the config: its header "
        "comment, its env id and the plants it trains on (its training suites: `env.suite`, a "
        "student's `student.suites`). An agent is good for the plants it was trained on; the "
        "budgets and measured results are in [the configs' table](configs.md).",
    ]
    for e in entries():
        lines += [
            "",
            f"## `{e['name']}`",
            "",
            e["about"],
            "",
            f"- **Algorithm, id:** {e['algorithm']} on `{e['env_id']}` ({e['status']}); "
            f"budget: {e['budget']}.",
            f"- **Trained for:** {'; '.join(e['plants'])}.",
            f"- **Good for:** agents that {e['task']} on `{e['env_id'].split('/')[-1]}`, on "
            + ("the nominal plant." if e["nominal_only"] else "the plants above and ones like them."),
            f"- **Evaluated on:** `{e['eval_suite']}`."
            if e["eval_suite"]
            else "- **Evaluated on:** its training env.",
        ]
        lines += [f"- **Not for:** {n}" for n in _not_for(e)]
    return "\n".join(lines) + "\n"


def on_files(files, config):
    from mkdocs.structure.files import File

    files.append(File.generated(config, "config-guide.md", content=page()))
    return files
