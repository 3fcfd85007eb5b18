"""What a controller may know of an env: its plant model, behind one declared interface.

Controllers are built from the env they drive (``make_controller(name, env)``); the model-based
ones need the plant it runs, as safe-control-gym's controllers read ``env.symbolic``. Ours read an
:class:`EnvModel`: ``model_of(env)`` for any env on the batched kernel (the rig ids and
``cepam_gym/CEPAMJoint-v1``; single or vector, under Gymnasium wrappers, the SB3 adapter and SB3
VecEnv wrappers), the same object as ``env.unwrapped.env_model``.

It declares two kinds of facts:

* **What a rig's engineer knows** (fixed for the env's life): the nominal plant, the timing, the
  action mode, the mechanism and the hinge's constants, the observation layout, the task's spec
  and the pressure a ``pressure``-mode command of +1 means. The practical controllers read only
  these (``baseline``, ``baseline_friction``, ``mpc``, ``mpc_friction``, ``adaptive_mpc``).
* **Privileged facts** (what only the simulator knows, live: they follow the env step by step):
  each env's true parameter row (randomized plants, the drifting supply), its plant state and
  auxiliary outputs, the episode's target and load schedules and each env's current step. Read
  by the privileged controllers only: ``oracle`` and ``oracle_causal`` (all of them),
  ``mpc_known_params`` and ``mpc_friction_known_params`` (the parameter rows), and the training
  package's asymmetric critic (:mod:`cepam_gym.policies.privileged`).

Nothing is written back: every array is a read-only view of the env's own (no copy; writing to
it raises ``ValueError: assignment destination is read-only``). A controller acts on the env only
through the Gymnasium API (``step``, ``reset(options=...)``).

This module is the one place outside ``envs`` that knows the batched core's attribute names
(:class:`~cepam_gym.envs.core.CEPAMBatch`): :meth:`EnvModel.of` and the properties below.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import versions
from ..plant.params import PlantParams, preset

if TYPE_CHECKING:  # types only: this module imports no env class
    from ..tasks.contract import TaskContract
    from ..tasks.layout import ObsLayout
    from ..tasks.mechanism import Mechanism
    from ..tasks.spec import TaskSpec


class NoModelError(TypeError):
    """The env does not run on the batched kernel (the MuJoCo joint, ``cepam_gym/CEPAMJoint-v0``,
    or a foreign env), so it has no :class:`EnvModel`."""


def _read_only(a: np.ndarray) -> np.ndarray:
    v = a.view()
    v.flags.writeable = False
    return v


@dataclass(frozen=True, eq=False)
class EnvModel:
    """The plant model of a batch of ``num_envs`` envs (one for a single env). SI units.

    Fixed facts (fields):

    * ``num_envs``; ``mech``: :data:`cepam_gym.plant.RIG` (a hanging load on the free end) or
      :data:`cepam_gym.plant.HINGE` (the joint), and ``mechanism`` its
      :class:`~cepam_gym.tasks.mechanism.Mechanism` (load mapping, measured view, geometry);
    * ``action_mode`` (``"valve"``, ``"pwm"``, ``"pressure"``) and ``mode``, its kernel code;
    * ``control_dt`` [s], ``sub_dt`` [s] the integration step, ``n_sub`` sub-steps per control
      step, ``n_steps`` control steps per episode (the identification window's included),
      ``window_steps`` the unscored identification window's control steps at the episode's
      start (0 without one: :mod:`cepam_gym.envs.id_window`);
    * ``nominal``: the nominal :class:`~cepam_gym.plant.params.PlantParams` (never randomized);
    * ``setpoint_max`` [Pa]: the gauge pressure a command of +1 asks for in ``pressure`` mode;
    * ``track_stiffness``: whether the task scores stiffness; ``task_spec``: its
      :class:`~cepam_gym.tasks.spec.TaskSpec`; ``obs_layout``: the observation's named columns
      (``decode(obs)`` in SI), ``obs_dim`` its width; ``preview_steps``: reference steps
      announced in the observation; ``contract``: the task's
      :class:`~cepam_gym.tasks.contract.TaskContract` (reward terms, info keys, what the score
      reads);
    * ``version``: the row of the version table (:mod:`cepam_gym.versions`) of the id the env
      runs, read from the task and plant it was built with (a plant given as a preset's
      parameters counts as that preset), None for a task or plant of one's own;
      ``task_version``: the version of its task (None for a Task object of one's own).

    Privileged, live, read-only (properties): :attr:`params`, :attr:`state`, :attr:`aux`,
    :attr:`target_l`, :attr:`target_k`, :attr:`load`, :attr:`t_idx`, :meth:`current_targets`.
    """

    num_envs: int
    mech: int
    mechanism: Mechanism = field(repr=False)
    action_mode: str
    mode: int
    control_dt: float
    sub_dt: float
    n_sub: int
    n_steps: int
    window_steps: int
    nominal: PlantParams = field(repr=False)
    setpoint_max: float
    track_stiffness: bool
    task_spec: TaskSpec = field(repr=False)
    obs_layout: ObsLayout = field(repr=False)
    obs_dim: int
    contract: TaskContract = field(repr=False)
    version: versions.Version | None = field(repr=False)
    task_version: int | None
    preview_steps: int
    _core: Any = field(repr=False)

    @classmethod
    def of(cls, core) -> EnvModel:
        """The model of a :class:`~cepam_gym.envs.core.CEPAMBatch` (what the envs build at
        construction; controllers call :func:`model_of`)."""
        return cls(
            num_envs=int(core.num_envs),
            mech=int(core.mech),
            mechanism=core.task.mechanism,
            action_mode=core.action_mode,
            mode=int(core.mode),
            control_dt=core.control_dt,
            sub_dt=core.sub_dt,
            n_sub=core.n_sub,
            n_steps=core.n_steps,
            window_steps=int(core.n_window),
            nominal=core.nominal,
            setpoint_max=float(core.task_params.setpoint_max),
            track_stiffness=bool(core.task.track_stiffness),
            task_spec=core.task.spec,
            obs_layout=core.obs_layout,
            obs_dim=int(core.obs_dim),
            contract=core.task.contract,
            version=_version(core),
            task_version=versions.task_version(core._init_args.get("task")),
            preview_steps=int(core.preview_steps),
            _core=core,
        )

    @property
    def task_params(self):
        """The task's settings as the compiled step reads them
        (:class:`~cepam_gym.envs.task_params.TaskParams`): the observation encoding that a rig's
        measurements go through too (:mod:`cepam_gym.rig.observation`)."""
        return self._core.task_params

    @property
    def hinge(self) -> np.ndarray:
        """(1, N_HINGE) the hinge's constants (lever arm ``[:, envs.step_kernel.H_R]``, ...), one row
        shared by the batch; unused on the rig."""
        return _read_only(self._core.hinge)

    # ------------------------------------------------------------------ privileged
    @property
    def params(self) -> np.ndarray:
        """Privileged: (num_envs, N_PARAMS) each env's true parameter row this episode
        (:mod:`cepam_gym.physics.layout` columns; randomized draws and supply drift included)."""
        return _read_only(self._core.params)

    @property
    def state(self) -> np.ndarray:
        """Privileged: (num_envs, N_STATE) the true plant state now (air masses and energies,
        spools, length and velocity, friction slips: :mod:`cepam_gym.plant` ``S_*`` columns)."""
        return _read_only(self._core.state)

    @property
    def aux(self) -> np.ndarray:
        """Privileged: (num_envs, N_AUX) the plant's outputs of the last step (pressures,
        stiffness, burst flag, ...: :mod:`cepam_gym.plant` ``A_*`` columns)."""
        return _read_only(self._core.aux)

    @property
    def target_l(self) -> np.ndarray:
        """Privileged: (num_envs, n_steps) the episode's position reference: the length [m] on
        the rig, the joint angle [rad] on the hinge."""
        return _read_only(self._core.target_l)

    @property
    def target_k(self) -> np.ndarray:
        """Privileged: (num_envs, n_steps) the stiffness reference: the muscle's [N/m] on the
        rig, the joint's [N m/rad] on the hinge."""
        return _read_only(self._core.target_k)

    @property
    def load(self) -> np.ndarray:
        """Privileged: (num_envs, n_steps) the load schedule: the hanging mass [kg] on the rig,
        the external torque [N m] on the hinge."""
        return _read_only(self._core.load)

    @property
    def t_idx(self) -> np.ndarray:
        """Privileged: (num_envs,) int each env's current control step in its episode (the
        column of the schedules that applies now, until the episode's end)."""
        return _read_only(self._core.t_idx)

    def current_targets(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Privileged: ``(target_l, target_k, load)`` each (num_envs,), what each env is asked
        for at its current step (the last column past the episode's end)."""
        return self._core.current_targets()


def _version(core) -> versions.Version | None:
    args = core._init_args
    plant = args.get("plant")
    if isinstance(plant, PlantParams):
        plant = next((name for name in versions.PLANT_PRESETS.values() if preset(name) == plant), plant)
    return versions.of_kwargs(args.get("task"), plant)


def env_layers(env, depth: int = 16, into_vector: bool = False):
    """``env`` and what it wraps, outermost first, each once: Gymnasium wrappers (``env``,
    ``unwrapped``), SB3's VecEnv wrappers (``venv``: they forward unknown attributes, so the layers
    are walked explicitly) and, with ``into_vector``, the first of a vector env's ``envs`` (every
    sub-env runs the same model); at most ``depth`` layers. The one walk of the package's lookups
    (:func:`model_of`, the controller registry, the joint's baseline)."""
    seen: set[int] = set()
    todo = [env]
    while todo and len(seen) < depth:
        e = todo.pop(0)
        if e is None or id(e) in seen:
            continue
        seen.add(id(e))
        yield e
        todo += [getattr(e, name, None) for name in ("env", "venv", "unwrapped")]
        subs = getattr(e, "envs", None) if into_vector else None
        if isinstance(subs, (list, tuple)) and subs:
            todo.append(subs[0])


def model_of(env) -> EnvModel:
    """The :class:`EnvModel` of ``env``: a single or vector env on the batched kernel, under any
    Gymnasium wrappers, the SB3 adapter or SB3 VecEnv wrappers (``VecNormalize``, ...).
    :class:`NoModelError` (a ``TypeError``) for an env without the kernel (the MuJoCo joint)."""
    for e in env_layers(env):
        model = getattr(e, "env_model", None)
        if isinstance(model, EnvModel):
            return model
    raise NoModelError(
        f"{_name(env)} does not run on the batched kernel, so it has no plant model "
        "(cepam_gym.envs.model.EnvModel): the rig ids and cepam_gym/CEPAMJoint-v1 have one, "
        "the MuJoCo joint cepam_gym/CEPAMJoint-v0 has not"
    )


def _name(env) -> str:
    spec = getattr(getattr(env, "unwrapped", env), "spec", None)
    return f"env {spec.id!r}" if getattr(spec, "id", None) else f"{type(env).__name__} {env!r}"
