"""Writing and finding Minari datasets (Younis et al. 2024). Minari is an optional extra
(``pip install 'cepam-gym[offline]'``), imported only here and only when called.

**Normalization.** Minari's ``get_normalized_score(dataset, returns)`` is ``(returns -
ref_min_score) / (ref_max_score - ref_min_score)``, with the references the mean episode returns
of a poor and an expert policy on the dataset's env (D4RL's random and expert policies; Fu et al.
2020). A dataset stores the mean episode returns of the zero controller (valves shut) and of the
oracle on its suite's episodes (``zero_return`` and ``oracle_return`` of the stored references,
:mod:`cepam_gym.bench.references`), so ``get_normalized_score(dataset, episode_returns)`` is 0 for
the zero controller's returns and 1 for the oracle's. The benchmark ranks by its score, not by the
return: its own figures (the headline, :mod:`cepam_gym.bench.headline`, and the normalized score)
are in the dataset's ``cepam_*`` metadata.

Written with ``minari.create_dataset_from_buffers``, not the ``DataCollector`` wrapper: the
benchmark's episode ``i`` is env ``i`` of one batched env seeded with the suite's seed (stream
``i``, :meth:`cepam_gym.envs.core.CEPAMBatch.seed`), which a wrapped single env seeded per reset
cannot replay, and the controller acts on the whole batch, as the benchmark runs it. Each
episode's metadata keeps ``seed`` and ``stream``: ``gym.make(env_id, stream=i, **kwargs)`` reset
with ``seed`` starts that episode again.
"""

from __future__ import annotations

import dataclasses
import shutil
import warnings
from importlib import metadata as importlib_metadata

from ..bench.suites import Suite
from ..errors import InputError

INSTALL = "pip install 'cepam-gym[offline]'"


def require_minari():
    """The ``minari`` module, or an ``ImportError`` naming the install command."""
    try:
        import minari
    except ImportError as e:
        raise ImportError(f"offline-RL datasets need minari (with h5py): {INSTALL}") from e
    return minari


def dataset_path(dataset_id: str):
    """Where Minari keeps ``dataset_id`` (under ``MINARI_DATASETS_PATH`` when set)."""
    require_minari()
    from minari.storage.datasets_root_dir import get_dataset_path

    return get_dataset_path(dataset_id)


def exists(dataset_id: str) -> bool:
    return dataset_path(dataset_id).exists()


def check_free(dataset_id: str, overwrite: bool) -> None:
    """Raise ``InputError`` if ``dataset_id`` exists and may not be replaced."""
    if not overwrite and exists(dataset_id):
        raise InputError(
            f"dataset {dataset_id} already exists in {dataset_path(dataset_id).parent}: "
            "pass --overwrite to replace it, or another --name or --dataset-version"
        )


def env_spec(suite: Suite, max_episode_steps: int | None = None):
    """The suite's env as a Gymnasium ``EnvSpec`` (its id with the suite's kwargs); the eval env
    of every dataset of the suite, with the id's own time limit unless ``max_episode_steps``."""
    import gymnasium as gym

    spec = gym.spec(suite.env_id)
    steps = spec.max_episode_steps if max_episode_steps is None else int(max_episode_steps)
    return dataclasses.replace(spec, kwargs={**spec.kwargs, **suite.env_kwargs}, max_episode_steps=steps)


def reference_scores(suite: Suite) -> dict[str, float]:
    """``{"ref_min_score": zero controller's mean episode return, "ref_max_score": the oracle's}``
    on the suite's episodes, from its stored references (empty where none are stored: the MuJoCo
    joint suite, which the oracle does not drive)."""
    from ..bench.references import stored_entry

    entry = stored_entry(suite.name, suite.episodes, suite.seed) or {}
    if "zero_return" not in entry or "oracle_return" not in entry:
        return {}
    return {"ref_min_score": float(entry["zero_return"]), "ref_max_score": float(entry["oracle_return"])}


def _version() -> str:
    try:
        return importlib_metadata.version("cepam-gym")
    except importlib_metadata.PackageNotFoundError:  # a source tree on PYTHONPATH
        return "0"


def write(
    dataset_id: str,
    episodes: list[dict],
    suite: Suite,
    *,
    seed: int,
    controller: str,
    extra: dict,
    max_episode_steps: int,
    overwrite: bool = False,
):
    """Write ``episodes`` (:meth:`cepam_gym.offline.episodes.EpisodeRecorder.episodes`) as the
    Minari dataset ``dataset_id``; ``extra`` goes into its metadata. Returns the dataset."""
    minari = require_minari()
    from minari.data_collector import EpisodeBuffer

    check_free(dataset_id, overwrite)
    if exists(dataset_id):  # --overwrite; not minari.delete_dataset: it prints on stdout (the id's place)
        shutil.rmtree(dataset_path(dataset_id))
    buffers = [
        EpisodeBuffer(
            id=i,
            seed=int(seed),
            observations=ep["observations"],
            actions=ep["actions"],
            rewards=ep["rewards"],
            terminations=ep["terminations"],
            truncations=ep["truncations"],
            infos=ep["infos"],
        )
        for i, ep in enumerate(episodes)
    ]
    refs = reference_scores(suite)
    version = _version()
    with warnings.catch_warnings():
        # Minari asks for an author, an e-mail and a code permalink: none belongs in a dataset
        # a user records on their machine
        warnings.filterwarnings("ignore", message=r"`(author|author_email|code_permalink)` is set to None")
        dataset = minari.create_dataset_from_buffers(
            dataset_id=dataset_id,
            buffer=buffers,
            env=env_spec(suite, max_episode_steps),
            eval_env=env_spec(suite),
            algorithm_name=str(controller),
            description=_description(suite, controller, refs),
            num_episodes_average_score=suite.episodes,  # the episodes the references were measured on
            requirements=[f"cepam-gym>={version}"] if version != "0" else None,
            **refs,
        )
    dataset.storage.update_metadata({**extra, "cepam_gym_version": version})
    dataset.storage.update_episode_metadata([_episode_metadata(i, ep) for i, ep in enumerate(episodes)])
    return dataset


def _episode_metadata(i: int, episode: dict) -> dict:
    """An episode's metadata: its ``stream`` of the dataset's seed (a single env replays it), and
    its plant's parameter row as ``plant_<NAME>`` (SI, the columns of
    :mod:`cepam_gym.physics.layout`) when it was recorded."""
    from ..physics.layout import NAMES

    meta = {"stream": i}
    if "plant" in episode:
        meta.update((f"plant_{name}", float(v)) for name, v in zip(NAMES, episode["plant"]))
    return meta


def _description(suite: Suite, controller: str, refs: dict) -> str:
    text = (
        f"cepam-gym: the controller {controller} on the benchmark suite {suite.name} "
        f"({suite.env_id}: {suite.doc}). Infos hold the env's per-step quantities (SI) and its "
        "named reward terms."
    )
    if refs:
        text += (
            f" ref_min_score / ref_max_score are the mean episode returns of the zero controller "
            f"(valves shut) and of the oracle on the suite's {suite.episodes} episodes (seed "
            f"{suite.seed}), the ends of minari.get_normalized_score(dataset, returns); the benchmark's "
            f"own scores of the recorded episodes are the cepam_* metadata."
        )
    return text
