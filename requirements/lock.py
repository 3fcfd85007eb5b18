"""Write the constraints files the Makefile installs from: every package, transitive ones included,
pinned to the version pip resolves today for the main venv's extras and for the Ray venv's.

``make lock`` runs it with the Makefile's torch pin and each venv's constraints file and extras::

    python3 requirements/lock.py --torch torch==2.13.0 \
        requirements/constraints.txt=train,test,mujoco,zoo,offline \
        requirements/constraints-ray.txt=train,test,distributed

pip resolves the CPU torch wheel and the package with its extras as a fresh
install would (``--dry-run --ignore-installed``: nothing is installed, no venv is built) and its
JSON report gives each package's version. Run it with the Python the venvs are built from (the
resolution follows its version and platform); review the diff and re-measure the README's figures
before committing a new lock (docs/reproducibility.md).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from datetime import UTC, datetime
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def resolve(torch: str, extras: str) -> dict[str, str]:
    """What ``pip install <torch> -e .[extras]`` installs in an empty venv, as {name: version}."""
    cmd = [sys.executable, "-m", "pip", "install", "--dry-run", "--ignore-installed", "--quiet"]
    cmd += ["--report", "-", torch, "-e", f"{ROOT}[{extras}]"]
    report = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True, cwd=ROOT).stdout)
    pins = {}
    for item in report["install"]:
        meta = item["metadata"]
        name = meta["name"].lower().replace("_", "-")
        if name == "cepam-gym":
            continue
        # a local label (torch's "+cpu") names the wheel, not the release: "==2.13.0" matches it
        pins[name] = meta["version"].split("+")[0]
    return pins


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    # torch first and pinned: the CPU wheel (the Makefile's TORCH); a bare "torch" pulls a CUDA build
    p.add_argument("--torch", required=True, help="the torch requirement, e.g. torch==2.13.0")
    p.add_argument("locks", nargs="+", metavar="FILE=EXTRAS", help="a constraints file and its extras")
    args = p.parse_args(argv)
    py = ".".join(map(str, sys.version_info[:3]))
    for spec in args.locks:
        fname, sep, extras = spec.partition("=")
        if not sep or not extras:
            p.error(f"expected FILE=EXTRAS (e.g. requirements/constraints.txt=train,test), got {spec!r}")
        pins = resolve(args.torch, extras)
        head = [
            f"# Every package of a venv with the extras [{extras}], pinned (python {py},",
            f"# resolved {datetime.now(UTC).date()}). Written by `make lock` (requirements/lock.py);",
            "# the Makefile installs with `pip install -c` this file. docs/reproducibility.md.",
        ]
        lines = head + [f"{n}=={v}" for n, v in sorted(pins.items())]
        Path(fname).write_text("\n".join(lines) + "\n")
        print(f"{fname}: {len(pins)} packages")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
