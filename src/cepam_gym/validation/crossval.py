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
    model_fn=None,
    diff_step: float = 1e-4,
    group_fn=None,
    prior=None,
) -> CrossValidation:
    """Fit without each experiment group in turn (``group_fn``, default :func:`experiment_group`)
    and predict it (``model_fn``, ``diff_step``, ``prior``: as :func:`~cepam_gym.validation.fit.fit`;
    a prior is not data: every fold keeps it)."""
    group_fn = group_fn or experiment_group
    model_fn = model_fn or model_values
    kw = dict(bounds=bounds, max_nfev=max_nfev, tol=tol, model_fn=model_fn, diff_step=diff_step, prior=prior)
    groups = list(dict.fromkeys(group_fn(e) for e in experiments))
    full = full or fit(experiments, base, names, x0s=x0s, **kw)
    pred, ins, vals = {}, {}, {}
    for g in groups:
        keep = [e for e in experiments if group_fn(e) != g]
        out = [e for e in experiments if group_fn(e) == g]
        res = fit(keep, base, names, x0s=[full.values] + list(x0s or []), **kw)
        pred[g] = relative_errors(model_fn(out, res.params), out)
        ins[g] = np.array([r for e, r in zip(experiments, full.residuals) if group_fn(e) == g])
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
