"""A trainer's progress shows the inverse-model baseline's score on the agent's own evaluation
episodes beside the agent's (agents/policy.py ``baseline_score``, agents/session/progress.py)."""

from __future__ import annotations

import pytest

from cepam_gym.bench.harness import run_suite
from cepam_gym.bench.suites import SUITES


def test_the_baseline_beside_an_evaluation_is_the_baseline_on_the_same_episodes():
    from cepam_gym_agents.policy import baseline_score

    s = SUITES["nominal-v2"]
    want, _ = run_suite("baseline", s, episodes=4)
    got = baseline_score(s.env_id, dict(s.env_kwargs), 4, s.seed, s.traces)
    assert got == pytest.approx(want["score"], rel=1e-12)
    other = baseline_score(s.env_id, dict(s.env_kwargs), 4, s.seed + 1, s.traces)
    assert other != pytest.approx(got, rel=1e-9)  # other episodes, another score


def test_the_progress_line_shows_the_baseline_beside_the_agents_score(capsys):
    from cepam_gym_agents.session.progress import ProgressBar

    bar = ProgressBar(100, "PPO run", quiet=False)
    bar.open(0, None, float("inf"))
    bar.baseline = 0.3125
    bar.score(0.25, 0.2)
    bar.close()
    err = capsys.readouterr().err
    assert "eval score 0.250 (best 0.200, baseline 0.312, lower is better)" in err
