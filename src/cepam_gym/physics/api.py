"""Array front-end of the physics kernels: every function accepts scalars or arrays of any shape
(broadcast together) and a parameter source (a :class:`~cepam_gym.plant.params.PlantParams`, one
parameter row, or an ``(N, N_PARAMS)`` array matching the batch), and returns arrays of the
broadcast shape (0-d arrays become Python-float-like numpy scalars).

The scalar kernels are the ones the plant runs; this module only loops over them.

**Naming convention.** ``api.<name>`` is the array form of the scalar kernel ``<name>`` of
:mod:`~cepam_gym.physics.muscle`, :mod:`~cepam_gym.physics.statics` or
:mod:`~cepam_gym.physics.valve` when one exists (``api.chamber_volumes`` of
``muscle.chamber_volumes``, ``api.static_pressures`` of ``statics.static_pressures``, ...), and
takes the same arguments with arrays and a parameter source in place of scalars and one row.
The two never meet unqualified: callers import the module (``from cepam_gym.physics import api``)
and write ``api.<name>``, never ``from cepam_gym.physics.api import <name>`` (a test checks this).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from . import bladder, muscle, statics, valve
from . import layout as ix

__all__ = [
    "force_terms",
    "force",
    "stiffness",
    "closed_chamber_stiffness",
    "chamber_volumes",
    "static_pressures",
    "static_pressures_exact",
    "iso6358_flow",
    "contact_pressures",
]


def _param_rows(params, n: int) -> np.ndarray:
    if hasattr(params, "to_array"):
        params = params.to_array()
    arr = np.asarray(params, dtype=float)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.shape[-1] != ix.N_PARAMS:
        raise ValueError(f"parameter rows must have {ix.N_PARAMS} columns, got shape {arr.shape}")
    arr = arr.reshape(-1, ix.N_PARAMS)
    if arr.shape[0] not in (1, n):
        raise ValueError(f"{arr.shape[0]} parameter rows do not match a batch of {n}")
    return np.ascontiguousarray(arr)


_LOOPS: dict = {}


def _loop(fn, n_in: int):
    """The compiled loop of kernel ``fn`` over n_in-argument rows: ``loop(*inputs, P, n_out, out)``.
    One loop per kernel with ``fn`` bound at compile time: passing a jitted function as an argument
    costs numba a typing of it on every call (about 20 us, more than a small batch's work)."""
    key = (fn, n_in)
    loop = _LOOPS.get(key)
    if loop is None:
        if n_in == 3:

            @njit(cache=False)
            def loop(a, b, c, P, n_out, out):
                shared = P.shape[0] == 1
                for i in range(a.shape[0]):
                    r = fn(a[i], b[i], c[i], P[0] if shared else P[i])
                    for j in range(n_out):
                        out[j, i] = r[j]
        else:

            @njit(cache=False)
            def loop(a, P, n_out, out):
                shared = P.shape[0] == 1
                for i in range(a.shape[0]):
                    r = fn(a[i], P[0] if shared else P[i])
                    for j in range(n_out):
                        out[j, i] = r[j]

        loop = _LOOPS[key] = loop
    return loop


def _call(fn, n_out, params, *args):
    arrays = np.broadcast_arrays(*[np.asarray(a, dtype=float) for a in args])
    shape = arrays[0].shape
    flat = [np.array(a, dtype=float).reshape(-1) for a in arrays]  # copies: broadcast views are read-only
    n = flat[0].shape[0]
    P = _param_rows(params, n)
    if P.shape[0] == n and n > 1 and shape != (n,):
        raise ValueError("per-plant parameters need 1-D inputs of the same length")
    out = np.empty((n_out, n))
    _loop(fn, len(flat))(*flat, P, n_out, out)
    return tuple(o.reshape(shape) for o in out)


def force_terms(length, pressure_c, pressure_e, params):
    """``(F, K, dF/dPc, dF/dPe)`` of the CE-PAM: push force [N], stiffness ``-dF/dL`` at constant
    pressures [N/m], and the force's pressure sensitivities [m^2]. Pressures gauge [Pa]."""
    return _call(muscle.cepam_force, 4, params, length, pressure_c, pressure_e)


def force(length, pressure_c, pressure_e, params):
    """Push force [N] (extension positive) at length [m] and gauge pressures [Pa] (Eq. 25/41/45)."""
    return force_terms(length, pressure_c, pressure_e, params)[0]


def stiffness(length, pressure_c, pressure_e, params):
    """Stiffness ``K = -dF/dL`` [N/m] at constant chamber pressures (exact derivative)."""
    return force_terms(length, pressure_c, pressure_e, params)[1]


@njit
def _closed(L, pc, pe, p):
    return (muscle.closed_chamber_stiffness(L, pc, pe, p),)


def closed_chamber_stiffness(length, pressure_c, pressure_e, params):
    """Stiffness [N/m] with both chambers sealed (air polytropic, dead volumes included)."""
    return _call(_closed, 1, params, length, pressure_c, pressure_e)[0]


def chamber_volumes(length, params):
    """``(V_cpam, V_annulus, dV_cpam/dL, dV_annulus/dL)`` [m^3, m^2], dead volumes included."""
    return _call(muscle.chamber_volumes, 4, params, length)


def static_pressures(length, stiffness_target, weight, params):
    """Inverse static model: ``(Pc, Pe, ok)`` gauge [Pa] holding ``length`` with
    ``stiffness_target`` under the downward force ``weight`` [N]; see physics.statics."""
    Pc, Pe, ok = _call(statics.static_pressures, 3, params, length, stiffness_target, weight)
    return Pc, Pe, ok.astype(bool)


def static_pressures_exact(length, stiffness_target, weight, params):
    """:func:`static_pressures` solved exactly for plant v2's extensible braids (the threads
    stretched at the solution); the same numbers for inextensible braids (v0, v1)."""
    Pc, Pe, ok = _call(statics.static_pressures_exact, 3, params, length, stiffness_target, weight)
    return Pc, Pe, ok.astype(bool)


@njit
def _flow(p_up, p_down, t_up, cbr):
    return (valve.iso6358_flow(p_up, p_down, t_up, cbr[0], cbr[1], cbr[2]),)


def iso6358_flow(p_up, p_down, t_up, conductance, critical_ratio, laminar_ratio=0.995):
    """ISO 6358 mass flow [kg/s] from absolute ``p_up`` to ``p_down`` [Pa] (``p_up >= p_down``)."""
    cbr = np.array([[conductance, critical_ratio, laminar_ratio]], dtype=float)
    arrays = np.broadcast_arrays(*[np.asarray(a, dtype=float) for a in (p_up, p_down, t_up)])
    flat = [np.array(a, dtype=float).reshape(-1) for a in arrays]  # copies: broadcast views are read-only
    out = np.empty((1, flat[0].shape[0]))
    _loop(_flow, 3)(flat[0], flat[1], flat[2], cbr, 1, out)
    return out[0].reshape(arrays[0].shape)


@njit
def _contact(L, p):
    prc, _, pre, _ = muscle.contact_pressures(L, p)
    return prc, pre


def contact_pressures(length, params):
    """``(P_rc, P_re)`` [Pa]: pressure each bladder spends reaching its sleeve (Eq. 27-28, 32)."""
    return _call(_contact, 2, params, length)


@njit
def _energy(L, p):
    return bladder.bladder_energies(L, p)


def bladder_energy(length, params):
    """``(U, dU/dL, d2U/dL2)`` [J, N, N/m]: strain energy stored in both bladder walls (plant v1,
    neo-Hookean; zeros for a v0 plant) and its length derivatives. The walls push with ``-dU/dL``."""
    return _call(_energy, 3, params, length)


def cpam_tension(length, pressure_c, pressure_e, params):
    """``(c, c_taut)`` [N] of :func:`cepam_gym.physics.muscle.cpam_tension`: the tension-only
    CPAM is fully taut where ``c <= c_taut``."""
    return _call(muscle.cpam_tension, 2, params, length, pressure_c, pressure_e)
