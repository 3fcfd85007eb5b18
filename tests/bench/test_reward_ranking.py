"""On the v3 ids the mean return ranks controllers as the benchmark's score does (ties within 2 %).

``docs/results/reward_ranking.json`` holds the ranking on every v3 headline suite at its 20
episodes (``python benchmarks/reward_ranking.py --json docs/results/reward_ranking.json``
regenerates it); the fast test checks that file covers every v3 headline suite with the controllers
the claim names and agrees; the slow test re-runs the ranking on shortened episodes of the nominal
suite, the oracle and the near-oracle included.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

from cepam_gym import versions
from cepam_gym.bench.suites import SUITES

ROOT = Path(__file__).resolve().parents[2]
STORED = ROOT / "docs" / "results" / "reward_ranking.json"


def _bench():
    spec = importlib.util.spec_from_file_location("reward_ranking", ROOT / "benchmarks" / "reward_ranking.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_agree_is_the_same_order_by_score_and_by_return_ties_left_unordered():
    bench = _bench()
    rows = [
        {"controller": "a", "score": 1.0, "mean_return": -10.0},
        {"controller": "b", "score": 0.5, "mean_return": -3.0},
    ]
    assert bench.agree(rows) and not bench.ties(rows)
    rows[1]["mean_return"] = -20.0
    assert not bench.agree(rows) and bench.misordered(rows) == [("a", "b")]
    rows[1]["score"] = 0.99  # within 2 % of a's: a tie, which the return may order either way
    assert bench.agree(rows) and bench.ties(rows) == [("a", "b")]


def test_the_stored_ranking_covers_every_v3_headline_suite_and_agrees():
    stored = json.loads(STORED.read_text())
    headline = [s for row in versions.VERSIONS.values() if row.version == 3 for s in row.suites]
    assert sorted(stored["suites"]) == sorted(headline)
    for name, entry in stored["suites"].items():
        labels = {r["controller"] for r in entry["rows"]}
        assert {"zero", "random", "oracle", "oracle (allowance_weight=1)"} <= labels, name
        rig = SUITES[name].traces.quantity != "angle"
        assert labels >= ({"baseline", "mpc", "adaptive_mpc"} if rig else {"joint_baseline"}), name
        assert entry["episodes"] == 20, name
        assert _bench().agree(entry["rows"]), f"{name}: the return ranks otherwise than the score"


@pytest.mark.slow
def test_return_ranks_as_the_score_on_shortened_episodes():
    bench = _bench()
    rows = bench.rank("nominal-v3", episodes=3, max_steps=150)
    assert len(rows) == 7
    assert bench.agree(rows), rows


def test_the_results_page_holds_the_stored_ranking():
    page = (ROOT / "docs" / "results" / "benchmark.md").read_text()
    assert _bench().markdown(json.loads(STORED.read_text())) in page, (
        "docs/results/benchmark.md: paste `python benchmarks/reward_ranking.py --markdown "
        "docs/results/reward_ranking.json` again"
    )
