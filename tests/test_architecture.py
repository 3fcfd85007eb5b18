"""The package's shape, read from its source: no import cycles, no training code, layers that
only look down.

Every ``import`` statement of every module of ``src/cepam_gym`` counts, wherever it stands (module
level, inside functions, under ``if TYPE_CHECKING``): an import hidden in a function still ties
two modules together, it only defers the failure. An edge goes to the module that is named
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
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PKG = "cepam_gym"


def _module_name(path: Path) -> str:
    parts = path.relative_to(SRC).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(p): p for p in sorted((SRC / PKG).rglob("*.py"))}


def _is_package(name: str) -> bool:
    return MODULES[name].name == "__init__.py"


def _imports(name: str) -> list[tuple[str, int]]:
    """``(absolute module name, line)`` of every import in module ``name`` (names as written,
    relative ones resolved; ``from X import y`` gives ``X.y`` when that is a module, else ``X``)."""
    tree = ast.parse(MODULES[name].read_text(), filename=str(MODULES[name]))
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
                out.append((sub if sub in MODULES else mod, node.lineno))
    return out


def _internal_target(mod: str) -> str | None:
    """The module of ``cepam_gym`` that an import of ``mod`` names (the longest known prefix)."""
    parts = mod.split(".")
    for k in range(len(parts), 0, -1):
        cand = ".".join(parts[:k])
        if cand in MODULES:
            return cand
    return None


def _graph() -> dict[str, dict[str, int]]:
    """module -> {imported module of cepam_gym: line of the first such import}."""
    graph: dict[str, dict[str, int]] = {}
    for name in MODULES:
        edges: dict[str, int] = {}
        for mod, line in _imports(name):
            target = _internal_target(mod) if mod.split(".")[0] == PKG else None
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
    assert "cepam_gym.control" in _graph()["cepam_gym.mujoco.video"]
    assert "cepam_gym.mujoco.rig" in _graph()["cepam_gym.envs.cepam"]  # inside render()
    assert _find_cycle({"a": {"b": 1}, "b": {"c": 1}, "c": {"a": 1}}) == ["a", "b", "c", "a"]
    assert _find_cycle({"a": {"b": 1}, "b": {}}) is None


def test_no_import_cycle_between_modules():
    graph = _graph()
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


def test_nothing_imports_the_sb3_adapter_but_its_old_path():
    users = [n for n, edges in _graph().items() if "cepam_gym.integrations.sb3" in edges]
    assert users == ["cepam_gym.envs.sb3"]


def test_importing_the_library_loads_no_torch_and_no_training_code():
    code = (
        "import sys\n"
        "import cepam_gym, cepam_gym.control, cepam_gym.bench, cepam_gym.envs, cepam_gym.cli\n"
        "import cepam_gym.integrations, cepam_gym.integrations.rllib, cepam_gym.rllib\n"
        "from cepam_gym.control import controller_names\n"
        "controller_names()\n"
        "bad = [m for m in sys.modules if m.split('.')[0] in "
        "('torch', 'stable_baselines3', 'agents', 'cepam_gym_agents', 'mujoco', 'ray')]\n"
        "assert not bad, bad\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr


# --------------------------------------------------------------------------- layers
# Each module's layer by its longest matching name prefix; a module imports nothing of a higher
# layer. The MuJoCo modules sit where their job is: the coupling beside the plant, the joint's
# task beside the tasks, the rig renderer and the joint env with the envs, ``cepam-gym video`` on top.
LAYERS = {
    "foundation": (
        "cepam_gym._jit",
        "cepam_gym.units",
        "cepam_gym.registration",
        "cepam_gym.viewer",
        "cepam_gym.mujoco._mj",
    ),
    "physics": ("cepam_gym.physics",),
    "plant": ("cepam_gym", "cepam_gym.params", "cepam_gym.plant", "cepam_gym.mujoco.coupling"),
    "tasks": ("cepam_gym.tasks", "cepam_gym.mujoco.joint_task"),
    "envs": (
        "cepam_gym.envs",
        "cepam_gym.mujoco.rig",
        "cepam_gym.mujoco.joint",
        "cepam_gym.mujoco.joint_sim",
        "cepam_gym.mujoco.joint_view",
    ),
    "control": ("cepam_gym.control",),
    "bench": ("cepam_gym.bench",),
    "top": (
        "cepam_gym.cli",
        "cepam_gym.demo",
        "cepam_gym.validation",
        "cepam_gym.identify",
        "cepam_gym.integrations",
        "cepam_gym.rllib",
        "cepam_gym.mujoco",
        "cepam_gym.mujoco.video",
    ),
}
ORDER = list(LAYERS)
# upward imports that are the point of a module, each with its reason
UPWARD_OK = {
    ("cepam_gym.envs.sb3", "cepam_gym.integrations.sb3"): "the adapter's old import path, kept as an alias",
}


def _layer(name: str) -> str:
    best, layer = -1, None
    for lay, prefixes in LAYERS.items():
        for p in prefixes:
            if (name == p or name.startswith(p + ".")) and len(p) > best:
                best, layer = len(p), lay
    assert layer is not None, f"{name}: give it a layer in tests/test_architecture.py LAYERS"
    return layer


def _upward(name: str, graph) -> list[str]:
    rank = ORDER.index(_layer(name))
    return [
        f"{name} ({_layer(name)}) imports {t} ({_layer(t)}) at line {line}"
        for t, line in sorted(graph[name].items())
        if ORDER.index(_layer(t)) > rank and (name, t) not in UPWARD_OK
    ]


def test_every_module_has_a_layer():
    for name in MODULES:
        _layer(name)


@pytest.mark.parametrize("layer", [lay for lay in ORDER if lay != "top"])
def test_layers_import_only_downward(layer):
    """physics imports nothing above it; plant nothing of tasks, envs, control, bench; tasks nothing
    of envs, control, bench; envs (the joint env included) nothing of control or bench."""
    graph = _graph()
    bad = [v for name in MODULES if _layer(name) == layer for v in _upward(name, graph)]
    assert not bad, bad
