"""Reference trajectories of the v0 plant and the v0 env ids, recorded once and compared bit for
bit by ``tests/golden/test_golden_v0.py``: a restructuring or a new plant version must leave them as they
are. ``python tests/golden/golden_v0.py`` re-records (only when a change of v0 behaviour is intended and
named in the commit)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

GOLDEN = Path(__file__).parent / "data" / "golden_v0.npz"
RIG_IDS = ("cepam_gym/CEPAM-v0", "cepam_gym/CEPAMLength-v0", "cepam_gym/CEPAMStiffness-v0")
MODES = ("valve", "pwm", "pressure")
N_STEPS = 120


def record_plant(presets, seed: int, n_state: int) -> dict[str, np.ndarray]:
    """The plant kernel alone, fixed inputs: each ``(key name, preset)`` and valve mode, 18 plants
    in 2 blocks, the first ``n_state`` state columns and ``aux`` per step (shared by the v0 and v1
    records)."""
    from cepam_gym import plant as pl
    from cepam_gym.plant.params import preset

    out = {}
    rng = np.random.default_rng(seed)
    for name, preset_name in presets:
        p = preset(preset_name).to_array()[None]
        for mode_name, mode in pl.MODES.items():
            n = 18  # two plant blocks of 16
            x = pl.initial_state(p, np.linspace(0.152, 0.19, n), 60e3, 40e3)
            rows = []
            for k in range(N_STEPS // 2):
                inp = np.zeros((n, pl.N_INPUT))
                u = rng.uniform(-1, 1, (n, 2))
                inp[:, :2] = (u + 1) * 120e3 if mode == pl.PRESSURE else u
                inp[:, pl.I_LOAD] = 0.1 + 0.05 * np.sin(0.1 * k + np.arange(n))
                x, aux = pl.step(x, inp, p, mode)
                rows.append(np.concatenate([x[:, :n_state], aux], axis=1))
            out[f"plant/{name}/{mode_name}"] = np.stack(rows)
    return out


def plant_trajectories() -> dict[str, np.ndarray]:
    """Every v0 preset. The keys keep the names the presets had when recorded ("balloon" is now
    ``balloon_v0``, "rubber_tube" ``rubber_tube_v0``; plant v1 took the old names); the v0 state
    columns only (plant v1 appended friction deflections, 0 without friction)."""
    from cepam_gym import plant as pl

    presets = (
        ("balloon", "balloon_v0"),
        ("balloon_uncalibrated", "balloon_uncalibrated"),
        ("rubber_tube", "rubber_tube_v0"),
    )
    return record_plant(presets, 1234, pl.N_STATE_V0)


def env_trajectories() -> dict[str, np.ndarray]:
    """Each v0 id and action mode: a single env and a 20-env vector env, seeded, random actions."""
    import gymnasium as gym

    import cepam_gym  # noqa: F401

    out = {}
    for env_id in RIG_IDS:
        for mode in MODES:
            env = gym.make(env_id, action_mode=mode)
            obs, _ = env.reset(seed=7)
            rng = np.random.default_rng(99)
            rows = []
            for _ in range(N_STEPS):
                obs, r, term, trunc, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
                rows.append(
                    np.concatenate(
                        [obs, [r, info["length"], info["pressure_c"], info["pressure_e"], info["stiffness"]]]
                    )
                )
                if term:
                    obs, _ = env.reset()
            out[f"single/{env_id}/{mode}"] = np.array(rows)
            venv = gym.make_vec(env_id, num_envs=20, action_mode=mode)
            obs, _ = venv.reset(seed=11)
            rows = []
            for _ in range(N_STEPS // 2):
                obs, r, term, trunc, info = venv.step(rng.uniform(-1, 1, (20, 2)).astype(np.float32))
                rows.append(np.concatenate([obs, r[:, None]], axis=1))
            out[f"vector/{env_id}/{mode}"] = np.stack(rows)
    return out


def joint_trajectories() -> dict[str, np.ndarray]:
    import gymnasium as gym

    import cepam_gym  # noqa: F401

    out = {}
    for mode in MODES:
        env = gym.make("cepam_gym/CEPAMJoint-v0", action_mode=mode)
        obs, _ = env.reset(seed=5)
        rng = np.random.default_rng(3)
        rows = []
        for _ in range(N_STEPS // 2):
            obs, r, term, trunc, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
            rows.append(
                np.concatenate([obs, [r, info["angle"], info["muscle_force"], info["joint_stiffness"]]])
            )
        out[f"joint/{mode}"] = np.array(rows)
    return out


if __name__ == "__main__":
    data = {**plant_trajectories(), **env_trajectories(), **joint_trajectories()}
    GOLDEN.parent.mkdir(exist_ok=True)
    np.savez_compressed(GOLDEN, **data)
    print(f"wrote {len(data)} trajectories to {GOLDEN}")
