"""The v3 env ids (the recommended version) reproduce their recorded trajectories bit for bit
(``tests/golden/golden_v3.py`` recorded them; a change of v3 behaviour must be intended and named)."""

import numpy as np
import pytest
from golden_v2 import ids_of
from golden_v3 import GOLDEN, VERSION, env_trajectories

from cepam_gym import versions

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def golden():
    with np.load(GOLDEN) as data:
        return dict(data)


def test_every_v3_id_is_recorded_and_v3_is_recommended(golden):
    """A v3 id of the version table without a record fails here, not silently; the goldens cover
    the recommended version."""
    ids = (*ids_of(VERSION, "rig"), *ids_of(VERSION, "hinge"))
    assert len(ids) == 4 and versions.RECOMMENDED_ID in ids
    for env_id in ids:
        assert any(k.startswith(f"single/{env_id}/") for k in golden), env_id
        assert any(k.startswith(f"vector/{env_id}/") for k in golden), env_id


def test_env_v3_trajectories_unchanged(golden):
    got = env_trajectories()
    assert got and set(got) == set(golden), "recorded keys changed"
    for key, value in got.items():
        np.testing.assert_array_equal(value, golden[key], err_msg=key)
