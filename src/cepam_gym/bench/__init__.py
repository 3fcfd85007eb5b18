"""Benchmark harness: fixed seeded suites, metrics, and the ``cepam-gym bench`` command."""

from .harness import make_controller, run_suite
from .metrics import score_traces
from .suites import SUITES

__all__ = ["SUITES", "make_controller", "run_suite", "score_traces"]
