"""Scripted step response of one CE-PAM plant, plotted (a smoke test you can look at).

The plant (:func:`cepam_gym.plant.step`, proportional valves, ``dt = 0.5 ms``, 40 sub-steps, i.e.
50 Hz control) hangs a 0.1 kg load and is driven open loop through a fixed sequence of valve
commands (:data:`SCRIPT`): pressurise the annulus (EPAM), then the CPAM, hold with closed valves,
add a load step, exhaust the CPAM, then the annulus. With both chambers at atmosphere the model
has no restoring force (no bladder elasticity by default), so the load then holds the muscle on
its upper end stop. The PNG shows, against time, both gauge
pressures [kPa], the length [cm], the constant-pressure and closed-chamber stiffness [N/m] and
the two valve spools.

Run ``python -m cepam_gym.demo --out-dir runs/demo`` (prints the PNG path).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import plant
from .cli_errors import CommandParser
from .plant.params import PlantParams, preset, preset_names

DT = 5e-4  # s, plant sub-step
N_SUB = 40  # sub-steps per control step: 50 Hz control
LOAD = 0.1  # kg, hanging load

#: (start time [s], command_c, command_e, load_mass [kg], external_force [N], label); each row
#: holds until the next row's start. Commands are proportional spool set-points (-1 exhaust,
#: 0 closed, +1 supply). Pulse lengths keep the pressures below the balloon's burst pressure.
SCRIPT = (
    (0.00, 0.0, 0.0, LOAD, 0.0, "settle"),
    (0.50, 0.0, 1.0, LOAD, 0.0, "fill annulus (EPAM)"),
    (0.66, 0.0, 0.0, LOAD, 0.0, "hold"),
    (1.50, 1.0, 0.0, LOAD, 0.0, "fill CPAM"),
    (1.54, 0.0, 0.0, LOAD, 0.0, "hold"),
    (3.00, 0.0, 0.0, 4 * LOAD, 0.0, "load step to 0.4 kg"),
    (4.00, -1.0, 0.0, 4 * LOAD, 0.0, "exhaust CPAM"),
    (5.00, -1.0, -1.0, 4 * LOAD, 0.0, "exhaust annulus"),
)
DURATION = 6.0  # s


def _inputs_at(t: float) -> np.ndarray:
    row = SCRIPT[0]
    for r in SCRIPT:
        if t + 1e-12 >= r[0]:
            row = r
    return np.array([row[1], row[2], row[3], row[4]], dtype=float)


def simulate(params: PlantParams | None = None, duration: float = DURATION) -> dict[str, np.ndarray]:
    """Run :data:`SCRIPT` on one plant; returns time series (SI units) keyed by name."""
    params = params or PlantParams()
    P = params.to_array()[None, :]
    x = plant.initial_state(P, params.min_length)
    aux = plant.measure(x, P)
    n = int(round(duration / (DT * N_SUB)))
    rows = {
        k: []
        for k in (
            "time",
            "length",
            "pressure_c",
            "pressure_e",
            "stiffness",
            "stiffness_closed",
            "spool_c",
            "spool_e",
            "command_c",
            "command_e",
            "load_mass",
            "burst",
            "end_stop",
        )
    }

    def record(x, aux, u):
        rows["time"].append(x[0, plant.S_T])
        rows["length"].append(x[0, plant.S_L])
        rows["pressure_c"].append(aux[0, plant.A_PC])
        rows["pressure_e"].append(aux[0, plant.A_PE])
        rows["stiffness"].append(aux[0, plant.A_STIFF])
        rows["stiffness_closed"].append(aux[0, plant.A_STIFF_CLOSED])
        rows["spool_c"].append(x[0, plant.S_SC])
        rows["spool_e"].append(x[0, plant.S_SE])
        rows["command_c"].append(u[plant.I_CMD_C])
        rows["command_e"].append(u[plant.I_CMD_E])
        rows["load_mass"].append(u[plant.I_LOAD])
        rows["burst"].append(aux[0, plant.A_BURST])
        rows["end_stop"].append(aux[0, plant.A_STOP])

    u = _inputs_at(0.0)
    record(x, aux, u)
    for _ in range(n):
        u = _inputs_at(float(x[0, plant.S_T]))
        x, aux = plant.step(x, u[None, :], P, plant.PROPORTIONAL, DT, N_SUB)
        if not aux[0, plant.A_FINITE]:
            raise RuntimeError(f"plant state became non-finite at t = {x[0, plant.S_T]:.3f} s")
        record(x, aux, u)
    return {k: np.asarray(v, dtype=float) for k, v in rows.items()}


def step_response(params: PlantParams | None = None, out_dir: str | Path = "runs/demo") -> Path:
    """Simulate :data:`SCRIPT` and write ``step_response.png`` into ``out_dir``; returns its path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    params = params or PlantParams()
    r = simulate(params)
    t = r["time"]
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "step_response.png"

    fig, ax = plt.subplots(4, 1, sharex=True, figsize=(8, 9.5))
    ax[0].plot(t, r["pressure_c"] / 1e3, label="CPAM  $P_c$")
    ax[0].plot(t, r["pressure_e"] / 1e3, label="annulus (EPAM)  $P_e$")
    ax[0].axhline(params.burst_pressure / 1e3, color="r", ls=":", lw=1, label="burst pressure")
    ax[0].set_ylabel("gauge pressure [kPa]")
    ax[0].legend(loc="center right", fontsize=8)

    ax[1].plot(t, r["length"] * 100, color="k", label="length $L$")
    for lim in (params.min_length, params.max_length):
        ax[1].axhline(lim * 100, color="grey", ls=":", lw=1)
    ax[1].set_ylabel("length [cm]")
    axl = ax[1].twinx()
    axl.plot(t, r["load_mass"] * 1e3, color="tab:purple", ls="--", lw=1)
    axl.set_ylabel("load [g]", color="tab:purple")
    axl.tick_params(axis="y", colors="tab:purple")
    axl.set_ylim(0, 1.2e3 * r["load_mass"].max())
    ax[1].set_title("grey dotted: end stops; purple dashed: hanging load", fontsize=8)

    ax[2].plot(t, r["stiffness"], label="constant pressure  $-\\partial F/\\partial L$")
    ax[2].plot(t, r["stiffness_closed"], label="closed chambers (polytropic air)")
    ax[2].set_ylabel("stiffness [N/m]")
    ax[2].legend(loc="center right", fontsize=8)

    ax[3].plot(t, r["spool_c"], label="spool CPAM")
    ax[3].plot(t, r["spool_e"], label="spool annulus")
    ax[3].step(t, r["command_c"], where="post", color="tab:blue", ls=":", lw=1, label="command CPAM")
    ax[3].step(t, r["command_e"], where="post", color="tab:orange", ls=":", lw=1, label="command annulus")
    ax[3].set_ylabel("valve spool [-1, 1]")
    ax[3].set_ylim(-1.15, 1.15)
    ax[3].set_xlabel("time [s]")
    ax[3].legend(loc="lower left", fontsize=8, ncol=2)

    for a in ax:
        a.grid(alpha=0.3)
        for row in SCRIPT[1:]:
            a.axvline(row[0], color="grey", lw=0.5, alpha=0.5)
    for row in SCRIPT[1:]:
        if row[5] != "hold":
            ax[0].annotate(
                row[5],
                (row[0], 1.02),
                xycoords=("data", "axes fraction"),
                fontsize=7,
                rotation=20,
                va="bottom",
                ha="left",
            )
    fig.suptitle(
        f"CE-PAM step response (proportional valves, {1 / (DT * N_SUB):.0f} Hz control, "
        f"force model {params.force_model}/{params.force_form})",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> int:
    ap = CommandParser(prog="python -m cepam_gym.demo", description=__doc__.splitlines()[0])
    ap.add_argument("--out-dir", default="runs/demo", help="directory for step_response.png")
    ap.add_argument(
        "--preset",
        default=None,
        choices=preset_names(),
        help="named parameter set (default: the dataclass defaults = balloon)",
    )
    args = ap.parse_args(argv)
    params = preset(args.preset) if args.preset else PlantParams()
    print(step_response(params, args.out_dir))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
