"""The headline score: one definition (cepam_gym.bench.headline), its ends stored per suite, and the
same function behind ``cepam-gym bench``, ``cepam-gym eval`` and the agents' comparison."""

from __future__ import annotations

import json
import math

import pytest

from cepam_gym.bench import references
from cepam_gym.bench.cli import add_headline, add_scores, main
from cepam_gym.bench.headline import headline_score
from cepam_gym.errors import InputError


def test_the_baseline_reads_0_the_oracle_100_and_worse_than_the_baseline_is_negative():
    assert headline_score(0.8, 0.8, 0.0) == 0.0
    assert headline_score(0.0, 0.8, 0.0) == 100.0
    assert headline_score(0.2, 0.8, 0.0) == pytest.approx(75.0)
    assert headline_score(1.6, 0.8, 0.0) == pytest.approx(-100.0)
    assert headline_score(-0.08, 0.8, 0.0) == pytest.approx(110.0)  # better than the oracle: above 100
    # the scale is linear in the raw score: equal steps of the score, equal steps of the headline
    a, b, c = (headline_score(s, 0.31, 0.01) for s in (0.25, 0.19, 0.13))
    assert b - a == pytest.approx(c - b) == pytest.approx(20.0)


@pytest.mark.parametrize(
    "baseline, oracle", [(0.5, 0.5), (0.1, 0.3), (math.nan, 0.01), (0.3, math.inf), (math.inf, 0.01)]
)
def test_a_degenerate_span_is_a_clear_error(baseline, oracle):
    with pytest.raises(InputError, match=r"baseline \(.*\) to score worse \(higher\) than the oracle"):
        headline_score(0.2, baseline, oracle)


def _row(suite, controller, score, episodes=2):
    return {"suite": suite, "controller": controller, "score": score, "episodes": episodes}


def test_rows_take_their_ends_from_the_run_or_from_the_stored_references():
    # a run on other episodes than the stored ones: the ends of this run
    rows = [_row("nominal-v2", c, s) for c, s in (("agent", 0.2), ("baseline", 0.3), ("oracle", 0.1))]
    add_headline(rows)
    assert [r["headline"] for r in rows] == pytest.approx([50.0, 0.0, 100.0])
    assert {r["headline_from"] for r in rows} == {"this run"}
    # the suite's own episodes: the stored baseline and oracle
    stored = references.load()["nominal-v2"]
    rows = [_row("nominal-v2", "agent", 0.5 * (stored["baseline"] + stored["oracle"]), stored["episodes"])]
    add_scores(rows)
    assert rows[0]["headline"] == pytest.approx(50.0) and rows[0]["headline_from"] == "reference scores"
    assert "normalized" in rows[0]
    # neither: no headline (the command says what to run)
    rows = [_row("nominal-v2", "agent", 0.2)]
    add_headline(rows)
    assert "headline" not in rows[0]


def test_every_stored_suite_has_its_baseline_between_zero_and_oracle():
    for name, entry in references.load().items():
        assert entry["oracle"] < entry["baseline"] < entry["zero"], name
        assert headline_score(entry["zero"], entry["baseline"], entry["oracle"]) < 0, name


def test_bench_prints_the_headline_of_the_stored_baseline(tmp_path, capsys):
    """The baseline on its suite's 20 episodes reads 0 against the stored references (cheap: the
    baseline drives in seconds), in the JSON rows and in the printed table with its legend."""
    name = "length-v1"
    assert main(["--controller", "baseline", "--suite", name, "--json"]) == 0
    (row,) = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert row["headline"] == pytest.approx(0.0, abs=1e-6) and row["headline_from"] == "reference scores"
    assert row["score"] == pytest.approx(references.load()[name]["baseline"], rel=1e-9)
    assert main(["--controller", "zero", "--suite", name, "--out-dir", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    head, _, zero_row = out.splitlines()[:3]
    assert "headline" in head and "normalized" in head
    entry = references.load()[name]
    expected = headline_score(entry["zero"], entry["baseline"], entry["oracle"])
    assert f"{expected:12.3f}" in zero_row and "0 = the inverse-model baseline" in out
    assert (tmp_path / "table.txt").read_text().startswith(head)


@pytest.mark.slow
def test_eval_and_the_agents_comparison_use_the_same_function():
    pytest.importorskip("cepam_gym_agents")
    from cepam_gym_agents import compare, evaluate

    assert not hasattr(evaluate, "gap_closed")  # no second definition
    rows = [_row("nominal-v1", c, s) for c, s in (("agent", 0.118), ("baseline", 0.3122), ("oracle", 0.0061))]
    (gap,) = evaluate.gaps_closed(rows)
    assert gap["headline"] == headline_score(0.118, 0.3122, 0.0061)
    assert (gap["baseline_headline"], gap["oracle_headline"], gap["mpc_headline"]) == (0.0, 100.0, None)
    cache = {}
    for suite in compare.SUITES:
        for where, names in (("suite", compare.CONTROLLERS), ("unseen", compare.UNSEEN_CONTROLLERS)):
            cache.update({f"{suite}|{where}|{n}": 0.25 for n in names})
            cache[f"{suite}|{where}|baseline"], cache[f"{suite}|{where}|oracle"] = 0.3122, 0.0061
            cache.update({f"{suite}|{where}|student-s{s}": 0.118 for s in range(5)})
    md = compare.table(["student"], range(5), cache)
    assert f"| {headline_score(0.118, 0.3122, 0.0061):.0f} |" in md
    assert f"| {headline_score(0.25, 0.3122, 0.0061):.0f} |" in md  # the MPC's row
