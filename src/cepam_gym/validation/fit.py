"""Fit the unknown plant parameters to measured static data (``cepam-gym calibrate``).

Input: a CSV with one measurement per row (format in docs/calibration.md; the paper's own numbers
ship as ``cepam_gym/data/paper_cepam.csv``, generated from ``data/reported.yaml``). Each row is
simulated exactly as :func:`cepam_gym.validation.equilibrium.simulate` simulates the paper's
experiments (pressures held, the free end hanging; stiffness by hanging weights or at a held
length; force at a held length), with the plant's own force model and form (``balloon``:
enhanced, virtual work).

Fit: bounded least squares (:func:`.fitcore.solve`) on the relative residuals
``(model - measured) / measured`` over the chosen parameters of :data:`.static_params.FIT_PARAMS`,
each scaled to ``[0, 1]`` inside its physical bounds; uncertainty from the Jacobian at the optimum
(:func:`.fitcore.uncertainty`). The result is written as a YAML that
:meth:`PlantParams.from_yaml` loads (:func:`fitted_yaml`). The dynamic counterpart is
:mod:`cepam_gym.identify`, on the same core.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..plant.params import PlantParams
from . import fitcore
from .equilibrium import simulate
from .experiments import Experiment
from .static_params import DEFAULT_FIT, FIT_PARAMS


def sleeve_diameter_ratio(length: float, free_length: float, free_angle: float) -> float:
    """``D / D_0`` of a braid of free length and angle (rad) pressed or pulled to ``length``."""
    c = length / free_length * math.cos(free_angle)
    return math.sqrt(1.0 - c * c) / math.sin(free_angle)


def experiment_group(exp: Experiment) -> str:
    """The experiment group a row belongs to (device and bladder): cross-validation leaves one out."""
    return exp.device if exp.device == "cepam" else f"{exp.device}_{exp.bladder}"


def apply(base: PlantParams, names: tuple[str, ...], values: np.ndarray) -> PlantParams:
    """``base`` with the static fit parameters ``names`` set to ``values`` (edge units); validated."""
    return fitcore.apply(FIT_PARAMS, base, names, values)


# ------------------------------------------------------------------ the fit
@dataclass
class FitResult:
    names: tuple[str, ...]
    start: np.ndarray  # edge units
    values: np.ndarray
    std: np.ndarray  # nan where not identifiable / undefined
    cov: np.ndarray
    at_bound: np.ndarray  # bool
    identifiable: np.ndarray  # bool
    params: PlantParams
    residuals: np.ndarray  # relative, at the optimum
    residuals_start: np.ndarray
    model: np.ndarray
    model_start: np.ndarray
    cost: float
    success: bool
    message: str
    starts_tried: int = 1
    notes: list[str] = field(default_factory=list)
    bounds: dict[str, tuple[float, float]] = field(default_factory=dict)  # as used (edge units)


def model_values(experiments: list[Experiment], params: PlantParams) -> np.ndarray:
    return np.array([simulate(e, params).value for e in experiments])


def relative_errors(model: np.ndarray, experiments: list[Experiment]) -> np.ndarray:
    meas = np.array([e.value for e in experiments])
    r = (model - meas) / np.abs(meas)
    return np.where(np.isfinite(r), r, 1.0)  # a model that gives no value is 100 % off


def fit(
    experiments: list[Experiment],
    base: PlantParams,
    names: tuple[str, ...] = DEFAULT_FIT,
    starts: int = 1,
    seed: int = 0,
    bounds: dict[str, tuple[float, float]] | None = None,
    max_nfev: int | None = None,
    tol: float = 1e-10,
    x0s: list[np.ndarray] | None = None,
    model_fn: Callable[[list[Experiment], PlantParams], np.ndarray] | None = None,
    diff_step: float = 1e-4,
    prior: Callable[[np.ndarray], np.ndarray] | None = None,
) -> FitResult:
    """Bounded least squares of the relative residuals over ``names`` (see the module docstring).

    ``starts > 1`` adds ``starts - 1`` random starting points inside the bounds (seeded); the
    lowest cost wins. ``bounds`` overrides :data:`FIT_PARAMS` bounds (edge units). ``x0s`` adds
    given starting points (edge units); ``max_nfev`` (default ``200 * len(names)``) and ``tol``
    (xtol, ftol, gtol) bound the work of each start. ``model_fn(experiments, params)`` computes
    the model's values (default :func:`model_values`, the static simulation; plant v2: the
    protocols, :func:`cepam_gym.validation.protocols.protocol_values`); ``diff_step`` is the
    finite-difference step in the scaled variables (larger for a protocol with dry friction,
    whose results are piecewise smooth). ``prior(values)`` (edge values in ``names`` order) adds
    residuals to the least squares, a maximum-a-posteriori fit (plant v2:
    :func:`cepam_gym.validation.calibrate_v2.prior_residuals`); ``residuals`` of the result stay the
    data's alone, ``cost`` includes the prior.
    """
    model_fn = model_fn or model_values
    names = tuple(names)
    fitcore.check_names(FIT_PARAMS, names)
    scale = fitcore.Scaling([FIT_PARAMS[n] for n in names], bounds)
    x_start = np.array([FIT_PARAMS[n].get(base) for n in names])
    model_start = model_fn(experiments, base)

    residuals = fit_residuals(experiments, base, names, scale, model_fn, prior)
    rng = np.random.default_rng(seed)
    z0s = [scale.to_z(x_start)] + [rng.uniform(0.05, 0.95, len(names)) for _ in range(starts - 1)]
    z0s += [scale.to_z(x) for x in (x0s or [])]
    best = fitcore.solve(residuals, z0s, max_nfev=max_nfev or 200 * len(names), tol=tol, diff_step=diff_step)
    values = scale.to_edge(best.x)
    params = apply(base, names, values)
    model = model_fn(experiments, params)
    r = relative_errors(model, experiments)
    r_all = residuals(best.x)  # with the prior's rows, if any: the posterior's uncertainty
    Jz = fitcore.fd_jacobian(residuals, best.x, r_all, h=diff_step)  # own differences: one-sided at a bound
    unc = fitcore.uncertainty(Jz, r_all, scale.dx_dz(best.x), names)
    at_bound = fitcore.at_bounds(best)
    notes = unc.notes[:1] if len(experiments) <= len(names) else []
    if np.any(at_bound):
        notes.append(
            "at a bound (the uncertainty of a bounded parameter is not a confidence interval): "
            + ", ".join(n for n, b in zip(names, at_bound) if b)
        )
    notes += unc.notes if len(experiments) > len(names) else []
    return FitResult(
        names,
        x_start,
        values,
        unc.std,
        unc.cov,
        at_bound,
        unc.rank_ok,
        params,
        r,
        relative_errors(model_start, experiments),
        model,
        model_start,
        float(best.cost),
        bool(best.success),
        str(best.message),
        len(z0s),
        notes,
        scale.bounds(),
    )


def fit_residuals(
    experiments: list[Experiment],
    base: PlantParams,
    names: tuple[str, ...],
    scale: fitcore.Scaling,
    model_fn: Callable[[list[Experiment], PlantParams], np.ndarray],
    prior: Callable[[np.ndarray], np.ndarray] | None = None,
) -> Callable[[np.ndarray], np.ndarray]:
    """The least-squares residuals of :func:`fit` as a function of the scaled variables ``z``: the
    relative errors of the experiments, then ``prior(values)`` if a prior is given."""

    def residuals(z: np.ndarray) -> np.ndarray:
        x = scale.to_edge(z)
        extra = prior(x) if prior is not None else np.empty(0)
        try:
            p = apply(base, names, x)
        except ValueError:
            r = np.full(len(experiments), 1.0)  # impossible geometry: 100 % off everywhere
        else:
            r = relative_errors(model_fn(experiments, p), experiments)
        return np.concatenate([r, extra])

    return residuals


def minimax(
    experiments: list[Experiment],
    base: PlantParams,
    names: tuple[str, ...] = DEFAULT_FIT,
    bounds: dict[str, tuple[float, float]] | None = None,
    seed: int = 0,
    maxiter: int = 200,
) -> tuple[float, np.ndarray]:
    """The smallest largest relative error the parameters ``names`` can reach inside their bounds
    (``scipy.optimize.differential_evolution`` on ``max |r|``): a check of whether a goal such as
    "every number within 5 %" is reachable at all, not a fit. Returns ``(max |r|, values)``."""
    from scipy.optimize import differential_evolution

    names = tuple(names)
    lims = [(bounds or {}).get(n, (FIT_PARAMS[n].lo, FIT_PARAMS[n].hi)) for n in names]

    def worst(x: np.ndarray) -> float:
        try:
            p = apply(base, names, x)
        except ValueError:
            return 10.0
        return float(np.max(np.abs(relative_errors(model_values(experiments, p), experiments))))

    res = differential_evolution(worst, lims, seed=seed, maxiter=maxiter, popsize=15, tol=1e-9, polish=True)
    return float(res.fun), np.asarray(res.x)


# ------------------------------------------------------------------ reporting
def format_report(res: FitResult, experiments: list[Experiment]) -> str:
    lines = ["parameters (edge units):"]
    lines += fitcore.parameter_lines(
        res.names,
        [FIT_PARAMS[n].unit for n in res.names],
        res.start,
        res.values,
        res.std,
        {n: res.bounds.get(n, (FIT_PARAMS[n].lo, FIT_PARAMS[n].hi)) for n in res.names},
        res.at_bound,
    )
    lines.append("")
    lines.append("residuals per measurement (relative, model vs measured):")
    w = max(len(e.name) for e in experiments)
    lines.append(
        f"  {'measurement':<{w}} {'measured':>10} {'unit':>4} {'before':>10} {'err':>7} "
        f"{'after':>10} {'err':>7}"
    )
    for i, e in enumerate(experiments):
        lines.append(
            f"  {e.name:<{w}} {e.value:>10.5g} {e.unit:>4} {res.model_start[i]:>10.5g} "
            f"{100 * res.residuals_start[i]:>+6.1f}% {res.model[i]:>10.5g} {100 * res.residuals[i]:>+6.1f}%"
        )
    rs, r = np.abs(res.residuals_start), np.abs(res.residuals)
    lines.append(
        f"  mean |error| {100 * rs.mean():.2f}% -> {100 * r.mean():.2f}%, max {100 * rs.max():.1f}% -> "
        f"{100 * r.max():.1f}%, within 5%: {int((rs <= 0.05).sum())} -> {int((r <= 0.05).sum())} of {len(r)}"
    )
    lines.append(
        f"  optimizer: {res.message} (success={res.success}, cost={res.cost:.4g}, starts={res.starts_tried})"
    )
    for n in res.notes + fitcore.correlation_notes(res.names, res.cov, res.at_bound):
        lines.append(f"  note: {n}")
    return "\n".join(lines)


def correlations(res: FitResult, threshold: float = 0.9) -> dict[tuple[str, str], float]:
    """Pairs of fitted parameters whose estimates correlate beyond ``threshold`` (from ``cov``)."""
    return fitcore.correlations(res.names, res.cov, res.at_bound, threshold)


def fitted_yaml(res: FitResult, base_preset: str, header: str = "") -> str:
    """``preset: <base>`` plus the fitted fields, unit-named (the keys of ``PlantParams.to_dict``)."""
    fields = [f for n in res.names for f in FIT_PARAMS[n].fields]
    return fitcore.fitted_yaml(res.params, fields, base_preset, header)
