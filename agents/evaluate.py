"""``cepam-gym eval``: score a trained agent with the benchmark harness beside the baseline.

    cepam-gym eval --run runs/quick-s0 [--episodes 20] [--suite nominal --suite randomized] [--model best]

Writes into ``<run>/eval/`` (or ``--out-dir``): ``table.txt`` (benchmark table), ``results.json``
(every metric), ``comparison.md`` (agent / baseline ratios and the issue's goals), ``scores.png``
and ``traces_<suite>_<controller>.png``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

# the goals of issue 5: score ratio agent / baseline
GOAL_NOMINAL_RATIO = 1.05  # within 5 % of the baseline on the nominal suite
GOAL_RANDOMIZED_RATIO = 0.70  # 30 % lower combined error on the randomized suite


def compare(rows: list[dict], agent: str = "agent", baseline: str = "baseline") -> list[dict]:
    """Per suite: both scores, their ratio, and whether the issue's goal for that suite is met."""
    out = []
    suites = list(dict.fromkeys(r["suite"] for r in rows))
    for s in suites:
        a = next((r for r in rows if r["suite"] == s and r["controller"] == agent), None)
        b = next((r for r in rows if r["suite"] == s and r["controller"] == baseline), None)
        if a is None or b is None:
            continue
        ratio = a["score"] / b["score"] if b["score"] > 0 else float("nan")
        goal = {"nominal": GOAL_NOMINAL_RATIO, "randomized": GOAL_RANDOMIZED_RATIO}.get(s)
        out.append(
            {
                "suite": s,
                "agent_score": a["score"],
                "baseline_score": b["score"],
                "ratio": ratio,
                "goal_ratio": goal,
                "goal_met": None if goal is None else bool(ratio <= goal),
                "agent_failures": a["failure_rate"],
                "baseline_failures": b["failure_rate"],
            }
        )
    return out


def comparison_markdown(cmp: list[dict], run: Path, which: str) -> str:
    lines = [
        f"# {run.name}: agent ({which} model) vs the inverse-model baseline",
        "",
        "| suite | agent score | baseline score | agent / baseline | goal | met |",
        "|---|---|---|---|---|---|",
    ]
    for c in cmp:
        goal = "-" if c["goal_ratio"] is None else f"<= {c['goal_ratio']:.2f}"
        met = "-" if c["goal_met"] is None else ("yes" if c["goal_met"] else "no")
        lines.append(
            f"| {c['suite']} | {c['agent_score']:.3f} | {c['baseline_score']:.3f} | "
            f"{c['ratio']:.3f} | {goal} | {met} |"
        )
    lines += [
        "",
        "Combined score (lower is better): length RMSE / 5 mm + stiffness RMSE / 20 % "
        "+ 2 x failure rate (cepam_gym.bench.metrics).",
    ]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    from cepam_gym.bench import report
    from cepam_gym.bench.harness import run_suite
    from cepam_gym.bench.metrics import RIG
    from cepam_gym.bench.suites import SUITES

    ap = argparse.ArgumentParser(prog="cepam-gym eval", description=__doc__.split("\n\n")[0])
    ap.add_argument("--run", required=True, help="run directory written by cepam-gym train")
    ap.add_argument(
        "--suite",
        action="append",
        default=None,
        help=f"one of {list(SUITES)} or 'all' (repeatable; default nominal and randomized)",
    )
    ap.add_argument(
        "--episodes", type=int, default=None, help="episodes per suite (default: the suite's, 20)"
    )
    ap.add_argument(
        "--model",
        default="auto",
        choices=("auto", "best", "final", "latest"),
        help="which model of the run (auto: best, else final, else latest checkpoint)",
    )
    ap.add_argument("--no-baseline", action="store_true", help="score the agent only")
    ap.add_argument("--out-dir", help="where the table and plots go (default <run>/eval)")
    args = ap.parse_args(argv)
    run = Path(args.run)
    if not (run / "config.yaml").is_file():
        ap.error(f"--run {run}: not a training run directory (no config.yaml)")
    suites = args.suite or ["nominal", "randomized"]
    if "all" in suites:  # the rig suites: agents are trained on the rig's observations
        suites = [s for s in SUITES if SUITES[s].traces is RIG]
    bad = [s for s in suites if s not in SUITES]
    if bad:
        ap.error(f"unknown suite(s) {bad}; choose from {list(SUITES)} or 'all'")
    if args.episodes is not None and args.episodes < 1:
        ap.error("--episodes must be >= 1")
    from .policy import _files

    try:
        model_path, _ = _files(run, args.model)
    except FileNotFoundError as e:
        ap.error(str(e))
    spec = str(model_path) if args.model != "auto" else str(run)
    out = Path(args.out_dir) if args.out_dir else run / "eval"
    out.mkdir(parents=True, exist_ok=True)
    rows, traces = [], {}
    for s in suites:
        controllers = [("agent", spec)] + ([] if args.no_baseline else [("baseline", "baseline")])
        for name, c in controllers:
            metrics, tr = run_suite(c, s, episodes=args.episodes)
            metrics["controller"] = name
            rows.append(metrics)
            traces[(s, name)] = tr
    text = report.table(rows)
    cmp = compare(rows)
    md = comparison_markdown(cmp, run, f"{args.model}: {model_path.name}")
    print(text)
    print()
    print(md)
    (out / "table.txt").write_text(text + "\n")
    (out / "results.json").write_text(
        json.dumps({"run": str(run), "model": str(model_path), "rows": rows, "comparison": cmp}, indent=2)
    )
    (out / "comparison.md").write_text(md)
    for (s, c), tr in traces.items():
        report.plot_traces(
            tr,
            f"{c} ({run.name}) on {s} (episode 0)" if c == "agent" else f"{c} on {s} (episode 0)",
            out / f"traces_{s}_{c}.png",
        )
    report.plot_bars(rows, out / "scores.png")
    print(f"wrote {out}/table.txt, results.json, comparison.md, scores.png and traces_*.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
