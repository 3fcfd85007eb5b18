"""MkDocs hook (mkdocs.yml ``hooks:``): the pages generated from the code at build time.

* ``envs/<name>.md``, one spec sheet per registered id in the sections of Gymnasium's v5 env pages
  (description, action space, observation space, rewards, starting state, episode end, arguments,
  version history), and ``envs/index.md``, the id table;
* the reference tables of ``suites.md`` (the ``<!-- reference-scores -->`` marker) from
  ``src/cepam_gym/data/reference_scores.json``: the ends of the headline and of the normalized
  score, and of the datasets' Minari normalization;
* ``configs.md`` (the training configs, ``configs/README.md``) and ``changelog.md``.

Everything the spec sheets say about an id comes from :func:`env_facts`, the one function that
reads the code: it builds the env and reads a few named attributes (the registration spec, the
spaces, the observation layout, the task's reward weights, scales, reset options and termination
names). Pointing the pages at another source (a task contract, a version table) means rewriting that
function only; the rest formats the facts it returns.
"""

from __future__ import annotations

import dataclasses
import inspect
import json
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# prose per task family (the id's name without its version); the numbers come from env_facts
DESCRIPTIONS = {
    "CEPAM": "A compound extensor pneumatic artificial muscle (CE-PAM: a contractor McKibben muscle "
    "inside an extensor one; [the model](../model.md)) hangs vertically from a mounting plate with a "
    "load on its free end. Two valves feed the two chambers: the contractor (CPAM, pressure `Pc`) and "
    "the annulus between the extensor's bladder and the CPAM (pressure `Pe`). Because length and "
    "stiffness depend on both pressures differently, both can be set independently (paper section "
    "XII). Task: track a target length AND a target stiffness while the hanging load changes.",
    "CEPAMLength": "The CE-PAM rig of `CEPAM` (a muscle hanging with a load on its free end, two "
    "chambers, two valves). Task: track a target length while the hanging load changes; the "
    "stiffness is free.",
    "CEPAMStiffness": "The CE-PAM rig of `CEPAM`. Task: hold a fixed length (17.5 cm) and track a "
    "target stiffness: the paper's section XII experiment, stiffness changed at a fixed length.",
    "CEPAMJoint": "A 1-DOF hinge, the elbow or wrist of a small wearable or rehabilitation device, "
    "driven by one CE-PAM through a rack and pinion (`L = L_max - r theta`), so the muscle's 15-19.5 cm "
    "span is the joint's flexion range ([MuJoCo and the joint](../mujoco.md)). The forearm hangs under "
    "gravity and an external torque changes over the episode. Task: track a target joint angle AND a "
    "target joint stiffness `K r^2`.",
}
VERSIONS = {
    "v0": "targets that step every 2-4 s without notice under changing loads, no preview; plant v0 "
    "(preset `balloon_v0`). Legacy: kept so every v0 figure reproduces.",
    "v1": "planned references (minimum-jerk moves, length sines and chirps, stiffness ramps) announced "
    "0.2 s ahead in the observation (`preview_steps=10`), every target reachable at its load; plant v1 "
    "(preset `balloon`: tension-only braids, neo-Hookean walls, braid-bladder friction). Supported.",
    "v2": "the v1 task on plant v2 (preset `balloon_v2`: a slack contractor pulls through its seal, "
    "contact-area friction, extensible braid threads; calibrated through the paper's protocols). "
    "Supported.",
    "v3": "the v1 task on plant v2 with the reward that is the benchmark score's per-step form and a "
    "rig's sensor noise in the observation by default (`sensor_noise=None`: ideal sensors). "
    "Recommended.",
}
JOINT_V0 = "The hinge is simulated in MuJoCo (needs the `[mujoco]` extra). "
ACTION_MODES = {
    "valve": "proportional valve spool set-point: -1 exhaust, 0 closed, +1 supply (default)",
    "pwm": "duty of two on/off solenoid valves (sign: supply or exhaust)",
    "pressure": "gauge pressure set-point, -1 -> 0 kPa, +1 -> min(supply, burst), held by a regulator",
}
ARGUMENTS = {
    "plant": "`PlantParams`, a preset name, a YAML path or a dict of unit-named keys",
    "action_mode": "`valve`, `pwm` or `pressure` (Action space)",
    "control_dt": "control period [s]",
    "sub_dt": "plant sub-step [s]; must divide `control_dt`",
    "episode_seconds": "length of the target and load schedule [s]; the episode itself is truncated "
    "at `max_episode_steps`",
    "reward_weights": "override any weight of the Rewards table",
    "randomize": "`{plant key: [low, high]}` in the key's units, drawn per episode (checked when the "
    "env is built; a draw that fails is redrawn, counted in `info['redraws']`)",
    "sensor_noise": '`{"length_mm" (or "angle_mrad"), "velocity_mm_s" (or "angular_velocity_mrad_s"), '
    '"pressure_kpa"}` standard deviations (v3: a rig\'s sensors by default; `None`: ideal sensors)',
    "action_latency_steps": "actions reach the valves this many control steps late",
    "supply_drift_kpa": "random-walk intensity of the supply pressure [kPa/sqrt(s)], clipped to +-20 %",
    "task_options": "override the task's fields (Starting state)",
    "stream": "index of the env's random stream: `reset(seed=s)` draws from "
    "`SeedSequence(s, spawn_key=(stream,))`, as element `stream` of a vector env seeded `s`",
    "num_threads": "threads of the batched kernel (`None`: the count that steps fastest now)",
    "preview_steps": "control steps of future targets appended to the observation",
    "joint": "the hinge's geometry (pinion radius, link), `{name: value}`",
    "render_mode": '`"rgb_array"` or `"human"`',
    "renderer": "the task's renderers (the first is the default)",
    "width": "frame width [px]",
    "height": "frame height [px]",
}


def env_facts(env_id: str) -> dict:
    """What the spec page of ``env_id`` says, read from the code: the registration, the spaces,
    the observation layout, the task (reward weights, scales, ranges, reset options) and the
    termination names. The one place the docs read the environments."""
    import gymnasium as gym

    import cepam_gym  # noqa: F401  (registers the ids)
    from cepam_gym import versions

    spec = gym.spec(env_id)
    env = gym.make(env_id)
    u = env.unwrapped
    core = getattr(u, "core", None)
    task = core.task.spec if core is not None else u.task  # TaskSpec (rig) or JointTask (hinge)
    weights = getattr(task, "weights", None) or getattr(getattr(core, "task", None), "weights", None)
    weights = weights if weights is not None else u.weights
    if core is not None:
        init = inspect.signature(type(core).__init__).parameters
        refused = _task_arguments_refused(type(core.task))
        kwargs = {k: p.default for k, p in init.items() if k not in ("self", "num_envs", "task", *refused)}
        kwargs.update(render_mode=None, renderer=core.task.renderers[0])
        renderers = core.task.renderers
    else:
        init = inspect.signature(type(u).__init__).parameters
        kwargs = {k: p.default for k, p in init.items() if k != "self" and p.kind is p.POSITIONAL_OR_KEYWORD}
        renderers = ("mujoco",)
    kwargs.update({k: v for k, v in spec.kwargs.items() if k != "task"})
    facts = {
        "id": env_id,
        "entry_point": spec.entry_point,
        "vector": spec.vector_entry_point is not None,
        "max_episode_steps": spec.max_episode_steps,
        "registered_kwargs": dict(spec.kwargs),
        "kwargs": kwargs,
        "action_space": u.action_space,
        "observation_space": u.observation_space,
        "columns": [(c.name, c.unit, c.offset, c.scale) for c in u.obs_layout.columns],
        "preview_steps": u.obs_layout.preview_steps,
        "weights": dataclasses.asdict(weights),
        "scales": task.scales,
        "task": task,
        "control_dt": u.control_dt,
        "plant": spec.kwargs.get("plant", "balloon"),
        "termination": u.contract.termination_names,  # the task's contract (cepam_gym.tasks.contract)
        "pin_keys": u.contract.pin_keys,
        "renderers": renderers,
        "status": versions.get(env_id).status,
        "task_fields": _task_fields(env_id, task, spec),
        "starts_on_reference": tuple(task.references) != ("step",),
        "start_keys": [
            (u.contract.score_keys[k], u.contract.score_keys[f"target_{k}"]) for k in ("length", "stiffness")
        ],
    }
    env.close()
    return facts


def _task_arguments_refused(task_class) -> list[str]:
    """The arguments of :func:`cepam_gym.envs.task_registry.make_task` (the env's task kwargs) that
    this task class does not take (the rig takes no ``joint``)."""
    from cepam_gym.envs.task_registry import make_task

    takes = inspect.signature(task_class.from_kwargs).parameters
    return [k for k in inspect.signature(make_task).parameters if k != "task" and k not in takes]


def _task_fields(env_id: str, task, spec) -> dict:
    """The fields of the task's declaration (its dataclass) that the kwarg ``task_options``
    overrides, with their values: each field is offered back at its own value, as the env's own
    check of ``task_options`` sees it (the batched tasks' ``from_kwargs``; the MuJoCo joint's
    constructor)."""
    import gymnasium as gym

    from cepam_gym.envs.task_registry import make_task
    from cepam_gym.errors import InputError

    out = {}
    for f in dataclasses.fields(task):
        value = getattr(task, f.name)
        try:
            if "task" in spec.kwargs:
                make_task(
                    spec.kwargs["task"], {f.name: value}, preview_steps=spec.kwargs.get("preview_steps", 0)
                )
            else:
                gym.make(env_id, task_options={f.name: value}).close()
        except (InputError, TypeError):
            continue
        out[f.name] = value
    return out


# how close the plant's stiffness comes to the first target's at rest on the reference: the
# inverse static model's pressures on the nominal plant (1.7 % at most over 20 seeds of each id)
START_STIFFNESS_TOL = 0.02


def starting_state(f: dict) -> list[str]:
    """The starting state, as the task's declaration has it (its reference kinds) and as
    ``tests/project/test_spec_pages.py`` checks against ``reset`` (20 seeds)."""
    (position, target), (stiffness, target_k) = (tuple(f"`{k}`" for k in pair) for pair in f["start_keys"])
    if f["starts_on_reference"]:
        return [
            "Each episode starts at rest on the first point of its reference: after `reset`, "
            f"{position} equals {target} and {stiffness} is within {START_STIFFNESS_TOL:.0%} of "
            f"{target_k} (the chamber pressures are the inverse static model's for the first target "
            "under the first load), so there is no jump at t = 0. The reference then moves smoothly "
            "(its kinds: the field `references`)."
        ]
    return [
        "Each episode starts at rest at a reachable operating point drawn apart from the first target: "
        f"after `reset`, ({position}, {stiffness}) is not ({target}, {target_k}), and the first "
        "set-point is a step away."
    ]


def _num(x) -> str:
    return f"{x:.6g}"


def _obs_rows(columns, preview_steps: int) -> list[str]:
    """One row per column, the preview columns of one quantity folded into one row."""
    rows, i = [], 0
    while i < len(columns):
        name, unit, offset, scale = columns[i]
        m = re.fullmatch(r"(.+)_\+1", name)
        if m and preview_steps > 1:
            last = i + preview_steps - 1
            rows.append(
                f"| {i}-{last} | `{m.group(1)}_+k`, k = 1..{preview_steps}: the target k control steps ahead "
                f"| {unit or '-'} | {_num(offset)} | {_num(scale)} |"
            )
            i = last + 1
            continue
        rows.append(f"| {i} | `{name}` | {unit or '-'} | {_num(offset)} | {_num(scale)} |")
        i += 1
    return rows


def spec_page(f: dict) -> str:
    """The Gymnasium-style spec page of one id, from :func:`env_facts`."""
    from cepam_gym import versions

    row = versions.get(f["id"])
    name, version = row.family, f"v{row.version}"
    sc, task = f["scales"], f["task"]
    joint = row.mechanism == "hinge"
    unit = (
        f"{sc.tracking_unit * 180 / 3.141592653589793:.3g} deg"
        if joint
        else f"{sc.tracking_unit * 100:.3g} cm"
    )
    lines = [
        f"# {f['id']}",
        "",
        f"| | |\n|---|---|\n| status | {f['status']} |",
        f"| action space | `{f['action_space']}` |",
        f"| observation space | `{f['observation_space']}` |",
        f"| plant preset | `{f['plant']}` |",
        f"| entry point | `{f['entry_point']}`{' (native vector env)' if f['vector'] else ''} |",
        f'| make | `gym.make("{f["id"]}")` |',
        "",
        "## Description",
        "",
        (JOINT_V0 if joint and version == "v0" else "") + DESCRIPTIONS[name],
        "",
        "## Action space",
        "",
        f"`{f['action_space']}`: one command per chamber `[CPAM, annulus]`. Out-of-range values are "
        "clipped; NaN, inf or a wrong shape raise `ValueError`. The kwarg `action_mode` sets what a "
        "command means:",
        "",
        "| action_mode | meaning of a command |",
        "|---|---|",
        *(f"| `{k}` | {v} |" for k, v in ACTION_MODES.items()),
        "",
        "## Observation space",
        "",
        f"`{f['observation_space']}`: what a rig measures, the targets and the previous action, "
        "scaled: `obs = (value - offset) / scale`, value in SI units, clipped to the box. The columns "
        "are named in `env.unwrapped.obs_layout` (`column(name)`, `decode(obs)` gives SI values).",
        "",
        "| # | observation | unit | offset | scale |",
        "|---|---|---|---|---|",
        *_obs_rows(f["columns"], f["preview_steps"]),
        "",
        "The true stiffness, load and every plant quantity are in `info`, in SI units.",
        "",
        "## Rewards",
        "",
        '`reward` is the sum of the terms below, each reported signed in `info["reward_<term>"]`.',
        "",
        "| term | value | weight `w` (kwarg `reward_weights`) |",
        "|---|---|---|",
    ]
    fmt = {
        "unit": unit,
        "clip": _num(sc.tracking_clip),
        "kclip": _num(sc.stiffness_clip),
        "kunit": _num(sc.stiffness_unit),
        "air": f"{sc.air_unit * 1e6:.3g} mg",
    }
    score_form = getattr(task, "reward_form", "abs") == "score"
    if score_form:
        lines[-3:-3] = [
            "The reward is the benchmark score's per-step form: squared errors at the score's trade, "
            "nothing paid within the 0.5 s settling allowance after a jump of a target (the steps the "
            "score leaves out), so the mean return ranks controllers as the score does "
            "([benchmark](../benchmark.md#reward-and-score-on-v3)).",
            "",
        ]
    formulas = {t.name: t.doc for t in task.reward.terms}  # the declaration's (tasks.reward)
    for term, w in f["weights"].items():
        lines.append(f"| {term} | `{formulas[term].format(**fmt)}` | {_num(w)} |")
    lines += [
        "",
        "## Starting state",
        "",
        *starting_state(f),
        "",
        "Targets change every `segment_duration` seconds and are drawn where the inverse static model "
        "finds pressures within the task's `pressure_margin` for every load of the segment: every "
        "episode is solvable. The task's fields, all of which the kwarg `task_options` overrides (SI "
        "units):",
        "",
        "| field | value |",
        "|---|---|",
        *(f"| `{k}` | `{v}` |" for k, v in f["task_fields"].items()),
        "",
        f"`reset(options={{...}})` pins any of {', '.join(f'`{k}`' for k in f['pin_keys'])} for the episode.",
        "",
        "## Episode end",
        "",
        f"**Truncation**: after `max_episode_steps` = {f['max_episode_steps']} control steps "
        f"({f['max_episode_steps'] * f['control_dt']:.3g} s at {1 / f['control_dt']:.3g} Hz).",
        "",
        '**Termination**: only on physical failure. `info["termination_reason"]` is an integer code '
        '(0 while running), named by `env.metadata["termination_reasons"]`: '
        + ", ".join(f"{i} `{n}`" for i, n in enumerate(f["termination"]) if i)
        + ".",
        "",
        "## Arguments",
        "",
        "`gym.make(id, **kwargs)`; the id registers "
        + (", ".join(f"`{k}={v!r}`" for k, v in f["registered_kwargs"].items()) or "no kwargs")
        + ". Unknown kwargs are refused by name.",
        "",
        "| kwarg | default | meaning |",
        "|---|---|---|",
    ]
    for k, default in f["kwargs"].items():
        lines.append(f"| `{k}` | `{default!r}` | {ARGUMENTS.get(k, '')} |")
    lines += ["", "## Version history", ""]
    for v in sorted(VERSIONS, reverse=True):
        ids = f"`cepam_gym/{name}-{v}`"
        if name == "CEPAMJoint" and v == "v0":
            lines.append(f"* {ids}: the hinge simulated in MuJoCo (the `[mujoco]` extra); {VERSIONS[v]}")
        else:
            lines.append(f"* {ids}: {VERSIONS[v]}")
    lines += ["", "What changed in each release: [the changelog](../changelog.md).", ""]
    return "\n".join(lines)


def registered_ids() -> list[str]:
    from cepam_gym import versions

    return sorted(versions.ids(), key=lambda i: (-versions.get(i).version, i))  # newest version first


def index_page(ids: list[str]) -> str:
    from cepam_gym import versions

    rows = []
    for env_id in ids:
        row = versions.get(env_id)
        rows.append(
            f"| [`{env_id}`]({row.name}.md) | {row.status} | {DESCRIPTIONS[row.family].split('Task: ')[-1]} |"
        )
    return "\n".join(
        [
            "# Environments",
            "",
            "Every registered id, newest version first; each page is generated from the code when the "
            "site is built. `import cepam_gym` registers them all (`gym.make` and `gym.make_vec`).",
            "",
            "| id | status | task |",
            "|---|---|---|",
            *rows,
            "",
        ]
    )


def reference_tables() -> str:
    """The stored references of every suite: the zero controller's, the baseline's and the oracle's
    scores, the zero controller's headline (``cepam_gym.bench.headline``), and the mean episode
    returns that are a Minari dataset's ``ref_min_score`` / ``ref_max_score``."""
    from cepam_gym import versions
    from cepam_gym.bench.headline import headline_score
    from cepam_gym.bench.suites import SUITES

    data = ROOT / "src/cepam_gym/data"
    # the suites' own episodes, then the unseen seed's (the reference grid's second episode set)
    tables = [
        json.loads((data / name).read_text()) for name in ("reference_scores.json", "unseen_references.json")
    ]

    def version_of(suite: str) -> int:  # a stored suite no longer defined goes first
        return versions.get(SUITES[suite].env_id).version if suite in SUITES else -1

    def cell(r, key, fmt):
        return format(r[key], fmt) if key in r else "-"

    rows = [
        f"| `{suite}` | {r['seed']} | {r['episodes']} | {r['zero']:.4f} | {cell(r, 'baseline', '.4f')} "
        f"| {r['oracle']:.4f} | "
        + (f"{headline_score(r['zero'], r['baseline'], r['oracle']):.0f}" if "baseline" in r else "-")
        + f" | {cell(r, 'zero_return', '.1f')} | {cell(r, 'oracle_return', '.1f')} |"
        for refs in tables
        for suite, r in sorted(refs.items(), key=lambda kv: (version_of(kv[0]), kv[0]))
    ]
    head = (
        "| suite | seed | episodes | zero | baseline (headline 0) | oracle (headline 100, normalized 100) "
        "| headline of zero | zero's mean return (Minari min) | oracle's mean return (Minari max) |"
    )
    return "\n".join([head, "|---|---|---|---|---|---|---|---|---|", *rows])


def on_files(files, config):
    from mkdocs.structure.files import File

    from cepam_gym import versions

    ids = registered_ids()
    pages = {f"envs/{versions.get(i).name}.md": spec_page(env_facts(i)) for i in ids}
    pages["envs/index.md"] = index_page(ids)
    configs = (ROOT / "configs/README.md").read_text()
    pages["configs.md"] = configs.replace("# Training configs", "# Training configs (`configs/`)", 1)
    pages["changelog.md"] = (ROOT / "CHANGELOG.md").read_text()
    for uri, text in pages.items():
        files.append(File.generated(config, uri, content=text))
    return files


def on_page_markdown(markdown, page, config, files):
    return markdown.replace("<!-- reference-scores -->", reference_tables())
