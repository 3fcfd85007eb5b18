"""The constraints files pin every package the Makefile's venvs install, at one version each, and the
Makefile installs from them; a run records the versions and machine facts its numbers depend on."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MAKEFILE = (ROOT / "Makefile").read_text()


def _make_var(name: str) -> str:
    m = re.search(rf"^{name}\s*:=\s*(\S+)\s*$", MAKEFILE, re.M)
    assert m, f"Makefile sets no {name}"
    return m.group(1)


def _pins(path: Path) -> dict[str, str]:
    pins: dict[str, str] = {}
    for line in path.read_text().splitlines():
        line = line.split("#")[0].strip()
        if not line:
            continue
        name, sep, version = line.partition("==")
        assert sep and version and not re.search(r"[<>=!~,;]", version), f"{path.name}: not a pin: {line}"
        key = re.sub(r"[-_.]+", "-", name.lower())
        assert key not in pins, f"{path.name}: {name} pinned twice"
        pins[key] = version
    return pins


def _requirement_names(reqs: list[str]) -> set[str]:
    return {re.sub(r"[-_.]+", "-", re.match(r"[A-Za-z0-9._-]+", r).group(0).lower()) for r in reqs}


@pytest.mark.parametrize(("lock_var", "extras_var"), [("LOCK", "MAIN_EXTRAS"), ("RAY_LOCK", "RAY_EXTRAS")])
def test_constraints_pin_every_declared_requirement_and_torch(lock_var, extras_var):
    lock = ROOT / _make_var(lock_var)
    pins = _pins(lock)
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    wanted = _requirement_names(project["dependencies"])
    for extra in _make_var(extras_var).split(","):
        wanted |= _requirement_names(project["optional-dependencies"][extra])
    missing = sorted(wanted - set(pins))
    assert not missing, f"{lock.name} pins none of {missing}: run make lock"
    assert "cepam-gym" not in pins  # the package itself is installed from the checkout
    torch = _make_var("TORCH")
    assert f"torch=={pins['torch']}" == torch, f"{lock.name} pins torch {pins['torch']}, the Makefile {torch}"


def test_makefile_installs_every_venv_with_its_constraints():
    recipe = MAKEFILE.split("define venv", 1)[1].split("endef", 1)[0]
    installs = [line for line in recipe.splitlines() if "pip install" in line and "--upgrade pip" not in line]
    assert installs and all("-c $(3)" in line for line in installs), installs
    for lock_var, extras_var in (("LOCK", "MAIN_EXTRAS"), ("RAY_LOCK", "RAY_EXTRAS")):
        assert f",$({extras_var}),$({lock_var}))" in MAKEFILE
    assert re.search(r"^lock:\n\tpython3 requirements/lock.py", MAKEFILE, re.M)


def test_a_run_records_the_versions_and_the_machine_its_numbers_depend_on():
    from cepam_gym_agents.session.provenance import package_versions

    v = package_versions()
    for name in ("numpy", "numba", "llvmlite", "scipy", "gymnasium", "torch", "stable-baselines3"):
        assert v[name], name
    assert "sb3-contrib" in v and "cloudpickle" in v
    assert v["cpu_llvm"]  # numba compiles for this CPU
