"""Does the env's mean return rank controllers as the benchmark's score does? On the v3 ids it
must (their reward is the score's per-step form: tasks.contract, "Reward and score").

For each suite, every controller's mean episode return and its score on the suite's seeded
episodes, then the two rankings side by side. The controllers span the range: valves shut, random
commands, the inverse-model baseline, the MPCs, the oracle, and a near-oracle that weighs the
settling allowance as the score does not (the oracle planned with ``allowance_weight=1``: the
policy an env that paid for the allowance would prefer). ``--agent RUN_DIR`` adds a trained
agent. ``--json FILE`` writes the rows (with the package version and commit) for the docs and
for ``tests/bench/test_reward_ranking.py``'s stored check.

Run: ``python benchmarks/reward_ranking.py [--suite nominal-v3 ...] [--episodes 20]
[--agent runs/main/agent --agent-label NAME]
[--json docs/results/reward_ranking.json]`` (the default suites: every v3 headline suite).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import time

import cepam_gym
from cepam_gym import versions
from cepam_gym.bench.harness import run_suite
from cepam_gym.bench.suites import SUITES
from cepam_gym.errors import InputError

NEAR_ORACLE = ("oracle", {"allowance_weight": 1.0}, "oracle (allowance_weight=1)")


def controllers_for(
    suite_name: str, agent: str | None = None, agent_label: str = "agent"
) -> list[tuple[str, dict, str]]:
    """``(controller, options, label)`` of every controller ranked on a suite."""
    joint = SUITES[suite_name].traces.quantity == "angle"
    base = "joint_baseline" if joint else "baseline"
    out = [("zero", {}, "zero"), ("random", {}, "random"), (base, {}, base)]
    if not joint:  # the MPCs plan through the rig's kernel only
        out += [("mpc", {}, "mpc"), ("adaptive_mpc", {}, "adaptive_mpc")]
    if "-id-" in suite_name:
        out.append(("identify_mpc", {}, "identify_mpc"))
    if agent:
        out.append((agent, {}, agent_label))
    return [*out, ("oracle", {}, "oracle"), NEAR_ORACLE]


def _stored_oracle(suite_name: str, episodes: int | None, max_steps: int | None) -> dict | None:
    """The oracle's score and mean return from the stored references (``cepam-gym bench
    --update-references`` measured them on the same episodes), so the ranking does not re-run
    the most expensive controller; None for other episodes."""
    from cepam_gym.bench.references import stored_entry

    suite = SUITES[suite_name]
    entry = None if max_steps else stored_entry(suite_name, episodes or suite.episodes, suite.seed)
    return None if entry is None else {"score": entry["oracle"], "mean_return": entry["oracle_return"]}


def rank(
    suite_name: str,
    episodes: int | None,
    agent: str | None = None,
    max_steps: int | None = None,
    agent_label: str = "agent",
) -> list:
    """Each controller's score and mean return on the suite's first ``episodes`` episodes
    (``max_steps``: the first steps only); the oracle's from the stored references where they
    hold the same episodes."""
    rows = []
    for controller, options, label in controllers_for(suite_name, agent, agent_label):
        t0 = time.perf_counter()
        stored = _stored_oracle(suite_name, episodes, max_steps) if label == "oracle" else None
        try:
            m = stored or run_suite(controller, suite_name, episodes, max_steps, **options)[0]
        except InputError as e:  # an agent of another observation (the length or joint ids)
            if controller != agent:
                raise
            print(f"  {label}: not run on {suite_name} ({e})", flush=True)
            continue
        rows.append(
            {
                "controller": label,
                "score": m["score"],
                "mean_return": m["mean_return"],
                "seconds": time.perf_counter() - t0,
            }
        )
        print(
            f"  {label:32s} score {m['score']:9.4f}  return {m['mean_return']:12.3f}"
            f"  ({rows[-1]['seconds']:.0f} s)",
            flush=True,
        )
    return rows


# Scores closer than this (relative) are a tie: the score's 95 % interval over a suite's 20 episodes
# is +-5-15 %, and no per-step reward can order two controllers exactly as a sum of two RMS errors
# does when one trades length error for stiffness error (docs/benchmark.md, "Reward and score on v3")
TIE = 0.02


def misordered(rows, tie: float = TIE) -> list[tuple[str, str]]:
    """The pairs of rows the mean return orders otherwise than the score (higher return, lower
    score), among pairs whose scores differ by more than ``tie`` (relative)."""
    out = []
    for i, a in enumerate(rows):
        for b in rows[i + 1 :]:
            lo, hi = sorted((a["score"], b["score"]))
            if hi - lo <= tie * lo:
                continue
            if (a["score"] < b["score"]) != (a["mean_return"] > b["mean_return"]):
                out.append((a["controller"], b["controller"]))
    return out


def ties(rows, tie: float = TIE) -> list[tuple[str, str]]:
    """The pairs within ``tie`` of each other whose order the return and the score do not share."""
    return [p for p in misordered(rows, tie=0.0) if p not in misordered(rows, tie)]


def agree(rows, tie: float = TIE) -> bool:
    """Whether the mean return orders the rows as the score does (higher return, lower score), ties
    of the score (within ``tie``) left unordered."""
    return not misordered(rows, tie)


def markdown(stored: dict) -> str:
    """The ranking as docs/results/benchmark.md prints it (a test checks the page holds exactly this)."""
    lines = [
        f"cepam-gym {stored['version']} at {stored['commit']}; 20 episodes per suite; mean return per "
        "episode, score (lower is better), rank by each; scores within 2 % of each other are a tie.",
        "",
    ]
    for name, entry in stored["suites"].items():
        rows = entry["rows"]
        by_score = sorted(range(len(rows)), key=lambda i: rows[i]["score"])
        by_return = sorted(range(len(rows)), key=lambda i: -rows[i]["mean_return"])
        tied = ties(rows)
        note = "; within 2 %, ordered otherwise: " + ", ".join(f"{a} / {b}" for a, b in tied) if tied else ""
        lines += [
            f"`{name}` (the return ranks as the score: {'yes' if agree(rows) else 'NO'}{note}):",
            "",
            "| controller | score | rank | mean return | rank |",
            "|---|---|---|---|---|",
        ]
        for i, r in enumerate(rows):
            lines.append(
                f"| {r['controller']} | {r['score']:.4g} | {by_score.index(i) + 1} | "
                f"{r['mean_return']:.4g} | {by_return.index(i) + 1} |"
            )
        lines.append("")
    return "\n".join(lines)


def headline_v3() -> list[str]:
    return [s for row in versions.VERSIONS.values() if row.version == 3 for s in row.suites]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--suite", action="append", help="suite (repeatable; default: every v3 headline suite)")
    ap.add_argument("--episodes", type=int, default=None, help="episodes per suite (default: the suite's)")
    ap.add_argument("--agent", default=None, help="a trained agent's run directory to rank too")
    ap.add_argument("--agent-label", default="agent", help="the agent's name in the table")
    ap.add_argument("--json", default=None, help="write the rows to this file")
    ap.add_argument(
        "--markdown", default=None, help="print the stored file FILE as the docs' tables, and exit"
    )
    args = ap.parse_args()
    if args.markdown:
        with open(args.markdown) as f:
            print(markdown(json.load(f)))
        return
    out = {
        "version": cepam_gym.__version__,
        "commit": subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True
        ).stdout.strip(),
        "suites": {},
    }
    for name in args.suite or headline_v3():
        print(f"{name}:", flush=True)
        rows = rank(name, args.episodes, args.agent, agent_label=args.agent_label)
        out["suites"][name] = {
            "episodes": args.episodes or SUITES[name].episodes,
            "rows": rows,
            "agree": agree(rows),
        }
        print(f"  return ranks as the score: {agree(rows)}", flush=True)
        if args.json:  # after every suite: a long run interrupted keeps what it measured
            with open(args.json, "w") as f:
                json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
