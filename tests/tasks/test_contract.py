"""Each task's contract (cepam_gym.tasks.contract) against what its envs emit, what the benchmark
reads, what the agents log, and the stated relation between the reward and the score."""

from __future__ import annotations

import dataclasses
import importlib.util

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym.control.objective import JOINT as JOINT_TRACES
from cepam_gym.control.objective import RIG as RIG_TRACES
from cepam_gym.control.objective import combined_score, step_error_sq
from cepam_gym.errors import InputError
from cepam_gym.tasks.contract import CONTRACTS, JOINT, RIG
from cepam_gym.tasks.spec import TERMINATION_NAMES

HAS_MUJOCO = importlib.util.find_spec("mujoco") is not None
IDS = sorted(k for k in gym.registry if k.startswith("cepam_gym/"))
_PINS = {
    "target_length": 0.17,
    "target_stiffness": 800.0,
    "load_mass": 0.1,
    "target_angle": 0.8,
    "external_torque": 0.01,
    "initial_angle": 0.7,
    "initial_stiffness": 0.4,
}


def _make(env_id):
    if env_id.endswith("Joint-v0") and not HAS_MUJOCO:
        pytest.skip("CEPAMJoint-v0 needs mujoco")
    return gym.make(env_id)


def _pins(contract):
    pins = {k: _PINS[k] for k in contract.pin_keys}
    if contract is JOINT:
        pins["target_stiffness"] = 0.4
    return pins


@pytest.mark.parametrize("env_id", IDS)
def test_each_registered_env_emits_its_contract(env_id):
    """Info keys of a reset and of a step, reward = sum of the named terms, the term names and
    the termination names: as the task's contract declares them."""
    env = _make(env_id)
    c = env.unwrapped.contract
    assert c in CONTRACTS.values()
    assert env.unwrapped.metadata["termination_reasons"] == c.termination_names == TERMINATION_NAMES
    obs, info = env.reset(seed=1)
    assert set(info) == set(c.info_keys)
    rng = np.random.default_rng(0)
    for _ in range(5):
        obs, reward, term, trunc, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        assert set(info) == set(c.step_keys)
        assert reward == pytest.approx(sum(info[k] for k in c.term_keys), rel=1e-12, abs=1e-15)
        assert all(info[k] <= 0.0 for k in c.term_keys)
    assert c.termination_names[info["termination_reason"]] == "none"
    # what the score reads is there, and the pin keys are the reset options the env takes
    assert set(c.score_keys.values()) <= set(info)
    _, info = env.reset(seed=2, options=_pins(c))
    for k in set(c.pin_keys) & set(info):
        assert info[k] == pytest.approx(_pins(c)[k])
    env.close()


@pytest.mark.parametrize("env_id", [i for i in IDS if not i.endswith("Joint-v0")])
def test_each_vector_env_masks_its_contracts_keys(env_id):
    venv = gym.make_vec(env_id, num_envs=3)
    c = venv.unwrapped.contract
    assert venv.unwrapped.core.task.reward_terms == c.reward_terms
    venv.reset(seed=0)
    _, reward, _, _, infos = venv.step(np.zeros((3, 2), np.float32))
    for k in c.step_keys:
        assert k in infos and infos["_" + k].all(), k
    np.testing.assert_allclose(reward, sum(infos[k] for k in c.term_keys), rtol=1e-12, atol=1e-15)
    assert venv.metadata["termination_reasons"] == c.termination_names
    venv.close()


def test_the_kernel_and_the_envs_read_their_names_from_the_contracts():
    from cepam_gym.envs import joint, joint_mujoco, shared
    from cepam_gym.envs.hinge_task import HingeTask
    from cepam_gym.envs.rig_task import RigTask
    from cepam_gym.tasks.joint import JointRewardWeights
    from cepam_gym.tasks.reward import ABS_REWARD, JOINT_ABS_REWARD, JOINT_SCORE_REWARD, SCORE_REWARD
    from cepam_gym.tasks.spec import RewardWeights

    assert ABS_REWARD.names == SCORE_REWARD.names == RIG.reward_terms
    assert JOINT_ABS_REWARD.names == JOINT_SCORE_REWARD.names == JOINT.reward_terms
    assert RIG.reward_terms == tuple(f.name for f in dataclasses.fields(RewardWeights))
    assert JOINT.reward_terms == tuple(f.name for f in dataclasses.fields(JointRewardWeights))
    assert (RigTask.contract, HingeTask.contract) == (RIG, JOINT)
    assert joint.REWARD_TERMS == joint_mujoco.REWARD_TERMS == JOINT.reward_terms
    assert shared.TERMINATION_NAMES is TERMINATION_NAMES


def test_the_benchmark_reads_the_contracts_columns_and_trade():
    for traces, c in ((RIG_TRACES, RIG), (JOINT_TRACES, JOINT)):
        assert traces.info_keys == c.score_keys
        assert traces.quantity == c.position and traces.position_norm == c.trade.position_norm
    assert RIG.trade.position_norm == 5e-3 and JOINT.trade.position_norm == pytest.approx(np.radians(10.0))


def test_the_planners_step_cost_is_the_squared_score_of_one_step():
    """The rollouts' per-step cost (objective.step_error_sq) is the square of the combined score
    of that one step, for each error alone (so the planner and the score trade alike)."""
    norm = RIG_TRACES.position_norm
    e = step_error_sq(0.173, 0.170, 800.0, 800.0, 1.0, True, norm, RIG.trade.stiffness_norm)
    assert e == pytest.approx(combined_score(0.003, 0.0, 0.0, RIG_TRACES) ** 2)
    e = step_error_sq(0.17, 0.17, 900.0, 800.0, 1.0, True, norm, RIG.trade.stiffness_norm)
    assert e == pytest.approx(combined_score(0.0, 100 / 800, 0.0, RIG_TRACES) ** 2)
    assert step_error_sq(0.18, 0.17, 900.0, 800.0, 0.0, True, norm, 0.2) == 0.0  # left out: weight 0


@pytest.mark.parametrize(
    ("env_id", "c_expected"), [("cepam_gym/CEPAM-v1", 2.0), ("cepam_gym/CEPAMJoint-v1", 1.0)]
)
def test_the_scores_step_error_is_the_rewards_tracking_terms_rescaled(env_id, c_expected):
    """The contract's relation: on every step whose errors are below the reward's clips,
    |e_x| / x_norm + |K / K* - 1| / 0.2 = -c (r_x + r_K), c from the declared weights."""
    env = gym.make(env_id)
    task = env.unwrapped.core.task
    u = task.spec.scales.tracking_unit
    weights = getattr(task, "weights", None) or task.spec.weights  # the joint's, the rig's
    c = env.unwrapped.contract
    factor = c.score_factor(weights, u)
    assert factor == pytest.approx(c_expected)
    k = c.score_keys
    env.reset(seed=3)
    rng = np.random.default_rng(1)
    checked = 0
    for _ in range(60):
        _, _, term, _, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        e_x = abs(info[k["length"]] - info[k["target_length"]])
        e_k = abs(info[k["stiffness"]] / info[k["target_stiffness"]] - 1.0)
        if e_x / u >= 5.0 or e_k >= 2.0:
            continue  # clipped: the relation holds below the clips only
        score_error = e_x / c.trade.position_norm + e_k / c.trade.stiffness_norm
        reward_tracking = info[c.term_keys[0]] + info[c.term_keys[1]]
        assert score_error == pytest.approx(-factor * reward_tracking, rel=1e-9)
        checked += 1
        assert not term
    assert checked > 30
    env.close()


def test_weights_that_trade_otherwise_than_the_score_are_named():
    from cepam_gym.tasks.spec import RewardWeights

    assert RIG.score_factor(RewardWeights(), 0.01) == pytest.approx(2.0)
    with pytest.raises(InputError, match="otherwise than the score"):
        RIG.score_factor(RewardWeights(stiffness=1.0), 0.01)


def test_a_policy_can_earn_more_return_and_a_worse_score():
    """The reward sums absolute errors over every step; the score takes RMS errors over the
    steps outside the settling allowance. Two hand-made policies on one v1-style trace, the first
    exact on the scored steps but slow in the allowance, the second off by a steady 0.5 mm
    everywhere: the first has the lower (worse) return and the far better score."""
    from cepam_gym.bench.metrics import RIG_V1, score_traces

    T, dt = 200, 0.02
    tl = np.where(np.arange(T) < 100, 0.170, 0.180)[:, None]
    tr = {
        "target_length": tl,
        "stiffness": np.full((T, 1), 800.0),
        "target_stiffness": np.full((T, 1), 800.0),
        "air_used": np.zeros((T, 1)),
        "alive": np.ones((T, 1), dtype=bool),
        "failed": np.zeros(1, dtype=bool),
        "dt": dt,
    }
    slow = tl.copy()
    slow[100:125] = 0.170  # 0.5 s at the old target after the jump: inside the allowance
    steady = tl + 5e-4
    w = RIG.weights()
    ret = lambda length: float(-(w.length * np.abs(length - tl) / 0.01).sum())  # noqa: E731
    a = score_traces({**tr, "length": slow, "reward": np.zeros((T, 1))}, True, RIG_V1)
    b = score_traces({**tr, "length": steady, "reward": np.zeros((T, 1))}, True, RIG_V1)
    assert ret(slow) < ret(steady) and a["score"] < b["score"]
