"""The fast paths change speed, never results: the thread choice of the batched kernel (it picks
the faster count, stops a slow trial at once, tries again when the machine changes), the single
env's one-call step (a refused action leaves the episode untouched)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401
from cepam_gym.envs.threads import ThreadChoice, thread_counts
from cepam_gym.errors import InputError


def _run(choice: ThreadChoice, cost: dict[int, float], calls: int) -> list[int]:
    """Drive ``choice`` with calls that take ``cost[count]`` seconds; the counts it picked."""
    picked = []
    for _ in range(calls):
        c = choice.pick()
        picked.append(c)
        choice.record(c, cost[c])
    return picked


def test_thread_choice_settles_on_the_faster_count_both_ways():
    quiet = {1: 2.0, 2: 1.0}  # two cores free: parallel twice as fast
    busy = {1: 2.0, 2: 30.0}  # one core taken by a learner: parallel 15 times slower
    choice = ThreadChoice((1, 2))
    picked = _run(choice, quiet, 400)
    assert choice.current == 2 and picked[-300:].count(2) == 300 - picked[-300:].count(1)
    assert picked[-300:].count(1) <= 12  # trials of the serial kernel only, few
    picked = _run(choice, busy, 2000)  # the machine gets busy: noticed, serial again
    assert choice.current == 1
    slow = picked[-1500:].count(2)
    assert slow * 30.0 / (1500 * 2.0) < 0.05  # the trials of the slow count cost < 5 %
    _run(choice, quiet, 5000)  # and quiet again (a lost trial waits at most 4000 calls)
    assert choice.current == 2


def test_a_noisy_busy_machine_costs_few_trials():
    """Beside a learner the serial kernel's times jump by 40 % from call to call; the parallel one
    is 26 times slower (measured at 256 envs): the trials of it cost under 3 % of the time."""
    rng = np.random.default_rng(0)
    choice = ThreadChoice((1, 2))
    slow = 0
    for k in range(5000):
        c = choice.pick()
        slow += c == 2 and k >= 200
        choice.record(c, {1: 1.0, 2: 26.0}[c] * np.exp(rng.normal(0.0, 0.4)))
    assert choice.current == 1 and slow * 25.0 / 4800 < 0.03


def test_a_slow_trial_stops_after_one_call():
    """(The first call of a count is not counted: it compiles, or starts the thread pool.)"""
    choice = ThreadChoice((1, 2))
    cost = {1: 1.0, 2: 50.0}
    picked = _run(choice, cost, 6000)
    first = picked.index(2)
    runs = [i for i in range(first + 2, len(picked)) if picked[i] == 2 and picked[i - 1] == 2]
    assert picked.count(2) >= 3 and not runs, "a trial went on after a call 50 times slower"


def test_thread_counts():
    assert thread_counts(1) == (1,) and thread_counts(2) == (1, 2) and thread_counts(8) == (1, 7, 8)


@pytest.mark.parametrize("env_id", ["cepam_gym/CEPAM-v1", "cepam_gym/CEPAMJoint-v1"])
def test_every_thread_count_gives_the_same_trajectory(env_id):
    """256 envs step in parallel: 1 thread, every thread and the automatic choice agree bit for
    bit (resets included: 2-step episodes)."""
    a = np.random.default_rng(0).uniform(-1, 1, (6, 256, 2))
    out = []
    for num_threads in (1, None, 2):
        env = gym.make_vec(env_id, num_envs=256, num_threads=num_threads, max_episode_steps=2)
        obs, _ = env.reset(seed=3)
        rows = [obs]
        for act in a:
            obs, r, _, _, info = env.step(act)
            rows += [obs, r[:, None], info["pressure_c"][:, None]]
        out.append(np.concatenate([np.asarray(x, dtype=float).reshape(256, -1) for x in rows], axis=1))
    np.testing.assert_array_equal(out[0], out[1])
    np.testing.assert_array_equal(out[0], out[2])


@pytest.mark.parametrize("bad", [np.array([np.nan, 0.1]), np.array([0.2, -np.inf], dtype=np.float32)])
def test_a_refused_action_leaves_the_episode_untouched(bad):
    env, twin = gym.make("cepam_gym/CEPAM-v1"), gym.make("cepam_gym/CEPAM-v1")
    env.reset(seed=1)
    twin.reset(seed=1)
    a = np.array([0.3, -0.2])
    env.step(a)
    twin.step(a)
    with pytest.raises(InputError, match="NaN or inf"):
        env.step(bad)
    o1, r1, _, _, i1 = env.step(a)
    o2, r2, _, _, i2 = twin.step(a)
    np.testing.assert_array_equal(o1, o2)
    assert r1 == r2 and i1 == i2
