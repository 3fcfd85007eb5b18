"""The joint's episodes: target schedules, external-torque profiles and reset options over the
hinge's mechanism map (:class:`~cepam_gym.tasks.joint.JointGeometry`), through the rig's planner
(:func:`~cepam_gym.planning.episodes.plan`)."""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from ..tasks.joint import INIT_KEYS, PIN_KEYS, JointGeometry, JointTask
from .episodes import plan
from .plan_vectors import joint_mechanism
from .schedules import load_profile, segments, stiffness_interval

_CANDIDATES = 8  # target candidates drawn per segment before the vectorised feasibility check
_TRIES = 8


def unreachable_torque(task: JointTask, geom: JointGeometry, p) -> float | None:
    """An external torque [N m] of the task's range (held constant) for which no target angle
    has a reachable joint stiffness on plant row ``p`` (``None`` when both ends are feasible):
    a necessary condition for the schedules to be solvable, as the rig's
    :func:`~cepam_gym.planning.randomization.unreachable_load`."""
    spec = task.muscle_spec(geom, p)
    th = np.linspace(*task.angle_range, 33)
    L = geom.length(th, p)
    for tau in task.torque_range:
        w = geom.equivalent_weight(th, tau, p)
        k_lo, k_hi = stiffness_interval(L, w, w, p, spec)
        if not np.any(k_hi > k_lo):
            return float(tau)
    return None


def joint_schedules(
    rng: np.random.Generator, task: JointTask, geom: JointGeometry, p, n_steps: int, dt: float
):
    """One episode: ``(target_angle, target_stiffness, external_torque)`` arrays of ``n_steps``
    and the initial ``(angle, stiffness)``. Every (angle, stiffness) target holds for a segment and
    is reachable (inverse static model, pressures within the margin) at both torque extremes of
    its segment, and therefore in between (the static model is affine in the load)."""
    spec = task.muscle_spec(geom, p)
    r2 = geom.lever_arm**2
    torque = load_profile(rng, spec, n_steps, dt)
    segs = segments(rng, spec, n_steps, dt) + [(0, 1)]  # the last one is the initial state
    ta = np.full(n_steps, np.nan)
    tk = np.full(n_steps, np.nan)
    initial = None
    for s, (a, b) in enumerate(segs):
        t_lo, t_hi = torque[a:b].min(), torque[a:b].max()
        for _ in range(_TRIES):
            th = rng.uniform(*task.angle_range, size=_CANDIDATES)
            u = rng.uniform(0.05, 0.95, size=_CANDIDATES)
            L = geom.length(th, p)
            k_lo, k_hi = stiffness_interval(
                L, geom.equivalent_weight(th, t_lo, p), geom.equivalent_weight(th, t_hi, p), p, spec
            )
            ok = np.flatnonzero(k_hi > k_lo)
            if ok.size:
                c = ok[0]
                target = th[c], (k_lo[c] + u[c] * (k_hi[c] - k_lo[c])) * r2
                break
        else:
            raise RuntimeError(
                f"joint task: found no reachable (angle, stiffness) target for external torques "
                f"{t_lo:.3g}-{t_hi:.3g} N m; lower torque_range or the link mass, or raise the supply"
            )
        if s == len(segs) - 1:
            initial = target
        else:
            ta[a:b], tk[a:b] = target
    return ta, tk, torque, initial


def joint_planned_schedules(
    rngs, task: JointTask, geom: JointGeometry, params, nominal_row, n_steps: int, dt: float
):
    """Schedules of several joint envs at once, ``(target_angle, target_stiffness,
    external_torque, initial)`` (arrays (n_envs, n_steps), ``initial`` (n_envs, 2) = angle, joint
    stiffness): the rig's planner (:func:`~cepam_gym.planning.episodes.plan`) through the joint's
    mechanism (targets drawn as muscle lengths of the nominal plant, ``task.muscle_spec``; env i
    draws only from ``rngs[i]``), each episode's targets shaped by a reference kind drawn from
    ``task.references`` in muscle coordinates under the equivalent hanging load (the link's weight
    depends on the angle, so a shaped reference is projected once more at its own angles; one that
    cannot be made reachable falls back to ``min_jerk`` moves, then to the set-points). With
    references other than ``step`` an episode starts at rest on its reference's first point.
    ``RuntimeError`` when a plant row leaves the task's angles outside the joint's range or has no
    reachable target (the env redraws it)."""
    params = np.atleast_2d(np.asarray(params, dtype=float))
    for row in params:
        try:
            task.check_range(geom, row)
        except ValueError as e:
            raise RuntimeError(str(e)) from None
    spec = task.muscle_spec(geom, nominal_row)
    mechanism = joint_mechanism(geom, nominal_row, task.angle_range)
    return plan(rngs, spec, params, n_steps, dt, mechanism)


_OPTION_UNITS = {
    "target_angle": "rad",
    "target_stiffness": "N m/rad",
    "external_torque": "N m",
    "initial_angle": "rad",
    "initial_stiffness": "N m/rad",
}


def _option_number(options, key: str) -> float:
    """Reset option ``key`` as a float (``InputError`` naming the key and its unit)."""
    value = options[key]
    try:
        if isinstance(value, (str, bytes, bool)) or np.iscomplexobj(value):
            raise TypeError
        return float(value)
    except (TypeError, ValueError):
        raise InputError(
            f"reset option {key} must be a number [{_OPTION_UNITS[key]}], got {value!r}"
        ) from None


def apply_reset_options(options, schedules, initial, geom: JointGeometry, p):
    """``reset(options=...)`` of the joint env on one episode's ``schedules`` (target angle,
    target stiffness, external torque: pinned in place by :data:`PIN_KEYS`) and ``initial``
    ``(angle, stiffness)`` (replaced by :data:`INIT_KEYS`, no reachability check); returns the
    initial pair. ``ValueError`` naming an unknown key or a bad value."""
    options = dict(options or {})
    bad = set(options) - set(PIN_KEYS) - set(INIT_KEYS)
    if bad:
        raise InputError(f"reset options: unknown keys {sorted(bad)}; valid: {list(PIN_KEYS + INIT_KEYS)}")
    for key, arr in zip(PIN_KEYS, schedules):
        if key in options:
            v = _option_number(options, key)
            if not math.isfinite(v):
                raise InputError(f"reset option {key} must be finite, got {options[key]!r}")
            if key == "target_stiffness" and not v > 0:  # the reward divides by it
                raise InputError(f"reset option target_stiffness must be > 0 N m/rad, got {v!r}")
            if key == "target_angle" and not 0.0 <= v <= geom.max_angle(p):
                raise InputError(
                    f"reset option target_angle is in radians and must lie within "
                    f"[0, {geom.max_angle(p):.3g}] rad, got {v!r}"
                )
            arr[:] = v
    a0 = _option_number(options, "initial_angle") if "initial_angle" in options else float(initial[0])
    k0 = _option_number(options, "initial_stiffness") if "initial_stiffness" in options else float(initial[1])
    if not (0.0 <= a0 <= geom.max_angle(p)) or not (math.isfinite(k0) and k0 > 0):
        raise InputError(
            f"initial_angle must be within [0, {geom.max_angle(p):.3g}] rad and "
            f"initial_stiffness > 0, got {a0}, {k0}"
        )
    return a0, k0
