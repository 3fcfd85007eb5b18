"""Reference trajectories of plant v1 and the v1 env ids, recorded once and compared bit for bit by
``tests/golden/test_golden_v1.py``: a restructuring (or a speed-up) must leave them as they are.
``python tests/golden/golden_v1.py`` re-records, only when a change of v1 behaviour is intended and named
in the commit (a behaviour change belongs in a new version: v2 ids and presets).

What is covered: the plant kernel (both v1 presets, every valve mode, friction on; the hinge
mechanics through the joint id); every v1 id, single and native vector env, every action mode, with short
episodes so that resets (reference planning, randomized plants, redraws) are inside the record;
sensor noise, supply drift and action latency (the randomized-v1 suite's kwargs); the info values
the benchmark reads."""

from __future__ import annotations

from pathlib import Path

import numpy as np

GOLDEN = Path(__file__).parent / "data" / "golden_v1.npz"
RIG_IDS = ("cepam_gym/CEPAM-v1", "cepam_gym/CEPAMLength-v1", "cepam_gym/CEPAMStiffness-v1")
JOINT_ID = "cepam_gym/CEPAMJoint-v1"
MODES = ("valve", "pwm", "pressure")
N_STEPS = 120
# 1.2 s episodes: a reset every 60 steps, so two planned references per recorded env
SHORT = {"episode_seconds": 1.2}
EPISODE_STEPS = 60
# the randomized-v1 suite's plant spread, noise and drift, plus a latency (a kwarg no suite uses)
ROBUST = {"supply_drift_kpa": 5.0, "sensor_noise": {"length_mm": 0.1, "pressure_kpa": 0.5}}
INFO_KEYS = ("length", "pressure_c", "pressure_e", "stiffness", "target_length", "target_stiffness")


def plant_trajectories() -> dict[str, np.ndarray]:
    """The plant kernel alone (:func:`golden_v0.record_plant`): each v1 preset and valve mode,
    every state column."""
    from golden_v0 import record_plant

    from cepam_gym import plant as pl

    return record_plant((("balloon", "balloon"), ("rubber_tube", "rubber_tube")), 4321, pl.N_STATE)


def _info_row(info: dict) -> list[float]:
    return [float(info[k]) for k in INFO_KEYS if k in info]


def env_trajectories() -> dict[str, np.ndarray]:
    """Each v1 id and action mode: a single env and a 12-env vector env, seeded, random actions,
    short episodes; the rig ids also with the randomized-v1 spread, noise, drift and latency."""
    return record_envs(RIG_IDS, JOINT_ID, "randomized-v1")


def record_envs(rig_ids, joint_id: str, randomized_suite: str) -> dict[str, np.ndarray]:
    """Each id of ``rig_ids`` and ``joint_id`` and action mode: a single env and a 12-env vector
    env, seeded, random actions, short episodes; the rig ids also with the spread, noise and drift
    of ``randomized_suite``, and :data:`ROBUST`'s noise, drift and a latency (shared by the v1, v2
    and v3 records)."""
    import cepam_gym  # noqa: F401
    from cepam_gym.bench.suites import SUITES

    randomized = dict(SUITES[randomized_suite].env_kwargs)
    out = {}
    for env_id in (*rig_ids, joint_id):
        variants = {"nominal": dict(SHORT)}
        if env_id != joint_id:
            variants["robust"] = {**SHORT, **randomized, **ROBUST, "action_latency_steps": 1}
        for variant, kwargs in variants.items():
            for mode in MODES:
                out.update(_record_mode(env_id, variant, mode, kwargs))
    return out


def _record_mode(env_id: str, variant: str, mode: str, kwargs: dict) -> dict[str, np.ndarray]:
    """The single env, then the vector env, on one stream of random actions."""
    import gymnasium as gym

    env = gym.make(env_id, action_mode=mode, max_episode_steps=EPISODE_STEPS, **kwargs)
    obs, info = env.reset(seed=7)
    rng = np.random.default_rng(99)
    rows = []
    for _ in range(N_STEPS):
        obs, r, term, trunc, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        rows.append(np.concatenate([obs, [r, float(term), float(trunc)], _info_row(info)]))
        if term or trunc:
            obs, info = env.reset()
            rows.append(np.concatenate([obs, [0.0, 0.0, 0.0], _info_row(info)]))
    out = {f"single/{env_id}/{variant}/{mode}": np.array(rows)}
    venv = gym.make_vec(env_id, num_envs=12, action_mode=mode, max_episode_steps=EPISODE_STEPS, **kwargs)
    obs, _ = venv.reset(seed=11)
    rows = []
    for _ in range(N_STEPS):
        obs, r, term, trunc, info = venv.step(rng.uniform(-1, 1, (12, 2)).astype(np.float32))
        rows.append(np.concatenate([obs, r[:, None], term[:, None], trunc[:, None]], axis=1))
    out[f"vector/{env_id}/{variant}/{mode}"] = np.stack(rows)
    venv.close()
    return out


if __name__ == "__main__":
    data = {**plant_trajectories(), **env_trajectories()}
    GOLDEN.parent.mkdir(exist_ok=True)
    np.savez_compressed(GOLDEN, **data)
    print(f"wrote {len(data)} trajectories to {GOLDEN}")
