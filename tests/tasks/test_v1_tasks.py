"""The v1 ids: planned references announced in named preview columns, on the v1 plant."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import cepam_gym  # noqa: F401
from cepam_gym.physics import layout as ix
from cepam_gym.planning.references import pressure_rate_ratio
from cepam_gym.planning.schedules import stiffness_interval
from cepam_gym.registration import ENV_IDS, PREVIEW_STEPS

V1_IDS = [i for i in ENV_IDS if i.endswith("-v1")]


def test_v1_ids_are_registered_with_a_preview():
    assert set(V1_IDS) == {"cepam_gym/CEPAM-v1", "cepam_gym/CEPAMLength-v1", "cepam_gym/CEPAMStiffness-v1"}
    for env_id in V1_IDS:
        assert gym.spec(env_id).kwargs["preview_steps"] == PREVIEW_STEPS


@pytest.mark.parametrize("env_id", V1_IDS)
@pytest.mark.parametrize("mode", ["valve", "pwm", "pressure"])
def test_gymnasium_and_sb3_check_env(env_id, mode):
    env = gym.make(env_id, action_mode=mode)
    check_env(env.unwrapped, skip_render_check=True)
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    sb3_check_env(gym.make(env_id, action_mode=mode).unwrapped, warn=False)


@pytest.mark.parametrize("env_id", V1_IDS)
def test_preview_columns_equal_the_schedule(env_id):
    """Column ``target_length_+j`` holds the target j steps after the one ``target_length``
    shows, at reset and after every step (the last target held past the end)."""
    env = gym.make(env_id)
    obs, _ = env.reset(seed=2)
    core = env.unwrapped.core
    layout = core.obs_layout
    track_k = core.task.track_stiffness
    n = core.n_steps
    for step in range(n + 3):
        d = layout.decode(obs)
        k = min(core.t_idx[0], n - 1)  # the step the target columns show
        for j in range(1, PREVIEW_STEPS + 1):
            kk = min(k + j, n - 1)
            assert d[f"target_length_+{j}"] == pytest.approx(
                core.target_l[0, kk], rel=1e-6
            )  # float32 columns
            if track_k:
                assert d[f"target_stiffness_+{j}"] == pytest.approx(core.target_k[0, kk], rel=1e-6)
        assert d["target_length"] == pytest.approx(core.target_l[0, k], rel=1e-6)
        if step == n - 1:
            break
        obs, *_ = env.step(np.zeros(2, np.float32))


def test_preview_zero_is_the_v0_observation_layout():
    a = gym.make("cepam_gym/CEPAM-v1", preview_steps=0)
    b = gym.make("cepam_gym/CEPAM-v0")
    assert a.unwrapped.core.obs_layout.names == b.unwrapped.core.obs_layout.names
    with pytest.raises(ValueError, match="preview_steps"):
        gym.make("cepam_gym/CEPAM-v1", preview_steps=-1)


@pytest.mark.parametrize("env_id", V1_IDS)
def test_v1_references_are_reachable_and_start_at_rest_on_the_reference(env_id):
    venv = gym.make_vec(env_id, num_envs=8)
    venv.reset(seed=7)
    core = venv.unwrapped.core
    for i in range(core.num_envs):
        p = core.params[i]
        w = (p[ix.M_END] + core.load[i]) * p[ix.GRAV]
        k_lo, k_hi = stiffness_interval(core.target_l[i], w, w, p, core.task.spec)
        assert np.all(core.target_k[i] >= k_lo - 1e-9) and np.all(core.target_k[i] <= k_hi + 1e-9)
        assert (
            pressure_rate_ratio(core.target_l[i], core.target_k[i], core.load[i], p, core.control_dt).max()
            <= 1.0
        )
    # the episode starts at rest where the reference starts: no jump at t = 0
    np.testing.assert_allclose(core.state[:, 0], core.target_l[:, 0], atol=1e-12)


def test_vector_env_equals_single_envs_on_v1():
    venv = gym.make_vec("cepam_gym/CEPAM-v1", num_envs=3)
    obs, _ = venv.reset(seed=4)
    for i in range(3):
        o, _ = gym.make("cepam_gym/CEPAM-v1", stream=i).reset(seed=4)
        np.testing.assert_array_equal(o, obs[i])
