"""The paper's experiments run through its own protocols on the dynamic plant.

:mod:`cepam_gym.validation.equilibrium` solves each experiment statically (pressures held, the
first equilibrium of ``F(L) + W = 0``). A rig does not: it pressurises the chambers in an order,
waits, hangs weights and reads lengths, and dry friction between braids and bladders (the plant's
Maxwell-slip elements, :mod:`cepam_gym.physics.friction`) makes the result depend on that history.
This module runs the same experiments on :func:`cepam_gym.plant.step` (regulated pressures, the
plant's valves, air, friction and free end), in the paper's order (sections II, III, XII):

1. the end hangs unloaded (its cap only) at its start length (CE-PAM and EPAM: 15 cm, the EPAM
   bladder's length; CPAM: its 19.5 cm rest length);
2. the extensor's regulator ramps to ``Pe`` in ``ramp_s`` and holds for ``settle_s`` ("the pressure
   was first applied to the extensor muscle until it reaches a length of 17.5 cm");
3. then the contractor's ramps to ``Pc`` and holds the same way ("then the pressure was increased
   for the contraction muscle"); the fixed-stiffness point of Fig. 26 has its own sequence: the
   extensor to 75 kPa first (18.5 cm), then both chambers together, gradually (three ramp times),
   to the pair;
4. the unloaded length ``L0`` is read; from that state each weight of ``loads_g`` is hung alone
   for ``hang_s`` (copies of the plant, so every weight starts from the same unloaded state, as
   "from the unloaded state" reads) and its length ``L_m`` read at the end;
   stiffness = ``mean(m g / (L_m - L0))`` (the paper's average of force over displacement).

A single muscle runs on the same kernel with the other muscle removed from its parameter row:
the coupling factors and the other bladder's wall are zeroed as in the static validation, and an
absent CPAM (the EPAM alone) gets a vanishing braid (``1e6`` turns: no air, no force), so the EPAM
can pass the CPAM's braid length. Every experiment of a table runs in one batch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import plant as pl
from ..errors import InputError
from ..physics import layout as ix
from ..plant.params import PlantParams
from ..units import from_si, to_si
from .equilibrium import _row, device_range, experiment_params
from .experiments import Experiment

RIG_SUPPLY = 600e3  # Pa gauge: the rig's regulators are fed above every pressure the paper used


@dataclass(frozen=True)
class Protocol:
    """Timing of a rig experiment [s] and the plant's integration step."""

    ramp_s: float = 1.0  # each regulator ramps to its set-point over this time
    settle_s: float = 3.0  # then holds it this long before the next action
    hang_s: float = 3.0  # each weight hangs this long before its length is read (the paper's protocol: 3 s)
    dt: float = 5e-4  # plant sub-step [s]
    chunk_s: float = 0.02  # set-points are updated at this period (50 Hz)
    # the paper does not say whether each weight hung alone or on top of the previous ones: False
    # (default) hangs each alone from the unloaded state, True adds them one after another
    cumulative: bool = False

    def __post_init__(self):
        for name in ("ramp_s", "settle_s", "hang_s", "dt", "chunk_s"):
            if not getattr(self, name) > 0.0:
                raise InputError(f"protocol {name} must be > 0, got {getattr(self, name)}")


@dataclass
class ProtocolResult:
    """What the rig read for one experiment: lengths in m, stiffness in N/m (nan if not measured)."""

    length0: float
    lengths: np.ndarray  # loaded lengths, one per weight
    stiffness: float
    value: float  # in the experiment's unit
    note: str = ""


def device_row(params: PlantParams, exp: Experiment) -> np.ndarray:
    """Kernel parameter row of the experiment's device with the rig's supply and its end stops."""
    p = experiment_params(exp, params)
    row = _row(p, exp.device)  # the EPAM alone has a vanishing CPAM there
    _start, lo, hi = device_range(p, exp.device)
    if exp.device == "cpam":
        # unpressurised, a lone CPAM hangs from its bladder glued at its rest length; without that
        # stop a plant with no wall energy (v0) would fall to the braid's limit, where its air
        # diameter (Eq. 34) vanishes, before the pressure is applied
        hi = min(hi, p.cpam_rest_length)
    row[ix.L_MIN], row[ix.L_MAX] = lo, hi
    row[ix.P_SUP] = row[ix.P_ATM] + RIG_SUPPLY
    row[ix.P_BURST] = math.inf
    return row


def _targets(exp: Experiment) -> tuple[float, float]:
    pc = to_si(exp.pc_kpa, "kpa") if exp.device != "epam" else 0.0
    pe = to_si(exp.pe_kpa, "kpa") if exp.device != "cpam" else 0.0
    return pc, pe


def is_fixed_stiffness_sequence(exp: Experiment) -> bool:
    """The CE-PAM experiment of Fig. 26 (section XII): reached by its own sequence, not the
    extensor-then-contractor order of Fig. 25."""
    return (
        exp.device == "cepam" and exp.pc_kpa > 0.0 and "Fig. 26" in exp.figure and "Fig. 25" not in exp.figure
    )


# Fig. 26: "increasing the pressure on the extensor muscle to 75 kPa, to reach its length of 18.5 cm
# ... With a gradual increasing in pressure on both muscles (maintaining a length of 18.5 cm)"
FIG26_START_PE = 75e3  # Pa
FIG26_RAMPS = 3.0  # the gradual joint ramp takes this many ramp times


def _advance(state, inputs, rows, proto: Protocol, seconds: float, ramps=()):
    """Run ``seconds`` in chunks; each of ``ramps`` = (column, start, end, ramp time), values or
    per-plant arrays, moves a set-point column linearly from ``start`` to ``end`` over its time."""
    n_sub = max(1, round(proto.chunk_s / proto.dt))
    chunks = max(1, round(seconds / (n_sub * proto.dt)))
    aux = np.empty((state.shape[0], pl.N_AUX))
    for k in range(chunks):
        t = (k + 1) * n_sub * proto.dt
        for col, a, b, tr in ramps:
            inputs[:, col] = a + np.minimum(1.0, t / tr) * (b - a)
        pl.step(state, inputs, rows, pl.PRESSURE, proto.dt, n_sub, out=state, aux=aux)
    return aux


def run(experiments: list[Experiment], params: PlantParams, proto: Protocol | None = None) -> list:
    """Run every experiment through the protocol in one batch; one :class:`ProtocolResult` each
    (``None`` for a non-computable one)."""
    proto = proto or Protocol()
    todo = [e for e in experiments if e.computable]
    out: dict[str, ProtocolResult] = {}
    if todo:
        out = dict(zip((e.id for e in todo), _run_batch(todo, params, proto)))
    return [out.get(e.id) if e.computable else None for e in experiments]


def _run_batch(exps: list[Experiment], params: PlantParams, proto: Protocol) -> list[ProtocolResult]:
    n = len(exps)
    rows = np.stack([device_row(params, e) for e in exps])
    starts = np.array([device_range(experiment_params(e, params), e.device)[0] for e in exps])
    pc, pe = np.array([_targets(e) for e in exps]).T
    fig26 = np.array([is_fixed_stiffness_sequence(e) for e in exps])
    state = pl.initial_state(rows, starts, 0.0, 0.0)
    inputs = np.zeros((n, pl.N_INPUT))
    # 2. the extensor first (Fig. 26: to 75 kPa), 3. then the contractor (Fig. 26: both, gradually)
    pe1 = np.where(fig26, FIG26_START_PE, pe)
    ramp = proto.ramp_s
    _advance(state, inputs, rows, proto, ramp + proto.settle_s, [(pl.I_CMD_E, 0.0, pe1, ramp)])
    ramp2 = np.where(fig26, FIG26_RAMPS * ramp, ramp)
    _advance(
        state,
        inputs,
        rows,
        proto,
        float(ramp2.max()) + proto.settle_s,
        [(pl.I_CMD_E, pe1, pe, ramp2), (pl.I_CMD_C, 0.0, pc, ramp2)],
    )
    L0 = state[:, pl.S_L].copy()
    loads = [np.asarray(e.loads_g if e.measured == "stiffness" else (), float) for e in exps]
    if proto.cumulative:
        lengths = _hang_cumulative(state, inputs, rows, proto, loads)
    else:
        lengths = _hang_alone(state, inputs, rows, proto, loads)
    return [_reading(e, params, L0[i], lengths[i], rows[i]) for i, e in enumerate(exps)]


def _hang_alone(state, inputs, rows, proto: Protocol, loads: list) -> list:
    """4. the weights, each alone from the unloaded state: copies of every plant, one per weight."""
    idx = np.array([i for i, ld in enumerate(loads) for _ in ld], dtype=int)
    lengths = [np.empty(0) for _ in loads]
    if idx.size:
        s2 = state[idx].copy()
        in2 = inputs[idx].copy()
        in2[:, pl.I_LOAD] = np.concatenate(loads) * to_si(1.0, "g")
        _advance(s2, in2, rows[idx], proto, proto.hang_s)
        k = 0
        for i, ld in enumerate(loads):
            lengths[i] = s2[k : k + ld.size, pl.S_L].copy()
            k += ld.size
    return lengths


def _hang_cumulative(state, inputs, rows, proto: Protocol, loads: list) -> list:
    """4'. the weights in turn on the same plant, each replacing the previous (a heavier one)."""
    n_max = max((ld.size for ld in loads), default=0)
    lengths = [np.empty(ld.size) for ld in loads]
    for k in range(n_max):
        for i, ld in enumerate(loads):
            inputs[i, pl.I_LOAD] = ld[min(k, ld.size - 1)] * to_si(1.0, "g") if ld.size else 0.0
        _advance(state, inputs, rows, proto, proto.hang_s)
        for i, ld in enumerate(loads):
            if k < ld.size:
                lengths[i][k] = state[i, pl.S_L]
    return lengths


def _reading(e: Experiment, params: PlantParams, L0: float, Lm: np.ndarray, row) -> ProtocolResult:
    note = []
    lo, hi = row[ix.L_MIN], row[ix.L_MAX]
    if L0 <= lo + 1e-9 or L0 >= hi - 1e-9:
        note.append(f"unloaded on the {'lower' if L0 <= lo + 1e-9 else 'upper'} stop")
    k = math.nan
    if e.measured == "stiffness":
        w = np.asarray(e.loads_g, float) * to_si(1.0, "g") * params.gravity
        dl = Lm - L0
        ok = (dl > 0.0) & (Lm < hi - 1e-9)
        if np.any(~ok):
            note.append(f"{int((~ok).sum())} weight(s) on a stop or not moving, left out")
        k = float(np.mean(w[ok] / dl[ok])) if np.any(ok) else math.nan
    if e.measured == "length":
        value = from_si(L0, "cm")
    elif e.measured == "contraction":
        value = 100.0 * (params.cpam_rest_length - L0) / params.cpam_rest_length
    elif e.measured == "extension":
        value = 100.0 * (L0 - params.min_length) / params.min_length
    elif e.measured == "stiffness":
        value = k
    else:
        value = math.nan
        note.append(f"a {e.measured} is not measured by this protocol")
    return ProtocolResult(L0, Lm, k, value, "; ".join(note))


def protocol_values(experiments: list[Experiment], params: PlantParams, proto: Protocol | None = None):
    """The protocol's value of each experiment in its unit (nan where none): the model function
    of the plant v2 calibration (:func:`cepam_gym.validation.fit.fit` ``model_fn``)."""
    try:
        results = run(experiments, params, proto)
    except ValueError:
        return np.full(len(experiments), math.nan)
    return np.array([math.nan if r is None else r.value for r in results])


def stiffness_notions(params: PlantParams, pairs_kpa, loads_g=(50, 100, 150, 200, 250, 300)) -> list[dict]:
    """Both stiffnesses at the unloaded static equilibrium of each ``(Pe, Pc)`` pair [kPa]: the
    tangent ``-dF/dL`` (what the envs regulate and their targets are stated in) and the protocol
    (secant) stiffness a rig reads, quasi-statically (:func:`cepam_gym.physics.secant.secant_stiffness`).
    Pairs whose unloaded end rests on a stop are skipped."""
    from ..physics import api, secant
    from .equilibrium import NetForce, settle

    row = params.to_array()
    weights = np.asarray(loads_g, float) * to_si(1.0, "g") * params.gravity
    out = []
    for pe_kpa, pc_kpa in pairs_kpa:
        pc, pe = to_si(pc_kpa, "kpa"), to_si(pe_kpa, "kpa")
        w_end = params.end_mass * params.gravity
        L0, where = settle(
            NetForce(pc, pe, row, w_end), params.min_length, params.min_length, params.max_length
        )
        if where != "free":
            continue
        kt = float(api.stiffness(L0, pc, pe, row))
        ks = float(secant.secant_stiffness(L0, pc, pe, row, weights))
        out.append(
            {"pe_kpa": pe_kpa, "pc_kpa": pc_kpa, "length_cm": from_si(L0, "cm"), "tangent": kt, "secant": ks}
        )
    return out
