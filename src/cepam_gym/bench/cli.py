"""``cepam-gym bench``: score controllers on the fixed suites."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ..control import check_controller_spec, controller_names
from .harness import run_suite
from .metrics import normalized_score
from .suites import SUITES, available


def add_normalized(rows: list[dict]) -> None:
    """``normalized`` (0 = zero controller, 100 = oracle) in each row: from the zero controller's
    and the oracle's scores of the same run on that suite when both ran, else from the suite's
    stored reference scores (``normalized_from`` says which); absent for a suite without either."""
    for suite in dict.fromkeys(r["suite"] for r in rows):
        ran = {r["controller"]: r["score"] for r in rows if r["suite"] == suite}
        if "zero" in ran and "oracle" in ran:
            ends, source = (ran["zero"], ran["oracle"]), "this run"
        elif SUITES[suite].reference is not None:
            ends, source = SUITES[suite].reference, "reference scores"
        else:
            continue
        for r in rows:
            if r["suite"] == suite:
                r["normalized"] = normalized_score(r["score"], *ends)
                r["normalized_from"] = source


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="cepam-gym bench", description=__doc__)
    ap.add_argument(
        "--controller",
        action="append",
        default=None,
        help=f"one of {', '.join(controller_names())}, or a trained agent's run directory (repeatable)",
    )
    ap.add_argument(
        "--suite",
        action="append",
        default=None,
        help=f"one of {list(SUITES)} or 'all' (repeatable; default all)",
    )
    ap.add_argument(
        "--episodes", type=int, default=None, help="episodes per suite (default: the suite's, 20)"
    )
    ap.add_argument("--json", action="store_true", help="print one JSON object per suite and controller")
    ap.add_argument("--out-dir", default="runs/bench", help="where the table and plots go (without --json)")
    args = ap.parse_args(argv)
    controllers = args.controller or ["baseline"]
    suites = args.suite or ["all"]
    if "all" in suites:  # every suite whose extra is installed (the joint suite needs mujoco)
        suites = [s for s in SUITES if available(s)]
    bad = [s for s in suites if s not in SUITES]
    if bad:
        ap.error(f"unknown suite(s) {bad}; choose from {list(SUITES)} or 'all'")
    if args.episodes is not None and args.episodes < 1:
        ap.error("--episodes must be >= 1")
    for c in controllers:
        check_controller_spec(c)  # before any work; the CLI prints its ValueError as one line
    from ..control.baseline import UnsupportedEnvError

    rows, traces = [], {}
    for s in suites:
        for c in controllers:
            try:
                metrics, tr = run_suite(c, s, episodes=args.episodes)
            except UnsupportedEnvError as e:  # e.g. the rig's MPC on the joint: not a failure
                print(f"cepam-gym bench: skipped {c} on {s}: {e}", file=sys.stderr, flush=True)
                continue
            rows.append(metrics)
            traces[(s, c)] = tr
    add_normalized(rows)
    if args.json:
        for metrics in rows:
            print(json.dumps(metrics), flush=True)
        return 0
    from . import report

    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    text = report.table(rows)
    print(text)
    (out / "table.txt").write_text(text + "\n")
    (out / "results.json").write_text(json.dumps(rows, indent=2))
    for (s, c), tr in traces.items():
        name = f"traces_{s}_{Path(c).name}.png"
        report.plot_traces(tr, f"{c} on {s} (episode 0)", out / name, spec=SUITES[s].traces)
    report.plot_bars(rows, out / "scores.png")
    print(f"wrote {out}/table.txt, results.json, scores.png and traces_*.png")
    return 0
