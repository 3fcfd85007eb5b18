"""Offline-RL datasets (Minari; Younis et al. 2024) of any controller or trained agent on the
benchmark suites: ``cepam-gym dataset --suite nominal-v1 --controller oracle``.

:mod:`~cepam_gym.offline.episodes` cuts a benchmark rollout into episodes (numpy),
:mod:`~cepam_gym.offline.naming` names datasets (``cepam/CEPAM-v1/nominal-oracle-v0``),
:mod:`~cepam_gym.offline.store` writes them with the benchmark's normalization in the metadata
(Minari is imported only there), :mod:`~cepam_gym.offline.record` records one and
:mod:`~cepam_gym.offline.cli` is the command. docs/datasets.md describes what is stored.
"""

from .naming import dataset_id
from .record import record_dataset

__all__ = ["dataset_id", "record_dataset"]
