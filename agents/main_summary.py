"""``runs/main/summary.md`` of the main job (:mod:`.main_job`): what ``cepam-gym run`` ran, with
which versions, where every output is, how its agent's training ended and the scores, written at
the end of the job (also when a step failed: what exists)."""

from __future__ import annotations

import json
import platform
from datetime import UTC, datetime
from pathlib import Path

from .session.provenance import package_versions


def versions() -> dict[str, str]:
    """The run's package versions and machine facts (:func:`.session.provenance.package_versions`, the
    ones ``run.json`` records), as text."""
    return {k: "not installed" if v is None else str(v) for k, v in package_versions().items()}


def _rel(path: Path, out: Path) -> str:
    try:
        return str(path.relative_to(out))
    except ValueError:
        return str(path)


def _duration(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


def write_summary(
    out: Path,
    argv: list[str],
    started: datetime,
    steps: list,
    run_dir: Path | None,
    table: Path | None,
) -> Path:
    """``steps``: (what, status, output path[, elapsed seconds]) per step of the job, in order."""
    out = Path(out)
    ended = datetime.now(UTC)
    lines = [
        "# cepam-gym run: summary",
        "",
        f"`cepam-gym run {' '.join(argv)}` ran from {started.isoformat(timespec='seconds')} to "
        f"{ended.isoformat(timespec='seconds')} ({(ended - started).total_seconds():.0f} s), "
        f"in `{Path.cwd()}` on {platform.node() or 'this machine'} ({platform.platform()}).",
        "",
        "Versions: " + ", ".join(f"{k} {v}" for k, v in versions().items()) + ".",
        "",
        "## What ran and where its output is",
        "",
        "| step | status | time | output |",
        "|---|---|---|---|",
    ]
    for what, status, path, *seconds in steps:
        where = "-" if path is None else f"`{_rel(path, out)}`"
        took = _duration(seconds[0]) if seconds and seconds[0] is not None else "-"
        lines.append(f"| {what} | {status} | {took} | {where} |")
    if run_dir is not None and (run_dir / "run.json").is_file():
        lines += ["", "## Training", "", *_training_lines(run_dir, out)]
    if table is not None and table.is_file():
        lines += [
            "",
            "## Scores (lower is better)",
            "",
            f"From `{_rel(table, out)}`:",
            "",
            "```",
            table.read_text().rstrip(),
            "```",
        ]
        cmp = table.parent / "comparison.md"
        if cmp.is_file():  # the agent's headline beside the baseline's, the MPC's and the oracle's
            lines += ["", *cmp.read_text().rstrip().splitlines()[2:]]
    path = out / "summary.md"
    path.write_text("\n".join(lines) + "\n")
    return path


# what a run directory may hold (a PPO run all of them; a student no best model, checkpoints or logs)
_RUN_FILES = {
    "config.yaml": "reproduces the run",
    "run.json": "seed, versions, commit, sessions",
    "model.zip": "final",
    "best_model.zip": "best periodic evaluation",
    "checkpoints": "",
    "evaluations.json": "",
    "tb": "TensorBoard",
    "logs": "CSV",
}


def _training_lines(run_dir: Path, out: Path) -> list[str]:
    """How training ended (steps, or a student's DAgger rounds), and the files the run holds."""
    run = json.loads((run_dir / "run.json").read_text())
    last = run.get("sessions", [{}])[-1]
    if "rounds" in last:  # a student (agents/learners/student.py): DAgger rounds of teacher labels
        rounds = last["rounds"]
        how = (
            f"Status **{run.get('status')}** after {len(rounds)} DAgger rounds, "
            f"{last.get('steps', '?')} labels ({last.get('wall_s', '?')} s of training)"
        )
    else:
        how = (
            f"Status **{run.get('status')}** at step {last.get('end_step')} of "
            f"{last.get('total_timesteps', '?')} ({last.get('wall_s', '?')} s of training)"
        )
    files = [
        f"`{name}`" + (f" ({what})" if what else "")
        for name, what in _RUN_FILES.items()
        if (run_dir / name).exists()
    ]
    lines = [f"{how}; seed {run.get('seed')}. Run directory `{_rel(run_dir, out)}`: {', '.join(files)}."]
    if run.get("status") == "stopped_by_time_limit":
        more = (
            "a student cannot be resumed: train it again with a larger `time_limit_minutes`"
            if "rounds" in last
            else f"continue with `cepam-gym train --out {run_dir} --resume`"
        )
        lines.append(
            "The time limit of the config stopped training early: the scores below are of a "
            f"shorter run; {more}."
        )
    return lines
