"""``cepam-gym dataset``: record a Minari dataset of a controller or a trained agent on a
benchmark suite; the dataset id is the last line printed."""

from __future__ import annotations

import sys

from ..bench.suites import SUITES
from ..cli_errors import CommandParser
from ..control import controller_names


def main(argv: list[str] | None = None) -> int:
    ap = CommandParser(prog="cepam-gym dataset", description=__doc__)
    ap.add_argument("--suite", required=True, help=f"one of {', '.join(SUITES)}")
    ap.add_argument(
        "--controller",
        required=True,
        help=f"one of {', '.join(controller_names())}, or a trained agent's run directory",
    )
    ap.add_argument("--episodes", type=int, default=None, help="episodes (default: the suite's, 20)")
    ap.add_argument("--seed", type=int, default=None, help="another seed than the suite's (other episodes)")
    ap.add_argument("--max-steps", type=int, default=None, help="cut each episode after this many steps")
    ap.add_argument("--name", default=None, help="dataset name (default: <task>-<controller>)")
    ap.add_argument("--dataset-version", type=int, default=0, help="the id's -v<N> (default 0)")
    ap.add_argument("--overwrite", action="store_true", help="replace a dataset of the same id")
    ap.add_argument("--json", action="store_true", help="print the summary as JSON before the id")
    args = ap.parse_args(argv)
    from . import store
    from .record import check_inputs, record_dataset

    check_inputs(args.suite, args.controller, args.episodes, args.max_steps, args.name, args.dataset_version)
    try:
        from .store import require_minari

        require_minari()
    except ImportError as e:
        print(f"cepam-gym dataset: error: {e}", file=sys.stderr)
        return 2
    from ..progress import runs

    with runs(1, "cepam-gym dataset"):
        out = record_dataset(
            args.suite,
            args.controller,
            args.episodes,
            seed=args.seed,
            max_steps=args.max_steps,
            name=args.name,
            dataset_version=args.dataset_version,
            overwrite=args.overwrite,
        )
    if not store.reference_scores(SUITES[out["suite"]]):
        from ..bench.cli import _oracle_drives

        how = (
            f"cepam-gym bench --update-references --suite {out['suite']} measures them"
            if _oracle_drives(out["suite"])
            else "the oracle does not drive this suite"
        )
        print(
            f"cepam-gym dataset: no reference returns stored for {out['suite']}: the dataset has no "
            f"ref_min_score / ref_max_score (minari.get_normalized_score refuses it; {how})",
            file=sys.stderr,
            flush=True,
        )
    if args.json:
        import json

        print(json.dumps(out), flush=True)
    else:
        head, norm = ("-" if out[k] is None else f"{out[k]:.1f}" for k in ("headline", "normalized"))
        print(
            f"{out['controller']} on {out['suite']}: {out['episodes']} episodes, {out['steps']} steps in "
            f"{out['record_seconds']:.1f} s, {out['size_mb']:.1f} MB at {out['path']}; benchmark score "
            f"{out['score']:.4g}, headline {head}, normalized {norm}"
            + ("" if out["suite_episodes"] else " (not the suite's episodes: not the benchmark's figure)"),
            flush=True,
        )
    print(out["dataset_id"], flush=True)
    return 0
