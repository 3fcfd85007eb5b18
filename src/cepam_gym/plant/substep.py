"""The one plant sub-step, in pieces every caller runs in the same order: the block kernel
(:mod:`cepam_gym.plant.kernel`, mechanics by the plant's own load step) and the MuJoCo coupling
(:mod:`cepam_gym.plant.coupling`, mechanics in MuJoCo); plus what a control step measures.
The force equations live in :mod:`cepam_gym.physics.muscle`; nothing here recomputes them.
"""

from __future__ import annotations

import math

from .._jit import fmax, fmin, jit, jit_inline, sqrt
from ..physics import layout as ix
from ..physics.air import chamber_rates, pressure_abs, pressure_abs_inv, temperature
from ..physics.friction import friction_force
from ..physics.muscle import (
    chamber_volumes,
    closed_chamber_stiffness,
    cpam_terms,
    epam_terms,
    force_from_slopes,
)
from ..physics.valve import spool_step
from .layout import (
    A_AIR,
    A_BURST,
    A_FINITE,
    A_FORCE,
    A_MDOT_C,
    A_MDOT_E,
    A_PC,
    A_PE,
    A_PMAX,
    A_STIFF,
    A_STIFF_CLOSED,
    A_STOP,
    A_TC,
    A_TE,
    A_VC,
    A_VE,
    I_CMD_C,
    I_CMD_E,
    ONOFF,
    ONOFF_EXACT,
    PRESSURE,
    S_L,
    S_MC,
    S_ME,
    S_UC,
    S_UE,
)

_MIN_MASS = 1e-15  # kg: keeps T = U/(m cv) defined if a chamber were ever emptied

# ------------------------------------------------------- the one sub-step, in three pieces
# Every caller runs a sub-step as
#
#   substep_forces (pre-mechanics half: pressures, spools, flows and push force at L)
#   -> mechanics   (the plant's own load step, or MuJoCo: the new L, v)
#   -> substep_air (post-mechanics half: flows and the work of the volume change V(L_old) -> V(L_new))
#
# with :func:`substep_account` keeping the control step's peak pressure and air use, and
# :func:`end_of_step` writing ``aux`` once per control step. :func:`cepam_gym.plant.kernel.lane_substep`
# (the plant's block kernel) and :mod:`cepam_gym.plant.coupling` (mechanics in MuJoCo) are the two callers.
# New physics belongs in these pieces (or the kernels they call), so both callers get it:
# muscle force (e.g. tension-only braids) in physics.muscle.force_from_slopes / cpam_terms /
# epam_terms, reached through substep_forces and measure_row; chamber volumes (e.g. elastic
# bladders) in volumes_at, which both callers use for V(L); valves and air in substep_rates /
# substep_air; new measurements in end_of_step. The mechanics is the caller's: friction with a
# state of its own goes into the plant's load step (physics.load.load_step_k, a new S_* column)
# and, for the coupling, into the MuJoCo model (joint frictionloss). The joint env's hinge is that
# load step in muscle coordinates plus the link's weight (physics.hinge; the HINGE branch of
# lane_substep), so it follows such changes too.


@jit_inline
def valve_command(mode, u, pressure_gauge, t, p):
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
def kernel_mode(mode, p):
    """The mode a sub-step of plant row ``p`` runs in: ``ONOFF_EXACT`` for the on/off valves of a
    plant with ``pwm_timing: exact``, else ``mode``."""
    return ONOFF_EXACT if mode == ONOFF and p[ix.PWM_EXACT] > 0.0 else mode


@jit_inline
def pwm_open_fraction(duty, p):
    """The share of a PWM period an on/off valve is open at ``duty`` in [0, 1]: the period
    average of :func:`valve_command`'s opening. With dead times the valve is open from ``d_on``
    after the rising edge to ``d_off`` after the falling one, so the share is
    ``duty + (d_off - d_on) / period`` within [0, 1] (a pulse shorter than ``d_on - d_off``: 0);
    without them (plant v0) it is the duty."""
    if duty >= 1.0:
        return 1.0
    return fmax(0.0, fmin(1.0, duty + (p[ix.D_OFF] - p[ix.D_ON]) / p[ix.PWM_PERIOD]))


@jit_inline
def pwm_spool_interval(s0, u, t, dt, tau, decay, p):
    """``(end, mean)`` opening of an on/off valve's first-order spool (``tau ds/dt = cmd - s``)
    over the sub-step ``[t, t + dt)`` with the PWM edges and dead times at their exact times
    (plant option ``pwm_timing: exact``; ``decay = exp(-dt / tau)``).

    The valve is open on the windows ``[k P + d_on, k P + duty P + d_off)`` of every period ``k``
    (:func:`valve_command`'s law, read continuously instead of at ``t``); the spool's response is
    linear in its command, so each open stretch ``[lo, hi)`` of the sub-step adds its exact
    exponential share to the end value and to the interval mean. ``mean`` is what the flow sees
    over the sub-step; ``end`` is the spool's state after it. Both are continuous in the duty and
    the dead times, which a sampled phase (2.5 % of duty per 0.5 ms sub-step at 50 Hz) is not."""
    duty = abs(u)
    sign = 1.0 if u > 0.0 else -1.0
    period = p[ix.PWM_PERIOD]
    a = p[ix.D_ON]
    b = duty * period + p[ix.D_OFF]
    ratio = tau / dt * (1.0 - decay)  # interval mean of exp(-(s - t) / tau) over the sub-step
    if duty >= 1.0 or b - period >= a:  # open throughout (full duty, or windows that overlap)
        return sign + (s0 - sign) * decay, sign + (s0 - sign) * ratio
    end = s0 * decay
    mean = s0 * ratio
    if b > a:  # a pulse shorter than d_on - d_off never opens the valve
        t1 = t + dt
        k_first = math.floor((t - b) / period) + 1  # the first window that ends after t
        k_last = math.floor((t1 - a) / period)  # the last one that starts before t1
        for k in range(k_first, k_last + 1):
            lo = fmax(t, k * period + a)
            hi = fmin(t1, k * period + b)
            if hi > lo:
                e_lo = math.exp(-(t1 - lo) / tau)  # the response to a unit step at lo, at t1
                e_hi = math.exp(-(t1 - hi) / tau)
                end += sign * (e_hi - e_lo)
                mean += sign * ((hi - lo) - tau * (e_hi - e_lo)) / dt
    return end, mean


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
    if mode == ONOFF or mode == ONOFF_EXACT:
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
    if mode == ONOFF_EXACT and p[ix.PWM_EXACT] > 0.0:  # a block may mix both timings
        sc, open_c = pwm_spool_interval(sc, inp[I_CMD_C], t, dt, tau, decay, p)
        se, open_e = pwm_spool_interval(se, inp[I_CMD_E], t, dt, tau, decay, p)
    else:  # the command read at t, held for the sub-step; the flow sees the spool's end value
        law = ONOFF if mode == ONOFF_EXACT else mode
        sc, src = spool_step(sc, src, valve_command(law, inp[I_CMD_C], pc, t, p), dt, tau, order, zeta, decay)
        se, sre = spool_step(se, sre, valve_command(law, inp[I_CMD_E], pe, t, p), dt, tau, order, zeta, decay)
        open_c, open_e = sc, se
    vk = (p[ix.B_CRIT], p[ix.INV_1MB], p[ix.R_LAM], p[ix.LAM_K])
    cleak = p[ix.C_LEAK]
    dmc, duc, supc = chamber_rates(
        pca,
        tc,
        sqrt(ix.T0 / tc),
        0.0,
        cvalve * fmax(open_c, 0.0),
        cvalve * fmax(-open_c, 0.0) + cleak,
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
        cvalve * fmax(open_e, 0.0),
        cvalve * fmax(-open_e, 0.0) + cleak,
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
    (:func:`measure_row`), then the step's bookkeeping: last sub-step's chamber mass flows, supply
    air used, peak gauge pressure (sub-steps and end state) and the burst flag, and the end stop
    the mechanics reported (-1 lower, +1 upper, 0 free)."""
    measure_row(x, p, aux)
    pmax = fmax(fmax(peak, aux[A_PC]), aux[A_PE])
    aux[A_MDOT_C] = mdot_c
    aux[A_MDOT_E] = mdot_e
    aux[A_AIR] = air
    aux[A_PMAX] = pmax
    aux[A_BURST] = 1.0 if pmax > p[ix.P_BURST] else 0.0
    aux[A_STOP] = stop


@jit
def measure_row(x, p, aux):
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
