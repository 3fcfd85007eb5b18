"""Leave-one-group-out cross-validation of the static fit (``cepam-gym calibrate --v1 --cv``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..plant.params import PlantParams
from .experiments import Experiment
from .fit import FitResult, experiment_group, fit, model_values, relative_errors


@dataclass
class CrossValidation:
    """Leave-one-group-out: per group, the errors of its rows predicted by a fit without them."""

    groups: list[str]
    predicted: dict[str, np.ndarray]  # group -> relative errors of its rows, out of sample
    in_sample: dict[str, np.ndarray]  # group -> relative errors of the fit to all data
    values: dict[str, np.ndarray]  # group -> parameters fitted without it


def cross_validate(
    experiments: list[Experiment],
    base: PlantParams,
    names: tuple[str, ...],
    bounds: dict[str, tuple[float, float]] | None = None,
    x0s=None,
    max_nfev: int | None = None,
    tol: float = 1e-7,
    full: FitResult | None = None,
) -> CrossValidation:
    """Fit without each experiment group in turn (:func:`experiment_group`) and predict it."""
    groups = list(dict.fromkeys(experiment_group(e) for e in experiments))
    full = full or fit(experiments, base, names, bounds=bounds, x0s=x0s, max_nfev=max_nfev, tol=tol)
    pred, ins, vals = {}, {}, {}
    for g in groups:
        keep = [e for e in experiments if experiment_group(e) != g]
        out = [e for e in experiments if experiment_group(e) == g]
        res = fit(
            keep, base, names, bounds=bounds, x0s=[full.values] + list(x0s or []), max_nfev=max_nfev, tol=tol
        )
        pred[g] = relative_errors(model_values(out, res.params), out)
        ins[g] = np.array([r for e, r in zip(experiments, full.residuals) if experiment_group(e) == g])
        vals[g] = res.values
    return CrossValidation(groups, pred, ins, vals)


def format_cross_validation(cv: CrossValidation) -> str:
    lines = [
        "leave-one-group-out (fit without the group, predict it): mean |error| in sample -> out of sample",
        f"  {'group':<16} {'rows':>4} {'in sample':>10} {'predicted':>10} {'worst pred.':>12}",
    ]
    for g in cv.groups:
        i, p = np.abs(cv.in_sample[g]), np.abs(cv.predicted[g])
        lines.append(
            f"  {g:<16} {len(p):>4} {100 * i.mean():>9.1f}% {100 * p.mean():>9.1f}% {100 * p.max():>11.1f}%"
        )
    alli = np.abs(np.concatenate([cv.in_sample[g] for g in cv.groups]))
    allp = np.abs(np.concatenate([cv.predicted[g] for g in cv.groups]))
    lines.append(
        f"  {'all':<16} {len(allp):>4} {100 * alli.mean():>9.1f}% {100 * allp.mean():>9.1f}% "
        f"{100 * allp.max():>11.1f}%"
    )
    return "\n".join(lines)
