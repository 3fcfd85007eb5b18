"""What the oracle's privileges are worth: the ladder from the practical MPC to the oracle.

The oracle (the 100 of every normalized score) reads four things no rig has: the future of the
load, the plant's hidden state (air temperatures, spool positions, friction slips), its true
parameters (randomized plants), and it searches harder than the practical MPC. An agent sees
only the sensors, and ``cepam-gym eval`` reports the share of the baseline-to-oracle gap it
closes (its headline score); this script measures how much of that gap each privilege carries,
by giving the MPC one privilege at a time and taking the foresight away from the oracle, all on
the same seeded episodes of a suite:

* ``mpc``: the nominal model, state from the sensors (air at ambient temperature, spools where the
  last command put them, friction relaxed), load from the static balance;
* ``mpc + oracle search``: the same with the oracle's search settings;
* ``mpc + true hidden state`` (and its parts: air, friction): the plant's true columns copied into
  the MPC's state estimate, with the oracle's search;
* ``mpc_friction`` (registered): the MPC whose load balance includes its friction elements,
  tracked from the measured length (practical: sensors only);
* ``mpc_known_params`` (registered): the MPC given each plant's true parameters, state and load
  still estimated; ``mpc_friction + true parameters`` the same on ``mpc_friction``;
* ``oracle_causal`` (registered): the oracle with the load of the current step held over its
  horizon (no foresight);
* ``oracle``.

Per row: the score, its 95 % interval and the share of the baseline-to-oracle gap it closes
(the headline score, :func:`cepam_gym.bench.headline.headline_score`, the yardstick of the agents'
goal).

Run: ``NUMBA_NUM_THREADS=1 python benchmarks/oracle_privileges.py [--suite nominal-v1] [--episodes 20]``
(about 12 minutes for both default suites on one core of a busy 2-core machine).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym import plant as pl
from cepam_gym.bench.harness import record
from cepam_gym.bench.headline import headline_score
from cepam_gym.bench.metrics import score_traces
from cepam_gym.bench.suites import SUITES
from cepam_gym.control import make_controller
from cepam_gym.control.mpc import ModelPredictiveController
from cepam_gym.control.oracle import ORACLE_CONFIG
from cepam_gym.envs.model import model_of
from cepam_gym.physics import layout as ix

AIR = (pl.S_MC, pl.S_UC, pl.S_ME, pl.S_UE)
SPOOLS = (pl.S_SC, pl.S_SE, pl.S_SRC, pl.S_SRE)
FRICTION = (pl.S_Z1, pl.S_Z2, pl.S_Z3)


class _TrueColumnsMPC(ModelPredictiveController):
    """The MPC with the oracle's search and some true state columns in place of its estimate;
    ``true_load``: the load of the current step instead of the static balance's estimate."""

    def __init__(self, env, columns: tuple[int, ...], true_load: bool = False):
        super().__init__(env, config=ORACLE_CONFIG)
        self.columns, self.model, self.true_load = list(columns), model_of(env), true_load

    def _filtered(self, load_now):
        if not self.true_load:
            return super()._filtered(load_now)
        m, p = self.model, self.params
        load = m.load[np.arange(m.num_envs), m.t_idx]
        return (load + p[ix.M_END]) * p[ix.GRAV]  # the weight the act turns back into the load

    def estimate_state(self, obs, L, pc, pe, params=None):
        x = super().estimate_state(obs, L, pc, pe, params)
        x[:, self.columns] = self.model.state[:, self.columns]
        return x


ROWS = {
    "baseline": lambda v: make_controller("baseline", v),
    "mpc": lambda v: make_controller("mpc", v),
    "mpc + oracle search": lambda v: _TrueColumnsMPC(v, ()),
    "mpc + true air": lambda v: _TrueColumnsMPC(v, AIR),
    "mpc + true friction": lambda v: _TrueColumnsMPC(v, FRICTION),
    "mpc + true hidden state": lambda v: _TrueColumnsMPC(v, AIR + SPOOLS + FRICTION),
    "mpc + true load": lambda v: _TrueColumnsMPC(v, (), true_load=True),
    "mpc + true hidden state and load": lambda v: _TrueColumnsMPC(v, AIR + SPOOLS + FRICTION, True),
    "mpc_friction": lambda v: make_controller("mpc_friction", v),
    "mpc_known_params": lambda v: make_controller("mpc_known_params", v),
    "mpc_friction + true parameters": lambda v: make_controller("mpc_friction_known_params", v),
    "oracle_causal": lambda v: make_controller("oracle_causal", v),
    "oracle": lambda v: make_controller("oracle", v),
}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--suite", action="append", help="repeatable; default nominal-v1, randomized-v1")
    ap.add_argument("--episodes", type=int, default=None, help="episodes per suite (default: the suite's)")
    ap.add_argument("--row", action="append", choices=sorted(ROWS), help="rows to run (default all)")
    args = ap.parse_args(argv)
    for name in args.suite or ["nominal-v1", "randomized-v1"]:
        s = SUITES[name]
        rows = {}
        for row in args.row or list(ROWS):
            t = time.perf_counter()
            episodes = args.episodes or s.episodes
            tr, track = record(ROWS[row], s.env_id, s.env_kwargs, episodes, s.seed, None, s.traces)
            rows[row] = (score_traces(tr, track, s.traces), time.perf_counter() - t)
        base = rows["baseline"][0]["score"] if "baseline" in rows else None
        top = rows["oracle"][0]["score"] if "oracle" in rows else None
        print(f"\n{name} ({args.episodes or s.episodes} episodes, seed {s.seed})")
        print("| row | length RMSE mm | stiffness RMSE % | score | 95 % CI | headline (gap closed) | s |")
        print("|---|---|---|---|---|---|---|")
        for row, (m, sec) in rows.items():
            gap = "" if base is None or top is None else f"{headline_score(m['score'], base, top):.0f}"
            lo, hi = m["score_ci95"]
            print(
                f"| {row} | {m['length_rmse_mm']:.3f} | {m['stiffness_rmse_pct']:.2f} | {m['score']:.4f} "
                f"| {lo:.4f}-{hi:.4f} | {gap} | {sec:.0f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
