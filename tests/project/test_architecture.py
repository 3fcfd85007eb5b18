"""The packages' shape, read from their source: no import cycles, no training code in the library,
layers that only look down.

Every ``import`` statement of every module of ``src/cepam_gym`` and of the training package
(``agents/``, installed as ``cepam_gym_agents``) counts, wherever it stands (module level, inside
functions, under ``if TYPE_CHECKING``): an import hidden in a function still ties two modules
together, it only defers the failure. An edge goes to the module that is named
(``from ..control import make_controller`` -> ``cepam_gym.control``, the package's ``__init__``;
``from .. import plant`` -> ``cepam_gym.plant``); the parent packages that Python runs first are
not edges, since a submodule always runs after its parents' ``__init__`` has started, whichever
module asks for it. No exception is needed for package ``__init__`` files: they import their own
submodules and none of those imports its package's ``__init__`` back.
"""

from __future__ import annotations

import ast
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / "src"
PKG = "cepam_gym"
AGENTS = "cepam_gym_agents"  # the training package: the folder agents/, installed under this name


def _modules(folder: Path, package: str) -> dict[str, Path]:
    """module name -> file, for every module of the package whose source is ``folder``."""
    out = {}
    for path in sorted(folder.rglob("*.py")):
        parts = path.relative_to(folder).with_suffix("").parts
        out[".".join((package, *(parts[:-1] if parts[-1] == "__init__" else parts)))] = path
    return out


MODULES = _modules(SRC / PKG, PKG)
AGENT_MODULES = _modules(ROOT / "agents", AGENTS)
ALL_MODULES = {**MODULES, **AGENT_MODULES}


def _is_package(name: str) -> bool:
    return ALL_MODULES[name].name == "__init__.py"


def _imports(name: str) -> list[tuple[str, int]]:
    """``(absolute module name, line)`` of every import in module ``name`` (names as written,
    relative ones resolved; ``from X import y`` gives ``X.y`` when that is a module, else ``X``)."""
    tree = ast.parse(ALL_MODULES[name].read_text(), filename=str(ALL_MODULES[name]))
    package = name if _is_package(name) else name.rpartition(".")[0]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(alias.name, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module
            for alias in node.names:
                sub = f"{mod}.{alias.name}"
                out.append((sub if sub in ALL_MODULES else mod, node.lineno))
    return out


def _internal_target(mod: str) -> str | None:
    """The module of ``cepam_gym`` or of the training package that an import of ``mod`` names (the
    longest known prefix)."""
    parts = mod.split(".")
    for k in range(len(parts), 0, -1):
        cand = ".".join(parts[:k])
        if cand in ALL_MODULES:
            return cand
    return None


def _graph(package: str = PKG) -> dict[str, dict[str, int]]:
    """module of ``package`` -> {imported module of cepam_gym or of the training package: line of
    the first such import}."""
    graph: dict[str, dict[str, int]] = {}
    for name in ALL_MODULES:
        if name.split(".")[0] != package:
            continue
        edges: dict[str, int] = {}
        for mod, line in _imports(name):
            target = _internal_target(mod)
            if target is not None and target != name:
                edges.setdefault(target, line)
        graph[name] = edges
    return graph


def _find_cycle(graph: dict[str, dict[str, int]]) -> list[str] | None:
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(u: str) -> list[str] | None:
        state[u] = 1
        path.append(u)
        for v in sorted(graph[u]):
            if state.get(v) == 1:
                return path[path.index(v) :] + [v]
            if v not in state:
                found = visit(v)
                if found:
                    return found
        path.pop()
        state[u] = 2
        return None

    for u in sorted(graph):
        if u not in state:
            found = visit(u)
            if found:
                return found
    return None


def test_the_graph_reader_sees_imports_inside_functions():
    # the check below is only as good as this reader: a known import inside a function
    assert "cepam_gym.control" in _graph()["cepam_gym.video"]
    assert "cepam_gym.mujoco.rig" in _graph()["cepam_gym.envs.shared"]  # inside mujoco_frames()
    agents = _graph(AGENTS)
    assert "cepam_gym_agents.learners.student" in agents["cepam_gym_agents.session.trainer"]  # inside train()
    assert "cepam_gym.bench.suites" in agents["cepam_gym_agents.config.schema"]  # inside a method
    assert set(agents) == set(AGENT_MODULES) and "cepam_gym_agents.main_job" in agents
    assert _find_cycle({"a": {"b": 1}, "b": {"c": 1}, "c": {"a": 1}}) == ["a", "b", "c", "a"]
    assert _find_cycle({"a": {"b": 1}, "b": {}}) is None


def test_no_import_cycle_between_modules():
    """Among the modules of the library and of the training package, across the two included."""
    graph = {**_graph(PKG), **_graph(AGENTS)}
    cycle = _find_cycle(graph)
    if cycle:
        steps = [f"{a} (line {graph[a][b]}) -> {b}" for a, b in zip(cycle, cycle[1:])]
        pytest.fail("import cycle:\n  " + "\n  ".join(steps))


# --------------------------------------------------------------------------- the training code
TRAINING = ("agents", "cepam_gym_agents")
HEAVY = ("torch",)
# the SB3 adapter exists to import stable-baselines3 (the [train] extra); no other module may
ALLOWED_EXTERNAL = {"stable_baselines3": {"cepam_gym.integrations.sb3"}}


def test_cepam_gym_never_imports_the_training_code_or_torch():
    bad = []
    for name in MODULES:
        for mod, line in _imports(name):
            top = mod.split(".")[0]
            if top in TRAINING + HEAVY or (top in ALLOWED_EXTERNAL and name not in ALLOWED_EXTERNAL[top]):
                bad.append(f"{MODULES[name].relative_to(SRC)}:{line} imports {mod}")
    assert not bad, bad


def test_no_module_path_of_the_training_code_in_the_library():
    """An ``import_module("agents.train")`` or a lazy ``"cepam_gym_agents.x:y"`` would be an import
    in disguise: the library names the training package only in docstrings (the entry points that
    lead there are declared in pyproject.toml)."""
    pattern = re.compile(r"^(agents|cepam_gym_agents)(\.[A-Za-z_]\w*)*(:[\w.]+)?$")
    bad = []
    for path in MODULES.values():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and pattern.match(node.value):
                bad.append(f"{path.relative_to(SRC)}:{node.lineno}: {node.value!r}")
    assert not bad, bad


def test_nothing_in_the_library_imports_the_sb3_adapter():
    """The adapter imports stable-baselines3; it is imported only by its users."""
    users = [n for n, edges in _graph().items() if "cepam_gym.integrations.sb3" in edges]
    assert users == []


def test_importing_the_library_loads_no_torch_and_no_training_code():
    code = (
        "import sys\n"
        "import cepam_gym, cepam_gym.control, cepam_gym.bench, cepam_gym.envs, cepam_gym.cli\n"
        "import cepam_gym.integrations, cepam_gym.integrations.rllib, cepam_gym.rllib\n"
        "import cepam_gym.offline, cepam_gym.offline.cli, cepam_gym.offline.store\n"
        "import cepam_gym.rig.cli, cepam_gym.rig.deploy, cepam_gym.rig.emulator, cepam_gym.rig.onnx_policy\n"
        "import cepam_gym.policies, cepam_gym.policies.privileged\n"
        "from cepam_gym.control import controller_names\n"
        "controller_names()\n"
        "bad = [m for m in sys.modules if m.split('.')[0] in "
        "('torch', 'stable_baselines3', 'agents', 'cepam_gym_agents', 'mujoco', 'ray', 'minari', 'h5py', "
        "'onnxruntime', 'onnx')]\n"
        "assert not bad, bad\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr


# --------------------------------------------------------------------------- the training package
# It stands on the library: it imports cepam_gym (never the other way round, tested above) and is
# reached from cepam_gym.cli only through the entry points it declares in pyproject.toml.
COMMANDS = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"][
    "cepam_gym.commands"
]


def test_the_training_package_imports_itself_by_its_installed_name():
    """``agents/`` installs as ``cepam_gym_agents``: an ``import agents.x`` works in a checkout only."""
    bad = [
        f"{AGENT_MODULES[name].relative_to(ROOT)}:{line} imports {mod}"
        for name in AGENT_MODULES
        for mod, line in _imports(name)
        if mod.split(".")[0] == "agents"
    ]
    assert not bad, bad


def test_the_training_package_never_imports_the_command_line_that_dispatches_to_it():
    """``cepam_gym.cli`` runs the training package's commands (``run``, ``train``, ``eval``) by their
    entry points; importing the command line back would close a circle through them."""
    bad = [
        f"{name} imports cepam_gym.cli at line {edges['cepam_gym.cli']}"
        for name, edges in _graph(AGENTS).items()
        if "cepam_gym.cli" in edges
    ]
    assert not bad, bad


def test_the_commands_of_the_training_package_load_without_torch():
    """The command line loads a command's module to run it, ``--help`` included; the main job runs
    without the [train] extra with ``--no-train``: torch and SB3 are imported only to train or
    to load a model."""
    assert set(COMMANDS) == {"run", "train", "eval", "export"}
    modules = sorted({target.partition(":")[0] for target in COMMANDS.values()})
    code = (
        "import importlib, sys\n"
        f"for m in {modules!r}:\n"
        "    importlib.import_module(m)\n"
        "bad = [m for m in sys.modules if m.split('.')[0] in ('torch', 'stable_baselines3', 'sb3_contrib')]\n"
        "assert not bad, bad\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr


# --------------------------------------------------------------------------- layers
# The folders are the layers, bottom-up; a module imports nothing of a higher layer, and a module
# of a folder imports nothing of a folder above its own. The package root's own modules are either
# foundations (imported by everything) or applications on top (the CLI and its commands).
FOLDER_LAYERS = (
    "physics",  # pure functions over parameter rows: no state layout, no RNG, no reward
    "plant",  # parameters, state layout, the sub-step and its compiled kernels, the MuJoCo coupling
    "tasks",  # task declarations: targets, loads, observation layouts, reward terms, info, schedules
    "planning",  # the reset's planner: each episode's targets, loads, starting point, plant draws
    "mujoco",  # rendering and the MuJoCo reference simulations only
    "envs",  # the Gymnasium API, single and batched: the rig's and both joints'
    "control",  # every controller behind one protocol and a registry
    "bench",  # suites, metrics, the harness
    "offline",  # offline-RL datasets (Minari) of the benchmark's rollouts
    "validation",  # the paper's experiments, calibration, the fitting core
    "identify",  # fitting the plant's dynamics to a rig's logs (on the fitting core)
    "policies",  # what a learned policy sees and sends: residual, target shift, history, plant features
    "rig",  # a rig's protocol and transport, the safety supervisor, deployment, the emulated rig
    "integrations",  # adapters to SB3 and RLlib
)
ROOT_FOUNDATION = {
    "_jit",
    "errors",
    "units",
    "registration",
    "versions",
    "viewer",
    "cli_errors",
    "_cli_errors",
    "progress",
}
ROOT_TOP = {"cli", "demo", "video", "rllib", "precompile"}
LAYERS = ["foundation", *FOLDER_LAYERS, "top"]
# the package's face (``cepam_gym/__init__``: the PlantParams re-export and the registration)
FACE = PKG


def _folder_layer(name: str) -> str:
    parts = name.split(".")
    if name == FACE:
        return "top"
    if len(parts) == 2 or (len(parts) > 2 and parts[1] not in FOLDER_LAYERS):
        top = parts[1]
        assert top in ROOT_FOUNDATION | ROOT_TOP | set(FOLDER_LAYERS), (
            f"{name}: a module at the package root must be named in ROOT_FOUNDATION or ROOT_TOP "
            "of tests/project/test_architecture.py, or live in one of the layer folders"
        )
        return "foundation" if top in ROOT_FOUNDATION else "top" if top in ROOT_TOP else top
    return parts[1]


def _layer(name: str) -> str:
    return _folder_layer(name)


def _upward(name: str, graph) -> list[str]:
    rank = LAYERS.index(_layer(name))
    return [
        f"{name} ({_layer(name)}) imports {t} ({_layer(t)}) at line {line}"
        for t, line in sorted(graph[name].items())
        if LAYERS.index(_layer(t)) > rank
    ]


def test_the_folders_are_the_layers():
    """Every folder of the package is a layer (a new folder must be placed in FOLDER_LAYERS)."""
    folders = {p.name for p in (SRC / PKG).iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    assert folders - {"data", "presets"} == set(FOLDER_LAYERS)


def test_every_module_has_a_layer():
    for name in MODULES:
        _layer(name)


@pytest.mark.parametrize("layer", [lay for lay in LAYERS if lay != "top"])
def test_layers_import_only_downward(layer):
    """physics imports nothing above it; plant nothing of tasks, mujoco, envs...; tasks nothing of
    mujoco, envs, control...; mujoco nothing of envs or control; envs (both joints included) nothing
    of control, bench or integrations. Imports inside functions count."""
    graph = _graph()
    bad = [v for name in MODULES if _layer(name) == layer for v in _upward(name, graph)]
    assert not bad, bad


# --------------------------------------------------------------------------- registries
# A registry's lazy entry ("module:attr") or an import_module("module") argument is an import in
# disguise: it ties the two modules together at run time, and a layer must not name a module of a
# layer above it that way either. Controllers of higher layers register through the entry-point
# group the registry reads (declared in pyproject.toml, checked below), not by a string in control.
MODULE_STRING = re.compile(r"^cepam_gym(\.[A-Za-z_]\w*)+(:[\w.]+)?$")
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def _named_modules(name: str) -> dict[str, int]:
    """{module of the library that a string constant of module ``name`` names: its line}: strings
    that are a module's whole dotted name, alone or as ``"module:attr"`` (docstrings that mention a
    module in prose do not match)."""
    out: dict[str, int] = {}
    for node in ast.walk(ast.parse(ALL_MODULES[name].read_text())):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and MODULE_STRING.match(node.value):
            target = node.value.partition(":")[0]
            if target in MODULES and target != name:
                out.setdefault(target, node.lineno)
    return out


def test_the_registry_reader_sees_lazy_entries():
    assert "cepam_gym.control.mpc" in _named_modules("cepam_gym.control.registry")
    assert MODULE_STRING.match("cepam_gym.identify.identify_mpc:IdentifyMPC")
    assert not MODULE_STRING.match("the MPC of :mod:`cepam_gym.control.mpc`")


def _gym_entry_points() -> set[str]:
    """The env classes the version table registers with Gymnasium: Gymnasium's registry takes them
    as ``"module:Class"`` strings by design and resolves them in ``make``; they are the table's
    published entry points (docs/versions.md), the one kind of string allowed to name a layer
    above the table's."""
    from cepam_gym import versions

    rows = versions.VERSIONS.values()
    return {ep for row in rows for ep in (row.entry_point, row.vector_entry_point) if ep}


def _string_edges(name: str) -> dict[str, int]:
    """:func:`_named_modules` without the version table's Gymnasium entry points."""
    allowed = {ep.partition(":")[0] for ep in _gym_entry_points()} if name == f"{PKG}.versions" else set()
    return {t: line for t, line in _named_modules(name).items() if t not in allowed}


@pytest.mark.parametrize("layer", [lay for lay in LAYERS if lay != "top"])
def test_no_string_names_a_module_of_a_higher_layer(layer):
    bad = [
        f"{name} ({layer}) names {t} ({_layer(t)}) at line {line}"
        for name in MODULES
        if _layer(name) == layer
        for t, line in sorted(_string_edges(name).items())
        if LAYERS.index(_layer(t)) > LAYERS.index(layer)
    ]
    assert not bad, bad


def test_no_import_cycle_with_the_lazy_entries():
    """The string edges count as imports: a lazy entry that closes a circle is a runtime cycle."""
    graph = _graph(PKG)
    for name in graph:
        for target, line in _string_edges(name).items():
            graph[name].setdefault(target, line)
    cycle = _find_cycle(graph)
    assert cycle is None, cycle


def test_the_librarys_entry_points_name_its_modules():
    """What the library's own distribution registers in the groups it reads (pyproject.toml) names
    existing modules: the registrations of higher layers are visible here, not hidden in strings."""
    groups = PYPROJECT["project"]["entry-points"]
    own = {
        (group, name): target
        for group, entries in groups.items()
        for name, target in entries.items()
        if target.startswith(f"{PKG}.")
    }
    assert own, "the library registers nothing through entry points"
    for (group, name), target in own.items():
        assert target.partition(":")[0] in MODULES, f"{group}: {name} = {target!r} names no module"


# --------------------------------------------------------------------------- public surface
# the training package imports the library's public modules only (cepam_gym.cli_errors, not the
# alias _cli_errors). Modules listed here still import a private alias; the second test fails once
# one no longer does, so the list only shrinks.
PRIVATE_IMPORT_PENDING: set[str] = set()


def _private_imports(name: str) -> list[str]:
    return [
        f"{mod} at line {line}"
        for mod, line in _imports(name)
        if mod.split(".")[0] == PKG and any(part.startswith("_") for part in mod.split(".")[1:])
    ]


def test_the_training_package_imports_only_public_modules_of_the_library():
    bad = {n: _private_imports(n) for n in AGENT_MODULES if n not in PRIVATE_IMPORT_PENDING}
    assert not {n: v for n, v in bad.items() if v}, bad


def test_the_pending_list_only_names_modules_that_still_need_it():
    assert all(_private_imports(n) for n in PRIVATE_IMPORT_PENDING), "remove switched modules from the list"


def test_the_private_error_module_is_the_public_one():
    import cepam_gym._cli_errors as old
    import cepam_gym.cli_errors as new

    assert old is new
