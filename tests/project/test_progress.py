"""The long commands' progress bar (cepam_gym.progress): shown on a terminal with the time left,
silent on a pipe, and moved by the harness's rollout loop step by step."""

from __future__ import annotations

import io

import pytest

pytest.importorskip("tqdm")

from cepam_gym import progress  # noqa: E402
from cepam_gym.bench.harness import run_suite  # noqa: E402


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_a_terminal_shows_the_bar_with_the_time_left(monkeypatch):
    err = _Terminal()
    monkeypatch.setattr("sys.stderr", err)
    with progress.runs(2, "cepam-gym bench") as bar:
        for _ in range(4):
            progress.advance(0.5)
        assert bar.n == pytest.approx(2.0)
    text = err.getvalue()
    assert "cepam-gym bench: 0.0/2 runs" in text and "elapsed" in text and " left" in text
    progress.advance(1.0)  # no bar open: nothing happens


def test_a_pipe_gets_no_bar(monkeypatch):
    err = io.StringIO()
    monkeypatch.setattr("sys.stderr", err)
    with progress.runs(1, "cepam-gym eval"):
        progress.advance(1.0)
    assert err.getvalue() == ""


def test_the_rollout_loop_advances_the_bar_by_one_run(monkeypatch):
    monkeypatch.setattr("sys.stderr", _Terminal())
    with progress.runs(2, "cepam-gym bench") as bar:
        run_suite("zero", "nominal-v2", episodes=1, max_steps=20)
        assert bar.n == pytest.approx(1.0)


def test_identify_counts_its_fits_evaluations_to_their_budget(monkeypatch, tmp_path):
    """``identify``'s bar counts the fit's residual evaluations: a budget of 12 per start and 60
    for the polish, each stage topped up to its budget when it converges early."""
    import contextlib

    from cepam_gym.cli import main

    err = _Terminal()
    monkeypatch.setattr("sys.stderr", err)
    ends, real = [], progress.runs

    @contextlib.contextmanager
    def spy(total, desc, unit="runs"):
        with real(total, desc, unit) as bar:
            yield bar
            ends.append((desc, unit, total, bar.n))

    monkeypatch.setattr(progress, "runs", spy)
    log = tmp_path / "run1.csv"
    assert main(["excite", "--simulate", "--preset", "balloon", "--seconds", "12", "--out", str(log)]) == 0
    argv = [
        "identify",
        "--data",
        str(log),
        "--mode",
        "valve",
        "--out",
        str(tmp_path / "p.yaml"),
        "--starts",
        "2",
    ]
    assert main(argv) == 0
    ((unit, total, n),) = [e[1:] for e in ends if e[0] == "cepam-gym identify"]
    assert (unit, total) == ("evaluations", 2 * 12 + 60) and n == pytest.approx(total)
    assert "cepam-gym identify: " in err.getvalue() and "/84 evaluations" in err.getvalue()
