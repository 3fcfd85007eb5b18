"""``cepam_gym/CEPAMJoint-v1``: the CE-PAM hinge on the batched kernel (single and vector env).

The same hinge as ``cepam_gym/CEPAMJoint-v0`` (:mod:`cepam_gym.envs.joint_mujoco`, which MuJoCo
integrates), here integrated by the plant's own block kernel: :func:`cepam_gym.plant.advance_block_hinge`
runs the hinge as the rig's load step in muscle coordinates (:mod:`cepam_gym.physics.hinge`), and
the task kernel (:func:`cepam_gym.tasks.kernel.env_step`) scores it through the mechanism map
(angle ``(L_max - L) / r``, joint stiffness ``K r^2``). The env is the rig's
(:mod:`cepam_gym.envs.cepam`) given the joint's Task object
(:class:`~cepam_gym.tasks.hinge_task.HingeTask`); the classes here only name that default task and
carry the spec sheet. MuJoCo stays the reference (``tests/test_joint_v1.py`` checks the two agree)
and draws the frames (:class:`~cepam_gym.mujoco.joint_view.BatchJointFrames`).
"""

from __future__ import annotations

from ..tasks.contract import JOINT
from ..tasks.hinge_task import INFO_KEYS, JOINT_TASKS, REWARD_TERMS
from .cepam import TERMINATION_NAMES, CEPAMEnv, CEPAMVectorEnv

__all__ = ["INFO_KEYS", "JOINT_TASKS", "REWARD_TERMS", "CEPAMJointV1Env", "CEPAMJointVectorEnv"]


_DOC = JOINT.spec_sheet(
    """

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

{REWARD_TABLE}

    ## Episode

    Starts at rest on the reference's first point, with the chamber pressures of the inverse
    static model for the first external torque. Truncated after ``max_episode_steps`` (500 =
    10 s at 50 Hz). Terminated only on physical failure: ``info["termination_reason"]`` is an
    integer code named by ``metadata["termination_reasons"]``: {TERMINATIONS}.

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
)


class CEPAMJointV1Env(CEPAMEnv):
    __doc__ = "A hinge driven by a CE-PAM on the batched kernel: joint angle and stiffness references." + _DOC
    metadata = {
        "render_modes": ["rgb_array", "human"],
        "render_fps": 50,
        "termination_reasons": TERMINATION_NAMES,
    }
    default_task = "joint_v1"


class CEPAMJointVectorEnv(CEPAMVectorEnv):
    __doc__ = (
        "N CE-PAM hinges stepped by one compiled kernel "
        "(``gym.make_vec('cepam_gym/CEPAMJoint-v1', num_envs=N)``); the rig vector env's "
        "conventions (autoreset modes, info masks, seeding) with the joint's task." + _DOC
    )
    default_task = "joint_v1"
