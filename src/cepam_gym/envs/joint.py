"""``cepam_gym/CEPAMJoint-v1``: the CE-PAM hinge on the batched kernel (single and vector env).

The same hinge as ``cepam_gym/CEPAMJoint-v0`` (:mod:`cepam_gym.envs.joint_mujoco`, which MuJoCo
integrates), here integrated by the plant's own block kernel: :func:`cepam_gym.plant.advance_block_hinge`
runs the hinge as the rig's load step in muscle coordinates (:mod:`cepam_gym.physics.hinge`), and
the task kernel (:func:`cepam_gym.tasks.kernel.env_step`) scores it through the mechanism map
(angle ``(L_max - L) / r``, joint stiffness ``K r^2``). :class:`JointBatch` is
:class:`~cepam_gym.envs.core.CEPAMBatch` with the joint's task hooks; the Gymnasium classes are
the rig's (:mod:`cepam_gym.envs.cepam`) on that core. MuJoCo stays the reference
(``tests/test_joint_v1.py`` checks the two agree) and draws the frames.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from .. import plant as pl
from ..physics import api
from ..physics import layout as ix
from ..plant.params import pressure_cap_of
from ..tasks import kernel as tk
from ..tasks.joint import (
    JointGeometry,
    JointRewardWeights,
    JointTask,
    apply_reset_options,
    joint_layout,
    joint_planned_schedules,
)
from ..tasks.spec import check_kwargs
from .cepam import TERMINATION_NAMES, CEPAMEnv, CEPAMVectorEnv
from .core import CEPAMBatch
from .randomization import Randomizer, unstable

__all__ = ["JOINT_TASKS", "JointBatch", "CEPAMJointV1Env", "CEPAMJointVectorEnv", "REWARD_TERMS"]

# v1: planned references (smooth moves, the paper's two profiles), as the rig's v1 tasks
V1_REFERENCES = ("min_jerk", "sine", "chirp", "stiffness_ramp")
JOINT_TASKS = {"joint": JointTask(), "joint_v1": JointTask(references=V1_REFERENCES)}
REWARD_TERMS = ("angle", "stiffness", "effort", "air", "burst")  # tasks.kernel.reward_terms, in order
_TERM_KEYS = tuple(f"reward_{t}" for t in REWARD_TERMS)
INFO_KEYS = (
    "angle",
    "angular_velocity",
    "muscle_length",
    "muscle_force",
    "muscle_torque",
    "stiffness",
    "joint_stiffness",
    "joint_stiffness_total",
    "pressure_c",
    "pressure_e",
    "air_used",
    "external_torque",
    "target_angle",
    "target_stiffness",
    "redraws",
)


class JointBatch(CEPAMBatch):
    """N hinge envs as arrays (:class:`~cepam_gym.envs.core.CEPAMBatch` with ``MECH = HINGE``).
    ``target_l``, ``target_k`` and ``load`` hold the target angle [rad], target joint stiffness
    [N m/rad] and external torque [N m] of every control step."""

    MECH = pl.HINGE
    PIN_KEYS = ("target_angle", "target_stiffness", "external_torque", "initial_angle", "initial_stiffness")

    def __init__(self, num_envs: int = 1, task: str | JointTask = "joint_v1", joint=None, **kwargs: Any):
        self.geometry = JointGeometry.from_kwargs(joint)
        super().__init__(num_envs, task=task, **kwargs)
        self.initial = np.zeros((self.num_envs, 2))  # (angle, joint stiffness) each episode starts at

    # ------------------------------------------------------------- task hooks
    def _resolve_task(self, task, task_options, reward_weights) -> JointTask:
        if isinstance(task, str):
            if task not in JOINT_TASKS:
                raise ValueError(f"unknown joint task {task!r}; available: {sorted(JOINT_TASKS)}")
            task = JOINT_TASKS[task]
        elif not isinstance(task, JointTask):
            raise TypeError(f"task must be a joint task name or a JointTask, got {type(task).__name__}")
        opts = check_kwargs(JointTask, task_options, "task_options", exclude=("scales",))
        if opts:
            task = dataclasses.replace(
                task, **{k: tuple(v) if isinstance(v, list) else v for k, v in opts.items()}
            )
        self.weights = JointRewardWeights(
            **check_kwargs(JointRewardWeights, reward_weights, "reward_weights", "terms")
        )
        return task

    def _check_task_units(self) -> None:
        self.task.check_range(self.geometry, self.nominal.to_array())

    def _check_plant(self, row: np.ndarray) -> str | None:
        """Why parameter row ``row`` cannot run the joint task (``None`` if it can): an unstable
        sub-step, target angles outside the joint's range, a torque with no reachable target."""
        why = unstable(row, self.sub_dt)
        if why:
            return why
        try:
            self.task.check_range(self.geometry, row)
        except ValueError as e:
            return str(e)
        tau = self.task.unreachable_torque(self.geometry, row)
        if tau is not None:
            return f"the joint task has no reachable target under an external torque of {tau:.3g} N m"
        return None

    def _make_randomizer(self) -> Randomizer:
        return Randomizer(self.randomize, self.nominal, None, self.sub_dt, check=self._check_plant)

    def _layout(self):
        self.angle_max = self.geometry.max_angle(self.nominal.to_array())
        return joint_layout(self.task, self.angle_max, self.nominal.supply_pressure, self.preview_steps)

    def _task_vector(self) -> np.ndarray:
        return tk.task_vector(
            dataclasses.astuple(self.weights),
            self.task.scales,
            self.obs_layout,
            self.nominal.pressure_cap,
            True,
            "angle",
        )

    def _hinge_row(self) -> np.ndarray:
        return self.geometry.hinge_row()

    # ------------------------------------------------------------------ reset
    def _plan(self, rngs: list, rows: np.ndarray) -> tuple:
        """:func:`~cepam_gym.tasks.joint.joint_planned_schedules` (the rig's sampler
        through the joint's mechanism map, then the references)."""
        return joint_planned_schedules(
            rngs, self.task, self.geometry, rows, self._nominal_row, self.n_steps, self.control_dt
        )

    def _start(self, idx: np.ndarray, initial: np.ndarray) -> None:
        """Envs ``idx`` at rest at their ``initial`` (angle, joint stiffness) rows with the chamber
        pressures of the inverse static model under the first external torque, clipped to
        ``[0, min(supply, burst)]`` (as :meth:`~cepam_gym.mujoco.joint_sim.JointSimulator.reset`)."""
        self.initial[idx] = initial
        p = self.params[idx]
        g, q = self.geometry, p.T  # q[col]: one column of the rows
        a0, k0 = self.initial[idx, 0], self.initial[idx, 1]
        L0 = g.length(a0, q)
        w0 = g.equivalent_weight(a0, self.load[idx, 0], q)
        pc, pe, _ = api.static_pressures(L0, k0 / g.lever_arm**2, w0, p)
        cap = pressure_cap_of(p)
        self.state[idx] = pl.initial_state(p, L0, np.clip(pc, 0.0, cap), np.clip(pe, 0.0, cap))
        self.aux[idx] = pl.measure(self.state[idx], p)
        self.t_idx[idx] = 0

    def apply_options(self, options: dict | None) -> None:
        """``reset(options=...)`` of every env: ``target_angle`` [rad], ``target_stiffness``
        [N m/rad], ``external_torque`` [N m] pinned for the episode; ``initial_angle`` [rad],
        ``initial_stiffness`` [N m/rad] the starting point (scalars;
        :func:`~cepam_gym.tasks.joint.apply_reset_options`)."""
        if not options:
            return
        for i in range(self.num_envs):
            sched = (self.target_l[i], self.target_k[i], self.load[i])
            self.initial[i] = apply_reset_options(
                options, sched, tuple(self.initial[i]), self.geometry, self.params[i]
            )
        self._start(np.arange(self.num_envs), self.initial.copy())
        self._observe()

    def pin_targets(self, **kwargs):
        raise NotImplementedError("the joint env pins targets through reset(options=...)")

    # ------------------------------------------------------------ measurements
    def info_single(self, scored: bool) -> dict[str, Any]:
        """:meth:`info_arrays` of env 0 as Python floats, built without temporary arrays (a
        single env's step is mostly Python overhead)."""
        g, r = self.geometry, self.geometry.lever_arm
        x, a = self.state[0].tolist(), self.aux[0].tolist()
        p = self.params[0]
        k = min(max(int(self.t_idx[0]) - (1 if scored else 0), 0), self.n_steps - 1)
        theta = float(g.angle(x[pl.S_L], p))
        ks = a[pl.A_STIFF] * r**2
        info = {
            "angle": theta,
            "angular_velocity": -x[pl.S_V] / r,
            "muscle_length": x[pl.S_L],
            "muscle_force": a[pl.A_FORCE],
            "muscle_torque": -r * a[pl.A_FORCE],
            "stiffness": a[pl.A_STIFF],
            "joint_stiffness": ks,
            "joint_stiffness_total": ks + float(g.link_mass * p[ix.GRAV] * g.link_com * np.cos(theta)),
            "pressure_c": a[pl.A_PC],
            "pressure_e": a[pl.A_PE],
            "air_used": a[pl.A_AIR] if scored else 0.0,
            "external_torque": float(self.load[0, k]),
            "target_angle": float(self.target_l[0, k]),
            "target_stiffness": float(self.target_k[0, k]),
        }
        if scored:
            info.update(zip(_TERM_KEYS, self.terms[0].tolist()))
        info["redraws"] = int(self.redraws[0])
        return info

    def info_arrays(self, scored: bool) -> dict[str, np.ndarray]:
        """Per-env info arrays (SI): the joint's quantities (as
        :meth:`~cepam_gym.mujoco.joint_sim.JointSimulator.measure`), loads, targets, reward terms."""
        g = self.geometry
        n = self.num_envs
        k = np.minimum(np.maximum(self.t_idx - (1 if scored else 0), 0), self.n_steps - 1)
        rows = np.arange(n)
        q = np.broadcast_to(self.params, (n, ix.N_PARAMS)).T
        L, v = self.state[:, pl.S_L].copy(), self.state[:, pl.S_V]
        theta = g.angle(L, q)
        ks = self.aux[:, pl.A_STIFF] * g.lever_arm**2
        out = {
            "angle": theta,
            "angular_velocity": -v / g.lever_arm,
            "muscle_length": L,
            "muscle_force": self.aux[:, pl.A_FORCE].copy(),
            "muscle_torque": -g.lever_arm * self.aux[:, pl.A_FORCE],
            "stiffness": self.aux[:, pl.A_STIFF].copy(),
            "joint_stiffness": ks,
            "joint_stiffness_total": ks + g.link_mass * q[ix.GRAV] * g.link_com * np.cos(theta),
            "pressure_c": self.aux[:, pl.A_PC].copy(),
            "pressure_e": self.aux[:, pl.A_PE].copy(),
            "air_used": self.aux[:, pl.A_AIR].copy() if scored else np.zeros(n),
            "external_torque": self.load[rows, k],
            "target_angle": self.target_l[rows, k],
            "target_stiffness": self.target_k[rows, k],
        }
        if scored:
            out.update(zip(_TERM_KEYS, np.ascontiguousarray(self.terms.T)))
        out["redraws"] = self.redraws.copy()
        return out


def _expose(env, core: JointBatch) -> None:
    """What the joint's controllers read of a joint env (as of ``CEPAMJoint-v0``,
    :class:`~cepam_gym.control.joint_baseline.JointInverseStaticController`): the nominal plant,
    geometry, task, observation layout, action mode and timing."""
    env.obs_layout, env.geometry, env.task = core.obs_layout, core.geometry, core.task
    env.nominal, env.nominal_row = core.nominal, core.nominal.to_array()
    env.setpoint_max, env.action_mode, env.control_dt = (
        core.nominal.pressure_cap,
        core.action_mode,
        core.control_dt,
    )


def _check_mujoco_renderer(renderer: str) -> None:
    if renderer != "mujoco":
        raise ValueError(
            f"the joint env renders with MuJoCo only: renderer must be 'mujoco', got {renderer!r}"
        )


class _Frames:
    """MuJoCo frames of env ``i`` of a :class:`JointBatch`: the v0 renderer
    (:class:`~cepam_gym.mujoco.joint_view.JointView`) on a MuJoCo model of the hinge whose
    angle is copied from the batch (nothing is simulated in MuJoCo)."""

    def __init__(self, core: JointBatch, width: int = 480, height: int = 480):
        from ..mujoco._mj import require_mujoco
        from ..mujoco.joint_sim import joint_xml
        from ..mujoco.joint_view import JointView
        from ..mujoco.rig import geom_ids

        self.core, self.width, self.height = core, width, height
        self.mujoco = require_mujoco()
        self._xml, self._geom_ids = joint_xml, geom_ids
        self.model = None
        self._p = None
        self.view = JointView(self)

    def frame(self, i: int) -> np.ndarray:
        core, mj = self.core, self.mujoco
        p = core.params[i if core.params.shape[0] > 1 else 0]
        if self._p is None or not np.array_equal(p, self._p):  # a randomized plant: a new model
            self._p = p.copy()
            self.model = mj.MjModel.from_xml_string(
                self._xml(core.geometry, p, core.sub_dt, self.width, self.height)
            )
            self.data = mj.MjData(self.model)
            self.geom_ids = self._geom_ids(mj, self.model, ("cpam", "epam", "cap", "rack"))
            self.view.model_changed()
        # what JointView reads of an env: this one's state
        self.geometry, self.params, self.n_steps = core.geometry, p, core.n_steps
        self.aux, self.t_idx = core.aux[i], int(core.t_idx[i])
        self.target_angle, self.external_torque = core.target_l[i], core.load[i]
        self.link = self  # JointView reads link.x[S_L]
        self.x = core.state[i]
        self.data.qpos[0] = self.joint_state()[0]
        return self.view.frame()

    def joint_state(self) -> tuple[float, float]:
        r = self.core.geometry.lever_arm
        return float((self.params[ix.L_MAX] - self.x[pl.S_L]) / r), float(-self.x[pl.S_V] / r)

    def close(self) -> None:
        self.view.close()


_DOC = """

    ## Description

    The hinge of ``cepam_gym/CEPAMJoint-v0`` (a 1-DOF elbow or wrist of a wearable device driven by
    one CE-PAM through a rack and pinion of radius ``r`` = 2.5 cm: ``L = L_max - r theta``, a
    0-1.8 rad flexion range; forearm 0.15 kg with its centre of mass 7 cm from the axis, under
    gravity and a changing external extension torque) on the plant v1 (default preset) and the
    batched kernel: ``gym.make_vec("cepam_gym/CEPAMJoint-v1", num_envs=N)`` steps N hinges in one
    compiled call, like the rig ids. Task: follow a planned joint angle AND joint stiffness
    ``K_joint = K r^2`` reference (minimum-jerk moves between set-points, sines and chirps of the
    angle at a constant stiffness, stiffness ramps at a fixed angle; every point reachable), the
    next ``preview_steps`` points announced. The hinge is integrated as the plant's own load step
    in muscle coordinates (:mod:`cepam_gym.physics.hinge`); MuJoCo (v0) is the reference it is
    tested against, and draws the frames (``pip install 'cepam-gym[mujoco]'`` for rendering only).

    ## Action space

    ``Box(-1, 1, (2,), float32)``: one command per chamber ``[CPAM, annulus]``. Out-of-range values
    are clipped; NaN, inf or a wrong shape raise ``ValueError``.

    | action_mode | meaning of a command |
    |---|---|
    | ``"valve"`` (default) | proportional valve spool set-point: -1 exhaust, 0 closed, +1 supply |
    | ``"pwm"`` | duty of two on/off solenoid valves (sign: supply or exhaust) |
    | ``"pressure"`` | gauge pressure set-point, -1 -> 0 kPa, +1 -> min(supply, burst), internal regulator |

    ## Observation space

    ``Box(-10, 10, (9 + 2 preview_steps,), float32)`` (29 with the registered ``preview_steps=10``):
    the columns are named in ``env.unwrapped.core.obs_layout``
    (:func:`~cepam_gym.tasks.joint.joint_layout`; ``decode(obs)`` gives them in SI units).

    | # | observation | scaling |
    |---|---|---|
    | 0 | joint angle theta [rad] | (theta - theta_max/2) / (theta_max/2), theta_max = 1.8 rad |
    | 1 | angular velocity [rad/s] | / 5 rad/s |
    | 2 | Pc (gauge) [Pa] | / supply |
    | 3 | Pe (gauge) [Pa] | / supply |
    | 4 | supply pressure (gauge) [Pa] | / nominal supply |
    | 5 | target angle [rad] | as 0 |
    | 6 | target joint stiffness [N m/rad] | / 1 N m/rad |
    | 7-8 | previous action | as is |
    | 9 ... | ``target_angle_+1 ...``, then ``target_stiffness_+1 ...``: the next ``preview_steps`` reference points | as 5 and 6 |

    ``info`` (SI): ``angle``, ``angular_velocity``, ``muscle_length``, ``muscle_force`` (push
    positive), ``muscle_torque`` (flexion positive), ``stiffness`` (muscle, N/m),
    ``joint_stiffness`` (``K r^2``), ``joint_stiffness_total`` (+ gravity ``m g l_c cos theta``),
    ``pressure_c``, ``pressure_e``, ``air_used``, ``external_torque``, ``target_angle``,
    ``target_stiffness``, ``redraws``, after a step the reward terms and ``termination_reason``.

    ## Rewards

    ``reward = sum of terms``, each reported signed in ``info["reward_<term>"]``; the rig's terms
    (:func:`cepam_gym.tasks.kernel.reward_terms`) with angle for length:

    | term | value | weight kwarg (default) |
    |---|---|---|
    | angle | ``-w |theta - theta*| / 10 deg`` (clipped at 5) | ``angle`` (1.0) |
    | stiffness | ``-w |K_joint - K*| / K*`` (clipped at 2) | ``stiffness`` (5.0) |
    | effort | ``-w mean(a^2)`` | ``effort`` (0.05) |
    | air | ``-w (supply air this step) / 10 mg`` | ``air`` (0.05) |
    | burst | ``-w`` once when a chamber exceeds the burst pressure | ``burst`` (100) |

    ## Episode

    Starts at rest on the reference's first point, with the chamber pressures of the inverse
    static model for the first external torque. Truncated after ``max_episode_steps`` (500 =
    10 s at 50 Hz). Terminated only on physical failure: ``info["termination_reason"]`` is an
    integer code named by ``metadata["termination_reasons"]``: 1 ``"burst"``, 2 ``"non_finite_state"``.

    ## Arguments

    | kwarg | default | meaning |
    |---|---|---|
    | ``task`` | ``"joint_v1"`` | ``"joint_v1"`` (planned references) or ``"joint"`` (v0's set-points) |
    | ``plant`` | ``None`` (balloon preset, plant v1) | PlantParams, preset name, YAML path, or dict of unit-named keys |
    | ``action_mode`` | ``"valve"`` | see above |
    | ``control_dt``, ``sub_dt`` | 0.02, 5e-4 | seconds |
    | ``episode_seconds`` | 10.0 | length of the reference and torque schedule [s] |
    | ``preview_steps`` | 10 (registered) | reference points announced, control steps |
    | ``joint`` | ``{}`` | override :class:`~cepam_gym.tasks.joint.JointGeometry`: ``lever_arm``, ``link_length``, ``link_mass``, ``link_com`` [m, kg], ``joint_damping`` [N m s/rad] |
    | ``task_options`` | ``{}`` | override :class:`~cepam_gym.tasks.joint.JointTask`: ``angle_range`` [rad], ``stiffness_range`` [N m/rad], ``torque_range`` [N m], ``load_kinds``, ``segment_duration`` [s], ``pressure_margin``, ``references``, ``move_s`` [s] |
    | ``reward_weights`` | ``{}`` | override any weight above |
    | ``randomize`` | ``None`` | ``{plant key: [low, high]}`` in the key's units, per episode (checked at build; a draw that fails is redrawn, ``info["redraws"]``) |
    | ``sensor_noise`` | ``None`` | as the rig's; ``length_mm`` and ``velocity_mm_s`` act on the angle [1e-3 rad] and its rate [1e-3 rad/s] |
    | ``action_latency_steps``, ``supply_drift_kpa``, ``stream``, ``num_threads`` | | as the rig envs (``cepam_gym/CEPAM-v1``) |
    | ``render_mode`` | ``None`` | ``"rgb_array"`` (vector env: one frame per env) or ``"human"`` (MuJoCo, headless with ``MUJOCO_GL=egl``) |

    ``reset(options=...)``: ``target_angle`` [rad], ``target_stiffness`` [N m/rad] and
    ``external_torque`` [N m] pin the value for the whole episode; ``initial_angle`` [rad] and
    ``initial_stiffness`` [N m/rad] choose the starting point (scalars; every env of a vector env).

    ## Seeding

    As the rig envs: env i of a vector env seeded ``s`` equals a single env made with
    ``stream=i`` and seeded ``s``.

    ## Version history

    * v1: the hinge on the batched kernel (native vector env), plant v1, planned references with
      preview. MuJoCo agreement: ``tests/test_joint_v1.py``.
    * v0: ``cepam_gym/CEPAMJoint-v0`` (MuJoCo hinge, plant balloon_v0, set-point targets), unchanged.
"""


class CEPAMJointV1Env(CEPAMEnv):
    __doc__ = "A hinge driven by a CE-PAM on the batched kernel: joint angle and stiffness references." + _DOC
    metadata = {
        "render_modes": ["rgb_array", "human"],
        "render_fps": 50,
        "termination_reasons": TERMINATION_NAMES,
    }
    _core_class = JointBatch
    _check_renderer = staticmethod(_check_mujoco_renderer)

    def __init__(
        self, task: str = "joint_v1", render_mode: str | None = None, renderer: str = "mujoco", **kwargs: Any
    ):
        super().__init__(task=task, render_mode=render_mode, renderer=renderer, **kwargs)
        _expose(self, self.core)

    def _info(self, scored: bool) -> dict[str, Any]:
        return self.core.info_single(scored)

    def _fast_info(self) -> dict[str, Any]:
        return self.core.info_single(True)

    def _frame(self):
        """The v0 MuJoCo model posed at env 0's angle (nothing is simulated in MuJoCo)."""
        if self._mujoco is None:
            self._mujoco = _Frames(self.core)
        return self._mujoco.frame(0)


class CEPAMJointVectorEnv(CEPAMVectorEnv):
    __doc__ = (
        "N CE-PAM hinges stepped by one compiled kernel "
        "(``gym.make_vec('cepam_gym/CEPAMJoint-v1', num_envs=N)``); the rig vector env's "
        "conventions (autoreset modes, info masks, seeding) on :class:`JointBatch`." + _DOC
    )
    _core_class = JointBatch
    _term_keys = _TERM_KEYS
    _check_renderer = staticmethod(_check_mujoco_renderer)

    def __init__(self, num_envs: int = 1, task: str = "joint_v1", renderer: str = "mujoco", **kwargs: Any):
        super().__init__(num_envs=num_envs, task=task, renderer=renderer, **kwargs)
        _expose(self, self.core)

    def _infos(self, scored: bool) -> dict[str, np.ndarray]:
        return self.core.info_arrays(scored)

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        if self._mujoco is None:
            self._mujoco = _Frames(self.core)
        return tuple(self._mujoco.frame(i) for i in range(self.num_envs))
