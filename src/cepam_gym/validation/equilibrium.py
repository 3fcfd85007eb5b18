"""How each experiment is simulated: the static equilibria of the free end and the stiffness
measured by hanging weights, on the plant's own force kernels.

regulators; the rig hangs vertically, so the end cap and any weight pull towards extension):

* ``length``: the unloaded free end (only its cap, ``end_mass``) settles from its starting length
  (CE-PAM and EPAM: the 15 cm bladder length; CPAM: its 19.5 cm rest length) to the first stable
  equilibrium ``F(L) + W = 0`` in the direction the net force moves it (grid scan, then
  ``brentq``). The CE-PAM has end stops at 15 and 19.5 cm; a single muscle is limited only by its
  braid (positive air diameter, Eq. 34).
* ``contraction`` / ``extension``: that length against 19.5 cm (CPAM) or 15 cm (EPAM, CE-PAM).
* ``stiffness``: as in the paper (sections II, III, XII; Fig. 5, 24): from the unloaded
  equilibrium ``L0`` the weights ``m`` are hung one at a time, each loaded equilibrium ``L_m`` is
  found the same way, and ``K = mean(m g / (L_m - L0))``. A weight that pulls the end onto a stop
  measures the stop and is left out (named in the note). If ``L0`` itself is on a stop there is no
  displacement to measure; the local ``-dF/dL`` at ``L0`` is reported instead and the note says so.
  With a *held* length (calibration data, ``held_length_cm``) the local ``-dF/dL`` there.
* ``force`` (calibration data): the push force at a held length.
* ``mean_force_error``: the paper's own model error against force curves that are only plotted
  (Fig. 18, 20, 23); listed, not computable.

Single muscles: the CPAM alone is the CE-PAM force with ``Pe = 0`` and the EPAM alone the one with
``Pc = 0`` and no CPAM term, each with its own air volume (Eq. 14 with ``P_a`` of Eq. 26-32 and
``V_air`` of Eq. 34-43); both are evaluated by the plant's kernels on a parameter row whose
coupling factors (kappa, lambda) and CE-PAM elasticity ``k_el`` are zeroed. Tube rows use the
plant's parameters with the tube's bladder thickness.

``cepam-gym validate`` prints the table and writes plots into ``--out-dir``; ``--json`` prints the
rows as a JSON list of objects with the keys ``name, unit, reported, model, rel_error,
model_level`` (plus ``id, source, force_model, force_form, method, note``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from .._jit import jit
from ..errors import InputError
from ..physics import api, muscle
from ..physics import layout as ix
from ..plant.params import PlantParams, fill_derived
from ..units import from_si, to_si
from .experiments import Experiment

_GRID = 4001  # scan points per settle search (about 0.01 mm over the CE-PAM range)


@jit
def _force_grid(lengths, pc, pe, row, weight):
    """``F(L) + weight`` on an array of lengths (the plant's kernel, Eq. 25 / 41-45)."""
    out = np.empty(lengths.shape[0])
    for i in range(lengths.shape[0]):
        out[i] = muscle.cepam_force(lengths[i], pc, pe, row)[0] + weight
    return out


class NetForce:
    """Net extension force on the free end, ``F(L) + weight`` [N], callable on a float or an
    array of lengths [m] (pressures held, kernel parameter row ``row``)."""

    def __init__(self, pc: float, pe: float, row: np.ndarray, weight: float):
        self.pc, self.pe, self.row, self.weight = float(pc), float(pe), row, float(weight)

    def __call__(self, L):
        if np.ndim(L) == 0:
            return muscle.cepam_force(float(L), self.pc, self.pe, self.row)[0] + self.weight
        return _force_grid(np.ascontiguousarray(L, dtype=float), self.pc, self.pe, self.row, self.weight)


def settle(g: Callable, start: float, lo: float, hi: float) -> tuple[float, str]:
    """Length where the end comes to rest when released at ``start`` under the net extension
    force ``g(L)`` (positive = extending; ``g`` takes a float or an array of lengths), with stops
    at ``lo`` and ``hi``.

    Returns ``(L, where)`` with ``where`` in ``{"free", "lower stop", "upper stop"}``; a free
    equilibrium is the first sign change of ``g`` in the direction of motion (found on a grid,
    refined by ``brentq``).
    """

    def g1(L: float) -> float:
        return float(g(L))

    g0 = g1(start)
    if g0 == 0.0:
        return start, "free"
    up = g0 > 0.0
    end = hi if up else lo
    if end == start:
        return start, "upper stop" if up else "lower stop"
    grid = np.linspace(start, end, _GRID)
    vals = g(grid)
    crossed = np.nonzero(vals <= 0.0 if up else vals >= 0.0)[0]
    if crossed.size == 0:
        return end, "upper stop" if up else "lower stop"
    i = int(crossed[0])
    if vals[i] == 0.0:
        return float(grid[i]), "free"
    a, b = sorted((float(grid[i - 1]), float(grid[i])))
    return float(brentq(g1, a, b, xtol=1e-13, rtol=1e-12)), "free"


# ------------------------------------------------------------------ the devices
def experiment_params(exp: Experiment, params: PlantParams) -> PlantParams:
    """The plant parameters of the device the experiment used: tube rows get the tube's wall and,
    with neo-Hookean bladders (plant v1), the tube rubber's modulus (braids are shared)."""
    if exp.bladder == "tube" and exp.bladder_thickness_mm is not None:
        return params.replace(
            bladder_thickness=to_si(exp.bladder_thickness_mm, "mm"),
            bladder_shear_modulus=params.tube_shear_modulus,
        )
    return params


def _row(params: PlantParams, device: str) -> np.ndarray:
    """Kernel parameter row. A single muscle: no CPAM-in-EPAM coupling (kappa = lambda = 0), no
    CE-PAM spring and no other muscle's bladder wall, so ``cepam_force`` reduces to
    ``P_ac dV_ac/dL`` (Pe = 0) or
    ``P_ae dV_ae/dL`` (Pc = 0), Eq. 14 of one muscle."""
    row = params.to_array()
    if device != "cepam":
        row[ix.KAPPA] = 0.0
        row[ix.LAMBDA] = 0.0
        row[ix.K_EL] = 0.0
        row[ix.COL_A] = 0.0  # plant v2: no CPAM to collapse
        if device == "epam":
            # the EPAM alone: a vanishing CPAM (no air, no force) whose braid the EPAM never
            # reaches (plant v2's stretched EPAM passes the CPAM's rest thread)
            row[ix.BC] = 4.0 * row[ix.BE]
            row[ix.NC] = 1e6
            fill_derived(row[None, :])
        # plant v1: only the muscle's own bladder wall stores energy
        row[ix.EL_E if device == "cpam" else ix.EL_C] = 0.0
    return row


def _pressures(exp: Experiment) -> tuple[float, float]:
    if exp.device == "cpam":
        return to_si(exp.pc_kpa, "kpa"), 0.0
    if exp.device == "epam":
        return 0.0, to_si(exp.pe_kpa, "kpa")
    return to_si(exp.pc_kpa, "kpa"), to_si(exp.pe_kpa, "kpa")


def braid_limit(params: PlantParams, device: str) -> float:
    """Longest length at which the braid keeps a positive air diameter ``D - 2 t_a`` (Eq. 34)."""
    b, n = params.cpam_braid() if device == "cpam" else params.epam_braid()
    s_min = min(2.0 * params.wall_thickness() * n * math.pi / b + 1e-6, 0.999)
    return b * math.sqrt(1.0 - s_min * s_min) * (1.0 - 1e-9)


def device_range(params: PlantParams, device: str) -> tuple[float, float, float]:
    """``(start, lo, hi)``: where a measurement starts and the stops the end meets [m]."""
    if device == "cepam":
        return params.min_length, params.min_length, params.max_length
    if device == "cpam":
        b, _ = params.cpam_braid()
        return params.cpam_rest_length, 0.05 * b, braid_limit(params, "cpam")
    # the EPAM bladder (15 cm = the CE-PAM's nominal length) is its shortest length
    return params.min_length, params.min_length, braid_limit(params, "epam")


@dataclass
class Outcome:
    value: float
    method: str
    note: str = ""


def simulate(exp: Experiment, params: PlantParams) -> Outcome:
    """The model's value of one experiment, in the experiment's unit (see the module docstring).

    ``params`` is the plant under test (force model and form included); tube rows replace the
    bladder thickness. Returns ``value = nan`` (with the reason in ``note``) if the device's
    parameter set is invalid or the quantity is not computable.
    """
    if not exp.computable:
        return Outcome(math.nan, "not computable", exp.note)
    try:
        p = experiment_params(exp, params)
    except ValueError as err:
        return Outcome(math.nan, "invalid parameters", str(err))
    row = _row(p, exp.device)
    pc, pe = _pressures(exp)
    start, lo, hi = device_range(p, exp.device)
    w_end = p.end_mass * p.gravity
    notes: list[str] = []

    def net(weight: float) -> NetForce:
        return NetForce(pc, pe, row, weight)

    if exp.measured == "force":
        L = to_si(exp.held_length_cm, "cm")
        return Outcome(float(api.force(L, pc, pe, row)), "force at held length")
    if exp.measured == "stiffness" and exp.held_length_cm is not None:
        L = to_si(exp.held_length_cm, "cm")
        return Outcome(float(api.stiffness(L, pc, pe, row)), "local -dF/dL at held length")

    load = to_si(exp.load_g, "g") * p.gravity if exp.measured == "length" else 0.0
    L0, where = settle(net(w_end + load), start, lo, hi)
    if where != "free":
        notes.append(f"rests on the {where} ({from_si(L0, 'cm'):.2f} cm)")
    if exp.measured == "length":
        return Outcome(from_si(L0, "cm"), "free length", "; ".join(notes))
    if exp.measured == "contraction":
        return Outcome(
            100.0 * (p.cpam_rest_length - L0) / p.cpam_rest_length, "free length", "; ".join(notes)
        )
    if exp.measured == "extension":
        return Outcome(100.0 * (L0 - p.min_length) / p.min_length, "free length", "; ".join(notes))
    if exp.measured != "stiffness":
        raise InputError(f"experiment {exp.id}: cannot simulate a {exp.measured!r}")

    # stiffness by hanging weights (sections II, III, XII)
    if where != "free":
        k = float(api.stiffness(L0, pc, pe, row))
        notes.append("no displacement to measure: local -dF/dL there reported")
        return Outcome(k, "local -dF/dL (on stop)", "; ".join(notes))
    ks, stopped = [], []
    for m in exp.loads_g:
        w = to_si(m, "g") * p.gravity
        Lm, wm = settle(net(w_end + w), L0, lo, hi)
        if wm != "free" or Lm <= L0:
            stopped.append(f"{m:g}")
            continue
        ks.append(w / (Lm - L0))
    notes.append(
        f"unloaded at {from_si(L0, 'cm'):.2f} cm"
        + (f" (paper {exp.at_length_cm:g} cm)" if exp.at_length_cm else "")
    )
    if stopped:
        notes.append(f"loads {', '.join(stopped)} g reach a stop and are left out")
    if not ks:
        k = float(api.stiffness(L0, pc, pe, row))
        notes.append("every load reaches a stop: local -dF/dL at the unloaded length reported")
        return Outcome(k, "local -dF/dL (loads on stop)", "; ".join(notes))
    return Outcome(float(np.mean(ks)), "hanging weights", "; ".join(notes))
