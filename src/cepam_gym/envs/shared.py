"""What the single and the vector env share: the termination names, the renderer and kwarg
checks, what controllers read of an env, and the episode that copies and pickles carry."""

from __future__ import annotations

import inspect
from typing import Any

from .. import plant as pl
from ..errors import InputError
from ..tasks import kernel as tk
from .core import CEPAMBatch
from .model import EnvModel

# names of the integer ``info["termination_reason"]`` codes (index = code; tasks.kernel's order)
TERMINATION_NAMES = ("none", "burst", "non_finite_state")
assert len(TERMINATION_NAMES) == len(tk.TERMINATION_REASONS)


def check_renderer(core: CEPAMBatch, renderer: str | None) -> str:
    """The renderer of the core's task (``None``: the task's default, its first). The rig's:
    ``"numpy"``, the 2-D drawing of :mod:`cepam_gym.envs.render` (no extra needed), or
    ``"mujoco"``, the 3-D rig of :class:`cepam_gym.mujoco.rig.RigRenderer`; the joint's: MuJoCo
    only (the ``[mujoco]`` extra)."""
    allowed = core.task.renderers
    if renderer is None:
        renderer = allowed[0]
    if renderer not in allowed:
        raise InputError(f"renderer must be one of {allowed} for the {core.task.name} task, got {renderer!r}")
    return renderer


def mujoco_frames(core: CEPAMBatch):
    """The MuJoCo frame source of the core's task (``render_core(core, i)`` draws env ``i``)."""
    from ..mujoco._mj import require_mujoco

    require_mujoco()  # the install hint, not an import error from deep inside
    if core.mech == pl.HINGE:
        from ..mujoco.joint_view import BatchJointFrames

        return BatchJointFrames(core)
    from ..mujoco.rig import RigRenderer

    return RigRenderer()


ENV_KWARGS = ("task", "render_mode", "renderer")
VECTOR_KWARGS = ("num_envs", "max_episode_steps", "autoreset_mode")


def check_kwargs(kwargs: dict, env_kwargs: tuple[str, ...]) -> None:
    """Unknown kwargs named in one line with the valid ones (not a TypeError of an inner class)."""
    core = set(inspect.signature(CEPAMBatch.__init__).parameters) - {"self", "num_envs", "task"}
    bad = sorted(set(kwargs) - core)
    if bad:
        valid = sorted(core | set(env_kwargs))
        raise InputError(f"unknown env kwarg(s) {bad}; valid: {valid}")


def seed_core(env, seed: int | None) -> None:
    """At ``reset(seed=...)`` (and at the first reset): the core draws from its own streams,
    derived from the env's generator, so that Gymnasium's seeding works for single and vector envs
    alike."""
    if seed is not None or not hasattr(env, "_seeded"):
        env.core.seed(int(env.np_random.integers(2**63)) if seed is None else seed)
        env._seeded = True


def episode_of(env) -> dict[str, Any]:
    return {
        "episode": env.core.episode_state(),
        "np_random": getattr(env, "_np_random", None),
        "seeded": getattr(env, "_seeded", False),
    }


def restore_episode(env, st: dict[str, Any]) -> None:
    env.core.restore(st["episode"])
    if st["np_random"] is not None:
        env._np_random = st["np_random"]
    if st["seeded"]:
        env._seeded = True


def expose(env, core: CEPAMBatch) -> None:
    """What controllers read of an env (the joint's, as of ``CEPAMJoint-v0``,
    :class:`~cepam_gym.control.joint_baseline.JointInverseStaticController`): the nominal plant,
    the task's spec (and the hinge's geometry), observation layout, action mode and timing; and
    the plant model of the batched kernel's envs (``env.env_model``, :mod:`cepam_gym.envs.model`)."""
    env.env_model = EnvModel.of(core)
    env.obs_layout, env.task = core.obs_layout, core.task.spec
    env.nominal, env.nominal_row = core.nominal, core.nominal.to_array()
    env.setpoint_max, env.action_mode, env.control_dt = (
        core.nominal.pressure_cap,
        core.action_mode,
        core.control_dt,
    )
    if core.mech == pl.HINGE:
        env.geometry, env.angle_max = core.task.geometry, core.task.angle_max


# the spec sheet of the rig ids (Gymnasium v5 style), shared by the single and the vector env
RIG_SPEC_SHEET = """

    ## Description

    A compound extensor pneumatic artificial muscle (CE-PAM: a contractor McKibben muscle inside an
    extensor one; docs/model.md summarises the paper) hangs vertically from a mounting plate with a load on
    its free end. Two valves feed the two chambers (the CPAM, pressure ``Pc``, and the annulus
    between the EPAM bladder and the CPAM, pressure ``Pe``). Because length and stiffness depend
    on both pressures differently, both can be set independently (paper section XII). The plant is
    :mod:`cepam_gym.plant`: enhanced static force model (Eq. 41, 45), ISO 6358 valves, first-law
    chamber air, vertical load with end stops at 15 and 19.5 cm.

    ## Tasks (ids)

    | id | task |
    |---|---|
    | ``cepam_gym/CEPAM-v0`` | hold a target length AND a target stiffness, both changing every 2-4 s, while the hanging load changes (step, ramp, sine, random) |
    | ``cepam_gym/CEPAMLength-v0`` | hold a target length under changing loads; stiffness free |
    | ``cepam_gym/CEPAMStiffness-v0`` | hold 17.5 cm and change stiffness (paper section XII) |

    Targets are sampled only where the inverse static model finds pressures between the bladder
    contact pressure and 85 % of min(supply, burst) for every load of the segment: every episode
    is solvable.

    ## Action space

    ``Box(-1, 1, (2,), float32)``: one command per chamber ``[CPAM, annulus]``. Out-of-range values
    are clipped; NaN, inf or a wrong shape raise ``ValueError``.

    | action_mode | meaning of a command |
    |---|---|
    | ``"valve"`` (default) | proportional valve spool set-point: -1 exhaust, 0 closed, +1 supply |
    | ``"pwm"`` | duty of two on/off solenoid valves (sign: supply or exhaust) at ``pwm_frequency`` |
    | ``"pressure"`` | gauge pressure set-point, -1 -> 0 kPa, +1 -> min(supply, burst), held by an internal regulator |

    ## Observation space

    ``Box(-10, 10, (9,), float32)`` (8 without the stiffness target, ``CEPAMLength-v0``): only what
    a rig measures, scaled to about unit range. The columns are named in ``env.unwrapped.core.obs_layout``
    (:class:`~cepam_gym.tasks.layout.ObsLayout`: ``column(name)``, ``decode(obs)`` in SI units).

    | # | observation | scaling |
    |---|---|---|
    | 0 | length L | (L - 17.25 cm) / 2.25 cm |
    | 1 | dL/dt | / 0.1 m/s |
    | 2 | Pc (gauge) | / supply |
    | 3 | Pe (gauge) | / supply |
    | 4 | supply pressure (gauge) | / nominal supply |
    | 5 | target length | as 0 |
    | 6 | target stiffness (if tracked) | / 1000 N/m |
    | 7-8 | previous action | as is |

    The true stiffness, load, force and every plant quantity are in ``info`` (SI units).

    ## Rewards

    ``reward = sum of terms``, each reported signed in ``info["reward_<term>"]``:

    | term | value | weight kwarg (default) |
    |---|---|---|
    | length | ``-w |L - L*| / 1 cm`` (error clipped at 5 cm) | ``length`` (1.0) |
    | stiffness | ``-w |K - K*| / K*`` (clipped at 2); K at constant pressures | ``stiffness`` (2.5: 20 % weighs like 5 mm, as in the benchmark score) |
    | effort | ``-w mean(a^2)`` | ``effort`` (0.05) |
    | air | ``-w (air drawn from supply this step) / 10 mg`` | ``air`` (0.05) |
    | burst | ``-w`` once when a chamber exceeds the burst pressure | ``burst`` (100) |

    ## Episode

    Starts at rest at a reachable (length, stiffness) different from the first target. Control
    period ``control_dt`` (default 0.02 s, 50 Hz) with plant sub-steps ``sub_dt`` (0.5 ms; must
    divide it). Truncated after ``max_episode_steps`` (500 = 10 s). Terminated only on physical
    failure: ``info["termination_reason"]`` is an integer code (0 while running), named by
    ``env.metadata["termination_reasons"]``: 1 ``"burst"``, 2 ``"non_finite_state"``.

    ## Arguments

    | kwarg | default | meaning |
    |---|---|---|
    | ``plant`` | ``None`` (balloon preset) | PlantParams, preset name, YAML path, or dict of unit-named keys |
    | ``action_mode`` | ``"valve"`` | see above |
    | ``control_dt``, ``sub_dt`` | 0.02, 5e-4 | seconds |
    | ``episode_seconds`` | 10.0 | length of the target and load schedule (beyond it the last targets hold); the episode itself is truncated by ``max_episode_steps`` (500 from the registration: pass both to change the episode length) |
    | ``reward_weights`` | ``{}`` | override any of the weights above |
    | ``randomize`` | ``None`` | ``{plant key: [low, high]}`` in the key's units, sampled per episode; checked when the env is built (each key's ends, corners, a sample: a valid plant, stable integration, reachable targets; the error names the key); a draw that still fails is redrawn, counted in ``info["redraws"]`` |
    | ``sensor_noise`` | ``None`` | ``{"length_mm", "velocity_mm_s", "pressure_kpa"}`` standard deviations |
    | ``action_latency_steps`` | 0 | actions reach the valves this many steps late |
    | ``supply_drift_kpa`` | 0.0 | random-walk intensity of the supply pressure, kPa/sqrt(s), clipped to +-20 % |
    | ``stream`` | 0 | index of the env's random stream (see Seeding) |
    | ``num_threads`` | ``None`` | threads of the batched kernel (vector env, 256 envs or more): ``None`` the count that steps fastest now (every core on a quiet machine, 1 beside a busy core; results are the same), an integer fixes it; see ``benchmarks/throughput.py --busy-core`` |
    | ``task_options`` | ``{}`` | override TaskSpec fields: ``length_range`` [m], ``load_range`` [kg], ``load_kinds``, ``segment_duration`` [s], ``stiffness_range`` [N/m], ``pressure_margin`` |
    | ``render_mode`` | ``None`` | ``"rgb_array"`` or ``"human"`` |
    | ``renderer`` | ``"numpy"`` | ``"numpy"`` (2-D drawing) or ``"mujoco"`` (3-D rig, ``pip install 'cepam-gym[mujoco]'``, headless with ``MUJOCO_GL=egl``) |

    ``reset(options={"target_length": m, "target_stiffness": N/m, "load_mass": kg})`` pins any of
    them for the episode (evaluation at chosen operating points; checked: length within the end
    stops, stiffness > 0, 0 <= load <= 20 kg; no reachability check). A supply above the burst
    pressure gives a warning.

    ## Seeding

    ``reset(seed=s)`` seeds per-env streams spawned from ``numpy.random.SeedSequence(s)``: env i
    of a vector env owns the spawned child ``i`` (``SeedSequence(s, spawn_key=(i,))``), which
    feeds its parameter draws, schedules, sensor noise and supply drift. A single env owns child
    ``stream`` (kwarg, default 0). So vector element i seeded ``s`` equals, bit for bit, a single
    env made with ``stream=i`` and seeded ``s``, noise and drift included; different seeds give
    independent streams.

    ## Version history

    * v0: initial release. Later v0 changes: per-env seed streams spawned from a SeedSequence
      (``stream`` kwarg); ``info["termination_reason"]`` an integer code (was a string);
      ``info["redraws"]``; the vector env's ``autoreset_mode`` (default ``"next_step"``, was
      same-step only) and info masks.
"""
