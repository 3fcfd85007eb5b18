"""The CE-PAM plant: parameters, state layout and the integration of one control period.

gymnax style: pure functions over an explicit state array and a frozen parameter array.

* :mod:`~cepam_gym.plant.params`: :class:`PlantParams` (SI, frozen), presets, YAML;
* :mod:`~cepam_gym.plant.layout`: the columns of the state, input and ``aux`` arrays, valve modes;
* :mod:`~cepam_gym.plant.substep`: the one sub-step every caller runs, in pieces;
* :mod:`~cepam_gym.plant.kernel`: the compiled block kernel (:func:`advance_block`, and
  :func:`step` over a batch); the hinge of the joint env is the same kernel
  (:func:`advance_block_hinge`);
* :mod:`~cepam_gym.plant.state`: plants at rest, measurements of a state, the stability limit;
* :mod:`~cepam_gym.plant.coupling`: the same sub-step with the mechanics handed to MuJoCo.

The names below are the plant's public face: ``from cepam_gym import plant as pl; pl.step(...)``.
"""

from .kernel import BLOCK, PARALLEL_MIN_BATCH, W_SIZE, advance_block, advance_block_hinge, step
from .layout import *  # noqa: F403 (the column constants, listed in layout.__all__)
from .layout import __all__ as _layout_names
from .params import PlantParams, preset
from .state import check_stability, initial_state, measure, stability_number
from .substep import (
    end_of_step,
    measure_row,
    substep_account,
    substep_air,
    substep_forces,
    valve_setup,
    volumes_at,
)

__all__ = [
    *_layout_names,
    "BLOCK",
    "PARALLEL_MIN_BATCH",
    "W_SIZE",
    "PlantParams",
    "advance_block",
    "advance_block_hinge",
    "check_stability",
    "end_of_step",
    "initial_state",
    "measure",
    "measure_row",
    "preset",
    "stability_number",
    "step",
    "substep_account",
    "substep_air",
    "substep_forces",
    "valve_setup",
    "volumes_at",
]
