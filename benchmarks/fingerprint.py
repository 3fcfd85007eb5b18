"""Fingerprints of the main job's stages on small fixed inputs, to compare two installs.

The main job (``cepam-gym run``: a DAgger student) chains four stages, here with the teacher and
features of ``configs/student.yaml``; each is run on inputs small enough to take a minute or two,
and its arrays are saved:

* ``env_<suite>``: the observations of 4 envs of the suite's plant driven by seeded random
  commands (the compiled plant and task: numba, numpy);
* ``teacher_<suite>``: one DAgger collection with the teacher driving (``student.collect``: the
  student's features and the teacher's commands; the MPC given the true parameters: numba,
  numpy, scipy);
* ``fit_fixed``: the student's MLP fitted for 300 Adam steps on a dataset drawn from a fixed
  generator (torch only), and ``fit_teacher`` the same on the teacher's labels above;
* ``eval``: the zero controller and the baseline scored on 4 episodes of each suite (the
  benchmark's scoring).

Run it in each install, then compare: the first stage whose arrays differ names the culprit::

    NUMBA_NUM_THREADS=1 python benchmarks/fingerprint.py --out a.npz
    NUMBA_NUM_THREADS=1 other-venv/bin/python benchmarks/fingerprint.py --out b.npz
    python benchmarks/fingerprint.py --compare a.npz b.npz

(about 2 minutes of one core per install, after numba's first compilation.)
"""

from __future__ import annotations

import argparse
import hashlib
import json
import time

import numpy as np

SUITES = ("nominal-v1", "randomized-v1")
NUM_ENVS = 4


def _env_obs(suite: str, seed: int = 7, steps: int = 200) -> np.ndarray:
    import gymnasium as gym

    from cepam_gym.bench.suites import SUITES as ALL

    s = ALL[suite]
    venv = gym.make_vec(s.env_id, num_envs=NUM_ENVS, **s.env_kwargs)
    try:
        rng = np.random.default_rng(seed)
        obs, _ = venv.reset(seed=seed)
        out = [obs]
        for _ in range(steps):
            act = rng.uniform(-1.0, 1.0, size=(NUM_ENVS, 2)).astype(np.float32)
            obs, *_ = venv.step(act)
            out.append(obs)
        return np.stack(out)
    finally:
        venv.close()


def _fit(x: np.ndarray, y: np.ndarray, steps: int = 300) -> np.ndarray:
    import torch

    from cepam_gym_agents.learners.student import _Actor, fit

    torch.set_num_threads(1)
    mean, std, scale = x.mean(0), x.std(0) + 1e-3, y.std(0) + 1e-6
    actor = _Actor(x.shape[1], [256, 256], 0)
    fit(actor, x, y, mean, std, scale, steps, 512, 1e-3, 0)
    return np.concatenate([p.detach().numpy().ravel() for p in actor.params])


def _eval(suite: str) -> np.ndarray:
    from cepam_gym.bench.harness import run_suite

    rows = []
    for name in ("zero", "baseline"):
        metrics, _ = run_suite(name, suite, episodes=NUM_ENVS)
        rows.append([float(metrics[k]) for k in sorted(metrics) if isinstance(metrics[k], float | int)])
    return np.asarray(rows, dtype=np.float64)


STAGES = ("env", "teacher", "fit", "eval")


def stages(which=STAGES) -> dict[str, np.ndarray]:
    from cepam_gym_agents.config.files import load_config
    from cepam_gym_agents.learners.student import collect

    cfg = load_config("student")
    out: dict[str, np.ndarray] = {}

    def timed(name, fn):
        t = time.perf_counter()
        out[name] = np.asarray(fn())
        print(f"{name}: {_digest(out[name])} ({time.perf_counter() - t:.1f} s)", flush=True)

    if "env" in which:
        for suite in SUITES:
            timed(f"env_{suite}", lambda s=suite: _env_obs(s))
    labels = {}
    if "teacher" in which:
        for suite in SUITES:
            x, y = collect(cfg, suite, NUM_ENVS, seed=1_000_003)
            labels[suite] = (x, y)
            timed(f"teacher_x_{suite}", lambda x=x: x)
            timed(f"teacher_y_{suite}", lambda y=y: y)
    if "fit" in which:
        rng = np.random.default_rng(0)
        xf = rng.standard_normal((4096, 124)).astype(np.float32)  # the student's feature count
        yf = np.tanh(xf[:, :2] - 0.5 * xf[:, 2:4]).astype(np.float32)
        timed("fit_fixed", lambda: _fit(xf, yf))
        if labels:
            x = np.concatenate([labels[s][0] for s in SUITES])
            y = np.concatenate([labels[s][1] for s in SUITES])
            timed("fit_teacher", lambda: _fit(x, y))
    if "eval" in which:
        for suite in SUITES:
            timed(f"eval_{suite}", lambda s=suite: _eval(s))
    return out


def _digest(a: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()[:16]


def compare(a_path: str, b_path: str) -> None:
    a, b = np.load(a_path), np.load(b_path)
    print(json.dumps({"a": str(a["versions"]), "b": str(b["versions"])}, indent=1))
    for k in a.files:
        if k == "versions" or k not in b.files:
            continue
        x, y = a[k], b[k]
        if x.shape != y.shape:
            print(f"{k}: shapes differ {x.shape} vs {y.shape}")
            continue
        if x.tobytes() == y.tobytes():
            print(f"{k}: identical bit for bit")
            continue
        differ = (x != y) & ~(np.isnan(x) & np.isnan(y))
        diff = np.abs(x.astype(np.float64) - y.astype(np.float64))[differ]
        first = tuple(int(i) for i in np.unravel_index(int(np.argmax(differ.ravel())), x.shape))
        print(
            f"{k}: {int(differ.sum())} of {x.size} values differ, max |diff| {diff.max():.3g}, "
            f"max relative {(diff / np.abs(x[differ]).clip(1e-30)).max():.3g}, first at index {first}"
        )


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="fingerprint.npz")
    p.add_argument("--stages", default=",".join(STAGES), help=f"a comma-separated subset of {STAGES}")
    p.add_argument("--compare", nargs=2, metavar=("A", "B"))
    args = p.parse_args(argv)
    if args.compare:
        compare(*args.compare)
        return 0
    from cepam_gym_agents.session.provenance import package_versions

    which = args.stages.split(",")
    if unknown := set(which) - set(STAGES):
        p.error(f"unknown stages {sorted(unknown)}: choose from {STAGES}")
    out = stages(which)
    np.savez(args.out, versions=json.dumps(package_versions()), **out)
    print(f"saved {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
