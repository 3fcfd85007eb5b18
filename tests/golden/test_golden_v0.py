"""The v0 plant and the v0 env ids reproduce their recorded trajectories bit for bit
(``tests/golden/golden_v0.py`` recorded them; a change of v0 behaviour must be intended and named)."""

import numpy as np
import pytest
from golden_v0 import GOLDEN, env_trajectories, joint_trajectories, plant_trajectories

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def golden():
    with np.load(GOLDEN) as data:
        return dict(data)


def _same(got: dict, golden: dict) -> None:
    assert got, "no trajectories recorded"
    for key, value in got.items():
        assert key in golden, f"{key} has no recorded trajectory"
        np.testing.assert_array_equal(value, golden[key], err_msg=key)


def test_plant_v0_trajectories_unchanged(golden):
    _same(plant_trajectories(), golden)


def test_env_v0_trajectories_unchanged(golden):
    _same(env_trajectories(), golden)


def test_joint_v0_trajectories_unchanged(golden):
    pytest.importorskip("mujoco")
    _same(joint_trajectories(), golden)
