"""Mechanics of a hinge driven through a rack and pinion (``cepam_gym/CEPAMJoint``).

The muscle's free end drives a pinion of radius ``r`` (the lever arm): ``L = L_max - r theta``,
``v = -r omega``. The hinge (docs/mujoco.md) obeys::

    I_tot domega/dt = -r (F + m_end g) - tau_ext - m_link g l_c sin(theta) - d omega

with ``I_tot = I_link + m_end r^2`` (link about the axis, plus the end cap as MuJoCo's armature)
and ``d = d_joint + c r^2`` (the hinge's own damping plus the free end's, ``c``). Divided by
``-r`` this is the rig's free-end equation (:mod:`cepam_gym.physics.load`) in muscle coordinates::

    (I_tot / r^2) dv/dt = F + m_end g + (tau_ext + m_link g l_c sin theta) / r - (d / r^2) v

so the hinge runs on the plant's own load step with an effective mass, an effective damping and
one extra force, the link's weight, that depends on the position. The joint limits
``[0, (L_max - L_min) / r]`` are the muscle's end stops.

A hinge row (``hinge``, :data:`HINGE_FIELDS`) holds the mechanism's constants; the plant's
parameter row keeps the end mass, damping, Coulomb friction and gravity.
"""

from __future__ import annotations

import math

from .._jit import jit_inline
from . import layout as ix

HINGE_FIELDS = ("lever_arm", "inertia", "mass_moment", "damping")
H_R, H_INERTIA, H_MASS_MOMENT, H_DAMP = range(4)  # m, kg m^2 (link about the axis), kg m, N m s/rad
N_HINGE = 4


@jit_inline
def hinge_constants(p, h, load_mass):
    """``(effective mass [kg], effective damping [N s/m], weight of the link per unit sin(theta)
    [N], 1 / r [1/m])`` of the hinge in muscle coordinates, for a control step (``load_mass``:
    what hangs on the free end itself, 0 on the joint)."""
    r = h[H_R]
    inv_r2 = 1.0 / (r * r)
    mass = p[ix.M_END] + load_mass + h[H_INERTIA] * inv_r2
    damping = p[ix.DAMP] + h[H_DAMP] * inv_r2
    return mass, damping, h[H_MASS_MOMENT] * p[ix.GRAV] / r, 1.0 / r


@jit_inline
def link_weight_force(L, l_max, weight_per_sin, inv_r):
    """Force [N, extension positive] of the link's weight on the muscle at length ``L``:
    ``m_link g l_c sin(theta) / r`` with ``theta = (L_max - L) / r``."""
    return weight_per_sin * math.sin((l_max - L) * inv_r)
