"""Mechanics of the free end: the rig of the paper hangs vertically (Fig. 5, 16, 17).

The mounting plate is on top, the free end moves down when the CE-PAM extends, so with ``L`` the
CE-PAM length and ``v = dL/dt``::

    M dv/dt = F_pneumatic + M g + F_ext - c v - F_coulomb sign(v)

where ``M`` is the end-cap mass plus the hanging load, ``F_pneumatic`` the push force of
:func:`cepam_gym.physics.muscle.cepam_force` and ``F_ext`` an external force (down positive).
End stops at ``L_min`` (15 cm, the nominal length) and ``L_max`` (19.5 cm, the CPAM's rest length,
which stops further extension, paper section V) are perfectly plastic.
"""

from __future__ import annotations

from .._jit import jit


@jit
def load_step(L, v, force, mass, f_ext, gravity, damping, coulomb, l_min, l_max, dt):
    """One semi-implicit Euler step of the free end; returns ``(L, v, at_stop)``.

    Damping is implicit (unconditionally stable for any ``c``); Coulomb friction is applied as an
    impulse that can stop the motion but never reverse it (stick when the net force is below it).
    """
    v_free = v + dt * (force + mass * gravity + f_ext) / mass
    dv_fric = dt * coulomb / mass
    if v_free > dv_fric:
        v_free -= dv_fric
    elif v_free < -dv_fric:
        v_free += dv_fric
    else:
        v_free = 0.0
    v_new = v_free / (1.0 + dt * damping / mass)
    L_new = L + dt * v_new
    at_stop = 0.0
    if L_new <= l_min:
        L_new = l_min
        if v_new < 0.0:
            v_new = 0.0
        at_stop = -1.0
    elif L_new >= l_max:
        L_new = l_max
        if v_new > 0.0:
            v_new = 0.0
        at_stop = 1.0
    return L_new, v_new, at_stop
