"""Agents against the model-based controllers, over training seeds: the README's "Agents that adapt"
table.

    python -m cepam_gym_agents.compare --config student --seeds 5 --jobs 2
    python -m cepam_gym_agents.compare --config student --config quick --seeds 5 --report-only
    python -m cepam_gym_agents.compare --config student_adaptive --suite randomized-id-v2 \
        --controller baseline --controller identify_mpc --controller mpc_known_params --controller oracle

Each config is trained once per seed (``cepam-gym train --config C --seed S``, its own process;
``--jobs 2`` runs two at a time, each on one core's numba thread, ``--jobs 1`` one on all cores)
into ``--out/<config>-s<seed>``, then its final model is scored on each suite's own 20 episodes
and on 20 episodes of an unseen seed (``--unseen-seed``; ``--unseen-episodes`` more of them, where 20
episodes cannot separate two agents), beside the baseline and the oracle on
the same episodes (their stored references where measured on those episodes; and the MPCs on the
suites' episodes; ``--suite`` and ``--controller`` choose others: then the controllers run on both
episode sets; ``--no-unseen-oracle``: no oracle on unseen episodes it has no stored reference for).
Per config and suite: the interquartile mean over seeds with a 95 % stratified-bootstrap interval
(Agarwal et al. 2021, :mod:`cepam_gym.bench.stats`), and its headline score, the share of the
baseline-to-oracle gap it closes (:func:`cepam_gym.bench.headline.headline_score`). Written to
``--out/compare.json`` and ``compare.md``.
"""

from __future__ import annotations

import json
from pathlib import Path

from cepam_gym.cli_errors import CommandParser

from .grid.trials import RAY_HELP

SUITES = ("nominal-v1", "randomized-v1")
CONTROLLERS = ("baseline", "mpc", "adaptive_mpc", "oracle")
UNSEEN_CONTROLLERS = ("baseline", "oracle")  # what the gap on an unseen seed needs


def train_runs(configs: list[str], seeds: list[int], out: Path, jobs: int, ray: str | None = None) -> None:
    """Every (config, seed) not yet trained: ``jobs`` processes at a time on this machine, or (``ray``:
    a Ray address, ``"local"`` for a new instance here) as Ray tasks of ``cores / jobs`` cores each
    (:mod:`agents.grid.trials`)."""
    from .grid.trials import Trial, run_trials

    todo = [
        Trial(c, s, out / f"{Path(c).stem}-s{s}")
        for c in configs
        for s in seeds
        if not (out / f"{Path(c).stem}-s{s}" / "model.zip").is_file()
    ]
    run_trials(todo, jobs, ray)


def score(spec: str, suite: str, seed: int | None, episodes: int = 20) -> float:
    """The benchmark score of controller ``spec`` on ``episodes`` episodes of ``suite`` from
    ``seed`` (None: the suite's own): the stored reference where the zero controller's, the
    baseline's or the oracle's was measured on these episodes, else measured."""
    from cepam_gym.bench.harness import run_suite, seeded

    from .grid.report import stored

    known = stored(spec, suite, seed, episodes)
    if known is not None:
        return known
    return float(run_suite(spec, seeded(suite, seed), episodes)[0]["score"])


def unseen_set(episodes: int = 20) -> str:
    """The name of the unseen seed's episode set in the cache and the table: ``unseen`` for the
    usual 20, ``unseen-<N>`` for another count (scores over different episode sets never mix)."""
    return "unseen" if episodes == 20 else f"unseen-{episodes}"


def measure(
    configs,
    seeds,
    out: Path,
    unseen: int,
    cache: dict,
    suites=SUITES,
    controllers=None,
    unseen_episodes=20,
    unseen_oracle=True,
) -> dict:
    """Scores of every run and controller (``cache``: what an earlier call measured, kept);
    ``controllers`` (None: :data:`CONTROLLERS`, and :data:`UNSEEN_CONTROLLERS` on the unseen seed);
    ``unseen_episodes`` of the unseen seed; ``unseen_oracle`` False: the oracle on the unseen seed
    only where its reference is stored (the table then gives no headline there)."""
    from cepam_gym.progress import runs

    sets = (("suite", None, 20), (unseen_set(unseen_episodes), unseen, unseen_episodes))
    todo = sum(
        len(_controllers(where, controllers)) + len(configs) * len(seeds)
        for _ in suites
        for where, _, _ in sets
    )
    with runs(todo, "compare: scoring"):
        _score_all(configs, seeds, out, cache, suites, controllers, sets, unseen_oracle)
    return cache


def _score_all(configs, seeds, out: Path, cache: dict, suites, controllers, sets, unseen_oracle) -> None:
    """The loop of :func:`measure` (cached keys are skipped; their bar steps go by unadvanced)."""
    from .grid.report import stored

    for suite in suites:
        for where, seed, episodes in sets:
            for name in _controllers(where, controllers):
                key = f"{suite}|{where}|{name}"
                skip = name == "oracle" and seed is not None and not unseen_oracle
                if key not in cache and not (skip and stored(name, suite, seed, episodes) is None):
                    cache[key] = score(name, suite, seed, episodes)
                    (out / "compare.json").write_text(json.dumps(cache, indent=1))
            for c in configs:
                for s in seeds:
                    key = f"{suite}|{where}|{Path(c).stem}-s{s}"
                    if key not in cache:
                        cache[key] = score(str(out / f"{Path(c).stem}-s{s}"), suite, seed, episodes)
                        (out / "compare.json").write_text(json.dumps(cache, indent=1))


def _controllers(where: str, controllers) -> tuple:
    """The controllers scored on an episode set (the headline needs the baseline and the oracle)."""
    if controllers is None:
        return CONTROLLERS if where == "suite" else UNSEEN_CONTROLLERS
    return tuple(dict.fromkeys(("baseline", *controllers, "oracle")))


def table(configs, seeds, cache: dict, suites=SUITES, controllers=None, unseen_episodes=20) -> str:
    import numpy as np

    from cepam_gym.bench.headline import headline_score
    from cepam_gym.bench.stats import MIN_SEEDS, iqm_interval

    lines = [
        "| suite | episodes | controller | score (IQM over seeds, 95 % CI) | headline (gap closed) |",
        "|---|---|---|---|---|",
    ]
    for suite in suites:
        for where in ("suite", unseen_set(unseen_episodes)):
            base, orc = cache[f"{suite}|{where}|baseline"], cache.get(f"{suite}|{where}|oracle")

            def gap(v, base=base, orc=orc):  # no oracle measured on these episodes: no headline
                return "-" if orc is None else f"{headline_score(v, base, orc):.0f}"

            for name in _controllers(where, controllers):
                v = cache.get(f"{suite}|{where}|{name}")
                if v is None:
                    continue
                lines.append(f"| {suite} | {where} | {name} | {v:.4f} | {gap(v)} |")
            for c in configs:
                vals = [cache[f"{suite}|{where}|{Path(c).stem}-s{s}"] for s in seeds]
                if len(vals) >= MIN_SEEDS:
                    iqm, lo, hi = iqm_interval({"x": vals})["x"]
                    cell = f"**{iqm:.4f}** ({lo:.4f}-{hi:.4f})"
                else:  # too few seeds for an IQM: the mean and the range, said so
                    iqm = float(np.mean(vals))
                    cell = f"**{iqm:.4f}** (mean, range {min(vals):.4f}-{max(vals):.4f}; no IQM"
                    cell += f" under {MIN_SEEDS} seeds)"
                lines.append(
                    f"| {suite} | {where} | **{Path(c).stem}** ({len(seeds)} seeds) | {cell} | {gap(iqm)} |"
                )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = CommandParser(prog="python -m cepam_gym_agents.compare", description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--config", action="append", required=True, help="a shipped config name or a file (repeatable)"
    )
    ap.add_argument("--seeds", type=int, default=5, help="training seeds 0..N-1 (at least 5 for the IQM)")
    ap.add_argument("--jobs", type=int, default=2, help="trainings at a time (per machine with --ray)")
    ap.add_argument(
        "--ray",
        metavar="ADDRESS",
        help=RAY_HELP,
    )
    ap.add_argument("--unseen-seed", type=int, default=99000, help="the episodes no suite uses")
    ap.add_argument(
        "--unseen-episodes",
        type=int,
        default=20,
        help="episodes of the unseen seed (more separate close agents)",
    )
    ap.add_argument(
        "--no-unseen-oracle",
        dest="unseen_oracle",
        action="store_false",
        help="no oracle on the unseen seed unless its reference is stored (most of the scoring's "
        "cost on many episodes): the unseen rows then give scores without a headline",
    )
    ap.add_argument("--out", default="runs/compare", help="run directories and the results")
    ap.add_argument("--report-only", action="store_true", help="score and report the runs already trained")
    ap.add_argument(
        "--suite", action="append", help=f"a suite to score on (repeatable; default {', '.join(SUITES)})"
    )
    ap.add_argument(
        "--controller",
        action="append",
        help="a registered controller to score beside the agents, on both episode sets (repeatable; "
        "the baseline and the oracle always are); default: the MPCs on the suites' episodes",
    )
    args = ap.parse_args(argv)
    if args.seeds < 1 or args.jobs < 1 or args.unseen_episodes < 1:
        ap.error("--seeds, --jobs and --unseen-episodes must be >= 1")
    from cepam_gym.bench.suites import SUITES as ALL
    from cepam_gym.control import controller_names

    suites = tuple(args.suite or SUITES)
    for name in suites:
        if name not in ALL:
            ap.error(f"unknown suite {name!r}; one of {', '.join(sorted(ALL))}")
    for name in args.controller or ():
        if name not in controller_names():
            ap.error(f"unknown controller {name!r}; one of {', '.join(controller_names())}")
    if args.ray is not None:
        import importlib.util

        from .grid.trials import NO_RAY

        if importlib.util.find_spec("ray") is None:
            ap.error(NO_RAY)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    seeds = list(range(args.seeds))
    if not args.report_only:
        train_runs(args.config, seeds, out, args.jobs, args.ray)
    path = out / "compare.json"
    cache = json.loads(path.read_text()) if path.is_file() else {}
    n = args.unseen_episodes
    cache = measure(
        args.config, seeds, out, args.unseen_seed, cache, suites, args.controller, n, args.unseen_oracle
    )
    md = table(args.config, seeds, cache, suites, args.controller, n)
    (out / "compare.md").write_text(md)
    print(md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
