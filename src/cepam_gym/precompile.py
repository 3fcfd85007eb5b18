"""Compile the kernels into numba's on-disk cache: ``python -m cepam_gym.precompile``.

The kernels are compiled on first use and kept beside the sources (``cache=True``,
:mod:`cepam_gym._jit`); the first process of a fresh install pays for it (minutes on 2 cores).
``make install`` (and so ``make run``) runs this once, so the main job and a user's first env
start from machine code. A process that finds the cache current takes a few seconds.

What it drives, a few steps each: the rig's env (batched, few and many envs, and single), the
baseline, the MPC, the adaptive MPC and the oracle on it, and the hinge's env, baseline and oracle.
"""

from __future__ import annotations

import time

CONTROLLERS = ("baseline", "mpc", "adaptive_mpc", "oracle")  # on the rig; the hinge's: its baseline, oracle


def _drive(env_id: str, controller: str | None, num_envs: int = 2, steps: int = 3, **kwargs) -> None:
    import gymnasium as gym
    import numpy as np

    from .control import make_controller

    venv = gym.make_vec(env_id, num_envs=num_envs, **kwargs)
    try:
        obs, info = venv.reset(seed=0)
        policy = None if controller is None else make_controller(controller, venv)
        if policy is not None:
            policy.reset()
        for _ in range(steps):
            act = np.zeros((num_envs, 2), np.float32) if policy is None else policy.act(obs, info)
            obs, _r, _te, _tr, info = venv.step(act)
    finally:
        venv.close()


def _cores() -> int:
    import numba

    return max(1, numba.config.NUMBA_NUM_THREADS)


def _single(env_id: str) -> None:
    import gymnasium as gym

    env = gym.make(env_id)
    try:
        env.reset(seed=0)
        for _ in range(3):
            env.step(env.action_space.sample())
    finally:
        env.close()


def main() -> int:
    from . import versions

    rig = versions.RECOMMENDED_ID
    joint = versions.id_of("CEPAMJoint", versions.get(rig).version)
    stages = [
        (f"{rig} (batched)", lambda: _drive(rig, None)),
        # the step's blocks over all cores: another kernel (the envs pick it when it pays)
        (f"{rig} (batched, parallel)", lambda: _drive(rig, None, num_envs=256, num_threads=_cores())),
        (f"{rig} (single)", lambda: _single(rig)),
        *((f"{n} on {rig}", lambda n=n: _drive(rig, n)) for n in CONTROLLERS),
        (f"{joint} (batched)", lambda: _drive(joint, None)),
        *((f"{name} on {joint}", lambda n=name: _drive(joint, n)) for name in ("baseline", "oracle")),
    ]
    t0 = time.perf_counter()
    for label, run in stages:
        t = time.perf_counter()
        run()
        print(f"precompile: {label} {time.perf_counter() - t:.1f} s", flush=True)
    print(f"precompile: the kernels are in numba's cache ({time.perf_counter() - t0:.0f} s)", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
