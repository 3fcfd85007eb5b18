"""What the muscle drives, one object per mechanism: the rig's hanging load or the joint's hinge.

A task's targets and loads are in its mechanism's coordinates (the rig: length [m], stiffness
[N/m], a hanging weight [N]; the joint: angle [rad], joint stiffness [N m/rad], an external torque
[N m]); the plant, the inverse static model and the planners work on the muscle (length, stiffness,
the weight on its free end). A :class:`Mechanism` maps between the two: its measured view
(:meth:`~Mechanism.muscle_length`, :meth:`~Mechanism.muscle_stiffness`), its load mapping
(:meth:`~Mechanism.load_from_force`: the load whose static balance the muscle's force is, and
:meth:`~Mechanism.muscle_weight`: the weight a load amounts to at a target), its geometry and its
constants for the compiled kernels (:meth:`~Mechanism.hinge_row`, ``code``). The env's tasks hold
one (``Task.mechanism``), the env's model exposes it, the planners take its vector
(:func:`cepam_gym.planning.plan_vectors.mechanism_vector`) and the baselines run the one inverse
static model through it (:class:`cepam_gym.control.InverseStaticController`).

The compiled step reads the same mapping from ``code`` and the hinge row
(:func:`cepam_gym.envs.step_kernel.mechanism_view`); this module is its Python form, for callers
that work on decoded observations.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import plant as pl
from ..physics import layout as ix
from ..physics.hinge import N_HINGE
from .joint import JointGeometry


@dataclass(frozen=True)
class Mechanism:
    """The rig: the muscle's free end carries a hanging load; positions are muscle lengths."""

    name: str = "rig"
    code: int = pl.RIG  # what the compiled kernels branch on
    position: str = "length"  # the observation's and info's name of the tracked position
    units: tuple[str, str, str] = ("m", "N/m", "N")  # position, stiffness, load (here a weight)

    @property
    def target(self) -> str:
        """The observation column of the position's target."""
        return f"target_{self.position}"

    def hinge_row(self) -> np.ndarray:
        """The mechanism's constants of the batched kernel (:mod:`cepam_gym.physics.hinge`)."""
        return np.zeros(N_HINGE)

    def muscle_length(self, position, p):
        """The muscle's length [m] at ``position``, on plant row ``p``."""
        return np.asarray(position, dtype=float)

    def muscle_stiffness(self, stiffness):
        """The muscle's stiffness [N/m] the task's ``stiffness`` is (``None`` stays ``None``)."""
        return stiffness

    def load_from_force(self, force, position, p):
        """The load (here the hanging weight [N]) whose static balance is the muscle's ``force``
        [N] at ``position`` (paper Eq. 25: ``F + W = 0``)."""
        return -force

    def muscle_weight(self, position, load, p):
        """The downward force [N] on the muscle's free end that ``load`` amounts to at
        ``position``; never below the end cap's own weight."""
        return np.maximum(load, p[ix.M_END] * p[ix.GRAV])


RIG_MECHANISM = Mechanism()


@dataclass(frozen=True)
class HingeMechanism(Mechanism):
    """The joint: the muscle turns a hinge through a rack and pinion (``geometry``); positions
    are joint angles, loads external torques (:class:`~cepam_gym.tasks.joint.JointGeometry`)."""

    name: str = "hinge"
    code: int = pl.HINGE
    position: str = "angle"
    units: tuple[str, str, str] = ("rad", "N m/rad", "N m")
    geometry: JointGeometry = JointGeometry()

    def hinge_row(self) -> np.ndarray:
        return self.geometry.hinge_row()

    def muscle_length(self, position, p):
        return self.geometry.length(position, p)

    def muscle_stiffness(self, stiffness):
        return None if stiffness is None else stiffness / self.geometry.lever_arm**2

    def load_from_force(self, force, position, p):
        """The external torque [N m] the hinge balances statically: ``-r (F + m_end g) - m g l_c
        sin(theta)``."""
        g, r = p[ix.GRAV], self.geometry.lever_arm
        return -r * (force + p[ix.M_END] * g) - self.geometry.gravity_torque(position, g)

    def muscle_weight(self, position, load, p):
        """The rig's hanging weight [N] that an extension torque ``load`` (never below 0) and the
        link's weight amount to at angle ``position`` (:meth:`JointGeometry.equivalent_weight`)."""
        return self.geometry.equivalent_weight(position, np.maximum(load, 0.0), p)
