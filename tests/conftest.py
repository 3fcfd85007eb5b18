"""Test-session settings shared by every test directory."""

from __future__ import annotations

import os


def pytest_configure(config):
    """Under pytest-xdist, one numba thread per worker by default. The workers already keep every
    core busy; a parallel region in each of them as well puts two threads on each core, and the
    planners' small batches (the oracle on two episodes) then run at half speed. Code that asks
    for a thread count of its own (the envs' ``num_threads``, their automatic choice) still gets
    it for its parallel regions, so the parallel kernels stay tested."""
    if int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1")) > 1:
        import numba

        numba.set_num_threads(1)
