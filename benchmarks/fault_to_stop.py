"""How fast each fault reaches the rig's safe state, and how often a healthy rig off the model trips.

1. **Fault to stop** (real time, on the loopback): an emulated rig (``cepam-gym rig-emulator``,
   balloon_v2 off the model as in ``tests/rig/test_deploy_e2e.py``) in its own process; the
   baseline deployed on it, each fault injected half a second in, ``--repeats`` times; printed per
   fault: the trip's reason and the time from the fault to the rig's stop on the emulator's clock
   (its ``safe`` event), median and range.
2. **False trips** (simulated time, no sockets): the baseline under the supervisor (its leak
   balance on the nominal preset) on healthy rigs off the model (valves, dead volume, spool and
   damping scaled as ``tests/rig/test_leak.py`` does, by a random exponent in [-2, 2] per run),
   ``--runs`` runs of ``--seconds`` with the emulator's sensor noise; printed: the trips and the
   largest leak estimate against the limit.

Run: ``.venv/bin/python benchmarks/fault_to_stop.py`` (options: ``--repeats``, ``--runs``,
``--seconds``, ``--only stop|healthy``).
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FAULTS_TIMED = [  # (fault, channel, size)
    ("frozen_sensor", "pressure_c", 0.0),
    ("frozen_channel", "length", 0.0),
    ("supply_drop", "pressure_c", 0.0),
    ("leak", "pressure_c", 0.0),
    ("stuck_valve", "pressure_c", 0.0),
    ("channel_value", "pressure_c", 0.0),
    ("channel_value", "pressure_c", -50e3),
    ("channel_value", "supply", 400e3),
    ("channel_value", "pressure_c", math.nan),
    ("channel_value", "supply", math.nan),
    ("reboot", "pressure_c", 0.0),
]


def fault_to_stop(repeats: int) -> None:
    sys.path.insert(0, str(ROOT / "tests" / "rig"))
    from test_deploy_e2e import DEFAULT_ENV, Emulator, _deploy, _episode

    from cepam_gym.control import make_controller
    from cepam_gym.rig.protocol import CHANNELS, FAULTS

    emu = Emulator(Path(tempfile.mkdtemp()), "--load-g", "100")
    episode = _episode(DEFAULT_ENV, {}, 1000, 0, 1)
    try:
        for fault, channel, size in FAULTS_TIMED:
            times, reasons = [], set()
            for _ in range(repeats):

                def inject(k, rig, fault=fault, channel=channel, size=size):
                    if k == 25:
                        rig.inject(FAULTS.index(fault), size, CHANNELS.index(channel))

                start = len(emu.events)
                result = _deploy(emu, episode, make_controller("baseline", episode[0]), 60, on_step=inject)
                time.sleep(0.1)
                safe = [e for e in emu.events[start:] if e["event"] == "safe"]
                reasons.add(result.trip["reason"] if result.trip else "none")
                times.append(safe[0]["after_fault_s"] * 1e3 if safe else math.nan)
            label = (
                fault if fault not in ("channel_value", "frozen_channel") else f"{fault}.{channel}={size:g}"
            )
            print(
                f"{label:34s} {'/'.join(sorted(reasons)):22s} fault to stop: "
                f"median {np.median(times):5.0f} ms "
                f"(range {min(times):.0f}-{max(times):.0f} ms, {repeats} runs)",
                flush=True,
            )
    finally:
        emu.close()


def healthy(runs: int, seconds: float) -> None:
    from cepam_gym.control import make_controller
    from cepam_gym.plant.params import preset
    from cepam_gym.rig.cli import DEFAULT_ENV, _episode
    from cepam_gym.rig.emulator import EmulatedPlant, RigImperfections
    from cepam_gym.rig.observation import RigObserver
    from cepam_gym.rig.protocol import Reading
    from cepam_gym.rig.supervisor import SafetyLimits, Supervisor

    base = preset("balloon_v2")
    factors = {"valve_conductance": 1.15, "dead_volume_cpam": 1.3, "damping": 1.5, "spool_time_constant": 0.8}
    rng = np.random.default_rng(0)
    trips, worst, dt, conductance = [], 0.0, 0.02, 1.0
    t0 = time.perf_counter()
    for run in range(runs):
        scale = rng.uniform(-2.0, 2.0)
        rig = base.replace(**{k: getattr(base, k) * f**scale for k, f in factors.items()})
        plant = EmulatedPlant(rig, load=0.1)
        env, model, tl, tk = _episode(DEFAULT_ENV, {}, 2000 + run, 0, 1)
        observer, controller = RigObserver(model, tl, tk), make_controller("baseline", env)
        sup = Supervisor(SafetyLimits.from_plant(model.nominal), dt, model=model)
        ticks = int(round(dt / plant.tick_dt))
        prev, imp, seq = np.zeros(2), RigImperfections(), 0
        for k in range(int(seconds / dt)):
            seq += ticks
            reading = Reading(plant.time, *plant.sensed(imp, rng), seq=seq)
            action = np.asarray(
                controller.act(observer.observe(reading, k % observer.n_steps, prev)), dtype=float
            )
            command, trip = sup.filter(reading, tuple(action), now=k * dt)
            if trip is not None:
                trips.append((run, scale, trip.reason, trip.detail))
                break
            worst = max(worst, *sup.leak.estimate, *sup.leak.inflow)
            conductance = sup.leak.conductance
            plant.command, prev = command, np.asarray(command)
            for _ in range(ticks):
                plant.tick()
    limit = SafetyLimits.leak_max_fraction
    print(
        f"healthy rigs off the model: {runs} runs of {seconds:g} s (simulated, "
        f"{time.perf_counter() - t0:.0f} s of wall time), {len(trips)} trips; largest leak or inflow "
        f"estimate {worst / conductance:.3f} of the valve's conductance (limit {limit:g})"
    )
    for t in trips:
        print("  trip:", t)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--only", choices=("stop", "healthy"))
    args = ap.parse_args()
    if args.only != "healthy":
        fault_to_stop(args.repeats)
    if args.only != "stop":
        healthy(args.runs, args.seconds)


if __name__ == "__main__":
    main()
