"""What a sensor-only agent would have to identify on randomized-v1, and how much a history reveals.

On ``randomized-v1`` the MPC given each plant's true parameters closes 78-82 % of the baseline-to-
oracle gap and without them 22-23 % (``benchmarks/oracle_privileges.py``): a student that sees
only the rig's sensors reaches the agents' goal of 80 % there only if it infers the parameters from its
history about as well as knowing them (RMA's adaptation module, Kumar et al. 2021). Two parts:

1. **Which parameters carry the gap**: ``mpc_friction`` given the true values of a subset of the
   randomized keys (the rest nominal), on the suite's own episodes; and planning with the centres
   of the randomization's ranges instead of the nominal plant (what a domain-randomized agent can
   know without identifying anything: the nominal CPAM angle sits at the lower end of its range).
2. **How much a history reveals**: an MLP regresses every randomized key (scaled to [-1, 1] over
   its range) from a window of the sensor signals (length, velocity, both pressures, the targets,
   the previous commands and ``mpc_friction``'s friction-aware force balance), trained on
   ``--plants`` randomized plants driven by the baseline (an excitation as rich as the tasks'
   own), tested on other plants driven by the baseline and by ``mpc_friction``: R^2 per key
   (0: no better than the range's mean; 1: identified).

Run: ``NUMBA_NUM_THREADS=1 python benchmarks/identifiability.py`` (about 8 minutes on one core).
Needs torch (the ``agents`` extra).
"""

from __future__ import annotations

import argparse
import math
import time

import gymnasium as gym
import numpy as np

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym.bench.harness import record
from cepam_gym.bench.metrics import score_traces
from cepam_gym.bench.suites import RANDOMIZE_V1, SUITES
from cepam_gym.control import make_controller
from cepam_gym.control.baseline import find_core
from cepam_gym.control.mpc import FrictionObserverMPC
from cepam_gym.physics import layout as ix
from cepam_gym.plant.params import PlantParams

KEYS = list(RANDOMIZE_V1)
STATIC = KEYS[:4]  # braid angles, the bladder's wall and modulus: the static map's stiffness
CENTRE = "none, planning with the ranges' centres"  # what a domain-randomized agent knows
SUBSETS = {
    "none (mpc_friction)": (),
    CENTRE: (),
    "angles, bladder wall and modulus": STATIC,
    "+ friction coefficient and presliding": KEYS[:6],
    "+ end mass, damping, Coulomb friction": KEYS[:6] + KEYS[11:14],
    "all 14 (mpc_friction_known_params)": KEYS,
}
SIGNALS = ("length", "velocity", "pressure_c", "pressure_e", "target_length", "target_stiffness")


def true_values(row: np.ndarray, nominal: PlantParams) -> dict[str, float]:
    """The randomized keys' values (their edge units) of a parameter row drawn around ``nominal``;
    the round trip through :meth:`PlantParams.from_dict` is checked (but for the supply pressure,
    which drifts within an episode and is measured: ``supply_drift_kpa``)."""
    v = {
        "cpam_rest_angle_deg": math.degrees(math.acos(nominal.cpam_rest_length / row[ix.BC])),
        "epam_sleeve_free_angle_deg": math.degrees(math.acos(nominal.epam_sleeve_free_length / row[ix.BE])),
        "bladder_thickness_mm": row[ix.TB_EL] * 1e3,
        "bladder_shear_modulus_kpa": row[ix.MU_B] / 1e3,
        "friction_coefficient_n_per_kpa": row[ix.FR_C] * 1e3,
        "friction_presliding_mm": row[ix.FR_D] * 1e3,
        "valve_conductance_dm3_per_s_bar": row[ix.C_PROP] * 1e8,
        "spool_time_constant_ms": row[ix.TAU_SPOOL] * 1e3,
        "heat_transfer_coefficient_w_per_m2_k": row[ix.H_WALL],
        "dead_volume_cpam_cm3": row[ix.VD_C] * 1e6,
        "dead_volume_epam_cm3": row[ix.VD_E] * 1e6,
        "end_mass_g": row[ix.M_END] * 1e3,
        "damping_ns_per_m": row[ix.DAMP],
        "coulomb_friction_n": row[ix.F_COUL],
    }
    back = PlantParams.from_dict(v, base=nominal).to_array()
    back[ix.P_SUP] = row[ix.P_SUP]
    if not np.allclose(back, row, rtol=1e-9, atol=0.0):
        raise RuntimeError("true_values: the randomized keys do not rebuild the row (a key is missing)")
    return v


class SubsetMPC(FrictionObserverMPC):
    """``mpc_friction`` planning with the true values of ``subset``, the other keys nominal (all
    of them: the true row, drifting supply included, as ``mpc_friction_known_params``)."""

    subset: tuple = ()
    centre: bool = False  # the other keys at the centres of their ranges, not nominal

    def __init__(self, env, **kwargs):
        super().__init__(env, **kwargs)
        self.core, self._rows = find_core(env), {}
        if self.centre:
            mid = {k: 0.5 * (lo + hi) for k, (lo, hi) in RANDOMIZE_V1.items()}
            self.params = PlantParams.from_dict(mid, base=self.nominal).to_array()

    def model_rows(self, n: int) -> np.ndarray:
        if not self.subset:  # the model's own row: nominal, or the ranges' centres
            return self.params[None]
        rows = np.asarray(self.core.params)
        if set(self.subset) == set(KEYS):
            return rows
        out = []
        for row in rows:
            key = row.tobytes()
            if key not in self._rows:
                v = true_values(row, self.nominal)
                changes = {k: v[k] for k in self.subset}
                self._rows[key] = PlantParams.from_dict(changes, base=self.nominal).to_array()
            out.append(self._rows[key])
        return np.array(out)


def subsets_table(suite_name: str, episodes: int | None) -> None:
    s = SUITES[suite_name]
    print(f"\n{suite_name}: mpc_friction given the true values of ... ({episodes or s.episodes} episodes)")
    print("| parameters known | length RMSE mm | stiffness RMSE % | score | s |\n|---|---|---|---|---|")
    for name, subset in SUBSETS.items():
        t = time.perf_counter()
        cls = type("Subset", (SubsetMPC,), {"subset": tuple(subset), "centre": name == CENTRE})
        tr, track = record(cls, s.env_id, s.env_kwargs, episodes or s.episodes, s.seed, None, s.traces)
        m = score_traces(tr, track, s.traces)
        print(
            f"| {name} | {m['length_rmse_mm']:.3f} | {m['stiffness_rmse_pct']:.2f} | {m['score']:.4f} "
            f"| {time.perf_counter() - t:.0f} |",
            flush=True,
        )


def histories(suite_name: str, driver: str, plants: int, seed: int):
    """Signals (plants, T, channels), scaled labels (plants, 14) of one episode per plant."""
    s = SUITES[suite_name]
    venv = gym.make_vec(s.env_id, num_envs=plants, **s.env_kwargs)
    try:
        obs, _info = venv.reset(seed=seed)
        ctrl = make_controller(driver, venv)
        ctrl.reset()
        balance = FrictionObserverMPC(venv)  # its friction-aware force balance, not its plan
        core, lay = find_core(venv), balance.layout
        lo, hi = np.array([RANDOMIZE_V1[k] for k in KEYS]).T
        y = np.array([[true_values(r, balance.nominal)[k] for k in KEYS] for r in core.params])
        y = 2 * (y - lo) / (hi - lo) - 1
        frames = []
        for _ in range(core.n_steps):
            a = ctrl.act(obs)
            v = lay.decode(obs)
            force = balance.measured_force(
                v["length"], v["pressure_c"], v["pressure_e"], balance.params[None]
            )
            frames.append(np.column_stack([obs[:, [lay.column(c) for c in SIGNALS]], a, force]))
            obs, _r, _term, _trunc, _info = venv.step(a)
        return np.stack(frames, axis=1).astype(np.float32), y.astype(np.float32)
    finally:
        venv.close()


def windows(x: np.ndarray, width: int, stride: int, every: int) -> np.ndarray:
    """(plants, windows, width / stride * channels): the history ending at every ``every``-th step."""
    ends = np.arange(width - 1, x.shape[1], every)
    return np.stack([x[:, t - width + 1 : t + 1 : stride].reshape(len(x), -1) for t in ends], axis=1)


def regression_table(suite_name: str, plants: int, width: int, stride: int, steps: int) -> None:
    import torch

    torch.manual_seed(0)
    t0 = time.perf_counter()
    x, y = histories(suite_name, "baseline", plants, seed=900)
    xw = windows(x, width, stride, 10)
    m = xw.shape[1]
    xf, yf = xw.reshape(-1, xw.shape[2]), np.repeat(y, m, axis=0)
    mu, sd = xf.mean(0), xf.std(0) + 1e-6
    xt, yt = torch.as_tensor((xf - mu) / sd), torch.as_tensor(yf)
    net = torch.nn.Sequential(
        torch.nn.Linear(xf.shape[1], 256), torch.nn.Tanh(), torch.nn.Linear(256, 256), torch.nn.Tanh(),
        torch.nn.Linear(256, len(KEYS)),
    )  # fmt: skip
    opt = torch.optim.Adam(net.parameters(), 1e-3)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, steps)
    g = torch.Generator().manual_seed(0)
    for _ in range(steps):
        idx = torch.randint(len(xt), (1024,), generator=g)
        loss = ((net(xt[idx]) - yt[idx]) ** 2).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
        sched.step()
    print(f"\n{suite_name}: R^2 of each key from {width * 0.02:.1f} s of history ({plants} training plants, "
          f"{time.perf_counter() - t0:.0f} s)")  # fmt: skip
    tests = {"baseline-driven": histories(suite_name, "baseline", 512, seed=901)}
    tests["mpc_friction-driven"] = histories(suite_name, "mpc_friction", 64, seed=902)
    print("| key | " + " | ".join(tests) + " |\n|---|" + "---|" * len(tests))
    r2 = {}
    for name, (x2, y2) in tests.items():
        w2 = windows(x2, width, stride, 10)
        with torch.no_grad():
            p = net(torch.as_tensor((w2.reshape(-1, w2.shape[2]) - mu) / sd)).numpy()
        truth = np.repeat(y2, w2.shape[1], axis=0)
        r2[name] = 1 - ((p - truth) ** 2).mean(0) / truth.var(0)
    for j, k in enumerate(KEYS):
        print(f"| {k} | " + " | ".join(f"{r2[n][j]:.2f}" for n in tests) + " |")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--suite", default="randomized-v1")
    ap.add_argument("--episodes", type=int, default=None, help="part 1: episodes (default: the suite's)")
    ap.add_argument("--plants", type=int, default=8192, help="part 2: training plants")
    ap.add_argument("--window-steps", type=int, default=150, help="part 2: history length (control steps)")
    ap.add_argument("--gradient-steps", type=int, default=6000)
    ap.add_argument("--part", choices=("1", "2", "both"), default="both")
    args = ap.parse_args(argv)
    if args.part in ("1", "both"):
        subsets_table(args.suite, args.episodes)
    if args.part in ("2", "both"):
        stride = max(1, args.window_steps // 25)
        regression_table(args.suite, args.plants, args.window_steps, stride, args.gradient_steps)


if __name__ == "__main__":
    main()
