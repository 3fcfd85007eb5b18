"""``cepam-gym eval``: score a trained agent with the benchmark harness beside model-based
controllers (default: the inverse-static baseline).

    cepam-gym eval --run runs/quick-s0 [--episodes 20] [--suite nominal-v1 --suite randomized-v1]
                   [--against zero --against baseline --against mpc --against oracle] [--model best]

The suites default to the headline suites of the id the agent was trained on (the version
table, :mod:`cepam_gym.versions`: ``CEPAM-v2``: ``nominal-v2``, ``randomized-v2``;
``CEPAMJoint-v2``: ``joint-v2``); ``--suite all`` scores every suite of its version whose env
observes what it does. Writes into ``<run>/eval/`` (or ``--out-dir``): ``table.txt``
(benchmark table with the headline and the normalized score), ``results.json`` (every metric),
``comparison.md`` (the agent's headline beside the baseline's 0, the MPC's and the oracle's 100,
the agent / MPC score ratio, and the agent / reference ratio per controller that ran),
``scores.png`` and ``traces_<suite>_<controller>.png``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from cepam_gym.bench.headline import BASELINE, LEGEND, ORACLE, headline_score
from cepam_gym.cli_errors import CommandParser
from cepam_gym.errors import InputError

# the model-based controller an agent is measured against between the headline's two ends
MPC = "mpc"


def _headline_of(row: dict | None, score: dict) -> tuple[float | None, str | None]:
    """A row's headline and where its ends come from: this run's baseline and oracle where both
    ran, else the ``headline`` that :func:`cepam_gym.bench.cli.add_scores` put in the row from the
    stored references of the same episodes; ``(None, None)`` where neither is known."""
    if row is None:
        return None, None
    if {BASELINE, ORACLE} <= score.keys() and score[BASELINE] > score[ORACLE]:
        return headline_score(row["score"], score[BASELINE], score[ORACLE]), "this run"
    if row.get("headline") is not None:
        return row["headline"], row.get("headline_from", "reference scores")
    return None, None


def gaps_closed(rows: list[dict], agent: str = "agent") -> list[dict]:
    """Per suite where the agent's headline score is known (the share of the gap from the
    baseline to the oracle it closes, in points): the agent's headline beside the baseline's 0,
    the MPC's headline (None where the MPC did not run) and the oracle's 100, with the agent / MPC
    score ratio (below 1: the agent's error is the lower)."""
    out = []
    for s in dict.fromkeys(r["suite"] for r in rows):
        score = {r["controller"]: r["score"] for r in rows if r["suite"] == s}
        by_name = {r["controller"]: r for r in rows if r["suite"] == s}
        closed, source = _headline_of(by_name.get(agent), score)
        if closed is None:
            continue
        mpc, _ = _headline_of(by_name.get(MPC), score)
        ratio = score[agent] / score[MPC] if score.get(MPC, 0) > 0 else None
        out.append(
            {
                "suite": s,
                "headline": closed,
                "headline_from": source,
                "baseline_headline": 0.0,
                "mpc_headline": mpc,
                "oracle_headline": 100.0,
                "mpc_ratio": ratio,
            }
        )
    return out


def compare(rows: list[dict], agent: str = "agent") -> list[dict]:
    """Per suite and reference controller that ran: both scores and their ratio (below 1: the
    agent's error is the lower), both headline and normalized scores, both failure rates."""
    out = []
    for s in dict.fromkeys(r["suite"] for r in rows):
        a = next((r for r in rows if r["suite"] == s and r["controller"] == agent), None)
        if a is None:
            continue
        for b in (r for r in rows if r["suite"] == s and r["controller"] != agent):
            out.append(
                {
                    "suite": s,
                    "reference": b["controller"],
                    "agent_score": a["score"],
                    "reference_score": b["score"],
                    "ratio": a["score"] / b["score"] if b["score"] > 0 else float("nan"),
                    "agent_headline": a.get("headline"),
                    "reference_headline": b.get("headline"),
                    "agent_normalized": a.get("normalized"),
                    "reference_normalized": b.get("normalized"),
                    "agent_failures": a["failure_rate"],
                    "reference_failures": b["failure_rate"],
                }
            )
    return out


def _headline_lines(gaps: list[dict]) -> list[str]:
    """The agent's headline beside the baseline's, the MPC's and the oracle's."""
    lines = [
        "",
        "| suite | agent's headline | baseline | MPC | oracle | agent / MPC score | ends from |",
        "|---|---|---|---|---|---|---|",
    ]
    for g in gaps:
        mpc = "not run (--against mpc)" if g["mpc_headline"] is None else f"{g['mpc_headline']:.0f}"
        ratio = "-" if g["mpc_ratio"] is None else f"{g['mpc_ratio']:.2f}"
        lines.append(
            f"| {g['suite']} | **{g['headline']:.0f}** | {g['baseline_headline']:.0f} | {mpc} | "
            f"{g['oracle_headline']:.0f} | {ratio} | {g['headline_from']} |"
        )
    stored = [g["suite"] for g in gaps if g["headline_from"] != "this run"]
    if stored:
        lines += [
            "",
            f"The baseline's and the oracle's scores on {', '.join(stored)}: the stored reference "
            "scores of the same episodes (cepam_gym/data/reference_scores.json, re-checked by the "
            "test suite).",
        ]
    return lines


def comparison_markdown(cmp: list[dict], run: Path, which: str, gaps: list[dict] = ()) -> str:
    lines = [f"# {run.name}: agent ({which} model) vs the model-based controllers"]
    if gaps:
        lines += _headline_lines(gaps)
    unknown = [s for s in dict.fromkeys(c["suite"] for c in cmp) if s not in {g["suite"] for g in gaps}]
    if unknown:
        lines += [
            "",
            f"No headline on {', '.join(unknown)}: no stored reference scores of these episodes; "
            "`--against baseline --against oracle` measures both ends in this run.",
        ]
    lines += [
        "",
        "| suite | reference | agent score | reference score | agent / reference | headline "
        "(agent, reference) | normalized (agent, reference) | failure rate (agent, reference) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for c in cmp:
        pair = {
            k: "-" if c[f"agent_{k}"] is None else f"{c[f'agent_{k}']:.1f}, {c[f'reference_{k}']:.1f}"
            for k in ("headline", "normalized")
        }
        lines.append(
            f"| {c['suite']} | {c['reference']} | {c['agent_score']:.3f} | "
            f"{c['reference_score']:.3f} | {c['ratio']:.3f} | {pair['headline']} | {pair['normalized']} | "
            f"{c['agent_failures']:.2f}, {c['reference_failures']:.2f} |"
        )
    lines += [
        "",
        "Combined score (lower is better): length RMSE / 5 mm + stiffness RMSE / 20 % "
        "+ 2 x failure rate (cepam_gym.bench.metrics); agent / reference below 1: the agent's error "
        f"is the lower; {LEGEND}.",
    ]
    return "\n".join(lines) + "\n"


def trained_env_id(files, given: str | None) -> str:
    """The env id a model was trained on: its record's (our ``config.yaml``, RL Zoo3's
    ``args.yml``) or ``given`` (``--env-id``); ``InputError`` when neither names one or they differ."""
    recorded = files.env_id()
    if given is not None and recorded is not None and given != recorded:
        raise InputError(f"--env-id {given}: {files.model} was trained on {recorded}")
    if given is None and recorded is None:
        raise InputError(
            f"--env-id is needed: nothing beside {files.model} names the env it was trained on "
            "(no config.yaml of cepam-gym train, no args.yml of RL Zoo3)"
        )
    return given or recorded


def default_suites(env_id: str, asked: list[str] | None = None) -> list[str]:
    """The suites an agent trained on ``env_id`` is scored on: ``asked`` (``--suite``), else the
    id's headline suites from the version table; ``all``: every suite whose env observes what the
    agent's does (its version's suites on the ids of the same observation)."""
    from cepam_gym.bench.suites import headline_suites, version_suites

    suites = asked or headline_suites(env_id)
    if "all" in suites:
        suites = version_suites(env_id)
    return suites


def _score_into(rows: list, traces: dict, suites: list, controllers: list, episodes: int | None) -> None:
    """Score every ``(name, spec)`` of ``controllers`` on every suite, into ``rows`` and ``traces``;
    a controller that cannot drive a suite's env is skipped, said on stderr."""
    from cepam_gym.bench.harness import run_suite
    from cepam_gym.control.baseline import UnsupportedEnvError

    for s in suites:
        for name, c in controllers:
            try:
                metrics, tr = run_suite(c, s, episodes=episodes)
            except UnsupportedEnvError as e:  # e.g. the rig's MPC on the joint
                print(f"cepam-gym eval: skipped {name} on {s}: {e}", file=sys.stderr, flush=True)
                continue
            metrics["controller"] = name
            rows.append(metrics)
            traces[(s, name)] = tr


def main(argv: list[str] | None = None) -> int:
    from cepam_gym.bench import report
    from cepam_gym.bench.cli import add_scores
    from cepam_gym.bench.suites import SUITES
    from cepam_gym.control.registry import controller_names
    from cepam_gym.progress import runs

    ap = CommandParser(prog="cepam-gym eval", description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--run",
        required=True,
        help="run directory written by cepam-gym train, an RL Zoo3 run folder, or an SB3 model .zip",
    )
    ap.add_argument(
        "--env-id",
        help="the env id the model was trained on (needed for a model .zip without a run's config.yaml "
        "or RL Zoo3's args.yml beside it)",
    )
    ap.add_argument(
        "--suite",
        action="append",
        default=None,
        help=f"one of {list(SUITES)} or 'all' (repeatable; default: the headline suites of the agent's id)",
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
    ap.add_argument(
        "--against",
        action="append",
        default=None,
        help="a controller to score beside the agent (repeatable; default baseline; e.g. zero, "
        "baseline, mpc, oracle: with baseline and oracle the headline is of this run, with zero and "
        "oracle the normalized score)",
    )
    ap.add_argument("--no-baseline", action="store_true", help="score the agent only")
    ap.add_argument("--out-dir", help="where the table and plots go (default <run>/eval)")
    args = ap.parse_args(argv)
    run = Path(args.run)
    from .policy import locate

    files = locate(run, args.model)
    env_id = trained_env_id(files, args.env_id)
    suites = default_suites(env_id, args.suite)
    bad = [s for s in suites if s not in SUITES]
    if bad:
        raise InputError(f"unknown suite(s) {bad}; choose from {list(SUITES)} or 'all'")
    if args.episodes is not None and args.episodes < 1:
        raise InputError("--episodes must be >= 1")
    against = [] if args.no_baseline else (args.against or ["baseline"])
    bad = [c for c in against if c not in controller_names()]
    if bad:
        raise InputError(f"--against: unknown controller(s) {bad}; choose from {list(controller_names())}")
    model_path = files.model
    spec = str(model_path) if args.model != "auto" or not run.is_dir() else str(run)
    default_out = run / "eval" if run.is_dir() else run.with_name(f"{run.stem}_eval")
    out = Path(args.out_dir) if args.out_dir else default_out
    out.mkdir(parents=True, exist_ok=True)
    rows, traces = [], {}
    controllers = [("agent", spec)] + [(c, c) for c in dict.fromkeys(against)]
    with runs(len(suites) * len(controllers), "cepam-gym eval"):
        _score_into(rows, traces, suites, controllers, args.episodes)
    add_scores(rows)
    text = report.table(rows)
    cmp, gaps = compare(rows), gaps_closed(rows)
    md = comparison_markdown(cmp, run, f"{args.model}: {model_path.name}", gaps)
    print(text)
    print()
    print(md)
    (out / "table.txt").write_text(text + "\n")
    (out / "results.json").write_text(
        json.dumps(
            {"run": str(run), "model": str(model_path), "rows": rows, "comparison": cmp, "gaps_closed": gaps},
            indent=2,
        )
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
