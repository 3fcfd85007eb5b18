"""The plant's compiled block kernel: :func:`advance_block` advances a block of up to
:data:`BLOCK` plants, vectorised across them; :func:`step` maps it over a batch of N plants
(serially for small N, over all cores with ``numba.prange`` for large N). There is no other copy of
the equations: single envs, vector envs, the controllers' simulations and the tests all run
:func:`advance_block`, and :func:`advance_block_hinge` is the same block kernel with the free end
driving a hinge (``cepam_gym/CEPAMJoint-v1``, :mod:`cepam_gym.physics.hinge`).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .._jit import jit, jit_inline, strided_tuple
from ..physics import layout as ix
from ..physics.friction import friction_slip
from ..physics.hinge import hinge_constants, link_weight_force
from ..physics.load import load_constants, load_step_k
from .layout import (
    HINGE,
    I_FEXT,
    I_LOAD,
    N_AUX,
    N_INPUT,
    N_STATE,
    ONOFF,
    ONOFF_EXACT,
    PRESSURE,
    PROPORTIONAL,
    RIG,
    S_L,
    S_MC,
    S_ME,
    S_SC,
    S_SE,
    S_SRC,
    S_SRE,
    S_T,
    S_UC,
    S_UE,
    S_V,
    S_Z1,
    S_Z2,
    S_Z3,
)
from .substep import end_of_step, substep_account, substep_air, substep_forces, valve_setup, volumes_at

PARALLEL_MIN_BATCH = (
    256  # below this thread start-up (and, on a busy 2-core VM, OpenMP wake-up) costs more than it saves
)


# ------------------------------------------------------- structure-of-arrays block kernel
# The plants of a batch are advanced BLOCK at a time. A block's scratch array ``W`` holds, row by
# row, one value per plant (structure of arrays): the state columns (S_*), the inputs (I_*), the
# constants of the control step, the volumes carried from one sub-step to the next, the step's
# accumulators and the parameter row. The innermost loop runs across the plants of the block on
# these contiguous rows, so LLVM vectorises it (4 plants per AVX2 instruction); the outer loop
# runs over the sub-steps. One plant (a single env) is the same code with a block of one.
BLOCK = 16
_W_IN = N_STATE  # inputs, in I_* order
_W_FEXT = _W_IN + N_INPUT  # gravity + external force [N]
_W_DTM, _W_DVF, _W_DAMP = _W_FEXT + 1, _W_FEXT + 2, _W_FEXT + 3  # load_constants
_W_VALVES = _W_FEXT + 4  # tau, conductance, order, zeta, decay of valve_setup
_W_VC, _W_VE, _W_DVC, _W_DVAC, _W_DVAE, _W_INVC, _W_INVE = range(_W_VALVES + 5, _W_VALVES + 12)
_W_AIR, _W_PMAX, _W_STOP, _W_DMC, _W_DME = range(_W_VALVES + 12, _W_VALVES + 17)
_W_LINK, _W_INVR = _W_VALVES + 17, _W_VALVES + 18  # hinge only: link weight per sin(theta), 1 / r
_W_P = _W_VALVES + 19  # the parameter row, N_PARAMS rows
W_SIZE = (_W_P + ix.N_PARAMS) * BLOCK
_NP = ix.N_PARAMS  # literal for strided_tuple


@jit_inline
def _w(row, i):
    """Index of plant ``i``'s value in scratch row ``row``."""
    return row * BLOCK + i


@jit_inline
def lane_substep(W, i, mode, dt, mech):
    """One sub-step of plant ``i`` of a block, read from and written back to ``W``.

    Per sub-step: pressures at ``L`` -> spools -> flows -> force at ``L`` -> load step (kick with
    that force, drift with the new velocity) -> air: flows, then the work of the volume change
    ``V(L_old) -> V(L_new)``. The parameter row and the inputs reach the physics as tuples
    (:func:`strided_tuple`), indexed like arrays.
    """
    p = strided_tuple(W, _w(_W_P, i), _NP, BLOCK)
    inp = strided_tuple(W, _w(_W_IN, i), N_INPUT, BLOCK)
    valves = (
        W[_w(_W_VALVES, i)],
        W[_w(_W_VALVES + 1, i)],
        W[_w(_W_VALVES + 2, i)],
        W[_w(_W_VALVES + 3, i)],
        W[_w(_W_VALVES + 4, i)],
    )
    L = W[_w(S_L, i)]
    vol_c = W[_w(_W_VC, i)]
    vol_e = W[_w(_W_VE, i)]
    mc, uc, me, ue = W[_w(S_MC, i)], W[_w(S_UC, i)], W[_w(S_ME, i)], W[_w(S_UE, i)]
    z1, z2, z3 = W[_w(S_Z1, i)], W[_w(S_Z2, i)], W[_w(S_Z3, i)]
    force, pc, pe, sc, se, src, sre, dmc, duc, dme, due, sup = substep_forces(
        mode, inp, p, W[_w(S_T, i)], dt, L, mc, uc, me, ue,
        W[_w(_W_INVC, i)], W[_w(_W_INVE, i)], W[_w(_W_DVC, i)], W[_w(_W_DVAC, i)], W[_w(_W_DVAE, i)],
        W[_w(S_SC, i)], W[_w(S_SE, i)], W[_w(S_SRC, i)], W[_w(S_SRE, i)], valves, z1, z2, z3,
    )  # fmt: skip
    W[_w(_W_PMAX, i)], W[_w(_W_AIR, i)] = substep_account(
        W[_w(_W_PMAX, i)], W[_w(_W_AIR, i)], pc, pe, sup, dt
    )
    L_old = L
    f_total = force + W[_w(_W_FEXT, i)]
    if mech == HINGE:  # a compile-time constant: the rig's loop has no trace of it
        f_total += link_weight_force(L, p[ix.L_MAX], W[_w(_W_LINK, i)], W[_w(_W_INVR, i)])
    L, v, stop = load_step_k(
        L, W[_w(S_V, i)], f_total, W[_w(_W_DTM, i)], W[_w(_W_DVF, i)], W[_w(_W_DAMP, i)],
        p[ix.L_MIN], p[ix.L_MAX], dt,
    )  # fmt: skip
    if p[ix.FR_C] > 0.0:
        W[_w(S_Z1, i)], W[_w(S_Z2, i)], W[_w(S_Z3, i)] = friction_slip(p, L - L_old, z1, z2, z3)
    vol_c_new, vol_e_new, dvc, dvac, dvae = volumes_at(L, p)
    inv_c = 1.0 / vol_c_new  # one division serves the work ratio and the next pressures
    inv_e = 1.0 / vol_e_new
    mc, uc, me, ue = substep_air(mc, uc, me, ue, dmc, duc, dme, due, vol_c * inv_c, vol_e * inv_e, dt)
    W[_w(S_L, i)], W[_w(S_V, i)], W[_w(_W_STOP, i)] = L, v, stop
    W[_w(S_MC, i)], W[_w(S_UC, i)], W[_w(S_ME, i)], W[_w(S_UE, i)] = mc, uc, me, ue
    W[_w(S_SC, i)], W[_w(S_SE, i)], W[_w(S_SRC, i)], W[_w(S_SRE, i)] = sc, se, src, sre
    W[_w(S_T, i)] += dt
    W[_w(_W_VC, i)], W[_w(_W_VE, i)], W[_w(_W_INVC, i)], W[_w(_W_INVE, i)] = (
        vol_c_new,
        vol_e_new,
        inv_c,
        inv_e,
    )
    W[_w(_W_DVC, i)], W[_w(_W_DVAC, i)], W[_w(_W_DVAE, i)] = dvc, dvac, dvae
    W[_w(_W_DMC, i)], W[_w(_W_DME, i)] = dmc, dme


@jit_inline
def _substeps_mode(W, n, mode, dt, n_sub, mech):
    for _ in range(n_sub):
        for i in range(n):
            lane_substep(W, i, mode, dt, mech)


@jit_inline
def _any_exact_pwm(W, n):
    """Whether a plant of the block switches its on/off valves at their exact PWM edges
    (``kernel_mode``): the block then runs the ``ONOFF_EXACT`` loop, each plant by its own timing."""
    for i in range(n):
        if W[_w(_W_P + ix.PWM_EXACT, i)] > 0.0:
            return True
    return False


@jit
def _substeps(W, n, mode, dt, n_sub):
    """``n_sub`` sub-steps of the first ``n`` plants of a rig block (the mode is made a
    compile-time constant of each loop, so its branches vanish)."""
    if mode == ONOFF and _any_exact_pwm(W, n):
        _substeps_mode(W, n, ONOFF_EXACT, dt, n_sub, RIG)
    elif mode == ONOFF:
        _substeps_mode(W, n, ONOFF, dt, n_sub, RIG)
    elif mode == PRESSURE:
        _substeps_mode(W, n, PRESSURE, dt, n_sub, RIG)
    else:
        _substeps_mode(W, n, PROPORTIONAL, dt, n_sub, RIG)


@jit
def _substeps_hinge(W, n, mode, dt, n_sub):
    """:func:`_substeps` of a hinge block (a function of its own, compiled only when used)."""
    if mode == ONOFF and _any_exact_pwm(W, n):
        _substeps_mode(W, n, ONOFF_EXACT, dt, n_sub, HINGE)
    elif mode == ONOFF:
        _substeps_mode(W, n, ONOFF, dt, n_sub, HINGE)
    elif mode == PRESSURE:
        _substeps_mode(W, n, PRESSURE, dt, n_sub, HINGE)
    else:
        _substeps_mode(W, n, PROPORTIONAL, dt, n_sub, HINGE)


@jit_inline
def _lane_in(W, i, x, inp, p, mode, dt, mass, damping, f_ext):
    """Load plant ``i`` of a block into ``W``: state row ``x``, inputs ``inp``, parameter row
    ``p``, the valve constants and the load step's constants for a moving ``mass`` [kg] with
    viscous ``damping`` [N s/m] under the constant force ``f_ext`` [N, extension positive]."""
    for f in range(N_STATE):
        W[_w(f, i)] = x[f]
    for f in range(N_INPUT):
        W[_w(_W_IN + f, i)] = inp[f]
    for f in range(ix.N_PARAMS):
        W[_w(_W_P + f, i)] = p[f]
    tau, cvalve, order, zeta, decay = valve_setup(mode, p, dt)
    W[_w(_W_VALVES, i)], W[_w(_W_VALVES + 1, i)], W[_w(_W_VALVES + 2, i)] = tau, cvalve, order
    W[_w(_W_VALVES + 3, i)], W[_w(_W_VALVES + 4, i)] = zeta, decay
    W[_w(_W_FEXT, i)] = f_ext
    W[_w(_W_DTM, i)], W[_w(_W_DVF, i)], W[_w(_W_DAMP, i)] = load_constants(mass, damping, p[ix.F_COUL], dt)
    vol_c, vol_e, dvc, dvac, dvae = volumes_at(x[S_L], p)
    W[_w(_W_VC, i)], W[_w(_W_VE, i)], W[_w(_W_INVC, i)], W[_w(_W_INVE, i)] = (
        vol_c,
        vol_e,
        1.0 / vol_c,
        1.0 / vol_e,
    )
    W[_w(_W_DVC, i)], W[_w(_W_DVAC, i)], W[_w(_W_DVAE, i)] = dvc, dvac, dvae
    W[_w(_W_AIR, i)] = 0.0
    W[_w(_W_PMAX, i)] = -np.inf
    W[_w(_W_STOP, i)] = 0.0
    W[_w(_W_DMC, i)] = 0.0
    W[_w(_W_DME, i)] = 0.0


@jit_inline
def _lane_out(W, i, x, p, a):
    """Plant ``i`` of a block back to its state row ``x``; its ``aux`` row ``a``."""
    for f in range(N_STATE):
        x[f] = W[_w(f, i)]
    end_of_step(
        x,
        p,
        W[_w(_W_PMAX, i)],
        W[_w(_W_AIR, i)],
        W[_w(_W_DMC, i)],
        W[_w(_W_DME, i)],
        W[_w(_W_STOP, i)],
        a,
    )


@jit
def advance_block(state, inputs, params, lo, n, mode, dt, n_sub, out, aux, W):
    """Advance plants ``lo .. lo + n - 1`` (``n <= BLOCK``) of a batch by ``n_sub`` sub-steps of
    ``dt``; write their rows of ``out`` (may be ``state``) and ``aux``. ``W`` is a scratch array of
    ``W_SIZE`` floats. Every plant takes exactly the same floating-point operations whatever the
    block it is in, so a batch and single plants agree bit for bit."""
    shared = params.shape[0] == 1
    for i in range(n):
        r = lo + i
        p = params[0] if shared else params[r]
        mass = p[ix.M_END] + inputs[r, I_LOAD]
        # gravity and external force, down (extension) positive
        f_ext = mass * p[ix.GRAV] + inputs[r, I_FEXT]
        _lane_in(W, i, state[r], inputs[r], p, mode, dt, mass, p[ix.DAMP], f_ext)
    _substeps(W, n, mode, dt, n_sub)
    for i in range(n):
        r = lo + i
        _lane_out(W, i, out[r], params[0] if shared else params[r], aux[r])


@jit
def advance_block_hinge(state, inputs, params, hinge, lo, n, mode, dt, n_sub, out, aux, W):
    """:func:`advance_block` of plants driving a hinge (:mod:`cepam_gym.physics.hinge`):
    ``hinge`` (N or 1, N_HINGE) rows of the mechanism's constants; the state stays in muscle
    coordinates (``S_L``, ``S_V``), the hinge angle is ``(L_max - L) / r``. ``inputs[:, I_FEXT]``
    is the external torque over the lever arm, ``tau_ext / r`` [N, extension positive]."""
    shared = params.shape[0] == 1
    shared_h = hinge.shape[0] == 1
    for i in range(n):
        r = lo + i
        p = params[0] if shared else params[r]
        mass, damping, link, inv_r = hinge_constants(p, hinge[0] if shared_h else hinge[r], inputs[r, I_LOAD])
        f_ext = (p[ix.M_END] + inputs[r, I_LOAD]) * p[ix.GRAV] + inputs[r, I_FEXT]
        _lane_in(W, i, state[r], inputs[r], p, mode, dt, mass, damping, f_ext)
        W[_w(_W_LINK, i)] = link
        W[_w(_W_INVR, i)] = inv_r
    _substeps_hinge(W, n, mode, dt, n_sub)
    for i in range(n):
        r = lo + i
        _lane_out(W, i, out[r], params[0] if shared else params[r], aux[r])


@jit
def _step_serial(state, inputs, params, mode, dt, n_sub, out, aux):
    W = np.empty(W_SIZE)
    n = state.shape[0]
    for lo in range(0, n, BLOCK):
        advance_block(state, inputs, params, lo, min(BLOCK, n - lo), mode, dt, n_sub, out, aux, W)


@njit(parallel=True, cache=True, error_model="numpy")
def _step_parallel(state, inputs, params, mode, dt, n_sub, out, aux):
    n = state.shape[0]
    for b in prange((n + BLOCK - 1) // BLOCK):
        lo = b * BLOCK
        advance_block(
            state, inputs, params, lo, min(BLOCK, n - lo), mode, dt, n_sub, out, aux, np.empty(W_SIZE)
        )


def step(
    state, inputs, params, mode: int = PROPORTIONAL, dt: float = 5e-4, n_sub: int = 40, out=None, aux=None
):
    """Advance a batch of plants by ``n_sub`` sub-steps of ``dt`` s; returns ``(new_state, aux)``.

    ``state`` (N, N_STATE), ``inputs`` (N, N_INPUT), ``params`` (N or 1, N_PARAMS). Pass ``out`` and
    ``aux`` to reuse buffers (the envs do); ``out`` may be ``state`` itself.
    """
    n = state.shape[0]
    if out is None:
        out = np.empty_like(state)
    if aux is None:
        aux = np.empty((n, N_AUX))
    kernel = _step_parallel if n >= PARALLEL_MIN_BATCH else _step_serial
    kernel(state, inputs, params, int(mode), float(dt), int(n_sub), out, aux)
    return out, aux
