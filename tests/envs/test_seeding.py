"""Per-env random streams: spawned from a SeedSequence, independent across seeds, and the same
for an env whatever batch it is in (noise and supply drift included)."""

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401

NOISY = {
    "sensor_noise": {"length_mm": 0.3, "velocity_mm_s": 5.0, "pressure_kpa": 2.0},
    "supply_drift_kpa": 5.0,
    "randomize": {"end_mass_g": [15.0, 30.0]},
}


@pytest.mark.parametrize("mode", ["next_step", "same_step"])
def test_vector_element_i_equals_single_env_with_stream_i_noise_and_drift_on(mode):
    n, seed, horizon = 3, 21, 30
    venv = gym.make_vec(
        "cepam_gym/CEPAM-v0", num_envs=n, max_episode_steps=horizon, autoreset_mode=mode, **NOISY
    )
    singles = [gym.make("cepam_gym/CEPAM-v0", max_episode_steps=horizon, stream=i, **NOISY) for i in range(n)]
    obs_v, _ = venv.reset(seed=seed)
    obs_s = np.stack([e.reset(seed=seed)[0] for e in singles])
    assert np.array_equal(obs_v, obs_s)
    rng = np.random.default_rng(0)
    pending = np.zeros(n, dtype=bool)  # next-step mode: singles to reset at this step
    # past two episodes: the vector env's autoreset and the singles' reset() draw alike
    for t in range(2 * horizon + 5):
        a = rng.uniform(-1, 1, (n, 2))
        obs_v, r_v, term_v, trunc_v, _ = venv.step(a)
        for i, e in enumerate(singles):
            if pending[i]:
                o, _ = e.reset()
                r, term, trunc = 0.0, False, False
            else:
                o, r, term, trunc, _ = e.step(a[i])
            assert r == r_v[i] and term == term_v[i] and trunc == trunc_v[i], (t, i)
            if (term or trunc) and mode == "same_step":
                o, _ = e.reset()
            pending[i] = (term or trunc) and mode == "next_step"
            assert np.array_equal(o, obs_v[i]), (t, i)
    # the noise and the drift were really on: supply pressures differ between envs
    assert np.ptp(venv.unwrapped.core.params[:, 17]) > 0


def test_streams_of_neighbouring_seeds_do_not_overlap():
    """Under ``seed + i`` seeding env i of seed s equalled env i+1 of seed s-1."""
    a = gym.make_vec("cepam_gym/CEPAM-v0", num_envs=4)
    b = gym.make_vec("cepam_gym/CEPAM-v0", num_envs=4)
    oa, _ = a.reset(seed=5)
    ob, _ = b.reset(seed=6)
    ta, tb = a.unwrapped.core.target_l, b.unwrapped.core.target_l
    for i in range(4):
        for j in range(4):
            assert not np.array_equal(ta[i], tb[j]), (i, j)
    # envs of one seed differ too, and a seed is reproducible
    assert len({tuple(r) for r in ta[:, :5]}) == 4
    oc, _ = gym.make_vec("cepam_gym/CEPAM-v0", num_envs=4).reset(seed=5)
    assert np.array_equal(oa, oc)


def test_stream_kwarg_checked():
    import pytest

    with pytest.raises(ValueError, match="stream"):
        gym.make("cepam_gym/CEPAM-v0", stream=-1)
