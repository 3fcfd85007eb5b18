"""Fit the unknown plant parameters to measured static data (``cepam-gym calibrate``).

Input: a CSV with one measurement per row (format in docs/calibration.md; the paper's own numbers
ship as ``cepam_gym/data/paper_cepam.csv``, generated from ``data/reported.yaml``). Each row is
simulated exactly as :func:`cepam_gym.validation.equilibrium.simulate` simulates the paper's
experiments (pressures
held, the free end hanging; stiffness by hanging weights or at a held length; force at a held
length), with the plant's own force model and form (``balloon``: enhanced, virtual work).

Fit: bounded least squares (``scipy.optimize.least_squares``, trust-region reflective) on the
relative residuals ``(model - measured) / measured`` over the chosen parameters, each scaled to
``[0, 1]`` inside its physical bounds (:data:`FIT_PARAMS`). Uncertainty from the Jacobian at the
optimum: ``cov = s^2 (J^T J)^-1`` with ``s^2 = sum(r^2) / (m - p)`` (pseudo-inverse when ``J``
is rank deficient; such directions are reported as not identifiable). The result is written as a
YAML that :meth:`PlantParams.from_yaml` loads: ``preset: <base>`` plus the fitted keys in edge
units (``PlantParams.to_dict`` names).

Parameters that only enter through a combination cannot be told apart: the bladder and sleeve
thicknesses enter only as ``t_a = t_s + t_b`` (Eq. 35), so the default set fits ``wall_thickness``
(``t_a``, keeping the base ratio ``t_b : t_s``); ``kr_scale`` scales both ``K_r`` of Eq. 27.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..plant.params import PlantParams
from ..units import from_si, to_si
from .equilibrium import simulate
from .experiments import Experiment

# ------------------------------------------------------------------ the parameters that can be fitted
KR_HIGH_PAPER = 2.0e6  # Pa/m, Eq. 27
KR_LOW_PAPER = 5.0e5


@dataclass(frozen=True)
class FitParam:
    """A fittable quantity in edge units, its physical bounds and how it maps onto PlantParams."""

    name: str
    unit: str
    lo: float
    hi: float
    why: str
    get: Callable[[PlantParams], float]
    set: Callable[[PlantParams, float], dict]
    fields: tuple[str, ...]  # PlantParams fields it writes


def _field(name: str) -> tuple[Callable[[PlantParams], float], Callable[[PlantParams, float], dict]]:
    """Getter and setter of a PlantParams field in its edge unit (the field's own unit)."""
    unit = PlantParams.__dataclass_fields__[name].metadata["unit"]
    return (lambda p: from_si(getattr(p, name), unit)), (lambda p, v: {name: to_si(v, unit)})


def _split_wall(p: PlantParams, ta_mm: float) -> dict:
    ta = to_si(ta_mm, "mm")
    total = p.bladder_thickness + p.sleeve_thickness
    frac = p.bladder_thickness / total if total > 0 else 0.5
    return {"bladder_thickness": ta * frac, "sleeve_thickness": ta * (1.0 - frac)}


FIT_PARAMS: dict[str, FitParam] = {
    fp.name: fp
    for fp in (
        FitParam(
            "cpam_rest_angle",
            "deg",
            5.0,
            50.0,
            "braid angle of the CPAM at rest: a contractor's braid is below 54.7 deg; commercial "
            "sleeves are woven at about 15-45 deg",
            *_field("cpam_rest_angle"),
            ("cpam_rest_angle",),
        ),
        FitParam(
            "epam_sleeve_free_angle",
            "deg",
            5.0,
            50.0,
            "braid angle of the EPAM sleeve before it is compressed (the same kind of sleeve)",
            *_field("epam_sleeve_free_angle"),
            ("epam_sleeve_free_angle",),
        ),
        FitParam(
            "wall_thickness",
            "mm",
            0.1,
            1.5,
            "t_a = t_s + t_b (Eq. 35): a balloon wall of a few tenths of a mm (< 1 mm, sections "
            "I-II) plus a braid of nylon threads; a wall cannot be thinner than 0.1 mm; the base "
            "ratio t_b : t_s is kept",
            lambda p: from_si(p.bladder_thickness + p.sleeve_thickness, "mm"),
            _split_wall,
            ("bladder_thickness", "sleeve_thickness"),
        ),
        FitParam(
            "bladder_thickness",
            "mm",
            0.0,
            1.0,
            "t_b (Eq. 35): the balloon is thinner than the 1 mm tube",
            *_field("bladder_thickness"),
            ("bladder_thickness",),
        ),
        FitParam(
            "sleeve_thickness",
            "mm",
            0.0,
            1.0,
            "t_s (Eq. 35): a braid of nylon threads",
            *_field("sleeve_thickness"),
            ("sleeve_thickness",),
        ),
        FitParam(
            "kr_scale",
            "",
            0.0,
            4.0,
            "factor on both K_r of Eq. 27 (2000 and 500 kPa/m, measured by Tsagarakis and "
            "Caldwell on another muscle); 4 lets a balloon lose up to 80 kPa to inflation",
            lambda p: p.kr_high / KR_HIGH_PAPER,
            lambda p, v: {"kr_high": v * KR_HIGH_PAPER, "kr_low": v * KR_LOW_PAPER},
            ("kr_high", "kr_low"),
        ),
        FitParam(
            "elastic_stiffness",
            "n_per_m",
            0.0,
            400.0,
            "axial stiffness of the two bladders (not in the paper): latex E of 1-2 MPa, wall "
            "<= 1 mm, 5 and 10 mm diameter, 15-20 cm long gives at most a few hundred N/m",
            *_field("elastic_stiffness"),
            ("elastic_stiffness",),
        ),
        FitParam(
            "elastic_rest_length",
            "cm",
            15.0,
            19.5,
            "rest length of that elasticity: between the EPAM bladder (15 cm) and the CPAM (19.5 cm)",
            *_field("elastic_rest_length"),
            ("elastic_rest_length",),
        ),
        FitParam(
            "bladder_shear_modulus",
            "kpa",
            50.0,
            3000.0,
            "neo-Hookean shear modulus of the balloon rubber (natural latex: about 0.3-0.6 MPa "
            "in small strain; wide bounds because only mu t_b is seen by most data)",
            *_field("bladder_shear_modulus"),
            ("bladder_shear_modulus",),
        ),
        FitParam(
            "tube_shear_modulus",
            "kpa",
            50.0,
            3000.0,
            "neo-Hookean shear modulus of the rubber-tube bladders (natural or silicone rubber: "
            "about 0.2-1 MPa)",
            *_field("tube_shear_modulus"),
            ("tube_shear_modulus",),
        ),
        FitParam(
            "friction_mu",
            "",
            0.0,
            1e-3,
            "plant v2 contact-area friction coefficient (F_b = mu (Pc+ S_c + Pe+ S_e)); up to 1e-3 "
            "lets friction hold up to about 2 N at the paper's highest pair, more than half the "
            "heaviest weight",
            *_field("friction_mu"),
            ("friction_mu",),
        ),
        FitParam(
            "collapse_seal_diameter",
            "mm",
            0.0,
            5.0,
            "plant v2: seal of the collapsed CPAM on the end cap, at most its 5 mm bladder",
            *_field("collapse_seal_diameter"),
            ("collapse_seal_diameter",),
        ),
        FitParam(
            "friction_presliding",
            "mm",
            0.1,
            2.0,
            "presliding displacement of the slowest Maxwell-slip element: PAM hysteresis loops "
            "show stick over a few tenths of a mm to about a mm",
            *_field("friction_presliding"),
            ("friction_presliding",),
        ),
        FitParam(
            "end_mass",
            "g",
            5.0,
            100.0,
            "the hanging end cap (3D printed)",
            *_field("end_mass"),
            ("end_mass",),
        ),
    )
}
DEFAULT_FIT = ("cpam_rest_angle", "epam_sleeve_free_angle", "wall_thickness", "kr_scale", "elastic_stiffness")

# ------------------------------------------------------------------ plant v1: one fit across all data
# The braid angles' lower bounds keep each sleeve within twice its nominal diameter over the stroke
# (docs/calibration.md, "Plant v1"): a braid of free length L_f, angle theta_0, pressed to L has
# D / D_0 = sin(theta) / sin(theta_0) with cos(theta) = (L / L_f) cos(theta_0); D / D_0 <= 2 at the
# shortest length (15 cm) needs theta_0 >= 20.3 deg (CPAM, L_f = 19.5 cm) and >= 26.6 deg (EPAM
# sleeve, L_f = 30 cm). Moduli: rubber in small strain, 0.2-1 MPa (latex, natural and silicone
# rubber); walls: a balloon of 0.05-0.5 mm, a braid of 0.05-0.5 mm.
# K_r of Eq. 27 stays the paper's (fitting its scale moves the mean error by 0.3 %).
V1_FIT = (
    "cpam_rest_angle",
    "epam_sleeve_free_angle",
    "bladder_thickness",
    "sleeve_thickness",
    "bladder_shear_modulus",
    "tube_shear_modulus",
)
V1_BOUNDS = {
    "cpam_rest_angle": (20.3, 50.0),
    "epam_sleeve_free_angle": (26.6, 50.0),
    "bladder_thickness": (0.05, 0.5),
    "sleeve_thickness": (0.05, 0.5),
    "bladder_shear_modulus": (200.0, 1000.0),
    "tube_shear_modulus": (200.0, 1000.0),
}
V1_STARTS = (
    [21.0, 35.0, 0.2, 0.1, 500.0, 300.0],
    [22.0, 40.0, 0.3, 0.1, 300.0, 600.0],
    [30.0, 45.0, 0.1, 0.2, 800.0, 200.0],
)  # edge units, in V1_FIT order


def sleeve_diameter_ratio(length: float, free_length: float, free_angle: float) -> float:
    """``D / D_0`` of a braid of free length and angle (rad) pressed or pulled to ``length``."""
    c = length / free_length * math.cos(free_angle)
    return math.sqrt(1.0 - c * c) / math.sin(free_angle)


def experiment_group(exp: Experiment) -> str:
    """The experiment group a row belongs to (device and bladder): cross-validation leaves one out."""
    return exp.device if exp.device == "cepam" else f"{exp.device}_{exp.bladder}"


def apply(base: PlantParams, names: tuple[str, ...], values: np.ndarray) -> PlantParams:
    """``base`` with the fit parameters ``names`` set to ``values`` (edge units); validated."""
    p = base
    for name, v in zip(names, values):
        p = p.replace(**FIT_PARAMS[name].set(p, float(v)))
    return p


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
) -> FitResult:
    """Bounded least squares of the relative residuals over ``names`` (see the module docstring).

    ``starts > 1`` adds ``starts - 1`` random starting points inside the bounds (seeded); the
    lowest cost wins. ``bounds`` overrides :data:`FIT_PARAMS` bounds (edge units). ``x0s`` adds
    given starting points (edge units); ``max_nfev`` (default ``200 * len(names)``) and ``tol``
    (xtol, ftol, gtol) bound the work of each start. ``model_fn(experiments, params)`` computes
    the model's values (default :func:`model_values`, the static simulation; plant v2: the
    protocols, :func:`cepam_gym.validation.protocols.protocol_values`); ``diff_step`` is the
    finite-difference step in the scaled variables (larger for a protocol with dry friction,
    whose results are piecewise smooth).
    """
    model_fn = model_fn or model_values
    from scipy.optimize import least_squares

    names = tuple(names)
    for n in names:
        if n not in FIT_PARAMS:
            raise ValueError(f"unknown fit parameter {n!r}; one of {sorted(FIT_PARAMS)}")
    written = [f for n in names for f in FIT_PARAMS[n].fields]
    if len(set(written)) != len(written):
        raise ValueError(
            f"fit parameters {list(names)} write the same field twice (e.g. wall_thickness "
            "and bladder_thickness); choose one"
        )
    lo = np.array([(bounds or {}).get(n, (FIT_PARAMS[n].lo, FIT_PARAMS[n].hi))[0] for n in names])
    hi = np.array([(bounds or {}).get(n, (FIT_PARAMS[n].lo, FIT_PARAMS[n].hi))[1] for n in names])
    span = hi - lo
    x_start = np.array([FIT_PARAMS[n].get(base) for n in names])
    model_start = model_fn(experiments, base)

    def to_edge(z: np.ndarray) -> np.ndarray:
        return lo + z * span

    def residuals(z: np.ndarray) -> np.ndarray:
        try:
            p = apply(base, names, to_edge(z))
        except ValueError:
            return np.full(len(experiments), 1.0)  # impossible geometry: 100 % off everywhere
        return relative_errors(model_fn(experiments, p), experiments)

    rng = np.random.default_rng(seed)
    z0s = [np.clip((x_start - lo) / span, 0.0, 1.0)] + [
        rng.uniform(0.05, 0.95, len(names)) for _ in range(starts - 1)
    ]
    z0s += [np.clip((np.asarray(x, float) - lo) / span, 0.0, 1.0) for x in (x0s or [])]
    best = None
    for z0 in z0s:
        try:
            sol = least_squares(
                residuals,
                z0,
                bounds=(0.0, 1.0),
                method="trf",
                diff_step=diff_step,
                x_scale=1.0,
                xtol=tol,
                ftol=tol,
                gtol=tol,
                max_nfev=max_nfev or 200 * len(names),
            )
        except ValueError:
            continue
        if best is None or sol.cost < best.cost:
            best = sol
    if best is None:
        raise RuntimeError("no start gave a valid parameter set")
    values = to_edge(best.x)
    params = apply(base, names, values)
    model = model_fn(experiments, params)
    r = relative_errors(model, experiments)
    m, k = len(experiments), len(names)
    Jz = _jacobian(residuals, best.x, r, h=diff_step)  # d r / d z, own finite differences (see _jacobian)
    J = Jz / span  # d r / d (edge value)
    notes: list[str] = []
    identifiable = np.ones(k, bool)
    if m > k:
        s2 = float(r @ r) / (m - k)
        JtJ = J.T @ J
        cov = s2 * np.linalg.pinv(JtJ, rcond=1e-10)
        # a parameter is not identifiable if the data do not move it: its column is (near) zero or it
        # lies in the null space of J
        _, s, vt = np.linalg.svd(Jz, full_matrices=False)
        tiny = s < 1e-8 * max(s.max(), 1e-300)
        for j in range(k):
            if np.any(tiny & (np.abs(vt[:, j]) > 1e-3)):
                identifiable[j] = False
        std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        std[~identifiable] = np.nan
    else:
        cov = np.full((k, k), np.nan)
        std = np.full(k, np.nan)
        notes.append(f"{m} measurements for {k} parameters: no residual degrees of freedom, no uncertainty")
    at_bound = (best.active_mask != 0) | (best.x < 1e-6) | (best.x > 1.0 - 1e-6)
    if np.any(at_bound):
        notes.append(
            "at a bound (the uncertainty of a bounded parameter is not a confidence interval): "
            + ", ".join(n for n, b in zip(names, at_bound) if b)
        )
    if np.any(~identifiable):
        notes.append(
            "not identifiable from these data (the Jacobian has no component along them): "
            + ", ".join(n for n, i in zip(names, identifiable) if not i)
        )
    return FitResult(
        names,
        x_start,
        values,
        std,
        cov,
        at_bound,
        identifiable,
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
        {n: (float(a), float(b)) for n, a, b in zip(names, lo, hi)},
    )


def _jacobian(
    fun: Callable[[np.ndarray], np.ndarray], z: np.ndarray, r0: np.ndarray, h: float = 1e-4
) -> np.ndarray:
    """Finite-difference Jacobian of the residuals in the scaled variables ``z`` in [0, 1]:
    central differences inside, one-sided at a bound (so a parameter that sits on its bound still
    shows how the data pull on it)."""
    J = np.empty((r0.size, z.size))
    for j in range(z.size):
        up, dn = z.copy(), z.copy()
        up[j], dn[j] = min(z[j] + h, 1.0), max(z[j] - h, 0.0)
        fu = fun(up) if up[j] != z[j] else r0
        fd = fun(dn) if dn[j] != z[j] else r0
        J[:, j] = (fu - fd) / (up[j] - dn[j])
    return J


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
    lines = [
        "parameters (edge units):",
        f"  {'name':<24} {'start':>10} {'fitted':>10} {'+/- 1 sd':>10} {'unit':>8}  bounds",
    ]
    for j, n in enumerate(res.names):
        fp = FIT_PARAMS[n]
        lo, hi = res.bounds.get(n, (fp.lo, fp.hi))
        sd = "n/a" if not math.isfinite(res.std[j]) else f"{res.std[j]:.3g}"
        flag = " (at bound)" if res.at_bound[j] else ""
        lines.append(
            f"  {n:<24} {res.start[j]:>10.4g} {res.values[j]:>10.4g} {sd:>10} {fp.unit:>8}  "
            f"[{lo:g}, {hi:g}]{flag}"
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
    for n in res.notes:
        lines.append(f"  note: {n}")
    for (a, b), rho in correlations(res).items():
        lines.append(
            f"  note: {a} and {b} are strongly correlated (rho = {rho:+.2f}): the data fix a "
            "combination of them better than either"
        )
    return "\n".join(lines)


def correlations(res: FitResult, threshold: float = 0.9) -> dict[tuple[str, str], float]:
    """Pairs of fitted parameters whose estimates correlate beyond ``threshold`` (from ``cov``)."""
    out = {}
    sd = np.sqrt(np.clip(np.diag(res.cov), 0.0, None)) if np.all(np.isfinite(res.cov)) else None
    if sd is None:
        return out
    for i in range(len(res.names)):
        for j in range(i + 1, len(res.names)):
            if sd[i] > 0 and sd[j] > 0 and not (res.at_bound[i] or res.at_bound[j]):
                rho = res.cov[i, j] / (sd[i] * sd[j])
                if abs(rho) > threshold:
                    out[(res.names[i], res.names[j])] = float(rho)
    return out


def fitted_yaml(res: FitResult, base_preset: str, header: str = "") -> str:
    """``preset: <base>`` plus the fitted fields, unit-named (the keys of ``PlantParams.to_dict``)."""
    edge = res.params.to_dict()
    keys = PlantParams.edge_keys()
    fields = [f for n in res.names for f in FIT_PARAMS[n].fields]
    lines = [f"# {ln}" if ln else "#" for ln in header.splitlines()]
    lines.append(f"preset: {base_preset}")
    for key, name in keys.items():
        if name in fields:
            lines.append(f"{key}: {edge[key]:.6g}")
    return "\n".join(lines) + "\n"


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
    model_fn: Callable[[list[Experiment], PlantParams], np.ndarray] | None = None,
    diff_step: float = 1e-4,
    group_fn: Callable[[Experiment], str] | None = None,
) -> CrossValidation:
    """Fit without each experiment group in turn (``group_fn``, default :func:`experiment_group`)
    and predict it (``model_fn``, ``diff_step``: as :func:`fit`)."""
    group_fn = group_fn or experiment_group
    model_fn = model_fn or model_values
    kw = dict(bounds=bounds, max_nfev=max_nfev, tol=tol, model_fn=model_fn, diff_step=diff_step)
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
