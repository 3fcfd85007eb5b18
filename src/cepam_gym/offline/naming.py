"""Dataset ids: ``cepam/<env>/<task>-<controller>-v<version>``, for example
``cepam/CEPAM-v1/randomized-oracle-v0``.

The namespace ``cepam`` groups every dataset of this package; ``<env>`` is the Gymnasium id
without its namespace (``cepam_gym/CEPAM-v1`` -> ``CEPAM-v1``), so the env's version is in the
namespace, and the task is the suite's name without that version (``randomized-v1`` ->
``randomized``). The last ``-v<version>`` is the dataset's own version (Minari's convention),
raised when a dataset is re-made differently. A trained run directory is named by its folder.
"""

from __future__ import annotations

import re
from pathlib import Path

from .. import versions
from ..bench.suites import Suite
from ..errors import InputError

NAMESPACE = "cepam"
# Minari's dataset id: (namespace/)name(-v<version>), names of [-_A-Za-z0-9] (minari.dataset_id)
_NAME = re.compile(r"^[-_A-Za-z0-9]+$")


def task_name(suite: Suite) -> str:
    """The suite's scenario, the same on every version (``nominal-v1`` -> ``nominal``); a suite
    made by hand without one by its name."""
    return suite.stem or suite.name


def env_name(suite: Suite) -> str:
    """The suite's id without its namespace, as the version table names it."""
    return versions.get(suite.env_id).name


def controller_label(spec: str) -> str:
    """A registered name as it is; a run directory or model file (``LOADER:SPEC`` too) by its
    folder or file stem, other characters than ``[-_A-Za-z0-9]`` replaced by ``_``."""
    spec = str(spec)
    if _NAME.match(spec):
        return spec
    path = Path(spec.rpartition(":")[2] if re.match(r"^\w{2,}:", spec) else spec)
    stem = path.stem if path.suffix == ".zip" else path.name
    return re.sub(r"[^-_A-Za-z0-9]", "_", stem) or "agent"


def dataset_id(suite: Suite, controller: str, name: str | None = None, version: int = 0) -> str:
    """``cepam/<env>/<name>-v<version>``; ``name`` defaults to ``<task>-<controller>``."""
    name = name if name is not None else f"{task_name(suite)}-{controller_label(controller)}"
    if not _NAME.match(name) or re.search(r"-v\d+$", name):
        raise InputError(
            f"dataset name must be letters, digits, '-' and '_' without a '-v<N>' ending "
            f"(the version is --dataset-version), got {name!r}"
        )
    if version < 0:
        raise InputError(f"dataset version must be >= 0, got {version}")
    return f"{NAMESPACE}/{env_name(suite)}/{name}-v{version}"
