"""The single env's step: its env state laid in two slabs, stepped by one jitted call.

A single env's step is dominated by Python overhead, a good part of it the dispatch of a jitted
call (about 55 ns per array argument). Its :class:`~cepam_gym.tasks.state.EnvState` (one env), its
:class:`~cepam_gym.tasks.state.StepSettings` and :class:`~cepam_gym.tasks.task_params.TaskParams`,
the values of its ``info`` and the plant's scratch therefore live in two slabs, one float64 and one
int64 (:data:`SLABS`, derived from the records' declarations), beside the float32 observation; its
step is one jitted call with these three arrays and two floats, which also writes the values of the
step's ``info`` in order (length, velocity, the AUX_INFO columns, load, targets, reward terms).
Inside, the records are rebuilt from the slabs as borrowed views (``records.Slabs.reader``): a
reshaped slice calls a helper and is reference counted across every call it is passed to, which
cost 0.3 us of the single step's 0.7 us of fixed compiled work.
"""

from __future__ import annotations

import math

from .. import plant as pl
from .._jit import jit
from .kernel import _env_block
from .records import Field, Slabs, record
from .state import N_TERMS, EnvState, StepSettings
from .task_params import TaskParams

AUX_INFO = (pl.A_STIFF, pl.A_STIFF_CLOSED, pl.A_FORCE, pl.A_PC, pl.A_PE, pl.A_TC, pl.A_TE, pl.A_AIR)
N_INFO = 2 + len(AUX_INFO) + 3 + N_TERMS
NONFINITE_ACTION = -1  # env_step_single's reason for an action it refused

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
_state_of, _settings_of = SLABS.reader(EnvState), SLABS.reader(StepSettings)
_task_of, _extras_of = SLABS.reader(TaskParams), SLABS.reader(SingleExtras)


def single_slabs(n_steps: int, obs_dim: int, settings, task):
    """``(slabs, state, extras)`` of a single env: the slabs ``(F, I, obs)`` holding ``settings``
    and ``task``, and its :class:`EnvState` and :class:`SingleExtras` as views into them."""
    slabs = SLABS.allocate(n_steps, obs_dim)
    SLABS.write(settings, slabs)
    SLABS.write(task, slabs)
    return slabs, SLABS.views(EnvState, slabs), SLABS.views(SingleExtras, slabs)


@jit
def env_step_single(F, I, obs, a0, a1):
    """One control step of a single env whose records live in the slabs ``F``, ``I``, ``obs``
    (see :func:`single_slabs`), with the action ``(a0, a1)``; returns ``(reward, reason)``, or
    ``(nan, NONFINITE_ACTION)`` without stepping when an action is NaN or inf (checked here: one
    call less on the single env's hot path)."""
    if not (math.isfinite(a0) and math.isfinite(a1)):
        return math.nan, NONFINITE_ACTION
    s = _state_of(F, I, obs)
    ex = _extras_of(F, I, obs)
    s.prev_action[0, 0] = a0
    s.prev_action[0, 1] = a1
    _env_block(0, 1, s, _settings_of(F, I, obs), _task_of(F, I, obs), ex.W)
    # info of the scored step (the targets and load of the step just taken)
    n_steps = s.target_l.shape[1]
    k = min(max(s.t_idx[0] - 1, 0), n_steps - 1)
    info, state, aux = ex.info, s.state, s.aux
    info[0] = state[0, pl.S_L]
    info[1] = state[0, pl.S_V]
    for j in range(len(AUX_INFO)):
        info[2 + j] = aux[0, AUX_INFO[j]]
    j = 2 + len(AUX_INFO)
    info[j] = s.load[0, k]
    info[j + 1] = s.target_l[0, k]
    info[j + 2] = s.target_k[0, k]
    for m in range(N_TERMS):
        info[j + 3 + m] = s.terms[0, m]
    return s.rewards[0], s.reasons[0]
