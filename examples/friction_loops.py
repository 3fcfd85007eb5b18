"""Force-length hysteresis of plant v1's braid-bladder friction (docs/physics.md section 13).

The free end is moved through +-3 mm around 17.5 cm at held chamber pressures (as a slow
tensile test would); the push force is the static force (enhanced model, virtual work, walls)
plus the Maxwell-slip elements' force. The loops widen with pressure because the break-away force
does. Writes docs/img/friction_loops.png. Run: python examples/friction_loops.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cepam_gym.physics import api
from cepam_gym.physics.friction import friction_force, friction_slip
from cepam_gym.plant.params import PlantParams


def loop(params: PlantParams, pc: float, pe: float, amplitude: float = 3e-3, n: int = 600):
    row = params.to_array()
    lengths = 0.175 + amplitude * np.sin(np.linspace(0.0, 4.0 * np.pi, 2 * n + 1))
    z = (0.0, 0.0, 0.0)
    forces = []
    for k, L in enumerate(lengths):
        if k:
            z = friction_slip(row, L - lengths[k - 1], *z)
        forces.append(float(api.force(L, pc, pe, row)) + friction_force(row, pc, pe, *z))
    return lengths[n:], np.array(forces[n:])  # the second cycle


def main(out: str = "docs/img/friction_loops.png") -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    p = PlantParams()
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for pe, pc in ((50e3, 75e3), (100e3, 175e3), (125e3, 250e3)):
        L, F = loop(p, pc, pe)
        area = -float(np.sum(0.5 * (F[1:] + F[:-1]) * np.diff(L)))
        ax.plot(L * 100, F, label=f"Pe={pe / 1e3:g}, Pc={pc / 1e3:g} kPa: loop {area * 1e3:.2f} mJ")
    ax.set_xlabel("length [cm]")
    ax.set_ylabel("push force [N]")
    ax.set_title("plant v1 friction: force-length loops, pressures held")
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = Path(out)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    return path


if __name__ == "__main__":
    print(main())
