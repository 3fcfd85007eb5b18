"""One mechanism object per mechanism (tasks.mechanism): its load mapping against the static
balance, its measured view against the joint's geometry, and the objects the env, the planner and
the baselines take."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym import plant as pl
from cepam_gym.envs.model import model_of
from cepam_gym.physics import layout as ix
from cepam_gym.planning.plan_vectors import joint_mechanism, mechanism_vector, rig_mechanism
from cepam_gym.plant.params import preset
from cepam_gym.tasks.joint import JointGeometry
from cepam_gym.tasks.mechanism import RIG_MECHANISM, HingeMechanism

P = preset("balloon_v2").to_array()
THETA = np.linspace(0.2, 1.6, 8)
FORCE = -np.linspace(2.0, 40.0, 8)  # a muscle in tension pulls up on its load [N]


def test_the_rig_is_its_muscle():
    L = np.linspace(0.16, 0.19, 8)
    assert np.array_equal(RIG_MECHANISM.muscle_length(L, P), L)
    assert RIG_MECHANISM.muscle_stiffness(800.0) == 800.0
    # Eq. 25: a muscle force F holds a hanging weight -F; never less than the end cap's weight
    assert np.array_equal(RIG_MECHANISM.load_from_force(FORCE, L, P), -FORCE)
    floor = P[ix.M_END] * P[ix.GRAV]
    assert np.array_equal(RIG_MECHANISM.muscle_weight(L, np.array([0.0, 5.0]), P), [floor, 5.0])
    assert RIG_MECHANISM.code == pl.RIG and not RIG_MECHANISM.hinge_row().any()


def test_the_hinges_load_mapping_inverts_its_static_balance():
    """The torque that balances the muscle's force, mapped back to the muscle, is that force's
    weight: the load estimate and the load mapping are one geometry."""
    hinge = HingeMechanism(geometry=JointGeometry(lever_arm=0.03, link_mass=0.2))
    tau = hinge.load_from_force(FORCE, THETA, P)
    ok = tau >= 0  # extension torques (the mapping clips flexion torques to 0)
    assert ok.sum() >= 4
    np.testing.assert_allclose(hinge.muscle_weight(THETA, tau, P)[ok], -FORCE[ok], rtol=1e-12)
    # positions: L = L_max - r theta; stiffness: K = K_joint / r^2
    np.testing.assert_allclose(hinge.muscle_length(THETA, P), P[ix.L_MAX] - 0.03 * THETA, rtol=1e-15)
    assert hinge.muscle_stiffness(0.9) == pytest.approx(0.9 / 0.03**2, rel=1e-15)
    assert hinge.muscle_stiffness(None) is None


@pytest.mark.parametrize(
    ("env_id", "code"), [("cepam_gym/CEPAM-v3", pl.RIG), ("cepam_gym/CEPAMJoint-v3", pl.HINGE)]
)
def test_the_env_model_and_the_planner_take_the_tasks_mechanism(env_id, code):
    env = gym.make(env_id)
    model = model_of(env)
    m = model.mechanism
    assert m is env.unwrapped.core.task.mechanism and m.code == model.mech == code
    assert np.array_equal(env.unwrapped.core.s.hinge[0], m.hinge_row())
    row = model.nominal.to_array()
    if code == pl.HINGE:
        task = env.unwrapped.core.task
        vec = joint_mechanism(task.geometry, row, task.spec.angle_range)
        assert np.array_equal(mechanism_vector(m, row, task.spec.angle_range), vec)
        assert m.geometry is task.geometry
    else:
        assert np.array_equal(mechanism_vector(m, row, (0.15, 0.19)), rig_mechanism())


def test_the_joints_measured_view_is_the_steps():
    """The mechanism's muscle length at the angle the joint env reports is the muscle length the
    env reports (info), step after step."""
    env = gym.make("cepam_gym/CEPAMJoint-v3")
    m = model_of(env).mechanism
    env.reset(seed=4)
    p = model_of(env).nominal.to_array()
    for _ in range(40):
        *_, info = env.step(np.array([0.3, -0.2], np.float32))
        assert m.muscle_length(info["angle"], p) == pytest.approx(info["muscle_length"], abs=1e-12)
