"""A plant's flat parameter row, the one the compiled kernels read (:mod:`cepam_gym.physics.layout`):
its columns from the fields (:func:`param_row`), the derived columns (:func:`fill_derived`, also
for randomized rows), and the pressure cap of rows."""

from __future__ import annotations

import math

import numpy as np

from ..physics import layout as ix
from ..physics.valve import laminar_factor


def param_row(self) -> np.ndarray:
    """The flat float64 parameter row the compiled kernels read (layout in physics.layout) of plant
    ``self`` (a :class:`~cepam_gym.plant.params.PlantParams`)."""
    p = np.zeros(ix.N_PARAMS)
    p[ix.BC], p[ix.NC] = self.cpam_braid()
    p[ix.BE], p[ix.NE] = self.epam_braid()
    p[ix.TA] = self.wall_thickness()
    p[ix.RADIAL] = 0.0 if self.force_model == "basic" else 1.0
    p[ix.DOC] = self.cpam_bladder_diameter
    p[ix.DOE] = self.epam_bladder_diameter
    p[ix.KR_LO] = self.kr_low
    p[ix.KR_HI] = self.kr_high
    paper = self.force_form == "paper"
    p[ix.KAPPA] = self.paper_length_ratio if paper else 1.0
    p[ix.LAMBDA] = 1.0 if paper else 0.0
    p[ix.K_EL] = (
        self.elastic_stiffness if self.bladder_model == "spring" else 0.0
    )  # v1: the walls' energy replaces it
    p[ix.L_EL0] = self.elastic_rest_length
    p[ix.L_MIN] = self.min_length
    p[ix.L_MAX] = self.max_length
    p[ix.P_ATM] = self.atmospheric_pressure
    p[ix.P_SUP] = self.atmospheric_pressure + self.supply_pressure
    p[ix.T_SUP] = self.supply_temperature
    p[ix.T_AMB] = self.ambient_temperature
    p[ix.C_PROP] = self.valve_conductance
    p[ix.B_CRIT] = self.valve_critical_ratio
    p[ix.R_LAM] = self.laminar_ratio
    p[ix.C_LEAK] = self.leak_conductance
    p[ix.TAU_SPOOL] = self.spool_time_constant
    p[ix.SPOOL_ORDER] = self.spool_order
    p[ix.ZETA] = self.spool_damping
    p[ix.C_ONOFF] = self.onoff_conductance
    p[ix.TAU_SWITCH] = self.onoff_switch_time
    p[ix.PWM_PERIOD] = 1.0 / self.pwm_frequency
    p[ix.VD_C] = self.dead_volume_cpam
    p[ix.VD_E] = self.dead_volume_epam
    p[ix.HA] = self.heat_transfer
    p[ix.P_BURST] = self.burst_pressure
    p[ix.N_POLY] = self.polytropic_exponent
    p[ix.M_END] = self.end_mass
    p[ix.DAMP] = self.damping
    p[ix.F_COUL] = self.coulomb_friction
    p[ix.GRAV] = self.gravity
    p[ix.REG_GAIN] = self.regulator_gain
    p[ix.SLACK_W] = self.slack_width if self.braid_tension == "tension_only" else 0.0
    p[ix.MU_B] = self.bladder_shear_modulus if self.bladder_model == "neo_hookean" else 0.0
    p[ix.TB_EL] = self.bladder_thickness
    p[ix.LREF_C] = self.cpam_rest_length
    p[ix.LREF_E] = self.epam_bladder_length
    p[ix.H_WALL] = self.heat_transfer_coefficient
    p[ix.D_ON] = self.onoff_open_delay
    p[ix.D_OFF] = self.onoff_close_delay
    # the contact-area law (v2) replaces the v1 coefficient: fill_derived sets FR_C = mu S_e
    p[ix.FR_C] = self.friction_coefficient if self.friction_law == "pressure_sum" else 0.0
    p[ix.FR_D] = self.friction_presliding
    p[ix.COL_A] = 0.25 * math.pi * self.collapse_seal_diameter**2
    p[ix.FR_MU] = self.friction_mu if self.friction_law == "contact_area" else 0.0
    p[ix.THR_E] = self.epam_thread_compliance
    p[ix.THR_C] = self.cpam_thread_compliance
    p[ix.PWM_EXACT] = 1.0 if self.pwm_timing == "exact" else 0.0
    fill_derived(p)
    return p


def pressure_cap_of(p) -> np.ndarray:
    """:attr:`PlantParams.pressure_cap` of parameter row(s) ``p`` (randomised plants):
    ``min(supply, burst)`` gauge [Pa]."""
    p = np.asarray(p, dtype=float)
    return np.minimum(p[..., ix.P_SUP] - p[..., ix.P_ATM], p[..., ix.P_BURST])


def fill_derived(p: np.ndarray) -> np.ndarray:
    """Fill the derived columns of parameter row(s) ``p`` (layout.INV_BC ... K_AMB) in place."""
    from ..physics.layout import T0

    q = p.T
    ta = q[ix.TA]
    for b_i, n_i, inv_b, qq, tbn, tan, dk, inv_pnb in (
        (ix.BC, ix.NC, ix.INV_BC, ix.QC, ix.TBN_C, ix.TAN_C, ix.DK_C, ix.INV_PNB_C),
        (ix.BE, ix.NE, ix.INV_BE, ix.QE, ix.TBN_E, ix.TAN_E, ix.DK_E, ix.INV_PNB_E),
    ):
        b, n = q[b_i], q[n_i]
        q[inv_b] = 1.0 / b
        q[qq] = 1.0 / (4.0 * math.pi * n * n)
        q[tbn] = ta * b / n
        q[tan] = ta / n
        q[dk] = b / (math.pi * n)
        q[inv_pnb] = 1.0 / (math.pi * n * b)
    q[ix.PTA2] = math.pi * ta * ta
    for lref, inv_l, inv_d, el, b_i, dk, d_o in (
        (ix.LREF_C, ix.INV_LREF_C, ix.INV_DREF_C, ix.EL_C, ix.BC, ix.DK_C, ix.DOC),
        (ix.LREF_E, ix.INV_LREF_E, ix.INV_DREF_E, ix.EL_E, ix.BE, ix.DK_E, ix.DOE),
    ):
        u = q[lref] / q[b_i]
        q[inv_l] = 1.0 / q[lref]
        q[inv_d] = 1.0 / (q[dk] * np.sqrt(1.0 - u * u))  # braid diameter at the bladder's rest length
        # mu times the rubber volume of a tube of outer diameter D_o and wall t_b, pi (D_o - t_b) t_b L
        q[el] = q[ix.MU_B] * math.pi * (q[d_o] - q[ix.TB_EL]) * q[ix.TB_EL] * q[lref]
    # chamber wall areas at mid-stroke: CPAM bladder inside; annulus = EPAM bladder inside + CPAM outside
    lm = 0.5 * (q[ix.L_MIN] + q[ix.L_MAX])
    d_c = q[ix.DK_C] * np.sqrt(1.0 - (lm / q[ix.BC]) ** 2)
    d_e = q[ix.DK_E] * np.sqrt(1.0 - (lm / q[ix.BE]) ** 2)
    # plant v2 contact-area friction: mu times each braid's inner surface pi D L at mid-stroke
    mu = q[ix.FR_MU]
    v2 = mu > 0.0
    q[ix.FR_CC] = np.where(v2, mu * math.pi * d_c * lm, 0.0)
    q[ix.FR_C] = np.where(v2, mu * math.pi * d_e * lm, q[ix.FR_C])
    # plant v2 extensible braids: a stretched thread is b / (1 - THR_A P L), P its net active pressure
    q[ix.THR_AE] = q[ix.THR_E] * q[ix.BE] / (2.0 * math.pi * q[ix.NE] ** 2)
    q[ix.THR_AC] = q[ix.THR_C] * q[ix.BC] / (2.0 * math.pi * q[ix.NC] ** 2)
    h = q[ix.H_WALL]
    q[ix.HA_C] = np.where(h > 0.0, h * math.pi * (d_c - 2.0 * ta) * lm, q[ix.HA])
    q[ix.HA_E] = np.where(h > 0.0, h * math.pi * (d_e - 2.0 * ta + d_c) * lm, q[ix.HA])
    bc = q[ix.B_CRIT]
    q[ix.INV_1MB] = 1.0 / (1.0 - bc)
    q[ix.LAM_K] = laminar_factor(q[ix.R_LAM], bc)
    q[ix.K_SUP] = np.sqrt(T0 / q[ix.T_SUP])
    q[ix.K_AMB] = np.sqrt(T0 / q[ix.T_AMB])
    return p
