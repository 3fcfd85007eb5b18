"""Plant v2 and the v2 env ids reproduce their recorded trajectories bit for bit
(``tests/golden/golden_v2.py`` recorded them; a change of v2 behaviour must be intended and named)."""

import numpy as np
import pytest
from golden_v2 import GOLDEN, VERSION, env_trajectories, ids_of, plant_trajectories

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def golden():
    with np.load(GOLDEN) as data:
        return dict(data)


def _same(got: dict, golden: dict, prefix) -> None:
    assert got, "no trajectories recorded"
    assert set(got) == {k for k in golden if k.startswith(prefix)}, "recorded keys changed"
    for key, value in got.items():
        np.testing.assert_array_equal(value, golden[key], err_msg=key)


def test_every_v2_id_is_recorded(golden):
    """A v2 id of the version table without a record fails here, not silently."""
    ids = (*ids_of(VERSION, "rig"), *ids_of(VERSION, "hinge"))
    assert len(ids) == 4
    for env_id in ids:
        assert any(k.startswith(f"single/{env_id}/") for k in golden), env_id
        assert any(k.startswith(f"vector/{env_id}/") for k in golden), env_id


def test_plant_v2_trajectories_unchanged(golden):
    _same(plant_trajectories(), golden, "plant/")


def test_env_v2_trajectories_unchanged(golden):
    _same(env_trajectories(), golden, ("single/", "vector/"))
