"""The plant's array layouts: the columns of a state row, an input row and an ``aux`` row, the
valve modes and the mechanics a block of plants drives.

Arrays (all float64, batch-first):

* ``state``  (N, N_STATE)  columns named in :data:`STATE_FIELDS`
* ``inputs`` (N, N_INPUT)  valve commands, hanging load [kg], external force [N, down positive]
* ``params`` (N, N_PARAMS) or (1, N_PARAMS) rows of :meth:`PlantParams.to_array`
  (columns in :mod:`cepam_gym.physics.layout`)
* ``aux``    (N, N_AUX)    what the step measured, columns named in :data:`AUX_FIELDS`

Valve modes: ``PROPORTIONAL`` (commands in [-1, 1] are spool set-points: -1 exhaust, 0 closed,
+1 supply), ``ONOFF`` (commands are PWM duties of two solenoid valves per chamber, sign picks
supply or exhaust), ``PRESSURE`` (commands are gauge pressure set-points [Pa] held by an in-plant
proportional regulator on the proportional valves, evaluated every sub-step).

The compiled kernels inline these constants, so ``cepam_gym._jit`` stamps this file's text and
drops every cached kernel when it changes.
"""

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
# the kernels' own variant of ONOFF for a block holding a plant with ``pwm_timing: exact``
# (:func:`cepam_gym.plant.substep.kernel_mode`); never a user's mode. A variant of its own, so the
# sampled ONOFF loop keeps no trace of the exact law's branch and stays vectorised across plants.
ONOFF_EXACT = 3
# the mechanics a block of plants drives: the rig's free end (physics.load), or a hinge through a
# rack and pinion (physics.hinge, the rig's load step in muscle coordinates plus the link's weight)
RIG, HINGE = 0, 1

__all__ = [
    "STATE_FIELDS",
    "S_L",
    "S_V",
    "S_MC",
    "S_UC",
    "S_ME",
    "S_UE",
    "S_SC",
    "S_SE",
    "S_SRC",
    "S_SRE",
    "S_T",
    "S_Z1",
    "S_Z2",
    "S_Z3",
    "N_STATE",
    "N_STATE_V0",
    "INPUT_FIELDS",
    "I_CMD_C",
    "I_CMD_E",
    "I_LOAD",
    "I_FEXT",
    "N_INPUT",
    "AUX_FIELDS",
    "N_AUX",
    "PROPORTIONAL",
    "ONOFF",
    "ONOFF_EXACT",
    "PRESSURE",
    "MODES",
    "RIG",
    "HINGE",
    "A_FORCE",
    "A_STIFF",
    "A_STIFF_CLOSED",
    "A_PC",
    "A_PE",
    "A_TC",
    "A_TE",
    "A_VC",
    "A_VE",
    "A_MDOT_C",
    "A_MDOT_E",
    "A_AIR",
    "A_PMAX",
    "A_BURST",
    "A_STOP",
    "A_FINITE",
]
