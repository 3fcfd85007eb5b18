"""Timing of the deploy loop (:mod:`cepam_gym.rig.deploy`) against an emulated rig on the loopback.

An emulated rig (``cepam-gym rig-emulator``, nominal ``balloon_v2``, 1 ms latency, 0.5 ms jitter)
runs in its own process; an untrained SB3 PPO MLP policy (``--net-arch``, default 64x64, the SB3
default) is exported with ``cepam-gym export`` and deployed for ``--seconds`` at the env's 50 Hz
under the safety supervisor (a trip would end the run early: the policy is untrained; the timing
holds either way). Printed:

* the loop's lateness (how long after its release each step woke) p50 / p99 / max, and the
  deadline misses;
* the step's compute time (read, observation, policy, supervisor, send) p50 / p99, and the
  capacity ``1 / p99(compute)``: the highest control rate this machine holds with the policy;
* the policy's own capacity: ``1 / p99`` of the ONNX call alone on one observation;
* the same for the baseline controller, for comparison.

The machine's load average is printed too: on a shared machine the lateness's tail is the other
processes' (the loop sleeps, then spins the last 1.5 ms); ``--realtime PRIORITY`` runs the loop and
the emulator under ``SCHED_FIFO`` (root or CAP_SYS_NICE), which removes it. Needs the [train] and
[deploy] extras.

Run: ``.venv/bin/python benchmarks/deploy_loop.py`` (options: ``--seconds``, ``--net-arch``,
``--realtime``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--net-arch", default="64,64")
    ap.add_argument(
        "--realtime", type=int, metavar="PRIORITY", help="SCHED_FIFO for the loop and the emulator"
    )
    args = ap.parse_args()
    import gymnasium as gym
    from stable_baselines3 import PPO

    from cepam_gym.control import make_controller
    from cepam_gym.rig.cli import DEFAULT_ENV, _episode
    from cepam_gym.rig.deploy import run, set_realtime
    from cepam_gym.rig.observation import RigObserver
    from cepam_gym.rig.onnx_policy import OnnxPolicy
    from cepam_gym.rig.supervisor import SafetyLimits, Supervisor
    from cepam_gym.rig.udp import UdpRig
    from cepam_gym_agents.export import export

    arch = [int(x) for x in args.net_arch.split(",")]
    tmp = Path(tempfile.mkdtemp(prefix="deploy_loop_"))
    PPO("MlpPolicy", gym.make(DEFAULT_ENV), policy_kwargs={"net_arch": arch}, seed=0).save(str(tmp / "a.zip"))
    with warnings.catch_warnings():  # an untrained bare model: no VecNormalize statistics, as meant
        warnings.simplefilter("ignore", UserWarning)
        export(tmp / "a.zip", tmp / "policy.onnx")
    policy = OnnxPolicy(tmp / "policy.onnx")
    env, model, tl, tk = _episode(DEFAULT_ENV, {}, 1000, 0, 1)
    obs = env.reset(seed=0)[0]

    def call_p99(controller, n=3000):
        controller.reset()
        t = np.empty(n)
        for i in range(n):
            t0 = time.perf_counter()
            controller.act(obs)
            t[i] = time.perf_counter() - t0
        return np.percentile(t, 50), np.percentile(t, 99)

    rt = [] if args.realtime is None else ["--realtime", str(args.realtime)]
    emu = subprocess.Popen(
        [sys.executable, "-m", "cepam_gym.cli", "rig-emulator", "--port", "0", *rt],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        port = json.loads(emu.stdout.readline())["port"]
        sched = "time-sharing" if args.realtime is None else set_realtime(args.realtime)
        n = int(round(args.seconds / model.control_dt))
        print(
            f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs; {sched}; MLP {arch}, "
            f"{n} steps at 50 Hz"
        )
        for name, controller in (("ONNX MLP policy", policy), ("baseline", make_controller("baseline", env))):
            p50, p99 = call_p99(controller)
            rig = UdpRig(("127.0.0.1", port))
            try:
                r = run(
                    rig,
                    controller,
                    RigObserver(model, tl, tk),
                    Supervisor(SafetyLimits.from_plant(model.nominal), model.control_dt, model=model),
                    0.1,
                    n_steps=n,
                )
            finally:
                rig.close()
            trip = ", " + r.trip["reason"] if r.trip else ""
            print(
                f"{name:16s} loop: {r.steps}/{n} steps ({r.stopped_by}{trip}), "
                f"lateness p50 {r.lateness_p50 * 1e3:.3f} ms p99 {r.lateness_p99 * 1e3:.3f} ms "
                f"max {r.lateness_max * 1e3:.3f} ms, {r.deadline_misses} deadline misses; step compute "
                f"p50 {r.compute_p50 * 1e3:.3f} ms p99 {r.compute_p99 * 1e3:.3f} ms "
                f"-> capacity {r.capacity_hz:.0f} Hz"
            )
            print(f"{'':16s} act() alone: p50 {p50 * 1e6:.0f} us p99 {p99 * 1e6:.0f} us -> {1 / p99:.0f} Hz")
    finally:
        emu.terminate()
        emu.wait(timeout=10)


if __name__ == "__main__":
    main()
