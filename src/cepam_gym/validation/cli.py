"""``cepam-gym validate`` and ``cepam-gym calibrate``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..cli_errors import CommandParser
from ..plant.params import PlantParams, preset
from .calibrate_v2 import calibrate_v2
from .crossval import cross_validate, format_cross_validation
from .experiments import load_experiments
from .fit import fit, fitted_yaml, format_report, minimax
from .measurements import read_csv, write_paper_csvs
from .plots import plot_fit, write_plots
from .static_params import DEFAULT_FIT, FIT_PARAMS, V1_BOUNDS, V1_FIT, V1_STARTS
from .table import base_params, format_headline, format_table, geometry_lines, json_rows, validation_rows


def validate_main(argv: list[str] | None = None) -> int:
    """``cepam-gym validate``: the table, its JSON and the plots."""
    ap = CommandParser(
        prog="cepam-gym validate",
        description="the paper's reported numbers beside the model's (computed, never stored)",
    )
    ap.add_argument("--json", action="store_true", help="print the rows as a JSON list (no plots)")
    ap.add_argument(
        "--preset", default=None, help="plant preset to validate (default: the dataclass defaults = balloon)"
    )
    ap.add_argument("--params", default=None, help="plant parameter YAML to validate (overrides --preset)")
    ap.add_argument("--out-dir", default="runs/validate", help="where the plots and the table go")
    args = ap.parse_args(argv)
    params = base_params(args.preset, args.params)
    experiments = load_experiments()
    rows = validation_rows(params, experiments=experiments)
    if args.json:
        print(json.dumps(json_rows(rows), indent=1))
        return 0
    what = (
        (args.params or f"preset {args.preset}")
        if (args.params or args.preset)
        else "default plant (balloon)"
    )
    table = "\n".join(
        [
            format_table(rows, title=f"reproduction table: {what}"),
            "",
            format_headline(rows),
            "",
            geometry_lines(params),
        ]
    )
    print(table)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / "validate.txt").write_text(table + "\n")
    (out / "validate.json").write_text(json.dumps(json_rows(rows), indent=1))
    for path in write_plots(params, experiments, rows, out):
        print(f"plot: {path}")
    print(f"table: {out / 'validate.txt'}, {out / 'validate.json'}")
    return 0


def calibrate_main(argv: list[str] | None = None) -> int:
    """``cepam-gym calibrate``: fit, report, fitted YAML and residual plot."""
    ap = CommandParser(
        prog="cepam-gym calibrate",
        description="fit unknown plant parameters to measured static data (format: docs/calibration.md)",
    )
    ap.add_argument(
        "--data",
        action="append",
        help="measurement CSV; repeat to fit several files jointly (the paper's numbers: "
        "cepam_gym/data/paper_cepam.csv and paper_single_muscles.csv)",
    )
    ap.add_argument("--out", help="fitted parameter YAML to write (loadable by PlantParams.from_yaml)")
    ap.add_argument(
        "--preset",
        default=None,
        help="base preset: the start and every unfitted value (default balloon; with --v2 balloon_v2)",
    )
    ap.add_argument(
        "--fit",
        default=",".join(DEFAULT_FIT),
        help=f"comma-separated parameters to fit; one of {sorted(FIT_PARAMS)}",
    )
    ap.add_argument("--bounds", default="", help="override bounds: name=lo:hi,... (edge units)")
    ap.add_argument(
        "--starts", type=int, default=1, help="starting points (1 = the preset; more: seeded random)"
    )
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--plot", default=None, help="residual plot (default: next to --out, .png)")
    ap.add_argument(
        "--minimax",
        action="store_true",
        help="also search (differential evolution, about a minute) for the smallest "
        "largest error the fit parameters can reach inside their bounds",
    )
    ap.add_argument(
        "--v1",
        action="store_true",
        help="plant v1's calibration: every computable reported number of "
        "data/reported.yaml (CE-PAM, single CPAM and EPAM, tube rows) at once, "
        "parameters and bounds of docs/calibration.md ('Plant v1'), several starts; "
        "--data, --fit and --starts are then not used (about a minute)",
    )
    ap.add_argument(
        "--v2",
        action="store_true",
        help="plant v2's calibration: every computable reported number through the paper's "
        "protocols on the dynamic plant (docs/calibration.md, 'Plant v2'); --data, --fit and "
        "--starts are then not used (about a minute)",
    )
    ap.add_argument(
        "--no-priors",
        action="store_true",
        help="with --v2: the plain least-squares fit, without the weak literature priors of "
        "calibrate_v2.PRIORS (maximum a posteriori by default)",
    )
    ap.add_argument(
        "--cv",
        action="store_true",
        help="with --v1 or --v2: also the leave-one-experiment-group-out cross-validation "
        "(one more fit per group, several minutes)",
    )
    ap.add_argument(
        "--write-paper-csv",
        metavar="DIR",
        default=None,
        help="write the paper's numbers (data/reported.yaml) as paper_cepam.csv and "
        "paper_single_muscles.csv into DIR and exit",
    )
    args = ap.parse_args(argv)
    if args.write_paper_csv:
        for path in write_paper_csvs(args.write_paper_csv):
            print(f"wrote {path}")
        return 0
    if args.v1 and args.v2:
        ap.error("choose one of --v1 and --v2")
    if args.v2:
        if not args.out:
            ap.error("--out is required")
        name = args.preset or "balloon_v2"
        return calibrate_v2(preset(name), args.out, cv=args.cv, preset_name=name, priors=not args.no_priors)
    args.preset = args.preset or "balloon"
    if args.v1:
        return _calibrate_v1(args)
    if not args.data or not args.out:
        ap.error("--data and --out are required")
    names = tuple(s.strip() for s in args.fit.split(",") if s.strip())
    bounds = {}
    for item in filter(None, (s.strip() for s in args.bounds.split(","))):
        try:
            k, rng = item.split("=")
            a, b = rng.split(":")
            bounds[k.strip()] = (float(a), float(b))
        except ValueError:
            ap.error(f"--bounds: cannot read {item!r}; expected name=lo:hi")
    base = preset(args.preset)
    experiments = [m.experiment for path in args.data for m in read_csv(path)]
    res = fit(experiments, base, names, starts=args.starts, seed=args.seed, bounds=bounds)
    report = format_report(res, experiments)
    print(
        f"calibration of preset {args.preset!r} ({base.force_model}/{base.force_form}) "
        f"to {', '.join(args.data)}: "
        f"{len(experiments)} measurements, {len(names)} parameters"
    )
    print(report)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    data = " ".join(f"--data {d}" for d in args.data)
    header = (
        f"fitted by `cepam-gym calibrate {data} --preset {args.preset} --fit {','.join(names)}`\n"
        f"mean |relative error| {100 * np.abs(res.residuals).mean():.2f}% over {len(experiments)} "
        f"measurements; the full report is printed by the command"
    )
    out.write_text(fitted_yaml(res, args.preset, header))
    PlantParams.from_yaml(out)  # round trip: the file loads
    plot = plot_fit(res, experiments, args.plot or out.with_suffix(".png"))
    print(f"wrote {out} and {plot}")
    if args.minimax:
        worst, x = minimax(experiments, base, names, bounds=bounds, seed=args.seed)
        pars = ", ".join(f"{n} = {v:.4g}" for n, v in zip(names, x))
        print(f"minimax check: the smallest largest |error| inside the bounds is {100 * worst:.2f}% ({pars})")
    return 0


def _calibrate_v1(args) -> int:
    """``cepam-gym calibrate --v1``: plant v1 fitted to every computable reported number."""
    if not args.out:
        raise SystemExit("cepam-gym calibrate --v1: --out is required")
    base = preset(args.preset)
    experiments = [e for e in load_experiments() if e.computable and not e.derived_from]
    starts = [list(x) for x in V1_STARTS]
    res = fit(experiments, base, V1_FIT, bounds=V1_BOUNDS, x0s=starts, max_nfev=40 * len(V1_FIT), tol=1e-7)
    print(
        f"plant v1 calibration of preset {args.preset!r} to the {len(experiments)} computable reported "
        f"numbers (data/reported.yaml), {len(V1_FIT)} parameters, bounds of docs/calibration.md"
    )
    print(format_report(res, experiments))
    if args.cv:
        print(
            format_cross_validation(
                cross_validate(
                    experiments,
                    base,
                    V1_FIT,
                    bounds=V1_BOUNDS,
                    x0s=starts,
                    max_nfev=40 * len(V1_FIT),
                    full=res,
                )
            )
        )
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    header = (
        f"fitted by `cepam-gym calibrate --v1 --preset {args.preset}`\n"
        f"mean |relative error| {100 * np.abs(res.residuals).mean():.2f}% over {len(experiments)} "
        "reported numbers; the full report is printed by the command"
    )
    out.write_text(fitted_yaml(res, args.preset, header))
    PlantParams.from_yaml(out)
    print(f"wrote {out}")
    return 0
