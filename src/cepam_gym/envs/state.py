"""The env state: the arrays an episode of N envs lives in, declared once.

:class:`EnvState` is what the compiled step (:mod:`cepam_gym.envs.step_kernel`) reads and writes, what
a :class:`~cepam_gym.envs.task.Task` is handed at reset and for its info (as dm_control's Task is
handed ``physics``), and what an env copies, pickles and restores. Its rows are envs; the dimension
names of the shapes are those of :func:`dims`. :class:`StepSettings` are the step's fixed settings.
The batched env allocates the record with :func:`~cepam_gym.envs.records.allocate`; the single
env lays it in two slabs (:mod:`cepam_gym.envs.single_slabs`).
"""

from __future__ import annotations

from .. import plant as pl
from ..physics import layout as ix
from ..physics.hinge import N_HINGE
from ..tasks.reward import MAX_TERMS
from .records import Field, record

# noise columns: length [m], velocity [m/s], pressure_c, pressure_e, supply [Pa]
N_NOISE = 5

EnvState = record(
    "EnvState",
    (
        Field("state", "f8", ("n", pl.N_STATE), "plant state rows (plant.S_*)"),
        Field("prev_action", "f8", ("n", 2), "the action a step applies (clipped in place), then a_{t-1}"),
        Field("params", "f8", ("n", ix.N_PARAMS), "plant parameter rows (physics.layout)"),
        Field("hinge", "f8", (1, N_HINGE), "the mechanism's constants, one row for the batch (rig: 0)"),
        Field("inputs", "f8", ("n", pl.N_INPUT), "plant input rows of the step (plant.I_*)"),
        Field("aux", "f8", ("n", pl.N_AUX), "what the plant measured at the step's end (plant.A_*)"),
        Field("terms", "f8", ("n", MAX_TERMS), "the step's signed reward terms, in the reward's order"),
        Field("rewards", "f8", ("n",), "the step's rewards"),
        Field("noise", "f8", ("noise_rows", N_NOISE), "sensor noise of the next observation"),
        Field("initial", "f8", ("n", 2), "the (position, stiffness) the episode started at"),
        Field("target_l", "f8", ("n", "n_steps"), "position target of every step [m or rad]"),
        Field("target_k", "f8", ("n", "n_steps"), "stiffness target of every step [N/m or N m/rad]"),
        Field("load", "f8", ("n", "n_steps"), "load of every step: a mass [kg] or a torque [N m]"),
        Field("t_idx", "i8", ("n",), "control steps taken in the episode"),
        Field("reasons", "i8", ("n",), "the step's termination reason (tasks.spec codes)"),
        Field("redraws", "i8", ("n",), "plant draws rejected at the episode's reset"),
        Field("obs", "f4", ("n", "obs_dim"), "the observations"),
    ),
    "The arrays of an episode of N envs (rows), in SI units.",
    __name__,
)

StepSettings = record(
    "StepSettings",
    (
        Field("mech", "i8", (), "plant.RIG or plant.HINGE"),
        Field("mode", "i8", (), "the valve mode (plant.actions)"),
        Field("dt", "f8", (), "the plant's sub-step [s]"),
        Field("n_sub", "i8", (), "sub-steps per control step"),
    ),
    "The step's fixed settings.",
    __name__,
)


def dims(num_envs: int, n_steps: int, obs_dim: int, noise: bool) -> dict[str, int]:
    """The dimensions of an :class:`EnvState`: ``noise`` whether sensor noise is on (else one row of
    zeros serves every env)."""
    return {"n": num_envs, "n_steps": n_steps, "obs_dim": obs_dim, "noise_rows": num_envs if noise else 1}
