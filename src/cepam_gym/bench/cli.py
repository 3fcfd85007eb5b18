"""``cepam-gym bench``: score controllers on the fixed suites."""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

from ..control import check_controller_spec, controller_names
from .harness import run_suite
from .headline import BASELINE, ORACLE, headline_score
from .metrics import normalized_score
from .references import stored_entry
from .suites import SUITES, available

# the controllers whose scores the normalized score (zero, oracle) and the headline (baseline,
# oracle) are measured against
ENDS = {"headline": (BASELINE, ORACLE), "normalized": ("zero", ORACLE)}
REFERENCE_CONTROLLERS = ("zero", BASELINE, ORACLE)  # every end, in the order a run measures them


def _add_relative(rows: list[dict], key: str, score_fn) -> None:
    """``key`` in each row, ``score_fn(score, low end, high end)`` with the ends :data:`ENDS`
    names: from the same run on that suite when both ran, else from the suite's stored reference
    scores when they were measured on the same episodes (``<key>_from`` says which); absent
    otherwise (:func:`missing_ends` says what to run)."""
    low, high = ENDS[key]
    for suite in dict.fromkeys(r["suite"] for r in rows):
        ran = {r["controller"]: r["score"] for r in rows if r["suite"] == suite}
        episodes = next(r["episodes"] for r in rows if r["suite"] == suite)
        stored = _stored(suite, episodes) or {}
        if low in ran and high in ran:
            ends, source = (ran[low], ran[high]), "this run"
        elif low in stored and high in stored:
            ends, source = (stored[low], stored[high]), "reference scores"
        else:
            continue
        for r in rows:
            if r["suite"] == suite:
                r[key] = score_fn(r["score"], *ends)
                r[f"{key}_from"] = source


def add_normalized(rows: list[dict]) -> None:
    """``normalized`` (0 = zero controller, 100 = oracle; D4RL) in each row where its ends are
    known (:func:`_add_relative`)."""
    _add_relative(rows, "normalized", normalized_score)


def add_headline(rows: list[dict]) -> None:
    """``headline`` (0 = the baseline, 100 = the oracle; :mod:`cepam_gym.bench.headline`) in each
    row where its ends are known (:func:`_add_relative`)."""
    _add_relative(rows, "headline", headline_score)


def add_scores(rows: list[dict]) -> None:
    """Both relative scores: the headline and the normalized score."""
    add_headline(rows)
    add_normalized(rows)


def _stored(suite: str, episodes: int) -> dict | None:
    """The stored references of ``suite`` if measured on these episodes (from the suite's seed)."""
    return stored_entry(suite, episodes, SUITES[suite].seed)


def missing_ends(rows: list[dict]) -> list[tuple[str, str]]:
    """``(suite, controller)`` pairs of the ends (zero, baseline, oracle) a run must measure itself
    to give every row both relative scores: its suites whose stored references were measured on
    other episodes (or never, or lack that end)."""
    out = []
    for suite in dict.fromkeys(r["suite"] for r in rows):
        ran = {r["controller"] for r in rows if r["suite"] == suite}
        episodes = next(r["episodes"] for r in rows if r["suite"] == suite)
        stored = _stored(suite, episodes) or {}
        out += [(suite, c) for c in REFERENCE_CONTROLLERS if c not in ran and c not in stored]
    return out


def expand_version(name: str) -> list[str]:
    """A version ``vN`` as the suites of its ids (names ending in ``-vN``), so one command
    re-measures exactly one version's references after its plant changes; any other name as is."""
    if re.fullmatch(r"v\d+", name):
        return [s for s in SUITES if s.endswith(f"-{name}")] or [name]
    return [name]


def _oracle_drives(suite: str) -> bool:
    """Whether the oracle drives the suite's env (every batched env; not the MuJoCo joint)."""
    return "CEPAMJoint-v0" not in SUITES[suite].env_id


def _run_into(rows: list, traces: dict, controller: str, suite: str, episodes: int | None) -> None:
    from ..control.baseline import UnsupportedEnvError

    try:
        metrics, tr = run_suite(controller, suite, episodes=episodes)
    except UnsupportedEnvError as e:  # e.g. the rig's MPC on the joint: not a failure
        print(f"cepam-gym bench: skipped {controller} on {suite}: {e}", file=sys.stderr, flush=True)
        return
    rows.append(metrics)
    traces[(suite, controller)] = tr


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
        help=f"one of {list(SUITES)}, 'all', or a version such as 'v2' (its suites: *-v2) (repeatable; "
        "default all)",
    )
    ap.add_argument(
        "--episodes", type=int, default=None, help="episodes per suite (default: the suite's, 20)"
    )
    ap.add_argument("--json", action="store_true", help="print one JSON object per suite and controller")
    ap.add_argument("--out-dir", default="runs/bench", help="where the table and plots go (without --json)")
    ap.add_argument(
        "--measure-references",
        action="store_true",
        help="run the zero controller, the baseline and the oracle too where the stored references do "
        "not fit the episodes, so every row gets a headline and a normalized score",
    )
    ap.add_argument(
        "--update-references",
        action="store_true",
        help="re-measure the zero controller, the baseline and the oracle on the suites (default "
        "episodes) and store them as the ends of the headline and the normalized score",
    )
    args = ap.parse_args(argv)
    controllers = args.controller or ["baseline"]
    suites = args.suite or ["all"]
    if "all" in suites:  # every suite whose extra is installed (the joint suite needs mujoco)
        suites = [s for s in SUITES if available(s)]
    suites = list(dict.fromkeys(n for s in suites for n in expand_version(s)))
    bad = [s for s in suites if s not in SUITES]
    if bad:
        ap.error(f"unknown suite(s) {bad}; choose from {list(SUITES)} or 'all'")
    if args.episodes is not None and args.episodes < 1:
        ap.error("--episodes must be >= 1")
    if args.update_references:
        if args.episodes is not None:
            ap.error("--update-references measures at each suite's default episodes: drop --episodes")
        import time

        from .harness import measure_references
        from .references import store

        for s in suites:
            if _oracle_drives(s):
                t = time.perf_counter()
                store({s: (entry := measure_references(s))})
                print(
                    f"{s}: zero {entry['zero']:.6g}, baseline {entry['baseline']:.6g}, oracle "
                    f"{entry['oracle']:.6g} ({time.perf_counter() - t:.0f} s)",
                    flush=True,
                )
        return 0
    for c in controllers:
        check_controller_spec(c)  # before any work; the CLI prints its ValueError as one line

    rows, traces = [], {}
    for s in suites:
        for c in controllers:
            _run_into(rows, traces, c, s, args.episodes)
    # the relative scores need their ends measured on these episodes: run the missing ones, or say so
    missing = missing_ends(rows)
    for s in dict.fromkeys(s for s, _ in missing):
        ends = [c for t, c in missing if t == s]
        if args.measure_references and _oracle_drives(s):
            for c in ends:
                _run_into(rows, traces, c, s, args.episodes)
        else:
            lacking = " or ".join(k for k, pair in ENDS.items() if set(pair) & set(ends))
            print(
                f"cepam-gym bench: no {lacking} score on {s}: its stored references were measured on "
                f"other episodes (or never); add {' '.join('--controller ' + c for c in ends)} or "
                "--measure-references",
                file=sys.stderr,
                flush=True,
            )
    add_scores(rows)
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
