"""The CE-PAM plant with its mechanics handed to MuJoCo.

The plant kernel :func:`cepam_gym.plant.advance_block` integrates the air, the valves *and* the free end
of the rig. When MuJoCo owns the mechanics (a slider in :class:`~cepam_gym.mujoco.rig.RigSimulator`,
a hinge in :class:`~cepam_gym.mujoco.joint.CEPAMJointEnv`), every plant sub-step is run like this:

1. the muscle length ``L`` and its rate ``v`` are *imposed* from the MuJoCo state (through the
   geometry of the mechanism);
2. the previous sub-step's air update is completed with the volume change to this ``L``
   (:func:`cepam_gym.plant.substep_air`), then the plant's first half-step runs at ``L``
   (:func:`cepam_gym.plant.substep_rates`: pressures, spools, valve flows) and the push force
   ``F(L, Pc, Pe)`` comes from the same force kernel (:func:`~cepam_gym.physics.muscle.force_from_slopes`);
3. the caller applies ``F`` to MuJoCo as a generalized force and calls ``mj_step``; the air
   update of this sub-step waits for the next call (or ``finish``), when the new length is known.

This is exactly the order of the plant's own sub-step (pressures at ``L`` -> spool -> flows with
``v`` -> force at ``L`` -> mechanics -> air), so with the same semi-implicit Euler scheme (MuJoCo's
``Euler`` integrator, implicit in joint damping, is the plant's load step) a MuJoCo slider
reproduces the plant's trajectories to round-off (``tests/test_mujoco.py``). The force equations
exist only in :mod:`cepam_gym.physics.muscle`; nothing here recomputes them.
"""

from __future__ import annotations

import numpy as np

from .. import plant as pl
from .._jit import jit
from ..physics import layout as ix

# accumulator columns over one control step, then the sub-step whose air update is pending
ACC_AIR, ACC_PMAX, PEND, PEND_DMC, PEND_DUC, PEND_DME, PEND_DUE, PEND_VC, PEND_VE = range(9)
N_ACC = 9


@jit
def _settle(x, p, dt, length, acc):
    """Apply the pending sub-step's air update now that the mechanism's new ``length`` is known
    (flows, then the compression work of the volume change, as in the plant's own loop)."""
    if acc[PEND] == 0.0:
        return
    vol_c, vol_e, _a, _b, _c = pl.volumes_at(length, p)
    x[pl.S_MC], x[pl.S_UC], x[pl.S_ME], x[pl.S_UE] = pl.substep_air(
        x[pl.S_MC], x[pl.S_UC], x[pl.S_ME], x[pl.S_UE], acc[PEND_DMC], acc[PEND_DUC],
        acc[PEND_DME], acc[PEND_DUE], acc[PEND_VC] / vol_c, acc[PEND_VE] / vol_e, dt)
    acc[PEND] = 0.0


@jit
def coupled_substep(x, inp, p, mode, dt, length, velocity, acc):
    """One plant sub-step at an imposed ``length`` [m] and ``velocity`` [m/s]; returns the push
    force [N] at the start of the sub-step (what the mechanism feels during it).

    The previous sub-step's air update is completed first, with the volume change to ``length``;
    this one's (flows, spools, time) is computed and left pending until the mechanism has moved.
    ``acc`` accumulates supply air used [kg] and the peak gauge pressure [Pa] of the control step.
    """
    _settle(x, p, dt, length, acc)
    x[pl.S_L] = length
    x[pl.S_V] = velocity
    vol_c, vol_e, dvc, dvac, dvae = pl.volumes_at(length, p)
    pc, pe, sc, se, src, sre, dmc, duc, dme, due, sup = pl.substep_rates(
        mode, inp, p, x[pl.S_T], dt, x[pl.S_MC], x[pl.S_UC], x[pl.S_ME], x[pl.S_UE], 1.0 / vol_c, 1.0 / vol_e,
        x[pl.S_SC], x[pl.S_SE], x[pl.S_SRC], x[pl.S_SRE], pl.valve_setup(mode, p, dt))
    x[pl.S_SC], x[pl.S_SE], x[pl.S_SRC], x[pl.S_SRE] = sc, se, src, sre
    x[pl.S_T] += dt
    acc[PEND], acc[PEND_DMC], acc[PEND_DUC], acc[PEND_DME], acc[PEND_DUE] = 1.0, dmc, duc, dme, due
    acc[PEND_VC], acc[PEND_VE] = vol_c, vol_e
    acc[ACC_AIR] += dt * sup
    acc[ACC_PMAX] = max(acc[ACC_PMAX], pc, pe)
    force, _k, _g, _h = pl.force_from_slopes(length, pc, pe, p, dvc, dvac, dvae, 0.0, 0.0, 0.0)
    return force


@jit
def finish_step(x, p, dt, length, velocity, acc, aux):
    """``aux`` of the state at the end of a control step, with the step's air use and peak
    pressure and the burst flag, like :func:`cepam_gym.plant.step` reports them."""
    _settle(x, p, dt, length, acc)
    x[pl.S_L] = length
    x[pl.S_V] = velocity
    pl._measure(x, p, aux)
    pmax = max(acc[ACC_PMAX], aux[pl.A_PC], aux[pl.A_PE])
    aux[pl.A_AIR] = acc[ACC_AIR]
    aux[pl.A_PMAX] = pmax
    aux[pl.A_BURST] = 1.0 if pmax > p[ix.P_BURST] else 0.0
    stop = 0.0
    if length <= p[ix.L_MIN]:
        stop = -1.0
    elif length >= p[ix.L_MAX]:
        stop = 1.0
    aux[pl.A_STOP] = stop


class PlantLink:
    """Buffers of one plant driven by an external mechanism (see the module docstring).

    ``begin()`` at the start of a control step, ``force(L, v)`` once per sub-step, ``finish(L, v)``
    at the end (returns ``aux``, columns :data:`cepam_gym.plant.AUX_FIELDS`).
    """

    def __init__(self, params_row: np.ndarray, mode: int, sub_dt: float):
        self.p = np.ascontiguousarray(params_row, dtype=float)
        self.mode = int(mode)
        self.dt = float(sub_dt)
        self.x = np.zeros(pl.N_STATE)
        self.inp = np.zeros(pl.N_INPUT)
        self.aux = np.zeros(pl.N_AUX)
        self._acc = np.zeros(N_ACC)

    def begin(self) -> None:
        self._acc[ACC_AIR] = 0.0
        self._acc[ACC_PMAX] = -np.inf
        self._acc[PEND] = 0.0

    def force(self, length: float, velocity: float) -> float:
        return coupled_substep(self.x, self.inp, self.p, self.mode, self.dt, length, velocity, self._acc)

    def finish(self, length: float, velocity: float) -> np.ndarray:
        finish_step(self.x, self.p, self.dt, length, velocity, self._acc, self.aux)
        return self.aux
