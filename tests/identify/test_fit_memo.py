"""The window fits remembered by their log and settings (:mod:`cepam_gym.identify.fit_memo`): a
second controller on the same episodes reuses the first one's fits and acts exactly as it would
have; a timed fit or other settings are fitted anew."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym.bench.suites import RANDOMIZE_V2
from cepam_gym.control import make_controller
from cepam_gym.identify.fit_memo import FITS, FitMemo, fit_key


def test_the_key_sees_every_bit_dtype_and_setting():
    a = np.linspace(0.0, 1.0, 12).reshape(3, 4)
    b = a.copy()
    b.view(np.uint64)[1, 2] ^= 1  # one bit of one sample
    assert fit_key(a, ("valve", 100)) == fit_key(a.copy(), ("valve", 100))
    assert fit_key(a, ("valve", 100)) != fit_key(b, ("valve", 100))
    assert fit_key(a, ("valve", 100)) != fit_key(a.astype(np.float32), ("valve", 100))
    assert fit_key(a, ("valve", 100)) != fit_key(a.reshape(4, 3), ("valve", 100))
    assert fit_key(a, ("valve", 100)) != fit_key(a, ("valve", 99))


def test_the_memo_drops_the_least_recently_used():
    memo = FitMemo(capacity=2)
    memo.put("a", 1)
    memo.put("b", 2)
    assert memo.get("a") == 1  # "a" is now the most recent
    memo.put("c", 3)
    assert memo.get("b") is None and memo.get("a") == 1 and memo.get("c") == 3
    assert (memo.hits, memo.misses, len(memo)) == (3, 1, 2)


def _window_venv():
    return gym.make_vec(
        "cepam_gym/CEPAM-v2", num_envs=2, task_options={"id_window_s": 1.5}, randomize=RANDOMIZE_V2
    )


def _play(ctrl, venv, steps: int) -> np.ndarray:
    obs, info = venv.reset(seed=3)
    ctrl.reset()
    actions = []
    for _ in range(steps):
        a = ctrl.act(obs, info)
        actions.append(a)
        obs, *_, info = venv.step(a)
    return np.array(actions)


def test_a_second_controller_on_the_same_episodes_reuses_the_fits():
    FITS.clear()
    venv = _window_venv()
    first = make_controller("identify_mpc", venv, max_nfev=3, population=8, iterations=1)
    steps = first.window + 4
    a1 = _play(first, venv, steps)
    assert (FITS.hits, FITS.misses, len(FITS)) == (0, 2, 2)
    second = make_controller("identify_mpc", venv, max_nfev=3, population=8, iterations=1)
    a2 = _play(second, venv, steps)
    assert FITS.hits == 2 and len(FITS) == 2
    assert all(f is g for f, g in zip(first.fits, second.fits, strict=True))
    np.testing.assert_array_equal(second.identifier.rows, first.identifier.rows)
    np.testing.assert_array_equal(a2, a1)  # the plan after the window too: the same plant, the same acts
    # other settings, or a time budget (the fit then depends on the machine), fit anew
    _play(make_controller("identify_mpc", venv, max_nfev=4, population=8, iterations=1), venv, steps)
    assert (FITS.hits, len(FITS)) == (2, 4)
    timed = make_controller("identify_mpc", venv, max_nfev=3, budget_s=60.0, population=8, iterations=1)
    _play(timed, venv, steps)
    assert (FITS.hits, FITS.misses, len(FITS)) == (2, 4, 4)
    assert all(f is not g for f, g in zip(timed.fits, first.fits, strict=True))
    venv.close()
