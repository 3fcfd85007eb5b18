"""Honest scores: stored references only for the episodes they were measured on (and kept
current by a slow test), intervals over episodes, IQM over seeds."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cepam_gym.bench import references
from cepam_gym.bench.cli import add_normalized, main, missing_ends
from cepam_gym.bench.harness import CHECK_EPISODES, CHECK_STEPS, measure_references
from cepam_gym.bench.metrics import RIG, score_interval, score_traces
from cepam_gym.bench.suites import SUITES


def test_stored_references_serve_only_the_episodes_they_were_measured_on():
    table = references.load()
    assert {"nominal-v1", "randomized-v1", "joint-v1"} <= set(table)
    e = table["nominal-v1"]
    assert e["episodes"] == SUITES["nominal-v1"].episodes and e["seed"] == SUITES["nominal-v1"].seed
    assert references.stored_ends("nominal-v1", 20, e["seed"]) == (e["zero"], e["oracle"])
    assert SUITES["nominal-v1"].reference == (e["zero"], e["oracle"])
    assert references.stored_ends("nominal-v1", 2, e["seed"]) is None
    assert references.stored_ends("nominal-v1", 20, 1) is None


def test_a_short_run_is_not_normalized_against_20_episode_references(capsys):
    """`bench --episodes 2` used to divide by the 20-episode references (the zero controller read
    -3.0 on length-v1): now it says it cannot normalize, or measures the ends when asked."""
    assert main(["--controller", "zero", "--suite", "length-v1", "--episodes", "2", "--json"]) == 0
    out, err = capsys.readouterr()
    row = json.loads(out.splitlines()[0])
    assert "normalized" not in row and "headline" not in row
    assert (
        "no headline or normalized score on length-v1" in err
        and "--controller baseline --controller oracle" in err
    )
    rows = [{"suite": "length-v1", "controller": "zero", "score": 2.0, "episodes": 2}]
    assert missing_ends(rows) == [("length-v1", "baseline"), ("length-v1", "oracle")]
    rows.append({"suite": "length-v1", "controller": "oracle", "score": 0.1, "episodes": 2})
    add_normalized(rows)
    assert [r["normalized"] for r in rows] == [0.0, 100.0] and rows[0]["normalized_from"] == "this run"


def test_the_score_interval_covers_the_score_and_narrows_with_agreeing_episodes():
    T, N = 50, 8
    rng = np.random.default_rng(0)
    tl = np.full((T, N), 0.17)
    base = {
        "target_length": tl,
        "stiffness": np.full((T, N), 800.0),
        "target_stiffness": np.full((T, N), 800.0),
        "air_used": np.zeros((T, N)),
        "reward": np.zeros((T, N)),
        "alive": np.ones((T, N), dtype=bool),
        "failed": np.zeros(N, dtype=bool),
        "dt": 0.02,
    }
    spread = dict(base, length=tl + rng.normal(0, 1e-3, (T, N)) * np.linspace(0.2, 3, N))
    same = dict(base, length=tl + rng.normal(0, 1e-3, (T, N)))
    m = score_traces(spread, True, RIG)
    lo, hi = m["score_ci95"]
    assert lo <= m["score"] <= hi
    lo2, hi2 = score_interval(same, True, RIG)
    assert hi2 - lo2 < 0.5 * (hi - lo)


def test_iqm_over_seeds_needs_rliable_and_says_how_to_get_it(monkeypatch):
    import sys

    from cepam_gym.bench.stats import iqm_interval

    monkeypatch.setitem(sys.modules, "rliable", None)
    with pytest.raises(ImportError, match="pip install rliable"):
        iqm_interval({"nominal-v1": [1.0] * 5})


def test_iqm_over_seeds_with_rliable():
    pytest.importorskip("rliable")
    from cepam_gym.bench.stats import iqm_interval

    with pytest.raises(ValueError, match="at least 5 seeds"):
        iqm_interval({"a": [1.0, 2.0]})
    got = iqm_interval({"a": [1.0, 2.0, 3.0, 4.0, 100.0], "b": [2.0] * 5}, reps=200)
    iqm, lo, hi = got["a"]
    assert 2.0 <= iqm <= 4.0 and lo <= iqm <= hi  # the outlier does not drag the IQM


def _entries() -> list:
    """Every stored entry; those of a version before the recommended one are marked
    ``previous_versions`` (``make test-all``): their plants and tasks are pinned step by step by the
    goldens (tests/golden), and the oracle they run is the one the recommended version's entries
    re-measure in ``make test``."""
    from cepam_gym import versions

    recommended = versions.get(versions.RECOMMENDED_ID).version
    out = []
    for table in references.FILES:
        for name in sorted(references.load(table)):
            previous = versions.get(SUITES[name].env_id).version != recommended
            marks = [pytest.mark.previous_versions] if previous else []
            out.append(pytest.param(table, name, marks=marks, id=f"{table}-{name}"))
    return out


# every stored entry, recomputed: a change of the plant, a suite or the oracle that moves a
# reference by more than 2 % fails here (then: cepam-gym bench --update-references). The zero
# controller and the baseline run the whole suite (seconds); the oracle (most of the cost) its
# stored check episodes, which move with the full score; CEPAM_ALL_REFERENCES=1 re-runs it all.
@pytest.mark.slow
@pytest.mark.parametrize(("table", "name"), _entries())
def test_stored_references_are_current(table, name):
    import os

    from cepam_gym.bench.harness import oracle_check, run_suite, seeded

    stored = references.load(table)[name]
    seed = None if table == "suite" else stored["seed"]
    episodes = None if table == "suite" else stored["episodes"]
    if os.environ.get("CEPAM_ALL_REFERENCES") == "1":
        now = measure_references(name, episodes, seed)
        assert now["oracle"] == pytest.approx(stored["oracle"], rel=0.02), name
        assert now["oracle_return"] == pytest.approx(stored["oracle_return"], rel=0.02), name
    else:
        zero, _ = run_suite("zero", seeded(name, seed), episodes)
        baseline, _ = run_suite("baseline", seeded(name, seed), episodes)
        now = {
            "seed": seeded(name, seed).seed,
            "episodes": zero["episodes"],
            "zero": zero["score"],
            "baseline": baseline["score"],
            "zero_return": zero["mean_return"],
            "oracle_check": oracle_check(name, seed),
        }
    assert now["episodes"] == stored["episodes"] and now["seed"] == stored["seed"]
    for end in ("zero", "baseline", "zero_return"):
        assert now[end] == pytest.approx(stored[end], rel=0.02), (name, end)
    check, was = now["oracle_check"], stored["oracle_check"]
    assert (check["steps"], check["episodes"]) == (was["steps"], was["episodes"])
    for key in ("score", "mean_return"):
        assert check[key] == pytest.approx(was[key], rel=0.02), (name, "oracle_check", key)


def test_every_stored_entry_has_an_oracle_check_and_the_headline_suites_both_minari_ends():
    """The test above re-runs ``oracle_check`` of every entry; the datasets'
    ``ref_min_score``/``ref_max_score`` read ``zero_return``/``oracle_return``
    (cepam_gym.offline.store), stored for the headline suites of every id not legacy (a dataset of
    another suite without them says so and names the command)."""
    from cepam_gym import versions

    headline = {s for row in versions.VERSIONS.values() if row.status != "legacy" for s in row.suites}
    for name, entry in references.load().items():
        check = entry["oracle_check"]
        assert (check["steps"], check["episodes"]) == (CHECK_STEPS, CHECK_EPISODES), name
        assert "zero_return" in entry, name
        if name in headline:
            assert "oracle_return" in entry, name


def test_the_unseen_table_is_measured_on_the_unseen_seeds_episodes(capsys):
    table = references.load("unseen")
    assert table, "cepam-gym bench --update-references --unseen writes it"
    for name, entry in table.items():
        assert (entry["seed"], entry["episodes"]) == (references.UNSEEN_SEED, references.UNSEEN_EPISODES)
        assert entry["seed"] not in {s.seed for s in SUITES.values()}  # no suite's episodes
        assert references.stored_entry(name, entry["episodes"], entry["seed"]) == entry
        assert references.stored_ends(name, entry["episodes"], entry["seed"]) == (
            entry["zero"],
            entry["oracle"],
        )
        assert entry["oracle"] < entry["baseline"] < entry["zero"], name
    with pytest.raises(SystemExit):
        main(["--unseen"])
    assert "--unseen goes with --update-references" in capsys.readouterr().err
    with pytest.raises(ValueError, match="no reference table 'unknown'"):
        references.load("unknown")


def test_update_unseen_regenerates_exactly_the_unseen_tables_suites(monkeypatch):
    from cepam_gym.bench import harness

    measured, stored = [], []
    monkeypatch.setattr(
        harness,
        "measure_references",
        lambda name, episodes, seed: (
            measured.append((name, episodes, seed)) or {"zero": 1.0, "baseline": 0.5, "oracle": 0.1}
        ),
    )
    monkeypatch.setattr(references, "store", lambda entries, table: stored.append((sorted(entries), table)))
    assert main(["--update-references", "--unseen"]) == 0
    unseen = (references.UNSEEN_EPISODES, references.UNSEEN_SEED)
    assert measured == [(n, *unseen) for n in sorted(references.load("unseen"))]
    assert stored == [([n], "unseen") for n in sorted(references.load("unseen"))]
