"""The identification window (:mod:`cepam_gym.envs.id_window`): unscored steps on the episode's own
plant, then the tracking exactly as without the window; the harness leaves the window out."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym.bench.harness import drop_window, record
from cepam_gym.bench.suites import RANDOMIZE_V2, SUITES
from cepam_gym.envs.id_window import INFO_KEY
from cepam_gym.errors import InputError

ENV_ID = "cepam_gym/CEPAM-v2"
KW = {"randomize": RANDOMIZE_V2}  # no noise, no drift: the plant alone decides the trajectory


def _run(window_s: float, n: int = 3, seed: int = 7):
    """Random valve commands in the window, then a fixed open-loop sequence; per-step info."""
    v = gym.make_vec(ENV_ID, num_envs=n, task_options={"id_window_s": window_s}, **KW)
    obs, info = v.reset(seed=seed)
    core = v.unwrapped.core
    rng = np.random.default_rng(0)
    tracked = np.random.default_rng(1).uniform(-0.3, 0.3, (core.n_tracked, n, 2))
    out = {"reset_window": info.get(INFO_KEY), "obs0": None, "rows": core.params.copy()}
    steps = []
    for t in range(core.n_steps):
        k = t - core.n_window
        if k == 0:
            out["obs0"] = obs.copy()
        a = rng.uniform(-0.4, 0.4, (n, 2)) if k < 0 else tracked[k]
        obs, r, term, trunc, info = v.step(a)
        steps.append((info["length"].copy(), info["pressure_c"].copy(), r, info.get(INFO_KEY), term | trunc))
    v.close()
    return core, out, steps


def test_the_scored_part_is_the_episode_without_the_window_on_the_same_plant():
    core0, out0, plain = _run(0.0)
    core1, out1, windowed = _run(1.0)
    w = core1.n_window
    assert (core0.n_window, w, core1.n_steps) == (0, 50, core0.n_steps + 50)
    assert np.array_equal(out0["rows"], out1["rows"])  # the same plants drawn
    assert out0["reset_window"] is None and out1["reset_window"].all()
    assert np.array_equal(out1["obs0"], _first_obs(0.0))  # the tracking starts where the episode did
    for (l0, p0, r0, _, d0), (l1, p1, r1, flag, d1) in zip(plain, windowed[w:]):
        assert np.array_equal(l0, l1) and np.array_equal(p0, p1) and np.array_equal(r0, r1)
        assert not flag.any() and np.array_equal(d0, d1)
    in_window = windowed[:w]
    assert all(flag.all() for *_, flag, _ in in_window)
    # unscored: no tracking, effort or air reward in the window (random commands cost effort)
    assert all((r == 0).all() for _, _, r, _, _ in in_window)
    assert any(not np.array_equal(length, in_window[0][0]) for length, *_ in in_window)  # the plant moved
    assert windowed[-1][-1].all() and not any(d.any() for *_, d in windowed[:-1])


def _first_obs(window_s: float) -> np.ndarray:
    v = gym.make_vec(ENV_ID, num_envs=3, task_options={"id_window_s": window_s}, **KW)
    obs, _ = v.reset(seed=7)
    v.close()
    return obs


def test_a_burst_in_the_window_ends_the_episode_and_is_charged():
    v = gym.make_vec(ENV_ID, num_envs=2, task_options={"id_window_s": 5.0}, **KW)
    v.reset(seed=0)
    for t in range(250):  # fill the CPAM, then shut it and fill the annulus: compressed, it bursts
        a = np.array([[1.0, -1.0]] * 2) if t < 50 else np.array([[0.0, 1.0]] * 2)
        _, r, term, _, info = v.step(a)
        if term.any():
            break
    assert term.any() and info[INFO_KEY][term].all()
    assert (r[term] < 0).all() and (info["reward_burst"][term] < 0).all()


def test_the_single_env_runs_the_window_too():
    env = gym.make(ENV_ID, task_options={"id_window_s": 0.5}, **KW)
    _, info = env.reset(seed=3)
    assert info[INFO_KEY] is True
    flags = []
    for _ in range(30):
        _, r, *_, info = env.step(np.array([0.2, -0.2], dtype=np.float32))
        flags.append(info[INFO_KEY])
    assert flags == [True] * 25 + [False] * 5 and r != 0.0


@pytest.mark.parametrize("bad", [-1.0, float("nan"), "10", True, 1e4])
def test_a_bad_window_length_is_refused_naming_the_option(bad):
    with pytest.raises(InputError, match="id_window_s"):
        gym.make_vec(ENV_ID, num_envs=1, task_options={"id_window_s": bad})


def test_the_harness_leaves_the_window_out_of_the_traces():
    suite = SUITES["randomized-id-v2"]
    kwargs = {**suite.env_kwargs, "task_options": {"id_window_s": 0.4}}
    tr, _ = record(lambda venv: _Zero(), suite.env_id, kwargs, 2, suite.seed, max_steps=30)
    plain, _ = record(
        lambda venv: _Zero(), "cepam_gym/CEPAM-v2", suite.env_kwargs, 2, suite.seed, max_steps=30
    )
    assert tr["length"].shape == plain["length"].shape == (30, 2)
    assert tr["alive"].all() and not tr["failed"].any()
    # an episode that failed in its window stays failed; its later window is not scored
    window = np.zeros((6, 2), dtype=bool)
    window[:3] = True
    window[3:5, 1] = True  # env 1 failed and started a new window
    cut = drop_window({"length": np.arange(12.0).reshape(6, 2), "failed": np.array([False, True])}, window)
    assert cut["length"].shape == (3, 2) and cut["failed"].tolist() == [False, True]


class _Zero:
    def reset(self, indices=None):
        pass

    def act(self, obs, info=None):
        return np.zeros((len(obs), 2), dtype=np.float32)
