"""The model beside the paper's reported numbers, and the fit of its unknown parameters.

* :mod:`.experiments`: the reported numbers and their conditions (``data/reported.yaml``);
* :mod:`.equilibrium`: how one experiment is simulated on the plant's force kernels (free
  lengths, stiffness by hanging weights, force at a held length);
* :mod:`.table`: the reproduction table per force-model level and form, and its summary;
* :mod:`.measurements`: calibration data (the measurement CSV, and the paper's numbers in it);
* :mod:`.fit`: bounded least squares over the unreported parameters, uncertainty, minimax check;
* :mod:`.plots`: the figures of both; :mod:`.cli`: ``cepam-gym validate`` and ``calibrate``.

Nothing model-related is stored: every model value is computed from a
:class:`~cepam_gym.params.PlantParams` each time (docs/calibration.md).
"""

from .equilibrium import Outcome, experiment_params, settle, simulate
from .experiments import DEVICES, MEASURED_UNITS, REPORTED_PATH, Experiment, load_experiments
from .fit import DEFAULT_FIT, FIT_PARAMS, FitResult, apply, fit, minimax, model_values, relative_errors
from .measurements import PAPER_CSV, PAPER_SINGLE_CSV, paper_csv_text, read_csv
from .table import LEVELS, format_table, summary, validation_rows

__all__ = [
    "DEFAULT_FIT", "DEVICES", "Experiment", "FIT_PARAMS", "FitResult", "LEVELS", "MEASURED_UNITS",
    "Outcome", "PAPER_CSV", "PAPER_SINGLE_CSV", "REPORTED_PATH", "apply", "experiment_params",
    "fit", "format_table", "load_experiments", "minimax", "model_values", "paper_csv_text",
    "read_csv", "relative_errors", "settle", "simulate", "summary", "validation_rows",
]
