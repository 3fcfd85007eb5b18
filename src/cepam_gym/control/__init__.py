"""Every controller behind one protocol (``reset``, ``act``) and a registry by name.

``make_controller(name_or_path, env)`` builds ``zero``, ``random``, ``baseline`` (the
inverse-static-model baseline; ``joint_baseline`` on the MuJoCo joint env), ``mpc`` (a
cross-entropy MPC on the nominal model, observations only), ``oracle`` (the same planner with the
true state, parameters, loads and future targets: the benchmark's headroom yardstick) or a trained
agent through an installed loader (:mod:`cepam_gym.control.registry`).
"""

from .baseline import InverseStaticController
from .registry import (
    CONTROLLERS,
    JOINT_VARIANTS,
    Controller,
    check_controller_spec,
    controller_names,
    is_joint_env,
    make_controller,
    register_controller,
)
from .trivial import RandomController, ZeroController

__all__ = [
    "CONTROLLERS",
    "JOINT_VARIANTS",
    "Controller",
    "InverseStaticController",
    "RandomController",
    "ZeroController",
    "check_controller_spec",
    "controller_names",
    "is_joint_env",
    "make_controller",
    "register_controller",
]
