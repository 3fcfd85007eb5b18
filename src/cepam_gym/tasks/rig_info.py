"""The rig's step info, declared once: each key with the env-state field and column it reads.

A key reads column ``column`` of the env's row of ``state`` or ``aux`` (``plant.S_*``,
``plant.A_*``), or the ``load``, ``target_l`` or ``target_k`` of the step just scored. The
contract's info keys (:data:`cepam_gym.tasks.contract.RIG`), the single env's compiled info row
(:func:`cepam_gym.envs.step.env_step_single`) and the rig task's info dicts
(:class:`~cepam_gym.envs.rig_task.RigTask`) all read this table, so a key cannot be paired with
another key's value.
"""

from __future__ import annotations

import numpy as np

from .. import plant as pl

STATE, AUX, LOAD, TARGET_L, TARGET_K = range(5)  # where a key's value is read
FIELDS = ("state", "aux", "load", "target_l", "target_k")  # the EnvState field of each source

RIG_INFO = (
    ("length", STATE, pl.S_L),
    ("velocity", STATE, pl.S_V),
    ("stiffness", AUX, pl.A_STIFF),
    ("stiffness_closed", AUX, pl.A_STIFF_CLOSED),
    ("force", AUX, pl.A_FORCE),
    ("pressure_c", AUX, pl.A_PC),
    ("pressure_e", AUX, pl.A_PE),
    ("temperature_c", AUX, pl.A_TC),
    ("temperature_e", AUX, pl.A_TE),
    ("air_used", AUX, pl.A_AIR),
    ("load_mass", LOAD, 0),
    ("target_length", TARGET_L, 0),
    ("target_stiffness", TARGET_K, 0),
)
INFO_KEYS = tuple(k for k, _, _ in RIG_INFO)
# the table as arrays, for the compiled single step
INFO_SRC = np.array([src for _, src, _ in RIG_INFO], dtype=np.int64)
INFO_COL = np.array([col for _, _, col in RIG_INFO], dtype=np.int64)


def columns(source: int) -> tuple[tuple[str, ...], np.ndarray]:
    """The keys read from ``source`` (``STATE`` or ``AUX``) and their columns."""
    rows = [(k, c) for k, s, c in RIG_INFO if s == source]
    return tuple(k for k, _ in rows), np.array([c for _, c in rows], dtype=np.int64)
