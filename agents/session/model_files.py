"""Where a trained model's files are, in the layouts a user brings: a run directory of
``cepam-gym train``, an RL Zoo3 run, or a bare SB3 model ``.zip``.

* The observation-normalisation statistics (SB3's ``VecNormalize``) of a model, found under every
  name these tools save them by (:data:`NORMALIZER_NAMES`), so that a policy is never scored
  without the normalisation it was trained with.
* Whether the model's record (our ``config.yaml``, RL Zoo3's ``config.yml``) says it normalises
  its observations: then a missing statistics file is refused, not skipped.
* The algorithm that saved a bare SB3 ``.zip`` (read from its ``data`` record, nothing unpickled)
  and the env id a model was trained on, where a record names it.
"""

from __future__ import annotations

import ast
import json
import re
import zipfile
from pathlib import Path
from typing import Any

import yaml

from cepam_gym.cli_errors import guarded_load
from cepam_gym.errors import InputError

# the names the statistics beside a model go by, in the order they are looked for
NORMALIZER_NAMES = (
    "<model name with 'vecnormalize' for 'model'>.pkl (cepam-gym train)",
    "<prefix>_vecnormalize_<N>_steps.pkl beside <prefix>_<N>_steps.zip (SB3's CheckpointCallback)",
    "vec_normalize.pkl (SB3's documentation)",
    "<env name>/vecnormalize.pkl (RL Zoo3)",
)
ZOO_RECORD = "args.yml"  # RL Zoo3's record of a run, in its <env name>/ folder beside the models


def zoo_params_dir(folder: Path) -> Path | None:
    """The RL Zoo3 folder (``<env name>/`` with ``args.yml``) of a run folder, if there is one."""
    found = sorted(p.parent for p in Path(folder).glob(f"*/{ZOO_RECORD}"))
    return found[0] if len(found) == 1 else None


def normalizer_beside(model: Path) -> Path | None:
    """The VecNormalize statistics saved with ``model`` (a ``.zip``), under the first of
    :data:`NORMALIZER_NAMES` that exists; ``None`` if none does."""
    model = Path(model)
    candidates = []
    ours = model.name.replace("model", "vecnormalize").replace(".zip", ".pkl")
    if ours != model.name:
        candidates.append(model.with_name(ours))
    if m := re.fullmatch(r"(.*)_(\d+)_steps\.zip", model.name):
        candidates.append(model.with_name(f"{m[1]}_vecnormalize_{m[2]}_steps.pkl"))
    candidates.append(model.with_name("vec_normalize.pkl"))
    if (zoo := zoo_params_dir(model.parent)) is not None:
        candidates.append(zoo / "vecnormalize.pkl")
    return next((p for p in candidates if p.is_file()), None)


class _ZooLoader(yaml.SafeLoader):
    """A safe YAML loader that reads RL Zoo3's records (``yaml.dump`` of an ``OrderedDict``)."""


def _ordered_dict(loader, suffix, node):
    args = loader.construct_sequence(node, deep=True)  # OrderedDict's one argument: [[key, value], ...]
    return {k: v for k, v in args[0]} if args else {}


_ZooLoader.add_multi_constructor(
    "tag:yaml.org,2002:python/object/apply:collections.OrderedDict", _ordered_dict
)


def zoo_record(params_dir: Path, name: str) -> dict[str, Any]:
    """RL Zoo3's ``args.yml`` or ``config.yml`` of a run as a dict (empty if absent)."""

    path = Path(params_dir) / name
    if not path.is_file():
        return {}
    data = guarded_load(path, "RL Zoo3 record", lambda: yaml.load(path.read_text(), Loader=_ZooLoader))
    return data if isinstance(data, dict) else {}


def zoo_normalizes_obs(params_dir: Path) -> bool:
    """Whether an RL Zoo3 run normalised observations (``normalize`` in its ``config.yml``: a
    bool, or a dict (or its string) whose ``norm_obs`` defaults to true)."""
    norm = zoo_record(params_dir, "config.yml").get("normalize", False)
    if isinstance(norm, str):
        try:
            norm = ast.literal_eval(norm)
        except (ValueError, SyntaxError):
            norm = norm.strip().lower() == "true"
    if isinstance(norm, dict):
        return bool(norm.get("norm_obs", True))
    return bool(norm)


# the policy's module in an SB3 zip -> the algorithm (PPO and A2C share ActorCriticPolicy)
_POLICY_MODULES = {
    "sb3_contrib.common.recurrent.policies": "RecurrentPPO",
    "stable_baselines3.sac.policies": "SAC",
    "stable_baselines3.td3.policies": "TD3",
}


def algorithm_of(model: Path) -> str:
    """The algorithm that saved the SB3 model ``model`` (``PPO``, ``A2C``, ``SAC``, ``TD3``,
    ``RecurrentPPO``), read from the zip's ``data`` record; ``InputError`` if it cannot tell."""

    def read():
        with zipfile.ZipFile(model) as z:
            return json.loads(z.read("data"))

    data = guarded_load(model, "SB3 model", read)
    module = (data.get("policy_class") or {}).get("__module__", "")
    if module == "stable_baselines3.common.policies":
        return "PPO" if "clip_range" in data else "A2C"
    if module in _POLICY_MODULES:
        return _POLICY_MODULES[module]
    raise InputError(
        f"cannot tell which algorithm saved {model} (its policy comes from "
        f"{module or 'an unnamed module'!r}); "
        "put it in a run directory with a config.yaml naming the algorithm"
    )
