"""Reference trajectories of plant v2 and the v2 env ids, recorded once and compared bit for bit by
``tests/golden/test_golden_v2.py``: a restructuring (or a speed-up) must leave them as they are.
``python tests/golden/golden_v2.py`` re-records, only when a change of v2 behaviour is intended and named
in the commit (a behaviour change belongs in a new version).

What is covered, as for v1 (:mod:`golden_v1`): the plant kernel on the v2 preset (contact-area
friction), every valve mode; every v2 id of the version table, single and native vector env, every
action mode, short episodes so that resets are inside the record; the randomized-v2 suite's spread,
noise and drift, and an action latency; the info values the benchmark reads."""

from __future__ import annotations

from pathlib import Path

import numpy as np

GOLDEN = Path(__file__).parent / "data" / "golden_v2.npz"
VERSION = 2


def ids_of(version: int, mechanism: str) -> tuple[str, ...]:
    """The ids of ``version`` driving ``mechanism``, as the version table lists them."""
    from cepam_gym import versions

    return tuple(
        r.env_id for r in versions.VERSIONS.values() if (r.version, r.mechanism) == (version, mechanism)
    )


def plant_trajectories() -> dict[str, np.ndarray]:
    """The plant kernel alone (:func:`golden_v0.record_plant`) on the v2 preset, every valve mode
    and state column."""
    from golden_v0 import record_plant

    from cepam_gym import plant as pl
    from cepam_gym.versions import PLANT_PRESETS

    return record_plant((("balloon_v2", PLANT_PRESETS[2]),), 2468, pl.N_STATE)


def env_trajectories() -> dict[str, np.ndarray]:
    """Each v2 id and action mode (:func:`golden_v1.record_envs`)."""
    from golden_v1 import record_envs

    (joint_id,) = ids_of(VERSION, "hinge")
    return record_envs(ids_of(VERSION, "rig"), joint_id, "randomized-v2")


if __name__ == "__main__":
    data = {**plant_trajectories(), **env_trajectories()}
    GOLDEN.parent.mkdir(exist_ok=True)
    np.savez_compressed(GOLDEN, **data)
    print(f"wrote {len(data)} trajectories to {GOLDEN}")
