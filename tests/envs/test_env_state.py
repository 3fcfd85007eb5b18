"""The env state is one declared record: allocation, the single env's slabs, copies and the
step's arguments all follow from its declaration."""

import copy
import inspect
import pickle
import re
from pathlib import Path

import numpy as np
import pytest

from cepam_gym import plant as pl
from cepam_gym.envs import step
from cepam_gym.envs import step_kernel as tk
from cepam_gym.envs.core import CEPAMBatch
from cepam_gym.envs.records import allocate
from cepam_gym.envs.single_slabs import SLABS
from cepam_gym.envs.state import EnvState, dims
from cepam_gym.plant.actions import plant_inputs

SRC = Path(__file__).resolve().parents[2] / "src" / "cepam_gym"


def test_single_slab_views_are_the_declared_record():
    slabs = SLABS.allocate(n_steps=7, obs_dim=11)
    views = SLABS.views(EnvState, slabs)
    want = allocate(EnvState, dims(1, 7, 11, noise=False))
    for name, a, b in zip(EnvState._fields, views, want):
        assert (a.shape, a.dtype) == (b.shape, b.dtype), name
    # every view writes into its slab, and no two views overlap
    for v in views:
        v[...] = 0
    for k, v in enumerate(views):
        v.flat[-1] = k + 1
    views2 = SLABS.views(EnvState, slabs)
    assert [int(v.flat[-1]) for v in views2] == list(range(1, len(views) + 1))


@pytest.mark.parametrize("num_envs", [1, 3])
def test_episode_state_covers_every_field_and_restores(num_envs):
    core = CEPAMBatch(num_envs, task="cepam")
    core.reset()
    for _ in range(3):
        core.step(core.check_actions(np.full((num_envs, 2), 0.3)))
    ep = core.episode_state()
    assert set(EnvState._fields) <= set(ep)
    twin = pickle.loads(pickle.dumps(core))
    other = copy.deepcopy(core)
    for c in (twin, other):
        for name in EnvState._fields:
            assert np.array_equal(getattr(c.s, name), getattr(core.s, name)), name
    a = np.full((num_envs, 2), -0.2)
    core.step(core.check_actions(a))
    twin.step(twin.check_actions(a))
    assert np.array_equal(core.obs, twin.obs) and np.array_equal(core.rewards, twin.rewards)


def test_core_attributes_are_the_records_fields():
    core = CEPAMBatch(2, task="cepam")
    for name in EnvState._fields:
        assert getattr(core, name) is getattr(core.s, name)
    with pytest.raises(AttributeError):
        core.state = np.zeros_like(core.state)


def test_the_step_functions_take_the_records():
    for f in (
        step._env_block,
        step._env_step_serial,
        step._env_step_parallel,
        tk.observe,
        step.env_step_single,
    ):
        assert len(inspect.signature(f.py_func).parameters) <= 8, f.__name__


def test_plant_inputs_clip_and_place_the_load():
    inp = np.full(pl.N_INPUT, np.nan)
    a = plant_inputs(inp, pl.PRESSURE, pl.RIG, 1.5, -0.5, 200e3, 0.3)
    assert a == (1.0, -0.5)
    assert inp.tolist() == [200e3, 50e3, 0.3, 0.0]
    a = plant_inputs(inp, pl.PROPORTIONAL, pl.HINGE, -2.0, 0.25, 200e3, 4.0)
    assert a == (-1.0, 0.25)
    assert inp.tolist() == [-1.0, 0.25, 0.0, 4.0]


def test_tasks_never_read_the_env_object():
    offenders = [
        f"{f.name}:{i}"
        for f in sorted((SRC / "tasks").glob("*.py"))
        for i, line in enumerate(f.read_text().splitlines(), 1)
        if re.search(r"(?<![.\w])core\.[A-Za-z_]", line.split("#")[0])
    ]
    assert offenders == []
