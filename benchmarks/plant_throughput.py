"""Throughput of :func:`cepam_gym.plant.step` for batches of N plants.

Proportional valves, ``dt = 0.5 ms``, 40 sub-steps per control step (50 Hz control). For each N
the plants start at 17 cm with some pressure in both chambers and are driven by fixed random
spool commands (seeded) with a 0.1 kg load; one warm-up call (compilation, caches) precedes the
timing, then ``step`` is called repeatedly, in place, for about ``--seconds`` seconds, timed with
``time.perf_counter``. Reported per N: plant sub-steps per second (N * n_sub * calls / time),
control steps per second (N * calls / time) and the batching speed-up, i.e. the per-plant
throughput relative to N = 1. There is no separate "pure numpy" reference: the honest
comparison available in the same run is the batch against the single plant.

Batches of ``plant.PARALLEL_MIN_BATCH`` or more use the ``prange`` kernel; if another process
keeps a CPU busy its threads wait for the scheduler and a call can take milliseconds, so the load
average is printed too. Every batch size runs the structure-of-arrays block kernel
(``plant.advance_block``, ``plant.BLOCK`` plants per SIMD block); ``--threads 1`` gives the
per-core figures.
On small VMs the OpenMP layer's thread wake-up alone can cost several ms per call; compare with
``NUMBA_THREADING_LAYER=workqueue``.

``--versions`` times plant v1 (preset ``balloon``) against the v0 plant (``balloon_v0``) and
plant v2 (``balloon_v2``) against v1 in the same run, interleaved in rounds (median per-call time
each), and prints the ratios.

Run: ``.venv/bin/python benchmarks/plant_throughput.py`` (options: ``--seconds``, ``--sizes``,
``--versions``).
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numba
import numpy as np

from cepam_gym import plant
from cepam_gym.plant.params import PlantParams, preset

DT = 5e-4
N_SUB = 40


def _setup(n: int, seed: int = 0, params: PlantParams | None = None):
    params = (params or PlantParams()).to_array()[None, :]
    state = plant.initial_state(params, np.full(n, 0.17), 80e3, 60e3)
    rng = np.random.default_rng(seed)
    inputs = np.zeros((n, plant.N_INPUT))
    inputs[:, plant.I_CMD_C] = rng.uniform(-0.05, 0.05, n)
    inputs[:, plant.I_CMD_E] = rng.uniform(-0.05, 0.05, n)
    inputs[:, plant.I_LOAD] = 0.1
    aux = np.empty((n, plant.N_AUX))
    return state, inputs, params, aux


def measure(n: int, seconds: float = 1.0) -> dict:
    """Time ``plant.step`` on ``n`` plants for about ``seconds``; returns the rates."""
    state, inputs, params, aux = _setup(n)
    plant.step(state, inputs, params, plant.PROPORTIONAL, DT, N_SUB, out=state, aux=aux)  # warm-up
    # calibrate the repetition count on a short run, then time the full run
    t0 = time.perf_counter()
    calls = 0
    while time.perf_counter() - t0 < 0.05 * seconds:
        plant.step(state, inputs, params, plant.PROPORTIONAL, DT, N_SUB, out=state, aux=aux)
        calls += 1
    per_call = (time.perf_counter() - t0) / calls
    reps = max(3, int(seconds / per_call))
    t0 = time.perf_counter()
    for _ in range(reps):
        plant.step(state, inputs, params, plant.PROPORTIONAL, DT, N_SUB, out=state, aux=aux)
    elapsed = time.perf_counter() - t0
    if not np.all(aux[:, plant.A_FINITE] == 1.0):
        raise RuntimeError(f"non-finite plant state during the N = {n} benchmark")
    return {
        "n": n,
        "calls": reps,
        "seconds": elapsed,
        "us_per_call": 1e6 * elapsed / reps,
        "substeps_per_s": n * N_SUB * reps / elapsed,
        "control_steps_per_s": n * reps / elapsed,
    }


def versions(n: int, rounds: int = 15, seconds: float = 0.05) -> dict:
    """Median us per ``plant.step`` call of the v0, v1 and v2 plants, ``n`` plants each,
    interleaved in ``rounds`` rounds of about ``seconds`` each (the same run, the same load)."""
    setups = {name: _setup(n, params=preset(name)) for name in ("balloon_v0", "balloon", "balloon_v2")}
    times: dict[str, list[float]] = {name: [] for name in setups}
    for state, inputs, params, aux in setups.values():
        plant.step(state, inputs, params, plant.PROPORTIONAL, DT, N_SUB, out=state, aux=aux)  # warm-up
    for _ in range(rounds):
        for name, (state, inputs, params, aux) in setups.items():
            t0, calls = time.perf_counter(), 0
            while time.perf_counter() - t0 < seconds:
                plant.step(state, inputs, params, plant.PROPORTIONAL, DT, N_SUB, out=state, aux=aux)
                calls += 1
            times[name].append((time.perf_counter() - t0) / calls)
    med = {name: 1e6 * float(np.median(t)) for name, t in times.items()}
    return {
        "n": n,
        "v0_us": med["balloon_v0"],
        "v1_us": med["balloon"],
        "v2_us": med["balloon_v2"],
        "ratio": med["balloon"] / med["balloon_v0"],
        "ratio_v2": med["balloon_v2"] / med["balloon"],
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=1.0, help="timed duration per batch size")
    ap.add_argument("--sizes", type=int, nargs="+", default=[1, 64, 1024, 4096])
    ap.add_argument("--threads", type=int, default=None, help="numba threads for the parallel kernel")
    ap.add_argument("--versions", action="store_true", help="plants v0, v1, v2 in the same run")
    args = ap.parse_args(argv)
    if args.threads:
        numba.set_num_threads(args.threads)
    if args.versions:
        print("# plants v0, v1, v2 (presets balloon_v0, balloon, balloon_v2): median us per plant.step call")
        print(f"{'N':>6} {'v0 us':>10} {'v1 us':>10} {'v2 us':>10} {'v1 / v0':>8} {'v2 / v1':>8}")
        for n in args.sizes:
            r = versions(n)
            print(
                f"{n:>6} {r['v0_us']:>10.1f} {r['v1_us']:>10.1f} {r['v2_us']:>10.1f} "
                f"{r['ratio']:>8.3f} {r['ratio_v2']:>8.3f}"
            )
        print(f"# 1-min load average: {os.getloadavg()[0]:.2f}")
        return 0
    load_before = os.getloadavg()[0]
    print(
        f"# plant.step throughput: proportional valves, dt = {DT * 1e3:g} ms, n_sub = {N_SUB} "
        f"({1 / (DT * N_SUB):g} Hz control)"
    )
    print(
        f"# numba {numba.__version__}, {numba.get_num_threads()} threads "
        f"(parallel kernel for N >= {plant.PARALLEL_MIN_BATCH}), {os.cpu_count()} CPUs, "
        f"{platform.processor() or platform.machine()}, Python {platform.python_version()}"
    )
    rows = [measure(n, args.seconds) for n in args.sizes]
    base = rows[0]["control_steps_per_s"] if rows[0]["n"] == 1 else None
    head = (
        f"{'N':>6} {'calls':>8} {'us/call':>10} {'sub-steps/s':>14} {'control steps/s':>16} "
        f"{'speed-up vs N=1':>16}"
    )
    print(head)
    print("-" * len(head))
    for r in rows:
        speed = f"{r['control_steps_per_s'] / base:16.1f}" if base else f"{'-':>16}"
        print(
            f"{r['n']:>6} {r['calls']:>8} {r['us_per_call']:>10.1f} {r['substeps_per_s']:>14.3e} "
            f"{r['control_steps_per_s']:>16.3e} {speed}"
        )
    try:
        layer = numba.threading_layer()
    except ValueError:  # no parallel region ran (only small N)
        layer = "not initialised"
    print(f"# numba threading layer: {layer} (choose with NUMBA_THREADING_LAYER=omp|tbb|workqueue)")
    print(
        f"# 1-min load average before / after: {load_before:.2f} / {os.getloadavg()[0]:.2f} "
        "(other busy processes slow the parallel kernel: its threads wait for a CPU)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
