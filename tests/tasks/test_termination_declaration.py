"""Terminations declared once (tasks.termination): the published ids' reasons, a user's
termination compiled into a step of its own (single, vector and joint env), bad declarations
refused by name."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym.envs import step_source
from cepam_gym.errors import InputError
from cepam_gym.tasks.joint import JointTask
from cepam_gym.tasks.spec import TASKS, TERMINATION_NAMES, TaskSpec
from cepam_gym.tasks.termination import BURST, DEFAULT_TERMINATIONS, Termination

# a termination a user might add: the muscle 1 cm longer than its target
TOO_LONG = Termination("too_long", "x > x_target + 0.01", "1 cm longer than the target")
GUARDED = dataclasses.replace(TASKS["length_v3"], name="length_guarded", terminations=(BURST, TOO_LONG))
PUSH = np.array([-1.0, 1.0], np.float32)  # contractor vented, extensor filled: the muscle lengthens


def test_the_published_ids_end_an_episode_on_a_burst_only():
    assert DEFAULT_TERMINATIONS == (BURST,)
    assert TERMINATION_NAMES == ("none", "burst", "non_finite_state")
    for spec in TASKS.values():
        assert spec.termination_names == TERMINATION_NAMES
    assert JointTask().termination_names == TERMINATION_NAMES
    for env_id in ("cepam_gym/CEPAM-v3", "cepam_gym/CEPAMJoint-v3"):
        env = gym.make(env_id)
        assert env.unwrapped.metadata["termination_reasons"] == TERMINATION_NAMES
        assert env.unwrapped.core.step_module.__name__ == "cepam_gym.envs.step"
    text = step_source.builtin_text()
    assert "NONFINITE = 2" in text and "if burst:  # burst" in text


def test_a_user_termination_ends_the_episode_and_changes_nothing_before():
    """The declared condition ends the episode with its code; up to that step the observations,
    rewards and info are those of the same task without it, bit for bit."""
    env = gym.make("cepam_gym/CEPAMLength-v3", task=GUARDED)
    ref = gym.make("cepam_gym/CEPAMLength-v3", task=dataclasses.replace(GUARDED, terminations=(BURST,)))
    names = env.unwrapped.metadata["termination_reasons"]
    assert names == ("none", "burst", "too_long", "non_finite_state")
    assert env.unwrapped.core.step_module.__name__.startswith("cepam_gym_step_")
    o, _ = env.reset(seed=5)
    o0, _ = ref.reset(seed=5)
    assert np.array_equal(o, o0)
    for k in range(500):
        o, r, term, trunc, info = env.step(PUSH)
        o0, r0, term0, _, info0 = ref.step(PUSH)
        assert np.array_equal(o, o0) and r == r0
        assert {key: info[key] for key in info0 if key != "termination_reason"} == {
            key: info0[key] for key in info0 if key != "termination_reason"
        }
        over = info["length"] > info["target_length"] + 0.01
        assert term == over and info["termination_reason"] == (names.index("too_long") if over else 0)
        assert not term0
        if term:
            break
    assert term, "the muscle never got 1 cm past its target"


def test_the_vector_env_ends_exactly_the_envs_whose_condition_holds():
    vec = gym.make_vec("cepam_gym/CEPAMLength-v3", num_envs=6, task=GUARDED)
    assert vec.metadata["termination_reasons"] == ("none", "burst", "too_long", "non_finite_state")
    vec.reset(seed=11)
    actions = np.tile(PUSH, (6, 1))
    for _ in range(300):
        _, _, term, _, infos = vec.step(actions)
        over = infos["length"] > infos["target_length"] + 0.01
        assert np.array_equal(term, over)
        assert np.array_equal(infos["termination_reason"], np.where(over, 2, 0))
        if term.any():
            break
    assert term.any()


def test_the_joint_takes_declared_terminations():
    """A condition over the joint's quantities (the angle in rad) on the joint kernel env."""
    wide = Termination("wide", "x > x_target + 0.05", "0.05 rad past the target angle")
    task = dataclasses.replace(JointTask(), terminations=(BURST, wide))
    env = gym.make("cepam_gym/CEPAMJoint-v1", task=task)
    assert env.unwrapped.metadata["termination_reasons"] == ("none", "burst", "wide", "non_finite_state")
    env.reset(seed=2)
    for _ in range(500):
        *_, term, _, info = env.step(PUSH)
        over = info["angle"] > info["target_angle"] + 0.05
        assert term == over
        if term:
            assert info["termination_reason"] == 2
            break
    assert term, "the joint never got 0.05 rad past its target"


def test_the_mujoco_joint_refuses_terminations():
    pytest.importorskip("mujoco")
    with pytest.raises(InputError, match="terminations"):
        gym.make("cepam_gym/CEPAMJoint-v0", task_options={"terminations": (BURST,)})


@pytest.mark.parametrize(
    ("build", "match"),
    [
        (lambda: Termination("none", "burst"), "reserved"),
        (lambda: Termination("non_finite_state", "burst"), "reserved"),
        (lambda: Termination("too long", "burst"), "not a valid name"),
        (lambda: Termination("early", "x >"), "not a Python expression"),
        (lambda: Termination("early", "length > 0.18"), r"reads \['length'\]"),
        (lambda: TaskSpec("t", terminations=(BURST, BURST)), "used twice"),
        (lambda: TaskSpec("t", terminations=BURST), "tuple of Termination"),
        (lambda: TaskSpec("t", terminations=("burst",)), "Termination objects"),
    ],
)
def test_bad_declarations_are_refused_by_name(build, match):
    with pytest.raises(InputError, match=match):
        build()


def test_a_condition_reading_an_unknown_task_parameter_is_refused_when_the_env_is_built():
    spec = dataclasses.replace(GUARDED, terminations=(Termination("late", "x > task.no_such_thing"),))
    with pytest.raises(InputError, match=r"termination 'late' reads task\.no_such_thing"):
        gym.make("cepam_gym/CEPAMLength-v3", task=spec)
