"""What a run directory records about where it came from: ``run.json`` (seed, command line, package
versions, git commit, one entry per training session), with the helpers every run-directory file
uses (an atomic JSON write, a UTC timestamp)."""

from __future__ import annotations

import json
import os
import platform
import subprocess
from datetime import UTC, datetime
from pathlib import Path


def now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def write_json(path: Path, data) -> None:
    """Write through a temporary file and a rename: a reader (or a kill) never sees half a file."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(data, indent=2, default=str))
    os.replace(tmp, path)


# the packages a run's numbers depend on: the compiled plant and tasks (numba and its LLVM, numpy),
# the teachers' and the metrics' numerics (scipy), the training and the saved policies (torch, SB3,
# sb3-contrib, cloudpickle), the envs' API (gymnasium); docs/reproducibility.md
_PACKAGES = (
    "cepam-gym",
    "numpy",
    "numba",
    "llvmlite",
    "scipy",
    "gymnasium",
    "torch",
    "stable-baselines3",
    "sb3-contrib",
    "cloudpickle",
    "pyyaml",
)


def package_versions() -> dict:
    """The versions of :data:`_PACKAGES` (None: not installed), Python's, and the machine facts that
    move floating-point results between machines (:func:`machine`)."""
    from importlib import metadata

    out = {"python": platform.python_version(), "platform": platform.platform()}
    for name in _PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    return {**out, **machine()}


def machine() -> dict:
    """What the compiled code was built for: numba compiles the kernels for the host CPU as LLVM
    names it (its vector width and instructions), torch picks its kernels by the CPU's capability
    (AVX2, AVX512); the same versions on another CPU may round differently."""
    out: dict = {"cpu_llvm": None, "torch_cpu_capability": None}
    try:
        import llvmlite.binding as llvm
        import numba

        out["cpu_llvm"] = numba.config.CPU_NAME or llvm.get_host_cpu_name()  # NUMBA_CPU_NAME overrides
    except Exception:  # provenance is best effort: it never fails a run
        pass
    try:
        import torch

        out["torch_cpu_capability"] = torch.backends.cpu.get_cpu_capability()
    except Exception:  # the same
        pass
    return out


def git_state() -> dict:
    root = Path(__file__).resolve().parents[2]  # agents/session/ -> the checkout
    try:
        commit = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, timeout=10
        ).stdout.strip()
        dirty = (
            subprocess.run(
                ["git", "status", "--porcelain", "--untracked-files=no"],
                cwd=root,
                capture_output=True,
                text=True,
                timeout=10,
            ).stdout.strip()
            != ""
        )
        return {"commit": commit or None, "dirty": dirty if commit else None}
    except (OSError, subprocess.SubprocessError):
        return {"commit": None, "dirty": None}


class RunRecord:
    """``run.json`` of one run directory, as one training session updates it: the run's seed,
    creation time, versions and git state (written once), then one entry per session whose status
    and extra fields each :meth:`write` updates (the fields accumulate over the session)."""

    def __init__(self, run: Path, seed: int, argv: list[str] | None):
        self.path = Path(run) / "run.json"
        self.seed, self.argv = seed, argv
        self._extra: dict = {}
        self._started: str | None = None

    def write(self, status: str, start_step: int, **extra) -> None:
        data = (
            json.loads(self.path.read_text())
            if self.path.is_file()
            else {
                "seed": self.seed,
                "created": now(),
                "versions": package_versions(),
                "git": git_state(),
                "sessions": [],
            }
        )
        self._extra = {**self._extra, **extra}
        session = {
            "started": self._started or now(),
            "argv": self.argv,
            "start_step": start_step,
            "status": status,
            "versions": package_versions(),
            **self._extra,
        }
        self._started = session["started"]
        if data["sessions"] and data["sessions"][-1].get("started") == session["started"]:
            data["sessions"][-1] = session
        else:
            last = data["sessions"][-1] if data["sessions"] else None
            if last is not None and last.get("status") == "running":
                last["status"] = "killed"  # we hold the run's lock: that session is gone (SIGKILL, crash)
            data["sessions"].append(session)
        data["status"] = status
        write_json(self.path, data)
