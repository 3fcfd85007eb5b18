"""The reward declared once (tasks.reward): the package's step compiled from its declarations, a
user's declaration compiled into a step of its own, and bad declarations refused by name."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym.envs import step_source
from cepam_gym.envs.hinge_task import JOINT_SCORE_WEIGHTS
from cepam_gym.errors import InputError
from cepam_gym.tasks.joint import JointRewardWeights
from cepam_gym.tasks.reward import (
    ABS_REWARD,
    JOINT_ABS_REWARD,
    JOINT_SCORE_REWARD,
    SCORE_REWARD,
    Reward,
    Term,
    is_builtin,
    reward_index,
)
from cepam_gym.tasks.spec import SCORE_WEIGHTS, TASKS, RewardWeights

# a term a user might add: the length's rate, per (5 cm/s)^2
RATE = Term("rate", "-w * (v / 0.05) ** 2", 0.01, "-w (dL/dt / 5 cm/s)^2")
RATE_REWARD = dataclasses.replace(SCORE_REWARD, name="score_rate", terms=(*SCORE_REWARD.terms, RATE))


def test_the_compiled_builtin_reward_is_generated_from_the_declarations():
    """envs/_reward_builtin.py is what the declarations generate (regenerate it with
    ``python -m cepam_gym.envs.write_reward_builtin`` after editing tasks/reward.py)."""
    assert step_source._BUILTIN_FILE.read_text() == step_source.builtin_text()


def test_the_weights_dataclasses_are_the_declared_defaults():
    def declared(r):
        return {t.name: t.weight for t in r.terms}

    assert dataclasses.asdict(RewardWeights()) == declared(ABS_REWARD)
    assert dataclasses.asdict(SCORE_WEIGHTS) == declared(SCORE_REWARD)
    assert dataclasses.asdict(JointRewardWeights()) == declared(JOINT_ABS_REWARD)
    assert dataclasses.asdict(JOINT_SCORE_WEIGHTS) == declared(JOINT_SCORE_REWARD)
    # the joint's rewards are the rig's code: one compiled branch serves both
    assert JOINT_ABS_REWARD.code() == ABS_REWARD.code() and JOINT_SCORE_REWARD.code() == SCORE_REWARD.code()
    assert [reward_index(r) for r in (ABS_REWARD, SCORE_REWARD, JOINT_SCORE_REWARD)] == [0, 1, 1]
    assert not is_builtin(RATE_REWARD)


def _pair(num_envs=None):
    spec = TASKS["cepam_v3"].with_reward(RATE_REWARD, rate=0.02)
    if num_envs is None:
        return gym.make("cepam_gym/CEPAM-v3", task=spec), gym.make("cepam_gym/CEPAM-v3")
    return (
        gym.make_vec("cepam_gym/CEPAM-v3", num_envs=num_envs, task=spec),
        gym.make_vec("cepam_gym/CEPAM-v3", num_envs=num_envs),
    )


def test_a_user_term_adds_to_the_packages_reward_and_changes_nothing_else():
    """The declared term is in the info, priced as its expression says, and the reward is the
    package's plus that term; observations and every other term are the package's, bit for bit."""
    env, ref = _pair()
    env.reset(seed=3)
    ref.reset(seed=3)
    assert env.unwrapped.core.step_module.__name__.startswith("cepam_gym_step_")
    for k in range(120):
        a = np.array([np.sin(k / 5), np.cos(k / 7)], np.float32)
        o, r, *_, info = env.step(a)
        o0, r0, *_, info0 = ref.step(a)
        assert np.array_equal(o, o0)
        assert all(info[key] == info0[key] for key in info0)
        assert info["reward_rate"] == pytest.approx(-0.02 * (info["velocity"] / 0.05) ** 2, rel=1e-12)
        assert r == pytest.approx(r0 + info["reward_rate"], rel=1e-12, abs=1e-15)
    assert info["reward_rate"] < 0  # the rate was not zero throughout


def test_a_user_term_in_the_native_vector_env():
    venv, ref = _pair(num_envs=64)
    venv.reset(seed=0)
    ref.reset(seed=0)
    rng = np.random.default_rng(1)
    for _ in range(10):
        a = rng.uniform(-1, 1, (64, 2)).astype(np.float32)
        o, r, _, _, info = venv.step(a)
        o0, r0, _, _, info0 = ref.step(a)
        assert np.array_equal(o, o0)
        np.testing.assert_allclose(r, r0 + info["reward_rate"], rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(info["reward_rate"], -0.02 * (info["velocity"] / 0.05) ** 2, rtol=1e-12)


def test_reward_weights_reach_a_user_term():
    spec = TASKS["cepam_v3"].with_reward(RATE_REWARD)
    env = gym.make("cepam_gym/CEPAM-v3", task=spec)
    assert env.unwrapped.core.task_params.w[5] == RATE.weight
    with pytest.raises(InputError, match=r"unknown terms \['speed'\]"):
        TASKS["cepam_v3"].with_reward(RATE_REWARD, speed=1.0)


@pytest.mark.parametrize(
    "terms, quantities, match",
    [
        ((Term("a", "-w * velocity", 1.0),), (), r"reads \['velocity'\], which the step does not have"),
        ((Term("a", "-w * (v", 1.0),), (), "not a Python expression"),
        ((Term("a", "-w", 1.0), Term("a", "-w", 1.0)), (), r"used twice or reserved: \['a'\]"),
        ((Term("a", "-w * x", 1.0),), (("x", "1.0"),), r"used twice or reserved: \['x'\]"),
        ((Term("a", "-w * e", 1.0),), (("d", "e"), ("e", "1.0")), r"d reads \['e'\]"),
        ((Term("a", "-w * v * counted", 1.0),), (), "declare it with allowance=True"),
        ((Term("a", "-w", -1.0),), (), "weight must be finite and >= 0"),
        (tuple(Term(f"t{i}", "-w", 1.0) for i in range(9)), (), "1 to 8 terms"),
    ],
)
def test_a_bad_declaration_is_refused_by_name(terms, quantities, match):
    with pytest.raises(InputError, match=match):
        Reward("mine", terms, quantities)


def test_a_task_parameter_the_step_does_not_have_is_refused_at_construction():
    r = Reward("mine", (Term("a", "-w * task.gain", 1.0),))
    with pytest.raises(InputError, match=r"reads task.gain; the task's parameters are"):
        gym.make("cepam_gym/CEPAM-v3", task=TASKS["cepam_v3"].with_reward(r))
