"""Why the env's reward and the benchmark's score rank policies differently, measured per term.

For each controller on a suite (the suite's seeded episodes) this prints the mean return and where
it comes from: the tracking and stiffness terms on the steps the score counts and on the steps of
the settling allowance it leaves out, the effort, air and burst terms. Beside them the score and
its mean-absolute form, ``mean|e_x| / x_norm + mean|e_K / K*| / 0.2`` over the scored steps, which
is exactly ``-c`` times the mean tracking + stiffness reward on those steps where no error is
clipped (the relation :meth:`cepam_gym.tasks.contract.TaskContract.score_factor` states; c = 2 on
the rig, 1 on the joint). docs/benchmark.md quotes its output.

Run: ``NUMBA_NUM_THREADS=1 python benchmarks/reward_vs_score.py [--suite nominal-v1]
[--controller zero --controller baseline --controller oracle] [--episodes 20]``
(``--controller runs/student`` scores a trained agent the same way).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym.bench.harness import record
from cepam_gym.bench.metrics import score_traces, tracking_mask
from cepam_gym.bench.suites import SUITES
from cepam_gym.control import make_controller


class _Terms:
    """Observer of :func:`~cepam_gym.bench.harness.record`: each step's reward terms (T, N)."""

    def __init__(self, keys):
        self.keys, self.rows = keys, {k: [] for k in keys}

    def start(self, obs, info):
        pass

    def step(self, actions, obs, rewards, terminated, truncated, info):
        src = info.get("final_info", info) if (terminated | truncated).any() else info
        for k in self.keys:
            self.rows[k].append(np.asarray(src[k], dtype=float))


def decompose(suite_name: str, controller: str, episodes: int) -> dict:
    """Mean return per term and where the tracking terms fall (scored steps or allowance)."""
    import gymnasium as gym

    suite = SUITES[suite_name]
    env = gym.make_vec(suite.env_id, num_envs=1, **suite.env_kwargs)
    contract = env.unwrapped.core.task.contract
    env.close()
    terms = _Terms(contract.term_keys)
    t0 = time.perf_counter()
    tr, track_k = record(
        lambda venv: make_controller(controller, venv),
        suite.env_id,
        suite.env_kwargs,
        episodes,
        suite.seed,
        spec=suite.traces,
        observer=terms,
    )
    wall = time.perf_counter() - t0
    alive = tr["alive"]
    scored = tracking_mask(tr, track_k, suite.traces)
    allowance = alive & ~scored
    per = {k: np.stack(v) for k, v in terms.rows.items()}
    track = per[contract.term_keys[0]] + per[contract.term_keys[1]]
    m = score_traces(tr, track_k, suite.traces)
    norm = suite.traces.position_norm
    e_x = np.abs(tr["length"] - tr["target_length"]) / norm
    e_k = np.abs(tr["stiffness"] / tr["target_stiffness"] - 1.0) / contract.trade.stiffness_norm
    l1 = float(e_x[scored].mean() + (e_k[scored].mean() if track_k else 0.0))
    ep = lambda a, mask: float(np.where(mask, a, 0.0).sum(axis=0).mean())  # noqa: E731
    out = {
        "suite": suite_name,
        "controller": controller,
        "score": m["score"],
        "score_l1": l1,
        "mean_return": m["mean_return"],
        "track_scored": ep(track, scored),
        "track_allowance": ep(track, allowance),
        "s": wall,
    }
    for k in contract.term_keys[2:]:
        out[k.removeprefix("reward_")] = ep(per[k], alive)
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--suite", default="nominal-v1")
    ap.add_argument("--controller", action="append")
    ap.add_argument("--episodes", type=int, default=None)
    a = ap.parse_args(argv)
    episodes = a.episodes or SUITES[a.suite].episodes
    cols = ("controller", "score", "score_l1", "mean_return", "track_scored", "track_allowance")
    rows = [decompose(a.suite, c, episodes) for c in a.controller or ("zero", "baseline", "oracle")]
    extra = [k for k in rows[0] if k not in cols and k not in ("suite", "s")]
    head = (*cols, *extra, "s")
    print(f"{a.suite}, {episodes} episodes; returns are means per episode")
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for r in rows:
        cells = [r[k] if isinstance(r[k], str) else f"{r[k]:.4g}" for k in head]
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
