"""The single env's step: its env state laid in two slabs, stepped by one jitted call.

A single env's step is dominated by Python overhead, a good part of it the dispatch of a jitted
call (about 55 ns per array argument). Its :class:`~cepam_gym.envs.state.EnvState` (one env), its
:class:`~cepam_gym.envs.state.StepSettings` and :class:`~cepam_gym.envs.task_params.TaskParams`,
the values of its ``info`` and the plant's scratch therefore live in two slabs, one float64 and one
int64 (:data:`SLABS`, derived from the records' declarations), beside the float32 observation; its
step is one jitted call with these three arrays and two floats, which also writes the values of the
step's ``info`` in order (the rig's declared info, :mod:`cepam_gym.tasks.rig_info`, then the reward
terms).
Inside, the records are rebuilt from the slabs as borrowed views (``records.Slabs.reader``): a
reshaped slice calls a helper and is reference counted across every call it is passed to, which
cost 0.3 us of the single step's 0.7 us of fixed compiled work.
"""

from __future__ import annotations

from .. import plant as pl
from ..tasks.reward import MAX_TERMS
from ..tasks.rig_info import RIG_INFO
from .records import Field, Slabs, record
from .state import EnvState, StepSettings
from .task_params import TaskParams

# the info row: the rig's declared info (tasks.rig_info), then the reward's terms (the first columns
# of the MAX_TERMS)
N_INFO = len(RIG_INFO) + MAX_TERMS
NONFINITE_ACTION = -1  # envs.step.env_step_single's reason for an action it refused

SingleExtras = record(
    "SingleExtras",
    (
        Field("info", "f8", (N_INFO,), "the values of the last step's info, in the task's step_keys order"),
        Field("W", "f8", (pl.W_SIZE,), "the plant's scratch"),
    ),
    "What the single env's one-call step needs beside its state, settings and task.",
    __name__,
)
SLABS = Slabs((EnvState, StepSettings, TaskParams, SingleExtras), {"n": 1, "noise_rows": 1})
# the records rebuilt inside the single step (envs.step.env_step_single)
SLAB_READERS = tuple(SLABS.reader(r) for r in (EnvState, StepSettings, TaskParams, SingleExtras))


def single_slabs(n_steps: int, obs_dim: int, settings, task):
    """``(slabs, state, extras)`` of a single env: the slabs ``(F, I, obs)`` holding ``settings``
    and ``task``, and its :class:`EnvState` and :class:`SingleExtras` as views into them."""
    slabs = SLABS.allocate(n_steps, obs_dim)
    SLABS.write(settings, slabs)
    SLABS.write(task, slabs)
    return slabs, SLABS.views(EnvState, slabs), SLABS.views(SingleExtras, slabs)
