"""Where a grid of training runs executes: processes on this machine, or Ray tasks on this machine
or a Ray cluster.

A trial is one ``cepam-gym train --config C --seed S --out DIR`` command, the same wherever it
runs: the run it writes depends on the config and the seed only (the thread counts change the
speed, not the numbers; ``tests/integrations/test_ray_grid.py`` holds a Ray trial to the same
seed run here). Locally, ``jobs`` processes at a time share the cores (numba's and OpenMP's
threads split among them). On Ray (Moritz et al. 2018) each trial is a task asking for its share
of a node's cores; on a cluster the output directory must be on a filesystem every node sees.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from cepam_gym.errors import InputError

NO_RAY = "--ray needs Ray: pip install 'cepam-gym[distributed]' (make install-distributed builds .venv-ray)"


@dataclass(frozen=True)
class Trial:
    config: str
    seed: int
    run: Path

    def command(self) -> list[str]:
        return [
            sys.executable,
            "-m",
            "cepam_gym.cli",
            "train",
            "--config",
            self.config,
            "--seed",
            str(self.seed),
            "--out",
            str(self.run),
            "--quiet",
        ]

    @property
    def log(self) -> Path:
        return self.run.parent / f"{self.run.name}.log"


def thread_env(threads: int) -> dict:
    t = str(max(1, threads))
    return {**os.environ, "NUMBA_NUM_THREADS": t, "OMP_NUM_THREADS": t}


def _failed(trial: Trial, code: int) -> RuntimeError:
    return RuntimeError(f"training {trial.run} failed (exit {code}): see {trial.log}")


def run_local(trials: list[Trial], jobs: int) -> None:
    """``jobs`` trials at a time as processes of this machine."""
    env = thread_env((os.cpu_count() or 1) // max(jobs, 1))
    todo, running = list(trials), []
    while todo or running:
        while todo and len(running) < jobs:
            t = todo.pop(0)
            log = open(t.log, "w")  # noqa: SIM115  (closed when the job ends)
            running.append(
                (subprocess.Popen(t.command(), env=env, stdout=log, stderr=subprocess.STDOUT), log, t)
            )
        time.sleep(2)
        for job in list(running):
            proc, log, t = job
            if proc.poll() is not None:
                log.close()
                running.remove(job)
                if proc.returncode != 0:
                    raise _failed(t, proc.returncode)


def _ray_trial(command: list[str], threads: int, log: str) -> int:
    with open(log, "w") as f:
        return subprocess.run(command, env=thread_env(threads), stdout=f, stderr=subprocess.STDOUT).returncode


def smallest_node_cpus(ray) -> int:
    """The CPUs of the smallest live node of the Ray instance that has any: a task asking for more
    would wait forever on a cluster of smaller nodes. (On nodes of mixed sizes a larger node runs
    several such tasks at once.)"""
    cpus = [n["Resources"].get("CPU", 0) for n in ray.nodes() if n.get("Alive")]
    cpus = [c for c in cpus if c > 0]  # a head started with --num-cpus=0 runs no task
    return max(1, int(min(cpus))) if cpus else 1


def run_ray(trials: list[Trial], address: str | None, cpus_per_trial: int | None) -> None:
    """Every trial as a Ray task needing ``cpus_per_trial`` cores (None: a whole node; never more
    than the smallest node has), on the Ray instance at ``address`` (``"auto"``: the running
    cluster; None: a new one on this machine)."""
    try:
        import ray
    except ImportError:
        raise InputError(NO_RAY) from None
    if not ray.is_initialized():
        ray.init(address=address, ignore_reinit_error=True, log_to_driver=False)
    node = smallest_node_cpus(ray)
    cpus_per_trial = node if cpus_per_trial is None else min(cpus_per_trial, node)
    task = ray.remote(num_cpus=cpus_per_trial)(_ray_trial)
    futures = {task.remote(t.command(), cpus_per_trial, str(t.log)): t for t in trials}
    for future, t in futures.items():
        code = ray.get(future)
        if code != 0:
            raise _failed(t, code)


RAY_HELP = (
    "train as Ray tasks: 'local' (a Ray instance on this machine), 'auto' (the running cluster) "
    "or the head's address; on a cluster --out must be on a filesystem every node sees"
)


def run_trials(trials: list[Trial], jobs: int, ray: str | None) -> None:
    """``jobs`` processes at a time on this machine, or (``ray``: a Ray address, ``"local"`` for a
    new instance here) Ray tasks of ``cores / jobs`` cores each."""
    if ray is None:
        run_local(trials, jobs)
    else:
        run_ray(trials, None if ray == "local" else ray, max(1, (os.cpu_count() or 1) // max(jobs, 1)))
