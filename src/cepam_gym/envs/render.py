"""A clear 2-D drawing of the rig, rasterised with numpy (no display, no extra dependency).

Left: mounting plate, the CE-PAM (width from the braid diameter, colour from the two pressures:
red = CPAM, blue = annulus), the target length (green line), the hanging load (grey box, size
from its mass). Right: bars of Pc and Pe against supply, and of stiffness against its target.
"""

from __future__ import annotations

import numpy as np

from .. import plant as pl
from ..physics import layout as ix
from ..physics.muscle import braid_diameter

W, H = 320, 400
_TOP = 40  # pixel row of the mounting plate
_PX_PER_M = 1500.0  # 19.5 cm -> 292 px


def _rect(img, x0, y0, x1, y1, color):
    x0, x1 = sorted((int(round(x0)), int(round(x1))))
    y0, y1 = sorted((int(round(y0)), int(round(y1))))
    img[max(y0, 0) : min(y1, H), max(x0, 0) : min(x1, W)] = color


def draw(core, i: int) -> np.ndarray:
    """RGB frame (H, W, 3) uint8 of env ``i`` of a :class:`~cepam_gym.envs.core.CEPAMBatch`."""
    img = np.full((H, W, 3), 250, dtype=np.uint8)
    p = core.params[i]
    x, aux = core.state[i], core.aux[i]
    L = x[pl.S_L]
    sup = max(p[ix.P_SUP] - p[ix.P_ATM], 1.0)
    tl, tk_, load = (a[i] for a in core.current_targets())
    cx = 110
    _rect(img, 20, _TOP - 12, 200, _TOP, (60, 60, 60))  # mounting plate
    d_e = braid_diameter(L, p[ix.BE], p[ix.NE]) * _PX_PER_M * 2.0  # drawn 2x wider to be visible
    d_c = braid_diameter(L, p[ix.BC], p[ix.NC]) * _PX_PER_M * 2.0
    y_end = _TOP + L * _PX_PER_M
    fe = np.clip(aux[pl.A_PE] / sup, 0, 1)
    fc = np.clip(aux[pl.A_PC] / sup, 0, 1)
    _rect(img, cx - d_e / 2, _TOP, cx + d_e / 2, y_end, (int(200 - 150 * fe), int(200 - 120 * fe), 255))
    _rect(img, cx - d_c / 2, _TOP, cx + d_c / 2, y_end, (255, int(200 - 170 * fc), int(200 - 170 * fc)))
    _rect(img, cx - 18, y_end, cx + 18, y_end + 6, (40, 40, 40))  # end cap
    side = 10 + 60 * np.sqrt(max(load, 0.0) / 0.3)
    _rect(img, cx - side / 2, y_end + 16, cx + side / 2, y_end + 16 + side, (120, 120, 120))
    _rect(img, cx - 1, y_end + 6, cx + 1, y_end + 16, (40, 40, 40))  # hook
    y_t = _TOP + tl * _PX_PER_M
    _rect(img, 40, y_t - 1, 180, y_t + 1, (0, 170, 0))  # target length
    for y in (_TOP + p[ix.L_MIN] * _PX_PER_M, _TOP + p[ix.L_MAX] * _PX_PER_M):
        _rect(img, 185, y - 1, 200, y + 1, (0, 0, 0))  # end stops
    # bars: Pc, Pe (fraction of supply), K vs target (fraction of 2500 N/m)
    base = H - 30
    kmax = 2500.0
    bars = ((fc, (220, 40, 40)), (fe, (40, 40, 220)), (np.clip(aux[pl.A_STIFF] / kmax, 0, 1), (90, 90, 90)))
    for j, (frac, col) in enumerate(bars):
        x0 = 220 + 30 * j
        _rect(img, x0, base - 300, x0 + 20, base, (225, 225, 225))
        _rect(img, x0, base - 300 * frac, x0 + 20, base, col)
    if core.task.track_stiffness:
        yk = base - 300 * np.clip(tk_ / kmax, 0, 1)
        _rect(img, 275, yk - 1, 305, yk + 1, (0, 170, 0))
    return img
