"""The CE-PAM plant with its mechanics handed to MuJoCo.

The plant kernel :func:`cepam_gym.plant.advance_block` integrates the air, the valves *and* the free end
of the rig. When MuJoCo owns the mechanics (a slider in :class:`~cepam_gym.mujoco.rig.RigSimulator`,
a hinge in :class:`~cepam_gym.envs.joint_mujoco.CEPAMJointEnv`), every plant sub-step is run like this:

1. the muscle length ``L`` and its rate ``v`` are *imposed* from the MuJoCo state (through the
   geometry of the mechanism);
2. the previous sub-step's post-mechanics half is completed with the volume change to this ``L``
   (:func:`cepam_gym.plant.substep_air`), then the plant's pre-mechanics half runs at ``L``
   (:func:`cepam_gym.plant.substep_forces`: pressures, spools, valve flows and the push force
   ``F(L, Pc, Pe)``), and :func:`cepam_gym.plant.substep_account` keeps the peak pressure and air use;
3. the caller applies ``F`` to MuJoCo as a generalized force and calls ``mj_step`` (the
   mechanics); the air update of this sub-step waits for the next call (or ``finish``), when the
   new length is known. ``finish`` writes ``aux`` with the plant's :func:`cepam_gym.plant.end_of_step`.

The plant's work ratio ``V_old / V_new`` is ``V_old * (1 / V_new)`` (it keeps ``1 / V_new`` for the
next sub-step's pressures); here it is a division. The two agree to round-off, and each is kept as
recorded (``tests/golden/test_golden_v0.py``).

These are the pieces of the plant's own sub-step, in its order (pressures at ``L`` -> spool ->
flows -> force at ``L`` -> mechanics -> air), so with the same semi-implicit Euler scheme (MuJoCo's
``Euler`` integrator, implicit in joint damping, is the plant's load step) a MuJoCo slider
reproduces the plant's trajectories to round-off (``tests/envs/test_mujoco.py``). The force equations
exist only in :mod:`cepam_gym.physics.muscle`; nothing here recomputes them.
"""

from __future__ import annotations

import numpy as np

from .._jit import jit
from ..physics import layout as ix
from ..physics.friction import friction_slip
from . import layout as lay
from . import substep as sub

# accumulator columns over one control step, then the sub-step whose air update is pending
ACC_AIR, ACC_PMAX, PEND, PEND_DMC, PEND_DUC, PEND_DME, PEND_DUE, PEND_VC, PEND_VE = range(9)
N_ACC = 9


@jit
def _settle(x, dt, vol_c, vol_e, acc):
    """Apply the pending sub-step's air update now that the mechanism has moved and the chamber
    volumes are ``vol_c, vol_e`` (flows, then the compression work of the volume change: the
    plant's post-mechanics half)."""
    if acc[PEND] == 0.0:
        return
    x[lay.S_MC], x[lay.S_UC], x[lay.S_ME], x[lay.S_UE] = sub.substep_air(
        x[lay.S_MC],
        x[lay.S_UC],
        x[lay.S_ME],
        x[lay.S_UE],
        acc[PEND_DMC],
        acc[PEND_DUC],
        acc[PEND_DME],
        acc[PEND_DUE],
        acc[PEND_VC] / vol_c,
        acc[PEND_VE] / vol_e,
        dt,
    )
    acc[PEND] = 0.0


@jit
def _slip(x, p, length):
    """The braid-bladder friction elements follow the imposed motion from ``x[S_L]`` to
    ``length`` (plant v1; nothing to do in v0 rows), as in the plant's own sub-step."""
    if p[ix.FR_C] > 0.0:
        x[lay.S_Z1], x[lay.S_Z2], x[lay.S_Z3] = friction_slip(
            p, length - x[lay.S_L], x[lay.S_Z1], x[lay.S_Z2], x[lay.S_Z3]
        )


@jit
def coupled_substep(x, inp, p, mode, dt, length, velocity, acc):
    """One plant sub-step at an imposed ``length`` [m] and ``velocity`` [m/s]; returns the push
    force [N] at the start of the sub-step (what the mechanism feels during it).

    The previous sub-step's air update is completed first, with the volume change to ``length``;
    this one's pre-mechanics half (:func:`cepam_gym.plant.substep_forces`: pressures, spools,
    flows, force) runs now and its air update is left pending until the mechanism has moved.
    ``acc`` accumulates supply air used [kg] and the peak gauge pressure [Pa] of the control step
    (:func:`cepam_gym.plant.substep_account`).
    """
    mode = sub.kernel_mode(mode, p)
    vol_c, vol_e, dvc, dvac, dvae = sub.volumes_at(length, p)
    _settle(x, dt, vol_c, vol_e, acc)
    _slip(x, p, length)
    x[lay.S_L] = length
    x[lay.S_V] = velocity
    force, pc, pe, sc, se, src, sre, dmc, duc, dme, due, sup = sub.substep_forces(
        mode,
        inp,
        p,
        x[lay.S_T],
        dt,
        length,
        x[lay.S_MC],
        x[lay.S_UC],
        x[lay.S_ME],
        x[lay.S_UE],
        1.0 / vol_c,
        1.0 / vol_e,
        dvc,
        dvac,
        dvae,
        x[lay.S_SC],
        x[lay.S_SE],
        x[lay.S_SRC],
        x[lay.S_SRE],
        sub.valve_setup(mode, p, dt),
        x[lay.S_Z1],
        x[lay.S_Z2],
        x[lay.S_Z3],
    )
    x[lay.S_SC], x[lay.S_SE], x[lay.S_SRC], x[lay.S_SRE] = sc, se, src, sre
    x[lay.S_T] += dt
    acc[PEND], acc[PEND_DMC], acc[PEND_DUC], acc[PEND_DME], acc[PEND_DUE] = 1.0, dmc, duc, dme, due
    acc[PEND_VC], acc[PEND_VE] = vol_c, vol_e
    acc[ACC_PMAX], acc[ACC_AIR] = sub.substep_account(acc[ACC_PMAX], acc[ACC_AIR], pc, pe, sup, dt)
    return force


@jit
def end_stop(length, p):
    """The end stop a mechanism's muscle ``length`` sits at: -1 lower, +1 upper, 0 free."""
    if length <= p[ix.L_MIN]:
        return -1.0
    if length >= p[ix.L_MAX]:
        return 1.0
    return 0.0


@jit
def finish_step(x, p, dt, length, velocity, acc, aux):
    """``aux`` of the state at the end of a control step, with the step's bookkeeping, through
    the plant's own :func:`cepam_gym.plant.end_of_step`."""
    vol_c, vol_e, _dvc, _dvac, _dvae = sub.volumes_at(length, p)
    _settle(x, dt, vol_c, vol_e, acc)
    _slip(x, p, length)
    x[lay.S_L] = length
    x[lay.S_V] = velocity
    sub.end_of_step(x, p, acc[ACC_PMAX], acc[ACC_AIR], acc[PEND_DMC], acc[PEND_DME], end_stop(length, p), aux)


class PlantLink:
    """Buffers of one plant driven by an external mechanism (see the module docstring).

    ``begin()`` at the start of a control step, ``force(L, v)`` once per sub-step, ``finish(L, v)``
    at the end (returns ``aux``, columns :data:`cepam_gym.plant.AUX_FIELDS`).
    """

    def __init__(self, params_row: np.ndarray, mode: int, sub_dt: float):
        self.p = np.ascontiguousarray(params_row, dtype=float)
        self.mode = int(mode)
        self.dt = float(sub_dt)
        self.x = np.zeros(lay.N_STATE)
        self.inp = np.zeros(lay.N_INPUT)
        self.aux = np.zeros(lay.N_AUX)
        self._acc = np.zeros(N_ACC)

    def begin(self) -> None:
        self._acc[ACC_AIR] = 0.0
        self._acc[ACC_PMAX] = -np.inf
        self._acc[PEND] = 0.0
        self._acc[PEND_DMC] = 0.0
        self._acc[PEND_DME] = 0.0

    def force(self, length: float, velocity: float) -> float:
        return coupled_substep(self.x, self.inp, self.p, self.mode, self.dt, length, velocity, self._acc)

    def finish(self, length: float, velocity: float) -> np.ndarray:
        finish_step(self.x, self.p, self.dt, length, velocity, self._acc, self.aux)
        return self.aux
