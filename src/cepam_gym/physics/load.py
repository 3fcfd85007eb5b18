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

from .._jit import jit, jit_inline


@jit
def load_step(L, v, force, mass, f_ext, gravity, damping, coulomb, l_min, l_max, dt):
    """One semi-implicit Euler step of the free end; returns ``(L, v, at_stop)``.

    Damping is implicit (unconditionally stable for any ``c``); Coulomb friction is applied as an
    impulse that can stop the motion but never reverse it (stick when the net force is below it).
    """
    k = load_constants(mass, damping, coulomb, dt)
    return load_step_k(L, v, force + mass * gravity + f_ext, k[0], k[1], k[2], l_min, l_max, dt)


@jit_inline
def load_constants(mass, damping, coulomb, dt):
    """``(dt/M, Coulomb velocity impulse dt F_c/M, implicit damping factor 1/(1 + dt c/M))``:
    constant over a control step, so the plant computes them once per step."""
    return dt / mass, dt * coulomb / mass, 1.0 / (1.0 + dt * damping / mass)


@jit_inline
def load_step_k(L, v, f_total, dt_over_m, dv_fric, damp_factor, l_min, l_max, dt):
    """:func:`load_step` with the net force (pneumatic + gravity + external) and the
    :func:`load_constants` precomputed."""
    v_free = v + dt_over_m * f_total
    if v_free > dv_fric:
        v_free -= dv_fric
    elif v_free < -dv_fric:
        v_free += dv_fric
    else:
        v_free = 0.0
    v_new = v_free * damp_factor
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
