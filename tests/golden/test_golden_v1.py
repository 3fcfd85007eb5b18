"""Plant v1 and the v1 env ids reproduce their recorded trajectories bit for bit
(``tests/golden/golden_v1.py`` recorded them; a change of v1 behaviour must be intended and named)."""

import numpy as np
import pytest
from golden_v1 import GOLDEN, env_trajectories, plant_trajectories

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def golden():
    with np.load(GOLDEN) as data:
        return dict(data)


def _same(got: dict, golden: dict, prefix: str) -> None:
    assert got, "no trajectories recorded"
    assert set(got) == {k for k in golden if k.startswith(prefix)}, "recorded keys changed"
    for key, value in got.items():
        np.testing.assert_array_equal(value, golden[key], err_msg=key)


def test_plant_v1_trajectories_unchanged(golden):
    _same(plant_trajectories(), golden, "plant/")


def test_env_v1_trajectories_unchanged(golden):
    _same(env_trajectories(), golden, ("single/", "vector/"))
