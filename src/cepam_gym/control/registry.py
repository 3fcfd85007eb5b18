"""Every controller by name: ``make_controller("baseline", env)``.

A controller is built from the env it will drive (``factory(env, **kwargs)``) and follows the
:class:`Controller` protocol. The benchmark harness, ``cepam-gym video`` and the command line
build controllers only through :func:`make_controller`.

Three kinds of names:

* **registered names** (:data:`CONTROLLERS`), each a lazy ``"module:attr"`` string or a callable,
  so that listing them imports nothing heavy; those of higher layers (``identify_mpc``) are
  declared in the entry-point group :data:`CONTROLLER_ENTRY_POINTS_GROUP`;
* **joint variants** (:data:`JOINT_VARIANTS`): on the MuJoCo joint env (``cepam_gym/CEPAMJoint-v0``)
  a name is replaced by its joint variant (``baseline`` -> ``joint_baseline``);
* **trained agents**: a run directory or model file (``runs/quick-s0``) goes to a loader that an
  installed distribution declares in the entry-point group :data:`AGENT_LOADERS_GROUP` (the
  training package ``cepam_gym_agents`` declares ``agent``), ``loader(spec, env)``. ``NAME:SPEC``
  picks the loader ``NAME``; a bare path goes to ``agent`` (or to the only loader installed).
  So ``cepam_gym`` never imports the training code.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

from .. import versions
from ..envs.model import env_layers
from ..errors import InputError

AGENT_LOADERS_GROUP = "cepam_gym.controllers"
DEFAULT_AGENT_LOADER = "agent"

CONTROLLERS: dict[str, str | Callable[..., Any]] = {
    "zero": "cepam_gym.control.trivial:ZeroController",
    "random": "cepam_gym.control.trivial:RandomController",
    "baseline": "cepam_gym.control.baseline:InverseStaticController",
    "joint_baseline": "cepam_gym.control.joint_baseline:JointInverseStaticController",
    # model-predictive: the nominal model on observations only, and the privileged headroom yardstick
    "mpc": "cepam_gym.control.mpc:ModelPredictiveController",
    # the MPC with an online estimate (EKF) of the load and of the static map's parameters
    "adaptive_mpc": "cepam_gym.control.adaptive_mpc:AdaptiveMPC",
    "oracle": "cepam_gym.control.oracle:OracleController",
    # privileged ceilings of what the oracle's inputs are worth (docs/benchmark.md): the oracle
    # without foresight of the load, and the MPC given each plant's true parameters
    "oracle_causal": "cepam_gym.control.oracle:CausalOracle",
    "mpc_known_params": "cepam_gym.control.mpc:KnownParamsMPC",
    # adaptive_mpc given the true parameters: the teacher of a student told the plant
    "adaptive_mpc_known_params": "cepam_gym.control.adaptive_mpc:KnownParamsAdaptiveMPC",
    # the MPC whose load estimate balances its friction elements too (tracked from the length)
    "mpc_friction": "cepam_gym.control.mpc:FrictionObserverMPC",
    # the same observer in the baseline's load estimate; mpc_friction given the true parameters
    "baseline_friction": "cepam_gym.control.baseline:FrictionAwareBaseline",
    "mpc_friction_known_params": "cepam_gym.control.mpc:KnownParamsFrictionMPC",
}
# Controllers of the layers above control (identify's ``identify_mpc``: the MPC on the plant it fits
# to the episode's identification window) register themselves: their distribution declares them
# in this entry-point group (pyproject.toml), read once here, so that no module of control names a
# module above it (a lazy string would be a runtime import cycle the layer test could not see).
CONTROLLER_ENTRY_POINTS_GROUP = "cepam_gym.registered_controllers"


def _entry_point_controllers() -> dict[str, str]:
    from importlib.metadata import entry_points

    return {ep.name: ep.value for ep in entry_points(group=CONTROLLER_ENTRY_POINTS_GROUP)}


for _name, _target in _entry_point_controllers().items():
    CONTROLLERS.setdefault(_name, _target)
# name -> the controller used instead on the joint env; names absent here serve both kinds of env
JOINT_VARIANTS: dict[str, str] = {"baseline": "joint_baseline"}
# the joint env's classes, as the version table's entry points of the hinge ids ("module:Class")
_JOINT_ENV_CLASSES = frozenset(
    entry
    for row in versions.VERSIONS.values()
    if row.mechanism == "hinge"
    for entry in (row.entry_point, row.vector_entry_point)
    if entry is not None
)


@runtime_checkable
class Controller(Protocol):
    """What every controller does. ``obs`` is one observation ``(obs_dim,)`` or a batch
    ``(N, obs_dim)``; ``act`` returns actions of the same leading shape. ``reset(indices)``
    forgets the internal state of the envs ``indices`` (all when ``None``), as their episodes
    restart."""

    def reset(self, indices=None) -> None: ...

    def act(self, obs, info=None): ...


def register_controller(
    name: str, factory: str | Callable[..., Any], *, joint_variant: str | None = None, replace: bool = False
) -> None:
    """Add a controller: ``factory`` is ``"module:attr"`` or a callable ``factory(env, **kwargs)``.
    ``joint_variant``: the registered name to use instead on the joint env."""
    if not isinstance(name, str) or not name or ":" in name:
        raise InputError(f"controller name must be a non-empty string without ':', got {name!r}")
    if name in CONTROLLERS and not replace:
        raise InputError(f"controller {name!r} is already registered (pass replace=True)")
    if not (callable(factory) or (isinstance(factory, str) and ":" in factory)):
        raise TypeError(f"factory of {name!r} must be a callable or a 'module:attr' string, got {factory!r}")
    CONTROLLERS[name] = factory
    if joint_variant is not None:
        JOINT_VARIANTS[name] = joint_variant


def controller_names() -> list[str]:
    """The registered names, sorted."""
    return sorted(CONTROLLERS)


def agent_loaders() -> dict[str, Any]:
    """The installed loaders of trained agents (entry points of :data:`AGENT_LOADERS_GROUP`), by
    name; not yet loaded."""
    from importlib.metadata import entry_points

    return {ep.name: ep for ep in entry_points(group=AGENT_LOADERS_GROUP)}


def load_factory(target: str | Callable[..., Any]) -> Callable[..., Any]:
    """The callable a registry entry names (``"module:attr"`` is imported here)."""
    if callable(target):
        return target
    module, _, attr = target.partition(":")
    obj: Any = importlib.import_module(module)
    for part in attr.split("."):
        obj = getattr(obj, part)
    return obj


def is_joint_env(env) -> bool:
    """Whether ``env`` (single, wrapped, Gymnasium vector or SB3 vector) runs the joint (v0 in
    MuJoCo or v1/v2 on the batched kernel): one of its layers is an instance of a class the
    version table names as a hinge id's entry point (a subclass counts). Imports nothing."""
    return any(
        f"{cls.__module__}:{cls.__qualname__}" in _JOINT_ENV_CLASSES
        for layer in env_layers(env, into_vector=True)
        for cls in type(layer).__mro__
    )


def make_controller(spec: str | Path, env, **kwargs: Any) -> Controller:
    """The controller ``spec`` names, built for ``env``: a registered name (:func:`controller_names`),
    a trained agent's run directory or model file, or ``LOADER:SPEC`` for an installed loader.
    ``kwargs`` go to a registered controller's constructor. Unknown names raise ``ValueError``
    listing what is available."""
    name = str(spec)
    if name in CONTROLLERS:
        joint = is_joint_env(env)
        resolved = JOINT_VARIANTS.get(name, name) if joint else name
        if resolved not in CONTROLLERS:
            raise InputError(f"controller {name!r} has joint variant {resolved!r}, which is not registered")
        if not joint and resolved in JOINT_VARIANTS.values():
            rig = sorted(k for k, v in JOINT_VARIANTS.items() if v == resolved)
            raise InputError(
                f"controller {name!r} drives the joint env (cepam_gym/CEPAMJoint-v0) only; "
                f"on this env use {' or '.join(map(repr, rig))}"
            )
        return load_factory(CONTROLLERS[resolved])(env, **kwargs)
    loaders = agent_loaders()
    loader_name, agent_spec = _split_loader(name, loaders)
    if loader_name is None:
        raise InputError(_unknown(name, loaders))
    if kwargs:
        # a trained agent's options are its run's: dropping these would score something else
        raise InputError(
            f"controller {name!r} is a trained agent and takes no options (given {sorted(kwargs)})"
        )
    if is_joint_env(env) and not _batched(env):
        raise InputError(
            f"controller {name!r}: a trained agent cannot drive the MuJoCo joint env "
            f"(cepam_gym/CEPAMJoint-v0; agents train on the batched kernel, CEPAMJoint-v1 included); "
            f"use one of {controller_names()}"
        )
    return loaders[loader_name].load()(agent_spec, env)


def agent_env_id(spec: str | Path) -> str | None:
    """The env id the trained agent ``spec`` was trained on, where its loader can tell (a loader
    may carry ``env_id_of(spec)``, reading the run's record); None for a registered controller,
    or an agent whose record names no id."""
    name = str(spec)
    if name in CONTROLLERS:
        return None
    loaders = agent_loaders()
    loader_name, agent_spec = _split_loader(name, loaders)
    if loader_name is None:
        raise InputError(_unknown(name, loaders))
    env_id_of = getattr(loaders[loader_name].load(), "env_id_of", None)
    return None if env_id_of is None else env_id_of(agent_spec)


def _batched(env) -> bool:
    """Whether ``env`` runs on the batched kernel (it has an ``EnvModel``): what agents train on."""
    from ..envs.model import NoModelError, model_of

    try:
        model_of(env)
    except NoModelError:
        return False
    return True


def check_controller_spec(spec: str | Path) -> None:
    """Raise ``ValueError`` (the message of :func:`make_controller`) unless ``spec`` is a registered
    name or goes to an installed loader of trained agents: a command line checks its arguments
    before it starts any work."""
    name = str(spec)
    if name in CONTROLLERS:
        return
    loaders = agent_loaders()
    if _split_loader(name, loaders)[0] is None:
        raise InputError(_unknown(name, loaders))


def _split_loader(name: str, loaders: dict) -> tuple[str | None, str]:
    """``(loader name, its spec)`` for a trained agent, or ``(None, name)``."""
    head, sep, rest = name.partition(":")
    if sep and head in loaders and len(head) > 1:  # "C:\\..." is a path, not the loader "C"
        return head, rest
    if Path(name).exists() and loaders:
        if DEFAULT_AGENT_LOADER in loaders:
            return DEFAULT_AGENT_LOADER, name
        if len(loaders) == 1:
            return next(iter(loaders)), name
    return None, name


def _unknown(name: str, loaders: dict) -> str:
    msg = f"unknown controller {name!r}: registered controllers are {', '.join(controller_names())}"
    if loaders:
        path_note = "" if Path(name).exists() else f" ({name!r} is not an existing path)"
        return (
            msg + f"; a trained agent's run directory or model file goes to an installed loader "
            f"({', '.join(sorted(loaders))}; or LOADER:SPEC){path_note}"
        )
    return (
        msg + "; a trained agent's run directory needs the training package: pip install "
        "'cepam-gym[train]' (no loader in the entry-point group " + AGENT_LOADERS_GROUP + ")"
    )
