"""The per-minute table of ``benchmarks/time_to_score.py``: what PPO reaches per minute of training,
read back from kept evaluations (training time = wall time less every evaluation's own)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _script():
    spec = importlib.util.spec_from_file_location("time_to_score", ROOT / "benchmarks" / "time_to_score.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _evals(points):
    """Evaluations at (training seconds, score), each taking 2 s of its own."""
    out, spent = [], 0.0
    for t, sc in points:
        spent += 2.0
        out.append({"step": int(t * 1000), "wall_s": t + spent, "eval_s": 2.0, "score": sc})
    return out


def test_best_so_far_per_minute_counts_training_time_and_keeps_a_stopped_runs_best():
    tts = _script()
    rows = tts.training_times(_evals([(30.0, 0.5), (70.0, 0.2), (110.0, 0.3)]))
    assert [t for t, _, _ in rows] == [30.0, 70.0, 110.0]  # the evaluations' own time taken out
    assert tts.best_by(rows, 60.0) == 0.5
    assert tts.best_by(rows, 120.0) == 0.2  # the best so far, not the latest
    assert tts.best_by(rows, 10.0) is None
    stopped = tts.training_times(_evals([(20.0, 0.1)]))  # reached the MPC at 20 s: stopped
    assert tts.best_by(stopped, 180.0) == 0.1

    runs = [_evals([(30.0, 0.5 + 0.01 * k), (100.0, 0.2 + 0.01 * k)]) for k in range(5)]
    results = {
        "CEPAM-v2": {
            "suite": "nominal-v2",
            "budget_s": 120.0,
            "yardsticks": {"baseline": 0.25, "mpc": 0.07},
            "runs": runs,
        }
    }
    table = tts.per_minute(results).splitlines()
    assert len(table) == 2 + 2  # header and one row per minute of the budget
    one, two = table[2].split(" | "), table[3].split(" | ")
    assert one[2] == "1 min" and one[3].startswith("0.52") and one[4] == "5 of 5"
    assert two[2] == "2 min" and two[3].startswith("0.22")
    few = {"CEPAM-v2": {**results["CEPAM-v2"], "runs": runs[:3]}}
    assert tts.per_minute(few).splitlines()[2].split(" | ")[3] == "-"  # no IQM under 5 seeds
