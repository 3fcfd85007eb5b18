"""Convergence of the oracle: its score against planning horizon and search effort, per suite.

The oracle is the benchmark's 100; it is firm when no other setting of it scores meaningfully
better. For every suite this runs the shipped setting (:func:`cepam_gym.control.oracle.oracle_config`),
the horizons ``--horizons`` [s] at the shipped effort, and the shipped horizon at ``--efforts``
times the shipped iterations (:meth:`~cepam_gym.control.planner.CEMConfig.scaled`), all on the
same seeded episodes (the suite's seed, ``--episodes`` of them), plus the zero controller for the
normalized scale. Per setting it prints the raw score, its difference from the shipped one in %
of the shipped score, and in normalized points, ``100 (score - shipped) / (zero - shipped)``
(what moves a normalized score), and the wall time.

Criteria: the shipped setting within 2 % of the best setting found, and doubling the
effort changing the score by less than 2 %. Near a score of zero a raw % is dominated by the
search's sampling noise (the oracle's errors are hundredths of a millimetre), so both are printed.

Run: ``NUMBA_NUM_THREADS=1 python benchmarks/oracle_convergence.py --episodes 3 [--suite NAME]``
(``--json`` writes the rows to a file; plant v2's check: ``--suite nominal-v2 --suite randomized-v2
--episodes 4 --horizons 0.2 0.5 --efforts 2 4``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import time

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym.bench.harness import record
from cepam_gym.bench.metrics import score_traces
from cepam_gym.bench.suites import SUITES
from cepam_gym.control import make_controller
from cepam_gym.control.baseline import find_core
from cepam_gym.control.oracle import OracleController, oracle_config

V1_SUITES = ("nominal-v1", "length-v1", "stiffness-at-fixed-length-v1", "randomized-v1", "joint-v1")


def score(make, suite, episodes: int) -> tuple[float, float]:
    """``(score, seconds)`` of the policy ``make(venv)`` on the suite's first ``episodes``."""
    t = time.perf_counter()
    tr, track_k = record(make, suite.env_id, suite.env_kwargs, episodes, suite.seed, None, suite.traces)
    return score_traces(tr, track_k, suite.traces)["score"], time.perf_counter() - t


def settings(shipped, dt: float, horizons, efforts) -> list[tuple[str, object]]:
    """(label, config): the shipped one first, then the horizons, then the efforts."""
    out = [(f"shipped ({shipped.horizon_steps * dt:g} s, x1)", shipped)]
    for h in horizons:
        steps = max(1, int(round(h / dt)))
        if steps != shipped.horizon_steps:
            out.append((f"horizon {h:g} s, x1", dataclasses.replace(shipped, horizon_steps=steps)))
    for e in efforts:
        if e != 1:
            out.append((f"horizon {shipped.horizon_steps * dt:g} s, x{e:g}", shipped.scaled(e)))
    return out


def run(name: str, episodes: int, horizons, efforts) -> list[dict]:
    suite = SUITES[name]
    zero, _ = score(lambda v: make_controller("zero", v), suite, episodes)
    box = {}

    def shipped_of(venv):
        box["core"] = find_core(venv)
        return make_controller("zero", venv)

    score(shipped_of, suite, 1)  # only to read the env's timing and mechanism
    core = box["core"]
    rows = []
    for label, cfg in settings(oracle_config(core), core.control_dt, horizons, efforts):
        s, sec = score(lambda v, c=cfg: OracleController(v, config=c), suite, episodes)
        rows.append({"suite": name, "setting": label, "score": s, "zero": zero, "seconds": sec})
        print(f"{name:30s} {label:24s} {s:.5f}  ({sec:.0f} s)", flush=True)
    ship = rows[0]["score"]
    for r in rows:
        r["vs_shipped_pct"] = 100.0 * (r["score"] - ship) / ship
        r["vs_shipped_points"] = 100.0 * (r["score"] - ship) / (zero - ship)
    return rows


def table(rows: list[dict]) -> str:
    lines = [
        "| suite | setting | score | vs shipped % | vs shipped (normalized points) | time s |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['suite']} | {r['setting']} | {r['score']:.4f} | {r['vs_shipped_pct']:+.1f} "
            f"| {r['vs_shipped_points']:+.2f} | {r['seconds']:.0f} |"
        )
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--suite", action="append", default=None, help=f"default: {', '.join(V1_SUITES)}")
    ap.add_argument("--episodes", type=int, default=3, help="episodes per setting (default 3)")
    ap.add_argument("--horizons", type=float, nargs="+", default=[0.1, 0.2, 0.5, 1.0], help="seconds")
    ap.add_argument("--efforts", type=float, nargs="+", default=[1, 2, 4], help="times the iterations")
    ap.add_argument("--json", default=None, help="write the rows to this file")
    args = ap.parse_args()
    bad = [s for s in args.suite or [] if s not in SUITES]
    if bad:
        ap.error(f"unknown suite(s) {bad}; choose from {list(SUITES)}")
    if args.episodes < 1:
        ap.error("--episodes must be >= 1")
    print(
        f"oracle convergence: {args.episodes} episodes per setting, load {os.getloadavg()[0]:.1f}", flush=True
    )
    rows = []
    for name in args.suite or V1_SUITES:
        rows += run(name, args.episodes, args.horizons, args.efforts)
    print(table(rows))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=2)


if __name__ == "__main__":
    main()
