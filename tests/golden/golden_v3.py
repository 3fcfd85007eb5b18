"""Reference trajectories of the v3 env ids (the recommended version), recorded once and compared bit
for bit by ``tests/golden/test_golden_v3.py``: a restructuring (or a speed-up) must leave them as they
are. ``python tests/golden/golden_v3.py`` re-records, only when a change of v3 behaviour is intended and
named in the commit (a behaviour change belongs in a new version).

v3 runs plant v2 (recorded by :mod:`golden_v2`), so only the envs are recorded, as for v1
(:mod:`golden_v1`): every v3 id of the version table, single and native vector env, every action
mode, short episodes so that resets are inside the record; the score-form reward; the rig's sensor
noise the ids observe through by default ("nominal"); the randomized-v3 suite's spread, noise and
drift, and an action latency ("robust"); the info values the benchmark reads."""

from __future__ import annotations

from pathlib import Path

import numpy as np

GOLDEN = Path(__file__).parent / "data" / "golden_v3.npz"
VERSION = 3


def env_trajectories() -> dict[str, np.ndarray]:
    """Each v3 id and action mode (:func:`golden_v1.record_envs`)."""
    from golden_v1 import record_envs
    from golden_v2 import ids_of

    (joint_id,) = ids_of(VERSION, "hinge")
    return record_envs(ids_of(VERSION, "rig"), joint_id, "randomized-v3")


if __name__ == "__main__":
    data = env_trajectories()
    GOLDEN.parent.mkdir(exist_ok=True)
    np.savez_compressed(GOLDEN, **data)
    print(f"wrote {len(data)} trajectories to {GOLDEN}")
