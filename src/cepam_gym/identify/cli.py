"""``cepam-gym identify`` and ``cepam-gym excite`` (docs/identify.md)."""

from __future__ import annotations

import argparse
import shlex
from pathlib import Path

from ..cli_errors import CommandParser
from ..errors import InputError
from ..plant import MODES
from ..plant.params import PlantParams, preset, preset_names


def _bounds(text: str) -> dict[str, tuple[float, float]]:
    out = {}
    for item in filter(None, (s.strip() for s in text.split(","))):
        try:
            k, rng = item.split("=")
            a, b = rng.split(":")
            out[k.strip()] = (float(a), float(b))
        except ValueError:
            raise InputError(f"--bounds: cannot read {item!r}; expected name=lo:hi") from None
    return out


def identify_main(argv: list[str] | None = None) -> int:
    """``cepam-gym identify``: fit, report, fitted YAML (and with --report, plots and JSON)."""
    ap = CommandParser(
        prog="cepam-gym identify",
        description="fit the plant's dynamics (valves, volumes, heat, friction, damping) and the "
        "sensors to a rig's logs (format: docs/identify.md)",
    )
    ap.add_argument("--data", action="append", default=[], help="log CSV; repeat to fit several jointly")
    ap.add_argument("--mode", default="valve", choices=sorted(MODES), help="what the logged commands drive")
    ap.add_argument(
        "--preset",
        default="balloon",
        help=f"base plant: the start and every frozen value ({', '.join(preset_names())})",
    )
    ap.add_argument("--out", help="fitted parameter YAML (loadable by PlantParams.from_yaml and gym.make)")
    ap.add_argument(
        "--holdout",
        action="append",
        default=[],
        help="log to score only (default: the last 25 %% of each --data)",
    )
    ap.add_argument("--report", metavar="DIR", help="write summary.json and one PNG per recording into DIR")
    ap.add_argument(
        "--free", action="append", default=[], help="also fit this parameter (repeatable; e.g. end_mass)"
    )
    ap.add_argument(
        "--only",
        action="append",
        default=[],
        help="fit only this plant parameter (repeatable; with the sensors) instead of the mode's "
        "default set: a short fit of what the rig may differ in; --free still adds",
    )
    ap.add_argument("--bounds", default="", help="override bounds: name=lo:hi,... (edge units)")
    ap.add_argument("--warmup", type=float, default=1.0, help="seconds at the start of each log not scored")
    ap.add_argument("--starts", type=int, default=4, help="starting points (1: the preset alone)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--self-check",
        metavar="DIR",
        help="simulate a rig outside every preset (60 s to fit, 20 s held out, sensor errors and "
        "noise) into DIR, identify it and compare with the truth; --data is then not used",
    )
    args = ap.parse_args(argv)
    from .report import format_report, recovery_lines, write_report
    from .run import identify

    if args.starts < 1:
        raise InputError(f"--starts must be >= 1, got {args.starts}")
    preset(args.preset)  # an unknown preset: one line before any work
    kw = dict(
        free=tuple(args.free),
        only=tuple(args.only),
        warmup_s=args.warmup,
        starts=args.starts,
        seed=args.seed,
        bounds=_bounds(args.bounds),
    )
    truth = None
    if args.self_check:
        from . import selfcheck

        ident, truth = selfcheck.run(args.self_check, args.preset, args.mode, **kw)
    else:
        if not args.data or not args.out:
            ap.error("--data and --out are required (or --self-check DIR)")
        ident = identify(args.data, args.preset, args.mode, holdout=args.holdout, **kw)
    print(format_report(ident))
    if truth is not None:
        print("recovered against the truth:")
        print("\n".join(recovery_lines(ident, truth)))
    if args.out:
        from .report import fitted_yaml

        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(fitted_yaml(ident, "cepam-gym identify " + shlex.join(argv or [])))
        PlantParams.from_yaml(out)  # round trip: the file loads
        print(f"wrote {out}")
    if args.report:
        for p in write_report(ident, args.report):
            print(f"report: {p}")
    return 0


def excite_parser() -> argparse.ArgumentParser:
    """The options of ``cepam-gym excite`` (:mod:`cepam_gym.rig.cli` adds ``--rig``)."""
    ap = CommandParser(
        prog="cepam-gym excite",
        description="write an excitation command schedule (steps, chirps, PRBS on both valves, a few "
        "loads) in the log format; --simulate adds what a plant's sensors would measure",
    )
    ap.add_argument("--out", required=True, help="CSV to write")
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument(
        "--rate",
        type=float,
        help="sample rate [Hz], 50-2000 (default 500; on a rig, 50: the envs' control rate)",
    )
    ap.add_argument("--mode", default="valve", choices=sorted(MODES))
    ap.add_argument(
        "--loads-g", help="hanging loads to cycle through [g] (default 0,100,200; on a rig: its one load)"
    )
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--simulate", action="store_true", help="also write the measured columns of a simulated rig"
    )
    ap.add_argument("--preset", default="balloon", help="with --simulate: the plant")
    ap.add_argument("--params", help="with --simulate: a plant parameter YAML (overrides --preset)")
    ap.add_argument("--noise-kpa", type=float, default=0.2, help="with --simulate: pressure noise sd [kPa]")
    ap.add_argument("--noise-mm", type=float, default=0.03, help="with --simulate: length noise sd [mm]")
    return ap


def excite_loads(text: str) -> tuple[float, ...]:
    """The loads [g] of ``--loads-g``."""
    try:
        return tuple(float(s) for s in text.split(",") if s.strip())
    except ValueError:
        raise InputError(f"--loads-g: expected comma-separated grams, got {text!r}") from None


def excite_main(argv: list[str] | None = None, args=None) -> int:
    """``cepam-gym excite``: an excitation schedule to play on a rig, or the log a plant writes
    (``args``: options already parsed by :func:`excite_parser`)."""
    args = args if args is not None else excite_parser().parse_args(argv)
    from .excite import schedule, simulate_log
    from .logs import write_log

    args.rate = args.rate or 500.0
    loads = excite_loads(args.loads_g or "0,100,200")
    cols = schedule(args.seconds, args.rate, args.mode, loads, args.seed)
    if args.simulate:
        if min(args.noise_kpa, args.noise_mm) < 0:
            raise InputError("--noise-kpa and --noise-mm must be >= 0")
        params = PlantParams.from_yaml(args.params) if args.params else preset(args.preset)
        noise = (args.noise_kpa * 1e3, args.noise_kpa * 1e3, args.noise_mm * 1e-3)
        cols = simulate_log(cols, params, args.mode, noise=noise, seed=args.seed)
    path = write_log(args.out, cols)
    what = "simulated log" if args.simulate else "command schedule (play it, log the measured columns)"
    print(f"wrote {path}: {what}, {args.seconds:g} s at {args.rate:g} Hz, {args.mode} mode")
    return 0
