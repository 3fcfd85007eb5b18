"""The CE-PAM plant: state layout and integration of one control period with sub-steps.

gymnax style: pure functions over an explicit state array and a frozen parameter array. The one
compiled kernel :func:`advance_block` advances a block of up to :data:`BLOCK` plants, vectorised
across them; :func:`step` maps it over a batch of N plants (serially for small N, over all cores
with ``numba.prange`` for large N). There is no other copy of the equations: single envs, vector
envs, the baseline's simulations and the tests all run :func:`advance_block`, and
:func:`advance_block_hinge` is the same block kernel with the free end driving a hinge
(``cepam_gym/CEPAMJoint-v1``, :mod:`cepam_gym.physics.hinge`).

Arrays (all float64, batch-first):

* ``state``  (N, N_STATE)  columns named in :data:`STATE_FIELDS`
* ``inputs`` (N, N_INPUT)  valve commands, hanging load [kg], external force [N, down positive]
* ``params`` (N, N_PARAMS) or (1, N_PARAMS) rows of :meth:`PlantParams.to_array`
* ``aux``    (N, N_AUX)    what the step measured, columns named in :data:`AUX_FIELDS`

Valve modes: ``PROPORTIONAL`` (commands in [-1, 1] are spool set-points: -1 exhaust, 0 closed,
+1 supply), ``ONOFF`` (commands are PWM duties of two solenoid valves per chamber, sign picks
supply or exhaust), ``PRESSURE`` (commands are gauge pressure set-points [Pa] held by an in-plant
proportional regulator on the proportional valves, evaluated every sub-step).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ._jit import fmax, fmin, jit, jit_inline, sqrt, strided_tuple
from .physics import layout as ix
from .physics.air import chamber_rates, pressure_abs, pressure_abs_inv, state_from_pressure, temperature
from .physics.friction import friction_force, friction_slip
from .physics.hinge import hinge_constants, link_weight_force
from .physics.load import load_constants, load_step_k
from .physics.muscle import (
    chamber_volumes,
    closed_chamber_stiffness,
    cpam_terms,
    epam_terms,
    force_from_slopes,
)
from .physics.valve import spool_step

# ---------------------------------------------------------------- layouts
STATE_FIELDS = (
    "length",
    "velocity",
    "mass_c",
    "energy_c",
    "mass_e",
    "energy_e",
    "spool_c",
    "spool_e",
    "spool_rate_c",
    "spool_rate_e",
    "time",
    "slip_1",
    "slip_2",
    "slip_3",
)
S_L, S_V, S_MC, S_UC, S_ME, S_UE, S_SC, S_SE, S_SRC, S_SRE, S_T, S_Z1, S_Z2, S_Z3 = range(14)
N_STATE = 14
N_STATE_V0 = 11  # the v0 plant's columns (the slip deflections of plant v1 stay 0 without friction)

INPUT_FIELDS = ("command_c", "command_e", "load_mass", "external_force")
I_CMD_C, I_CMD_E, I_LOAD, I_FEXT = range(4)
N_INPUT = 4

AUX_FIELDS = (
    "force",
    "stiffness",
    "stiffness_closed",
    "pressure_c",
    "pressure_e",
    "temperature_c",
    "temperature_e",
    "volume_c",
    "volume_e",
    "mass_flow_c",
    "mass_flow_e",
    "air_used",
    "max_pressure",
    "burst",
    "end_stop",
    "finite",
)
(
    A_FORCE,
    A_STIFF,
    A_STIFF_CLOSED,
    A_PC,
    A_PE,
    A_TC,
    A_TE,
    A_VC,
    A_VE,
    A_MDOT_C,
    A_MDOT_E,
    A_AIR,
    A_PMAX,
    A_BURST,
    A_STOP,
    A_FINITE,
) = range(16)
N_AUX = 16

PROPORTIONAL, ONOFF, PRESSURE = 0, 1, 2
MODES = {"valve": PROPORTIONAL, "pwm": ONOFF, "pressure": PRESSURE}
# the mechanics a block of plants drives: the rig's free end (physics.load), or a hinge through a
# rack and pinion (physics.hinge, the rig's load step in muscle coordinates plus the link's weight)
RIG, HINGE = 0, 1

_MIN_MASS = 1e-15  # kg: keeps T = U/(m cv) defined if a chamber were ever emptied
_PARALLEL_MIN_BATCH = (
    256  # below this thread start-up (and, on a busy 2-core VM, OpenMP wake-up) costs more than it saves
)


@jit_inline
def _command(mode, u, pressure_gauge, t, p):
    """Spool command of one chamber's valve for this sub-step."""
    if mode == ONOFF:
        period = p[ix.PWM_PERIOD]
        d_on, d_off = p[ix.D_ON], p[ix.D_OFF]
        duty = abs(u)
        if d_on == 0.0 and d_off == 0.0:  # v0: the valve follows the PWM edges (after its lag)
            phase = (t - period * math.floor(t / period)) / period
            if phase < duty:
                return 1.0 if u > 0.0 else -1.0
            return 0.0
        # v1: dead times. The valve opens d_on after the rising edge and closes d_off after the
        # falling one; a pulse shorter than d_on - d_off never opens it. Full duty never switches.
        tp = t - period * math.floor(t / period)
        close = duty * period + d_off
        is_open = duty >= 1.0 or (close > d_on and ((d_on <= tp < close) or tp < close - period))
        if is_open:
            return 1.0 if u > 0.0 else -1.0
        return 0.0
    if mode == PRESSURE:
        c = p[ix.REG_GAIN] * (u - pressure_gauge)
        return fmax(-1.0, fmin(1.0, c))
    return u


@jit_inline
def _isentropic_factor(r):
    """``r^(gamma - 1)`` for a volume ratio ``r = V_old / V_new`` close to 1: how the internal
    energy of air scales when its volume changes with no heat and no flow (``U V^(gamma-1)``
    constant). A 4th-order series in ``r - 1`` (|r - 1| < 0.03 per sub-step even at 1 m/s; the
    truncation is then below 1e-7 relative) instead of ``pow``. Applying the work term this way,
    with the volume change over the whole sub-step, makes a sealed chamber an exactly
    conservative air spring, so the symplectic load step keeps the total energy bounded (an
    explicit ``-p dV/dt`` term made undamped oscillations grow)."""
    x = r - 1.0
    return 1.0 + x * (0.4 + x * (-0.12 + x * (0.064 - 0.0416 * x)))


@jit_inline
def valve_setup(mode, p, dt):
    """``(tau, conductance, order, zeta, decay)`` of the valves of this action mode."""
    if mode == ONOFF:
        tau = p[ix.TAU_SWITCH]
        return tau, p[ix.C_ONOFF], 1, p[ix.ZETA], math.exp(-dt / tau)
    tau = p[ix.TAU_SPOOL]
    return tau, p[ix.C_PROP], int(p[ix.SPOOL_ORDER]), p[ix.ZETA], math.exp(-dt / tau)


@jit_inline
def volumes_at(L, p):
    """Chamber air volumes (dead volumes included) and the slopes the force needs, at ``L``:
    ``(V_cpam, V_annulus, dV_c/dL, dV_ac/dL, dV_ae/dL)`` (Eq. 3, 10, 13, 34-43)."""
    vc_out, vc_air, dvc, dvac, _a, _b = cpam_terms(L, p)
    _c, ve_air, _d, dvae, _e, _f = epam_terms(L, p)
    return vc_air + p[ix.VD_C], ve_air - vc_out + p[ix.VD_E], dvc, dvac, dvae


@jit_inline
def substep_rates(mode, inp, p, t, dt, mc, uc, me, ue, inv_vol_c, inv_vol_e, sc, se, src, sre, valves):
    """First half of a sub-step at fixed length (``inv_vol = 1 / chamber volume``): chamber
    pressures, spool update, valve flows and wall heat. Returns
    ``(pc, pe, sc, se, src, sre, dmc, duc, dme, due, supply_flow)`` with gauge
    pressures [Pa] and rates [kg/s, W]; the ``p dV`` work is left to :func:`substep_air`."""
    tau, cvalve, order, zeta, decay = valves
    patm = p[ix.P_ATM]
    pca = pressure_abs_inv(uc, inv_vol_c)  # absolute
    pea = pressure_abs_inv(ue, inv_vol_e)
    tc = temperature(mc, uc)
    te = temperature(me, ue)
    pc = pca - patm  # gauge
    pe = pea - patm
    sc, src = spool_step(sc, src, _command(mode, inp[I_CMD_C], pc, t, p), dt, tau, order, zeta, decay)
    se, sre = spool_step(se, sre, _command(mode, inp[I_CMD_E], pe, t, p), dt, tau, order, zeta, decay)
    vk = (p[ix.B_CRIT], p[ix.INV_1MB], p[ix.R_LAM], p[ix.LAM_K])
    cleak = p[ix.C_LEAK]
    dmc, duc, supc = chamber_rates(
        pca,
        tc,
        sqrt(ix.T0 / tc),
        0.0,
        cvalve * fmax(sc, 0.0),
        cvalve * fmax(-sc, 0.0) + cleak,
        p[ix.P_SUP],
        p[ix.T_SUP],
        p[ix.K_SUP],
        patm,
        p[ix.T_AMB],
        p[ix.K_AMB],
        vk,
        p[ix.HA_C],
    )
    dme, due, supe = chamber_rates(
        pea,
        te,
        sqrt(ix.T0 / te),
        0.0,
        cvalve * fmax(se, 0.0),
        cvalve * fmax(-se, 0.0) + cleak,
        p[ix.P_SUP],
        p[ix.T_SUP],
        p[ix.K_SUP],
        patm,
        p[ix.T_AMB],
        p[ix.K_AMB],
        vk,
        p[ix.HA_E],
    )
    return pc, pe, sc, se, src, sre, dmc, duc, dme, due, fmax(supc, 0.0) + fmax(supe, 0.0)


@jit_inline
def substep_air(mc, uc, me, ue, dmc, duc, dme, due, ratio_c, ratio_e, dt):
    """Post-mechanics half of a sub-step, once the new length is known: flows and heat
    (explicit), then the compression work over the volume change of the step,
    ``ratio = V_old / V_new`` (:func:`_isentropic_factor`)."""
    mc = fmax(mc + dt * dmc, _MIN_MASS)
    me = fmax(me + dt * dme, _MIN_MASS)
    uc = fmax((uc + dt * duc) * _isentropic_factor(ratio_c), _MIN_MASS)
    ue = fmax((ue + dt * due) * _isentropic_factor(ratio_e), _MIN_MASS)
    return mc, uc, me, ue


# ------------------------------------------------------- the one sub-step, in three pieces
# Every caller runs a sub-step as
#
#   substep_forces (pre-mechanics half: pressures, spools, flows and push force at L)
#   -> mechanics   (the plant's own load step, or MuJoCo: the new L, v)
#   -> substep_air (post-mechanics half: flows and the work of the volume change V(L_old) -> V(L_new))
#
# with :func:`substep_account` keeping the control step's peak pressure and air use, and
# :func:`end_of_step` writing ``aux`` once per control step. :func:`_lane_substep` (the plant's
# block kernel) and :mod:`cepam_gym.mujoco.coupling` (mechanics in MuJoCo) are the two callers.
# New physics belongs in these pieces (or the kernels they call), so both callers get it:
# muscle force (e.g. tension-only braids) in physics.muscle.force_from_slopes / cpam_terms /
# epam_terms, reached through substep_forces and _measure; chamber volumes (e.g. elastic
# bladders) in volumes_at, which both callers use for V(L); valves and air in substep_rates /
# substep_air; new measurements in end_of_step. The mechanics is the caller's: friction with a
# state of its own goes into the plant's load step (physics.load.load_step_k, a new S_* column)
# and, for the coupling, into the MuJoCo model (joint frictionloss). The joint env's hinge is that
# load step in muscle coordinates plus the link's weight (physics.hinge; the HINGE branch of
# _lane_substep), so it follows such changes too.


@jit_inline
def substep_forces(
    mode,
    inp,
    p,
    t,
    dt,
    L,
    mc,
    uc,
    me,
    ue,
    inv_vol_c,
    inv_vol_e,
    dvc,
    dvac,
    dvae,
    sc,
    se,
    src,
    sre,
    valves,
    z1,
    z2,
    z3,
):
    """Pre-mechanics half of a sub-step at length ``L`` (``inv_vol`` = 1 / chamber volumes and
    ``dvc, dvac, dvae`` the volume slopes at ``L``, from :func:`volumes_at`): pressures, spools,
    valve flows (:func:`substep_rates`) and the push force at ``L``, the friction of the slip
    deflections ``z1..z3`` included (:mod:`cepam_gym.physics.friction`; 0 in a v0 row). Returns
    ``(force, pc, pe, sc, se, src, sre, dmc, duc, dme, due, supply_flow)``."""
    pc, pe, sc, se, src, sre, dmc, duc, dme, due, sup = substep_rates(
        mode, inp, p, t, dt, mc, uc, me, ue, inv_vol_c, inv_vol_e, sc, se, src, sre, valves
    )
    force, _k, _g, _h = force_from_slopes(L, pc, pe, p, dvc, dvac, dvae, 0.0, 0.0, 0.0)
    force += friction_force(p, pc, pe, z1, z2, z3)
    return force, pc, pe, sc, se, src, sre, dmc, duc, dme, due, sup


@jit_inline
def substep_account(peak, air, pc, pe, supply_flow, dt):
    """The control step's running peak gauge pressure [Pa] and supply air used [kg] after a
    sub-step with gauge pressures ``pc, pe`` and supply mass flow ``supply_flow``."""
    return fmax(fmax(peak, pc), pe), air + dt * supply_flow


@jit
def end_of_step(x, p, peak, air, mdot_c, mdot_e, stop, aux):
    """``aux`` at the end of a control step: the static quantities of state row ``x``
    (:func:`_measure`), then the step's bookkeeping: last sub-step's chamber mass flows, supply
    air used, peak gauge pressure (sub-steps and end state) and the burst flag, and the end stop
    the mechanics reported (-1 lower, +1 upper, 0 free)."""
    _measure(x, p, aux)
    pmax = fmax(fmax(peak, aux[A_PC]), aux[A_PE])
    aux[A_MDOT_C] = mdot_c
    aux[A_MDOT_E] = mdot_e
    aux[A_AIR] = air
    aux[A_PMAX] = pmax
    aux[A_BURST] = 1.0 if pmax > p[ix.P_BURST] else 0.0
    aux[A_STOP] = stop


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
def _lane_substep(W, i, mode, dt, mech):
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
        mode,
        inp,
        p,
        W[_w(S_T, i)],
        dt,
        L,
        mc,
        uc,
        me,
        ue,
        W[_w(_W_INVC, i)],
        W[_w(_W_INVE, i)],
        W[_w(_W_DVC, i)],
        W[_w(_W_DVAC, i)],
        W[_w(_W_DVAE, i)],
        W[_w(S_SC, i)],
        W[_w(S_SE, i)],
        W[_w(S_SRC, i)],
        W[_w(S_SRE, i)],
        valves,
        z1,
        z2,
        z3,
    )
    W[_w(_W_PMAX, i)], W[_w(_W_AIR, i)] = substep_account(
        W[_w(_W_PMAX, i)], W[_w(_W_AIR, i)], pc, pe, sup, dt
    )
    L_old = L
    f_total = force + W[_w(_W_FEXT, i)]
    if mech == HINGE:  # a compile-time constant: the rig's loop has no trace of it
        f_total += link_weight_force(L, p[ix.L_MAX], W[_w(_W_LINK, i)], W[_w(_W_INVR, i)])
    L, v, stop = load_step_k(
        L,
        W[_w(S_V, i)],
        f_total,
        W[_w(_W_DTM, i)],
        W[_w(_W_DVF, i)],
        W[_w(_W_DAMP, i)],
        p[ix.L_MIN],
        p[ix.L_MAX],
        dt,
    )
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
            _lane_substep(W, i, mode, dt, mech)


@jit
def _substeps(W, n, mode, dt, n_sub):
    """``n_sub`` sub-steps of the first ``n`` plants of a rig block (the mode is made a
    compile-time constant of each loop, so its branches vanish)."""
    if mode == ONOFF:
        _substeps_mode(W, n, ONOFF, dt, n_sub, RIG)
    elif mode == PRESSURE:
        _substeps_mode(W, n, PRESSURE, dt, n_sub, RIG)
    else:
        _substeps_mode(W, n, PROPORTIONAL, dt, n_sub, RIG)


@jit
def _substeps_hinge(W, n, mode, dt, n_sub):
    """:func:`_substeps` of a hinge block (a function of its own, compiled only when used)."""
    if mode == ONOFF:
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
def _measure(x, p, aux):
    """Fill the static quantities of ``aux`` from a state row (force, stiffness, pressures...)."""
    L = x[S_L]
    vol_c, vol_e, _dvc, _dve = chamber_volumes(L, p)
    patm = p[ix.P_ATM]
    pc = pressure_abs(x[S_UC], vol_c) - patm
    pe = pressure_abs(x[S_UE], vol_e) - patm
    _v1, _v2, dvc, dvac, d2vc, d2vac = cpam_terms(L, p)
    _v3, _v4, _s, dvae, _s2, d2vae = epam_terms(L, p)
    force, k, _g, _h = force_from_slopes(L, pc, pe, p, dvc, dvac, dvae, d2vc, d2vac, d2vae)
    aux[A_FORCE] = force
    aux[A_STIFF] = k
    aux[A_STIFF_CLOSED] = closed_chamber_stiffness(L, pc, pe, p)
    aux[A_PC] = pc
    aux[A_PE] = pe
    aux[A_TC] = temperature(x[S_MC], x[S_UC])
    aux[A_TE] = temperature(x[S_ME], x[S_UE])
    aux[A_VC] = vol_c
    aux[A_VE] = vol_e
    finite = 1.0
    for j in range(x.shape[0]):
        if not math.isfinite(x[j]):
            finite = 0.0
    aux[A_FINITE] = finite


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
    kernel = _step_parallel if n >= _PARALLEL_MIN_BATCH else _step_serial
    kernel(state, inputs, params, int(mode), float(dt), int(n_sub), out, aux)
    return out, aux


@jit
def _initial_row(L, pc, pe, temp, p, x):
    vol_c, vol_e, _a, _b = chamber_volumes(L, p)
    patm = p[ix.P_ATM]
    x[:] = 0.0
    x[S_L] = L
    x[S_MC], x[S_UC] = state_from_pressure(pc + patm, temp, vol_c)
    x[S_ME], x[S_UE] = state_from_pressure(pe + patm, temp, vol_e)


def initial_state(params, length, pressure_c=0.0, pressure_e=0.0, temperature=None):
    """Plants at rest at ``length`` [m] with gauge chamber pressures [Pa], air at ``temperature``.

    Arguments broadcast over the batch given by ``params`` (N or 1 rows) and the arguments.
    """
    params = np.atleast_2d(np.asarray(params, dtype=float))
    L, pc, pe = np.broadcast_arrays(
        np.atleast_1d(length).astype(float),
        np.atleast_1d(pressure_c).astype(float),
        np.atleast_1d(pressure_e).astype(float),
    )
    n = max(L.shape[0], params.shape[0])
    L, pc, pe = (np.broadcast_to(a, (n,)) for a in (L, pc, pe))
    temp = np.broadcast_to(params[:, ix.T_AMB] if temperature is None else np.atleast_1d(temperature), (n,))
    prow = np.broadcast_to(params, (n, params.shape[1]))
    lo, hi = prow[:, ix.L_MIN], prow[:, ix.L_MAX]
    if np.any((L < lo) | (L > hi)) or not np.all(np.isfinite(L)):
        raise ValueError(f"initial length must lie within the end stops [{lo.min()}, {hi.max()}] m, got {L}")
    if np.any(pc + prow[:, ix.P_ATM] <= 0) or np.any(pe + prow[:, ix.P_ATM] <= 0):
        raise ValueError("initial gauge pressures must be above vacuum (> -atmospheric)")
    x = np.zeros((n, N_STATE))
    for i in range(n):
        _initial_row(L[i], pc[i], pe[i], temp[i], prow[i], x[i])
    return x


def stability_number(params, dt: float) -> np.ndarray:
    """``dt * lambda_max`` of the explicit chamber-air integration, per parameter row.

    Two stiff modes act on a chamber's air, both largest at its smallest volume ``V``:

    * the valve flow: a chamber fed through a fully open valve in the linearised (laminar)
      region near equal pressures, ``lambda_v = gamma R T / V * dmdot/dp`` with
      ``dmdot/dp = C rho0 sqrt(T0/T) sqrt(1 - x^2) / (1 - r_lam)``, ``x = (r_lam - b) / (1 - b)``;
    * the wall heat transfer: ``dU/dt = hA (T_amb - T)`` with ``U = m cv T`` relaxes the air
      temperature at ``lambda_h = hA / (m cv)``. The least air a chamber holds is at atmospheric
      pressure (it exhausts to the atmosphere): ``m = p_atm V / (R T)``, so with
      ``cv = R / (gamma - 1)``: ``lambda_h = hA (gamma - 1) T / (p_atm V)``.

    Both modes damp the same state (mass and energy of one chamber), so their sum bounds the
    largest eigenvalue (Gershgorin). Explicit Euler is stable below 2 and free of overshoot
    below 1. ``T`` is the hotter of supply and ambient air (least mass, fastest flow).
    """
    p = np.atleast_2d(params)
    c = np.maximum(p[:, ix.C_PROP], p[:, ix.C_ONOFF]) + p[:, ix.C_LEAK]
    x = (p[:, ix.R_LAM] - p[:, ix.B_CRIT]) / (1.0 - p[:, ix.B_CRIT])
    t = np.maximum(p[:, ix.T_SUP], p[:, ix.T_AMB])
    slope = c * ix.RHO0 * np.sqrt(ix.T0 / t) * np.sqrt(1.0 - x * x) / (1.0 - p[:, ix.R_LAM])
    v_min = np.full(p.shape[0], np.inf)
    from .physics import api

    for L in np.linspace(p[:, ix.L_MIN], p[:, ix.L_MAX], 16):
        vc, ve, _, _ = api.chamber_volumes(L, p)
        v_min = np.minimum(v_min, np.minimum(vc, ve))
    lam_valve = ix.GAMMA * ix.R_AIR * t / v_min * slope
    lam_heat = p[:, ix.HA] * (ix.GAMMA - 1.0) * t / (p[:, ix.P_ATM] * v_min)
    return dt * (lam_valve + lam_heat)


def check_stability(params, dt: float, limit: float = 1.2) -> None:
    """Raise ``ValueError`` when the sub-step ``dt`` is too long for these valves, heat transfer
    and volumes (:func:`stability_number` above ``limit``)."""
    s = stability_number(params, dt)
    if np.any(s > limit):
        worst = float(s.max())
        raise ValueError(
            f"sub-step {dt * 1e3:.3g} ms is too long for the valve conductance, heat transfer and "
            f"chamber volume (stability number {worst:.2f} > {limit}): use sub_dt <= "
            f"{dt * limit / worst * 1e3:.3g} ms, a smaller valve_conductance or heat_transfer, "
            "or a larger dead volume"
        )


def measure(state, params):
    """``aux`` of states without stepping them (force, stiffness, pressures, volumes...)."""
    state = np.atleast_2d(state)
    params = np.atleast_2d(params)
    aux = np.zeros((state.shape[0], N_AUX))
    for i in range(state.shape[0]):
        _measure(state[i], params[0] if params.shape[0] == 1 else params[i], aux[i])
    return aux
