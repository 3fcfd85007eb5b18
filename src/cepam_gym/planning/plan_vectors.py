"""What the compiled reset planner reads of a task, flattened into float vectors (numba freezes
no Python objects): the spec vector of a :class:`~cepam_gym.tasks.spec.TaskSpec` and the
mechanism vector (the rig, or the joint's rack and pinion), with the joint's map from its
position and torque to the muscle's length and weight."""

from __future__ import annotations

import math

import numpy as np

from .. import plant as pl
from .._jit import jit_inline
from ..physics import layout as ix
from ..tasks.spec import LOAD_KINDS, REFERENCE_KINDS, TaskSpec

_KINDS = 5  # slots for load kinds and reference kinds (both lists have five entries)
assert len(LOAD_KINDS) == _KINDS and len(REFERENCE_KINDS) == _KINDS
(
    SV_LEN_LO,
    SV_LEN_HI,
    SV_FIXED,  # NaN: no fixed length
    SV_K_MIN,
    SV_K_MAX,
    SV_LOAD_LO,
    SV_LOAD_HI,
    SV_SEG_LO,
    SV_SEG_HI,
    SV_MARGIN,
    SV_MOVE_S,
    SV_N_LOADS,
) = range(12)
SV_LOADS = 12  # the load kinds' indices in LOAD_KINDS
SV_N_REFS = SV_LOADS + _KINDS
SV_REFS = SV_N_REFS + 1  # the reference kinds' indices in REFERENCE_KINDS
N_SV = SV_REFS + _KINDS
# load kinds and reference kinds as the compiled code names them
LOAD_CONSTANT, LOAD_STEP, LOAD_RAMP, LOAD_SINE, LOAD_RANDOM = range(5)
REF_STEP, REF_MIN_JERK, REF_SINE, REF_CHIRP, REF_STIFFNESS_RAMP = range(5)
assert LOAD_KINDS == ("constant", "step", "ramp", "sine", "random")
assert REFERENCE_KINDS == ("step", "min_jerk", "sine", "chirp", "stiffness_ramp")

# the mechanism vector: 0 for the rig; for the joint 1, then the nominal plant's upper end stop
# [m] (positions are muscle lengths of the nominal plant), lever arm r [m], r^2 [m^2], link mass
# [kg], the distance of its centre of mass from the hinge [m] and the task's angle range [rad]
MV_JOINT, MV_L_MAX, MV_R, MV_R2, MV_MASS, MV_COM, MV_A_LO, MV_A_HI = range(8)
N_MV = 8


_CACHE: dict[int, tuple[TaskSpec, np.ndarray]] = {}


def spec_vector(spec: TaskSpec) -> np.ndarray:
    """The spec vector of ``spec`` (``SV_*`` columns; built once per spec object: a single env's
    reset asks for it every episode)."""
    hit = _CACHE.get(id(spec))
    if hit is not None and hit[0] is spec:
        return hit[1]
    v = _build(spec)
    v.setflags(write=False)
    if len(_CACHE) > 256:
        _CACHE.clear()
    _CACHE[id(spec)] = (spec, v)
    return v


def _build(spec: TaskSpec) -> np.ndarray:
    v = np.zeros(N_SV)
    v[SV_LEN_LO], v[SV_LEN_HI] = spec.length_range
    v[SV_FIXED] = math.nan if spec.fixed_length is None else spec.fixed_length
    v[SV_K_MIN], v[SV_K_MAX] = spec.stiffness_range
    v[SV_LOAD_LO], v[SV_LOAD_HI] = spec.load_range
    v[SV_SEG_LO], v[SV_SEG_HI] = spec.segment_duration
    v[SV_MARGIN], v[SV_MOVE_S] = spec.pressure_margin, spec.move_s
    v[SV_N_LOADS] = len(spec.load_kinds)
    v[SV_LOADS : SV_LOADS + len(spec.load_kinds)] = [LOAD_KINDS.index(k) for k in spec.load_kinds]
    v[SV_N_REFS] = len(spec.references)
    v[SV_REFS : SV_REFS + len(spec.references)] = [REFERENCE_KINDS.index(k) for k in spec.references]
    return v


def rig_mechanism() -> np.ndarray:
    """The rig's mechanism vector: positions are muscle lengths, loads hanging masses."""
    return np.zeros(N_MV)


def mechanism_vector(mechanism, nominal_row, position_range) -> np.ndarray:
    """The planner's vector of a :class:`~cepam_gym.tasks.mechanism.Mechanism` (the rig's, or a
    hinge's through its geometry with ``position_range`` its target angles [rad])."""
    if mechanism.code == pl.HINGE:
        return joint_mechanism(mechanism.geometry, nominal_row, position_range)
    return rig_mechanism()


def joint_mechanism(geom, nominal_row, angle_range) -> np.ndarray:
    """The joint's mechanism vector (``geom`` a :class:`~cepam_gym.tasks.joint.JointGeometry`,
    ``angle_range`` the task's target angles [rad])."""
    r = geom.lever_arm
    return np.array(
        [1.0, float(nominal_row[ix.L_MAX]), r, r**2, geom.link_mass, geom.link_com, *angle_range], dtype=float
    )


@jit_inline
def equivalent_weight(theta, torque, p, mv):
    """The downward force [N] on the muscle's free end that the joint's loads at angle ``theta``
    amount to (the rig's hanging weight): ``m_end g + (tau_ext + m g l_c sin theta) / r``."""
    g = p[ix.GRAV]
    return p[ix.M_END] * g + (torque + mv[MV_MASS] * g * mv[MV_COM] * math.sin(theta)) / mv[MV_R]


@jit_inline
def muscle_of(position, torque, p, mv):
    """The joint's target position (a muscle length of the nominal plant, ``L_max - r theta``)
    and external torque [N m] as the muscle of row ``p`` sees them: ``(length [m], weight [N])``."""
    theta = (mv[MV_L_MAX] - position) / mv[MV_R]
    return p[ix.L_MAX] - mv[MV_R] * theta, equivalent_weight(theta, torque, p, mv)
