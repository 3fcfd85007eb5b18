"""The fitting core that ``calibrate`` (statics) and ``identify`` (dynamics) share.

* parameter tables: :class:`FitParam` names a fittable quantity in edge units, its physical bounds
  and how it maps onto :class:`~cepam_gym.plant.params.PlantParams` fields; :func:`apply` writes values,
  :func:`check_names` refuses unknown names and two names writing one field;
* scaling: :class:`Scaling` maps each parameter onto ``z`` in [0, 1] inside its bounds, linearly
  or (``FitParam.log``, for quantities spanning decades) logarithmically, so one finite-difference
  step and one trust region suit all of them;
* the solver: :func:`solve` runs bounded least squares (``scipy.optimize.least_squares``,
  trust-region reflective) from several starts and keeps the lowest cost;
* uncertainty: :func:`uncertainty` gives ``cov = s^2 (J^T J)^-1`` at the optimum (pseudo-inverse;
  directions the Jacobian does not see are flagged as not identifiable), :func:`correlations` the
  pairs the data cannot separate;
* output: :func:`fitted_yaml` (``preset: <base>`` plus the fitted fields, unit-named keys that
  :meth:`PlantParams.from_yaml` reads) and :func:`parameter_lines` (the report's table).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..plant.params import PlantParams
from ..units import from_si, to_si


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
    log: bool = False  # scaled logarithmically between its bounds (needs lo > 0)


def field_accessors(name: str) -> tuple[Callable[[PlantParams], float], Callable[[PlantParams, float], dict]]:
    """Getter and setter of a PlantParams field in its edge unit (the field's own unit)."""
    unit = PlantParams.__dataclass_fields__[name].metadata["unit"]
    return (lambda p: from_si(getattr(p, name), unit)), (lambda p, v: {name: to_si(v, unit)})


def field_param(name: str, lo: float, hi: float, why: str, log: bool = False) -> FitParam:
    """A :class:`FitParam` that is one PlantParams field in its own edge unit."""
    unit = PlantParams.__dataclass_fields__[name].metadata["unit"]
    return FitParam(name, unit, lo, hi, why, *field_accessors(name), (name,), log)


def check_names(table: dict[str, FitParam], names: Sequence[str]) -> None:
    """``ValueError`` for a name the table lacks, or two names that write the same field."""
    for n in names:
        if n not in table:
            raise InputError(f"unknown fit parameter {n!r}; one of {sorted(table)}")
    written = [f for n in names for f in table[n].fields]
    if len(set(written)) != len(written):
        raise InputError(
            f"fit parameters {list(names)} write the same field twice (e.g. wall_thickness "
            "and bladder_thickness); choose one"
        )


def apply(table: dict[str, FitParam], base: PlantParams, names, values) -> PlantParams:
    """``base`` with the fit parameters ``names`` set to ``values`` (edge units); validated."""
    p = base
    for name, v in zip(names, values):
        p = p.replace(**table[name].set(p, float(v)))
    return p


class Scaling:
    """Edge values <-> ``z`` in [0, 1] inside each parameter's bounds (linear or logarithmic)."""

    def __init__(self, params: Sequence[FitParam], bounds: dict[str, tuple[float, float]] | None = None):
        self.names = tuple(fp.name for fp in params)
        lim = [(bounds or {}).get(fp.name, (fp.lo, fp.hi)) for fp in params]
        self.lo = np.array([a for a, _ in lim], float)
        self.hi = np.array([b for _, b in lim], float)
        if np.any(self.hi <= self.lo):
            bad = [n for n, a, b in zip(self.names, self.lo, self.hi) if not b > a]
            raise InputError(f"fit bounds must have lo < hi: {bad}")
        self.log = np.array([fp.log and a > 0 for fp, a in zip(params, self.lo)])
        self._a = np.where(self.log, np.log(np.where(self.log, self.lo, 1.0)), self.lo)
        self._b = np.where(self.log, np.log(np.where(self.log, self.hi, 1.0)), self.hi)

    def to_edge(self, z: np.ndarray) -> np.ndarray:
        u = self._a + np.asarray(z, float) * (self._b - self._a)
        return np.where(self.log, np.exp(np.where(self.log, u, 0.0)), u)

    def to_z(self, x: np.ndarray) -> np.ndarray:
        x = np.clip(np.asarray(x, float), self.lo, self.hi)
        u = np.where(self.log, np.log(np.where(self.log, x, 1.0)), x)
        return np.clip((u - self._a) / (self._b - self._a), 0.0, 1.0)

    def dx_dz(self, z: np.ndarray) -> np.ndarray:
        """Slope of the edge value in ``z`` (turns a covariance in ``z`` into edge units)."""
        span = self._b - self._a
        return np.where(self.log, self.to_edge(z) * span, span)

    def bounds(self) -> dict[str, tuple[float, float]]:
        return {n: (float(a), float(b)) for n, a, b in zip(self.names, self.lo, self.hi)}


def solve(
    residuals: Callable[[np.ndarray], np.ndarray],
    z0s: Sequence[np.ndarray],
    jac: Callable[[np.ndarray], np.ndarray] | str = "2-point",
    max_nfev: int | None = None,
    tol: float = 1e-10,
    diff_step: float = 1e-4,
):
    """Bounded least squares in ``z`` in [0, 1] from each start; the lowest-cost solution (scipy's
    ``OptimizeResult``). Starts that fail with ``ValueError`` are skipped."""
    from scipy.optimize import least_squares

    best = None
    for z0 in z0s:
        try:
            sol = least_squares(
                residuals,
                np.asarray(z0, float),
                jac=jac,
                bounds=(0.0, 1.0),
                method="trf",
                diff_step=diff_step,
                x_scale=1.0,
                xtol=tol,
                ftol=tol,
                gtol=tol,
                max_nfev=max_nfev,
            )
        except ValueError:
            continue
        if best is None or sol.cost < best.cost:
            best = sol
    if best is None:
        raise RuntimeError("no start gave a valid parameter set")
    return best


def fd_jacobian(
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


@dataclass
class Uncertainty:
    cov: np.ndarray  # edge units; nan without residual degrees of freedom
    std: np.ndarray  # nan where not identifiable / undefined
    rank_ok: np.ndarray  # bool: the Jacobian has a component along the parameter
    notes: list[str]


def uncertainty(
    Jz: np.ndarray, r: np.ndarray, dx_dz: np.ndarray, names: Sequence[str], inflation: float = 1.0
) -> Uncertainty:
    """``cov = s^2 (J^T J)^-1`` in edge units from the Jacobian ``Jz`` in ``z`` and the residuals
    ``r`` at the optimum, ``s^2 = inflation * sum(r^2) / (m - k)``. ``inflation`` > 1 widens the
    intervals when the residuals are correlated in time (fewer independent samples than rows).
    A parameter lying in the (numerical) null space of ``Jz`` is not identifiable: no
    uncertainty is given for it."""
    m, k = Jz.shape
    notes: list[str] = []
    rank_ok = np.ones(k, bool)
    if m <= k:
        notes.append(f"{m} residuals for {k} parameters: no residual degrees of freedom, no uncertainty")
        return Uncertainty(np.full((k, k), np.nan), np.full(k, np.nan), rank_ok, notes)
    _, s, vt = np.linalg.svd(Jz, full_matrices=False)
    tiny = s < 1e-8 * max(s.max(), 1e-300)
    for j in range(k):
        if np.any(tiny & (np.abs(vt[:, j]) > 1e-3)):
            rank_ok[j] = False
    J = Jz / dx_dz  # d r / d (edge value)
    s2 = inflation * float(r @ r) / (m - k)
    cov = s2 * np.linalg.pinv(J.T @ J, rcond=1e-10)
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    std[~rank_ok] = np.nan
    if np.any(~rank_ok):
        notes.append(
            "not identifiable from these data (the Jacobian has no component along them): "
            + ", ".join(n for n, i in zip(names, rank_ok) if not i)
        )
    return Uncertainty(cov, std, rank_ok, notes)


def at_bounds(sol, eps: float = 1e-6) -> np.ndarray:
    """Which parameters of a :func:`solve` solution sit on a bound."""
    return (sol.active_mask != 0) | (sol.x < eps) | (sol.x > 1.0 - eps)


def correlations(names, cov, at_bound, threshold: float = 0.9) -> dict[tuple[str, str], float]:
    """Pairs of fitted parameters whose estimates correlate beyond ``threshold`` (from ``cov``)."""
    out = {}
    if not np.all(np.isfinite(cov)):
        return out
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            if sd[i] > 0 and sd[j] > 0 and not (at_bound[i] or at_bound[j]):
                rho = cov[i, j] / (sd[i] * sd[j])
                if abs(rho) > threshold:
                    out[(names[i], names[j])] = float(rho)
    return out


def correlation_notes(names, cov, at_bound) -> list[str]:
    return [
        f"{a} and {b} are strongly correlated (rho = {rho:+.2f}): the data fix a combination of "
        "them better than either"
        for (a, b), rho in correlations(names, cov, at_bound).items()
    ]


def parameter_lines(names, units, start, values, std, bounds, at_bound, extra=None) -> list[str]:
    """The report's parameter table (edge units): start, fitted, 1 sd, unit, bounds, flags;
    ``extra`` (optional, per parameter) is appended to each row."""
    lines = [f"  {'name':<28} {'start':>10} {'fitted':>10} {'+/- 1 sd':>10} {'unit':>13}  bounds"]
    for j, n in enumerate(names):
        lo, hi = bounds[n]
        sd = "n/a" if not math.isfinite(std[j]) else f"{std[j]:.3g}"
        flag = " (at bound)" if at_bound[j] else ""
        more = f"  {extra[j]}" if extra is not None and extra[j] else ""
        lines.append(
            f"  {n:<28} {start[j]:>10.4g} {values[j]:>10.4g} {sd:>10} {units[j]:>13}  "
            f"[{lo:g}, {hi:g}]{flag}{more}"
        )
    return lines


def fitted_yaml(params: PlantParams, fields: Sequence[str], base_preset: str, header: str = "") -> str:
    """``preset: <base>`` plus the ``fields`` of ``params``, unit-named (``PlantParams.to_dict``
    keys), under a ``#`` comment ``header``."""
    edge = params.to_dict()
    lines = [f"# {ln}" if ln else "#" for ln in header.splitlines()]
    lines.append(f"preset: {base_preset}")
    for key, name in PlantParams.edge_keys().items():
        if name in fields:
            value = edge[key]
            lines.append(f"{key}: {value}" if isinstance(value, str) else f"{key}: {value:.6g}")
    return "\n".join(lines) + "\n"
