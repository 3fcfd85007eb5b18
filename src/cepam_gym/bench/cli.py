"""``cepam-gym bench``: score controllers on the fixed suites."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

from .. import versions
from ..cli_errors import CommandParser
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
    """A version ``vN`` as the suites of its ids (the version table, :mod:`cepam_gym.versions`), so
    one command re-measures exactly one version's references after its plant changes; any other
    name as is."""
    if re.fullmatch(r"v\d+", name):
        ids = set(versions.ids(version=int(name[1:])))
        return [s for s, suite in SUITES.items() if suite.env_id in ids] or [name]
    return [name]


def default_suites(controllers: list[str], env_id: str | None) -> list[str]:
    """The suites ``bench`` runs without ``--suite``: the suites of ``--env-id``; else the headline
    suites of the ids the trained agents among ``controllers`` were trained on (their records,
    :func:`cepam_gym.control.registry.agent_env_id`), as ``cepam-gym eval`` scores them; else
    every suite (``all``)."""
    from ..control.registry import agent_env_id
    from ..errors import InputError
    from .suites import headline_suites

    if env_id is not None:
        suites = [s for s in SUITES if SUITES[s].env_id == env_id]
        if not suites:
            ids = sorted({v.env_id for v in SUITES.values()})
            raise InputError(f"--env-id {env_id}: no suite runs it; suites run {ids}")
        return suites
    trained = [i for i in (agent_env_id(c) for c in controllers) if i is not None]
    return list(dict.fromkeys(s for i in trained for s in headline_suites(i))) or ["all"]


def _oracle_drives(suite: str) -> bool:
    """Whether the oracle drives the suite's env (the version table names its setting: every
    batched env; not the MuJoCo joint)."""
    return versions.get(SUITES[suite].env_id).oracle is not None


def _run_into(rows: list, traces: dict, controller: str, suite: str, episodes: int | None) -> None:
    from ..control.baseline import UnsupportedEnvError

    try:
        metrics, tr = run_suite(controller, suite, episodes=episodes)
    except UnsupportedEnvError as e:  # e.g. the rig's MPC on the joint: not a failure
        print(f"cepam-gym bench: skipped {controller} on {suite}: {e}", file=sys.stderr, flush=True)
        return
    rows.append(metrics)
    traces[(suite, controller)] = tr


def check_agents_fit(controllers: list[str], suites: list[str]) -> None:
    """Build every trained agent on a one-env copy of each suite's env before any suite runs: an
    agent that does not fit a suite (its observation shape, its action mode) is refused in one line
    naming the suite, the env's observation shape and why, and the suites the agent fits."""
    import warnings

    import gymnasium as gym

    from ..control import make_controller
    from ..errors import InputError

    agents = [c for c in controllers if c not in controller_names()]
    misfits, fits = [], {c: [] for c in agents}
    for s in suites if agents else ():
        suite = SUITES[s]
        venv = gym.make_vec(suite.env_id, num_envs=1, **suite.env_kwargs)
        try:
            for c in agents:
                try:
                    with warnings.catch_warnings():  # the loader's notes come once, in the run
                        warnings.simplefilter("ignore")
                        make_controller(c, venv)
                except InputError as e:
                    shape = venv.single_observation_space.shape
                    misfits.append(f"{c} does not fit suite {s} ({suite.env_id}, observations {shape}): {e}")
                else:
                    fits[c].append(s)
        finally:
            venv.close()
    if misfits:
        more = f" (and {len(misfits) - 1} more suite/agent pairs)" if len(misfits) > 1 else ""
        hint = "; ".join(
            f"{c} fits {' '.join('--suite ' + s for s in ok) or 'none of them'}" for c, ok in fits.items()
        )
        raise InputError(f"{misfits[0]}{more}; {hint}")


def _write(out: Path, rows: list[dict]) -> None:
    """The table and every metric so far, rewritten as each suite finishes."""
    from . import report

    out.mkdir(parents=True, exist_ok=True)
    (out / "table.txt").write_text(report.table(rows) + "\n")
    (out / "results.json").write_text(json.dumps(rows, indent=2))


def _run_suites(args, controllers: list[str], suites: list[str], rows: list, traces: dict) -> None:
    """Run the suites one after the other; each suite's results are kept as it finishes (written
    to ``--out-dir``, or printed with ``--json`` if a later suite fails). A failing suite is named:
    in one line for a user error, as a note on the traceback of anything else."""
    from ..errors import InputError

    out = Path(args.out_dir)
    for s in suites:
        try:
            for c in controllers:
                _run_into(rows, traces, c, s, args.episodes)
        except Exception as e:
            finished = [r for r in rows if r["suite"] != s]
            add_scores(finished)
            if args.json:
                for metrics in finished:
                    print(json.dumps(metrics), flush=True)
                kept = "printed above"
            else:
                _write(out, finished)
                kept = f"in {out}/results.json"
            done = sorted({r["suite"] for r in finished})
            where = (
                f"the finished suites' results ({', '.join(done)}) are {kept}"
                if done
                else "no suite finished"
            )
            if isinstance(e, InputError):
                raise InputError(f"suite {s} failed: {e}; {where}") from e
            e.add_note(f"cepam-gym bench: suite {s} failed; {where}")
            raise
        if not args.json:
            add_scores(rows)
            _write(out, rows)


def main(argv: list[str] | None = None) -> int:
    ap = CommandParser(prog="cepam-gym bench", description=__doc__)
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
        help=f"one of {list(SUITES)}, 'all', or a version such as 'v2' (the suites of its ids) (repeatable; "
        "default: a trained agent's headline suites, those of its env id, else all)",
    )
    ap.add_argument(
        "--episodes", type=int, default=None, help="episodes per suite (default: the suite's, 20)"
    )
    ap.add_argument(
        "--env-id",
        help="the env id the agents were trained on (e.g. for a bare SB3 model .zip): the suites "
        "default to that id's suites",
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
    ap.add_argument(
        "--unseen",
        action="store_true",
        help="with --update-references: measure them on the unseen seed's episodes instead (those "
        "the reference grid scores every run on a second time) and store them in their own table "
        "(default: the suites that table holds)",
    )
    args = ap.parse_args(argv)
    controllers = args.controller or ["baseline"]
    for c in controllers:
        check_controller_spec(c)  # before any work; the CLI prints its ValueError as one line
    suites = args.suite or default_suites(controllers, args.env_id)
    if args.unseen and not args.suite:  # regenerate the unseen table's own suites, not every suite
        from .references import load

        suites = sorted(load("unseen"))
    if "all" in suites:  # every suite whose extra is installed (the joint suite needs mujoco)
        suites = [s for s in SUITES if available(s)]
    suites = list(dict.fromkeys(n for s in suites for n in expand_version(s)))
    bad = [s for s in suites if s not in SUITES]
    if bad:
        ap.error(f"unknown suite(s) {bad}; choose from {list(SUITES)} or 'all'")
    if args.episodes is not None and args.episodes < 1:
        ap.error("--episodes must be >= 1")
    if args.unseen and not args.update_references:
        ap.error("--unseen goes with --update-references")
    if args.update_references:
        if args.episodes is not None:
            ap.error("--update-references measures at each suite's default episodes: drop --episodes")
        import time

        from .harness import measure_references
        from .references import UNSEEN_EPISODES, UNSEEN_SEED, store

        episodes, seed, table = (
            (UNSEEN_EPISODES, UNSEEN_SEED, "unseen") if args.unseen else (None, None, "suite")
        )
        for s in suites:
            if _oracle_drives(s):
                t = time.perf_counter()
                store({s: (entry := measure_references(s, episodes, seed))}, table)
                print(
                    f"{s}: zero {entry['zero']:.6g}, baseline {entry['baseline']:.6g}, oracle "
                    f"{entry['oracle']:.6g} ({time.perf_counter() - t:.0f} s)",
                    flush=True,
                )
        return 0
    check_agents_fit(controllers, suites)

    from ..progress import runs

    rows, traces = [], {}
    with runs(len(suites) * len(controllers), "cepam-gym bench"):
        _run_suites(args, controllers, suites, rows, traces)
    # a normalized score needs both ends measured on these episodes: run the missing ones, or say so
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
    _write(out, rows)
    print(report.table(rows))
    for (s, c), tr in traces.items():
        name = f"traces_{s}_{Path(c).name}.png"
        report.plot_traces(tr, f"{c} on {s} (episode 0)", out / name, spec=SUITES[s].traces)
    report.plot_bars(rows, out / "scores.png")
    print(f"wrote {out}/table.txt, results.json, scores.png and traces_*.png")
    return 0
