"""What the single and the vector env share: the termination names, the renderer and kwarg
checks, what controllers read of an env, and the episode that copies and pickles carry."""

from __future__ import annotations

import inspect
from typing import Any

from .. import plant as pl
from ..errors import InputError, UnexpectedKwargError
from ..tasks.spec import TERMINATION_NAMES  # noqa: F401  (the env modules' name for them)
from .core import CEPAMBatch


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


def check_kwargs(kwargs: dict, env_kwargs: tuple[str, ...], owner: str = "env") -> None:
    """Unknown kwargs of the env class ``owner`` named in one line with the valid ones, as
    Python's ``TypeError`` words it (:class:`~cepam_gym.errors.UnexpectedKwargError`), not the
    ``TypeError`` of an inner class."""
    core = set(inspect.signature(CEPAMBatch.__init__).parameters) - {"self", "num_envs", "task"}
    bad = sorted(set(kwargs) - core)
    if bad:
        raise UnexpectedKwargError.naming(owner, bad, sorted(core | set(env_kwargs)))


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
    the task's spec (and the hinge's geometry) and contract, observation layout, action mode and
    timing."""
    env.obs_layout, env.task, env.contract = core.obs_layout, core.task.spec, core.task.contract
    env.nominal, env.nominal_row = core.nominal, core.nominal.to_array()
    env.setpoint_max, env.action_mode, env.control_dt = (
        core.nominal.pressure_cap,
        core.action_mode,
        core.control_dt,
    )
    if core.mech == pl.HINGE:
        env.geometry, env.angle_max = core.task.geometry, core.task.angle_max


# the docstring tail of the rig envs: their spec sheets are generated per id by the docs build
# (docs/gen_env_pages.py reads the registration, the spaces, the layout and the task)
RIG_SPEC_SHEET = """

    The spec sheet of each rig id (action and observation tables with units, reward terms,
    starting state, episode end, arguments, version history) is generated from the code into the
    documentation: ``docs/envs/<id>.md`` on the site (``make docs``). The named observation
    columns: ``env.unwrapped.core.obs_layout``.
"""
