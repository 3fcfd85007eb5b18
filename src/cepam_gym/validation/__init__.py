"""The model beside the paper's reported numbers, and the fit of its unknown parameters.

* :mod:`.experiments`: the reported numbers and their conditions (``data/reported.yaml``);
* :mod:`.equilibrium`: how one experiment is simulated on the plant's force kernels (free
  lengths, stiffness by hanging weights, force at a held length);
* :mod:`.table`: the reproduction table per force-model level and form, and its summary;
* :mod:`.measurements`: calibration data (the measurement CSV, and the paper's numbers in it);
* :mod:`.fitcore`: the fitting core shared with :mod:`cepam_gym.identify` (parameter tables,
  scaling, bounded least squares, uncertainty, the fitted YAML);
* :mod:`.static_params`: the static parameters and their bounds; :mod:`.fit`: their fit to the
  measured numbers, minimax check; :mod:`.crossval`: leave-one-group-out;
* :mod:`.plots`: the figures of both; :mod:`.cli`: ``cepam-gym validate`` and ``calibrate``.

Nothing model-related is stored: every model value is computed from a
:class:`~cepam_gym.plant.params.PlantParams` each time (docs/calibration.md).
"""

from .crossval import CrossValidation, cross_validate, format_cross_validation
from .equilibrium import Outcome, experiment_params, settle, simulate
from .experiments import DEVICES, MEASURED_UNITS, REPORTED_PATH, Experiment, load_experiments
from .fit import (
    FitResult,
    apply,
    experiment_group,
    fit,
    minimax,
    model_values,
    relative_errors,
    sleeve_diameter_ratio,
)
from .measurements import PAPER_CSV, PAPER_SINGLE_CSV, paper_csv_text, read_csv
from .static_params import DEFAULT_FIT, FIT_PARAMS, V1_BOUNDS, V1_FIT, V1_STARTS
from .table import (
    DEFAULT_LEVELS,
    LEVELS,
    PLANT_LEVEL,
    device_headline,
    format_headline,
    format_table,
    geometry_lines,
    summary,
    validation_rows,
)

__all__ = [
    "CrossValidation",
    "DEFAULT_LEVELS",
    "PLANT_LEVEL",
    "V1_BOUNDS",
    "V1_FIT",
    "V1_STARTS",
    "cross_validate",
    "device_headline",
    "experiment_group",
    "format_cross_validation",
    "format_headline",
    "geometry_lines",
    "sleeve_diameter_ratio",
    "DEFAULT_FIT",
    "DEVICES",
    "Experiment",
    "FIT_PARAMS",
    "FitResult",
    "LEVELS",
    "MEASURED_UNITS",
    "Outcome",
    "PAPER_CSV",
    "PAPER_SINGLE_CSV",
    "REPORTED_PATH",
    "apply",
    "experiment_params",
    "fit",
    "format_table",
    "load_experiments",
    "minimax",
    "model_values",
    "paper_csv_text",
    "read_csv",
    "relative_errors",
    "settle",
    "simulate",
    "summary",
    "validation_rows",
]
