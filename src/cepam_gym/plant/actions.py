"""The action modes: the one place that says what an env action means to the valves.

An env action is two numbers in [-1, 1], one per chamber. What they command depends on the mode:

* ``"valve"`` (:data:`PROPORTIONAL`): proportional valve spool set-points, -1 exhaust, 0 closed,
  +1 supply;
* ``"pwm"`` (:data:`ONOFF`): duties of two on/off solenoid valves per chamber (sign: supply or
  exhaust) at the PWM period;
* ``"pressure"`` (:data:`PRESSURE`): gauge pressure set-points, -1 -> 0 Pa, +1 -> ``setpoint_max``
  (min(supply, burst)), held by an in-plant regulator on the proportional valves.

:func:`valve_commands` maps an action to the plant's valve inputs (:func:`plant_inputs` writes
a whole input row, the load included) and :func:`pressure_actions` inverts
the pressure map (controllers); how each mode drives a spool every sub-step, and which valve
(conductance, time constant) it uses, are :func:`cepam_gym.plant.substep.valve_command` and
:func:`cepam_gym.plant.substep.valve_setup`.
"""

from __future__ import annotations

import numpy as np

from .._jit import jit
from ..errors import InputError
from .layout import HINGE, I_CMD_C, I_CMD_E, I_FEXT, I_LOAD, MODES, ONOFF, PRESSURE, PROPORTIONAL

ACTION_MODES = tuple(MODES)  # "valve", "pwm", "pressure"
__all__ = [
    "ACTION_MODES",
    "ONOFF",
    "PRESSURE",
    "PROPORTIONAL",
    "check_action_mode",
    "plant_inputs",
    "pressure_actions",
]


def check_action_mode(action_mode: str) -> int:
    """The plant's valve mode of an env ``action_mode`` (``InputError`` naming the valid ones)."""
    if not isinstance(action_mode, str) or action_mode not in MODES:
        raise InputError(f"action_mode must be one of {ACTION_MODES}, got {action_mode!r}")
    return MODES[action_mode]


@jit
def valve_commands(mode, a0, a1, setpoint_max):
    """The plant's two valve inputs for an (already clipped) action: in pressure mode the action
    maps [-1, 1] to a gauge set-point in [0, setpoint_max] [Pa]; otherwise it is the command."""
    if mode == PRESSURE:
        half = 0.5 * setpoint_max
        return half * (a0 + 1.0), half * (a1 + 1.0)
    return a0, a1


@jit
def plant_inputs(inp, mode, mech, a0, a1, setpoint_max, load):
    """Write the plant's input row ``inp`` of an env action ``(a0, a1)``, clipped to [-1, 1], and
    the step's load: a hanging mass [kg] on the rig, the external force on the muscle [N] on a
    hinge (``mech == HINGE``: an external torque over the lever arm). Returns the clipped action.
    The env step and the planners' rollouts both assemble their inputs here."""
    a0 = max(-1.0, min(1.0, a0))
    a1 = max(-1.0, min(1.0, a1))
    inp[I_CMD_C], inp[I_CMD_E] = valve_commands(mode, a0, a1, setpoint_max)
    if mech == HINGE:
        inp[I_LOAD] = 0.0
        inp[I_FEXT] = load
    else:
        inp[I_LOAD] = load
        inp[I_FEXT] = 0.0
    return a0, a1


def pressure_actions(pc_set, pe_set, setpoint_max: float) -> np.ndarray:
    """The pressure-mode actions (N, 2) that ask for gauge set-points ``pc_set``, ``pe_set`` [Pa]:
    the inverse of :func:`valve_commands` (not clipped)."""
    return np.stack([2 * pc_set / setpoint_max - 1, 2 * pe_set / setpoint_max - 1], axis=1)
