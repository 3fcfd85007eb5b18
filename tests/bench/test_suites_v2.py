"""The v2 suites: one per v2 id, the v1 suites' options on plant v2, their stored references, and
the randomization of what plant v2 actually uses."""

from __future__ import annotations

import copy

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym.bench import references
from cepam_gym.bench.cli import expand_version
from cepam_gym.bench.harness import run_suite
from cepam_gym.bench.metrics import JOINT_V1, RIG_V1
from cepam_gym.bench.suites import ID_WINDOW_S, RANDOMIZE_V2, SUITES, available, trace_spec_for
from cepam_gym.physics import layout as ix
from cepam_gym.plant.params import preset
from cepam_gym.registration import ENV_IDS, JOINT_ENV_IDS

# the v2 suites that mirror a v1 suite; the identification-window variants (``-id-v2``) run one
# of them with a window in front, on its seed (the same episodes, scored after the window)
V2_SUITES = [s for s in SUITES if s.endswith("-v2") and "-id-" not in s]
ID_SUITES = [s for s in SUITES if s.endswith("-id-v2")]
V2_IDS = [i for i in (*ENV_IDS, *JOINT_ENV_IDS) if i.endswith("-v2")]


def test_every_v2_id_has_suites_mirroring_v1():
    assert set(V2_IDS) == {s.env_id for s in map(SUITES.get, V2_SUITES)}
    assert expand_version("v2") == V2_SUITES + ID_SUITES
    seeds = [s.seed for name, s in SUITES.items() if "-id-" not in name]  # a window runs its suite's seed
    assert len(seeds) == len(set(seeds)), "two suites share a seed"
    for name in V2_SUITES:
        v1, v2 = SUITES[name.replace("-v2", "-v1")], SUITES[name]
        assert v2.env_id == v1.env_id.replace("-v1", "-v2") and v2.traces == v1.traces and not v2.extra
        assert v2.seed == v1.seed + 10000 and v2.episodes == v1.episodes, name
        if name != "randomized-v2":
            assert v2.env_kwargs == v1.env_kwargs, name
    # the scoring of a v2 id is v1's (settling allowance), not the v0 fallback
    assert trace_spec_for("cepam_gym/CEPAM-v2") == RIG_V1
    assert trace_spec_for("cepam_gym/CEPAMJoint-v2") == JOINT_V1


@pytest.mark.slow
@pytest.mark.parametrize("name", V2_SUITES)
def test_v2_suite_runs(name):
    """One short episode of the zero controller and of the oracle on each v2 suite."""
    assert available(name)
    zero, tr = run_suite("zero", name, episodes=1, max_steps=40)
    oracle, _ = run_suite("oracle", name, episodes=1, max_steps=40)
    assert tr["length"].shape == (40, 1) and np.isfinite(tr["length"]).all()
    assert np.isfinite(zero["score"]) and np.isfinite(oracle["score"])
    assert oracle["score"] < zero["score"], name


def test_randomized_v2_spreads_the_friction_plant_v2_uses():
    """Under v2's contact-area law the v1 coefficient changes nothing in the plant's row: the suite
    spreads friction_mu, the presliding and the collapsed CPAM's seal instead, each drawn per
    episode within its range, and every draw of the suite's episodes runs without a redraw."""
    assert "friction_coefficient_n_per_kpa" not in RANDOMIZE_V2
    v2 = preset("balloon_v2")
    assert np.array_equal(v2.to_array(), v2.replace(friction_coefficient=4e-6).to_array())
    assert not np.array_equal(v2.to_array(), v2.replace(friction_mu=4e-4).to_array())
    suite = SUITES["randomized-v2"]
    venv = gym.make_vec(suite.env_id, num_envs=suite.episodes, **suite.env_kwargs)
    _, info = venv.reset(seed=suite.seed)
    rows = venv.unwrapped.core.params
    drawn = {  # in the keys' own units
        "friction_mu": rows[:, ix.FR_MU],
        "friction_presliding_mm": rows[:, ix.FR_D] * 1e3,
        "collapse_seal_diameter_mm": np.sqrt(4.0 * rows[:, ix.COL_A] / np.pi) * 1e3,
    }
    for key, values in drawn.items():
        lo, hi = RANDOMIZE_V2[key]
        assert (values >= lo * (1 - 1e-9)).all() and (values <= hi * (1 + 1e-9)).all(), key
        assert np.ptp(values) > 0.3 * (hi - lo), key
    assert (info["redraws"] == 0).all()
    venv.close()


def test_v2_references_are_stored_for_each_suite_on_its_episodes():
    table = references.load()
    for name in V2_SUITES + ID_SUITES:
        entry = table[name]
        suite = SUITES[name]
        assert (entry["seed"], entry["episodes"]) == (suite.seed, suite.episodes) == (suite.seed, 20)
        assert 0.0 < entry["oracle"] < 0.1 * entry["zero"], name
        assert suite.reference == (entry["zero"], entry["oracle"])


def test_the_window_suite_is_randomized_v2_with_a_window_in_front():
    """Its scored episodes are randomized-v2's (the same seed, plants, noise and drift), each
    after an unscored identification window; its references are stored on them."""
    assert ID_SUITES == ["randomized-id-v2"]
    base, suite = SUITES["randomized-v2"], SUITES["randomized-id-v2"]
    assert (suite.env_id, suite.seed, suite.episodes, suite.traces) == (
        base.env_id,
        base.seed,
        base.episodes,
        base.traces,
    )
    kwargs = copy.deepcopy(suite.env_kwargs)
    window = kwargs["task_options"].pop("id_window_s")
    assert window == ID_WINDOW_S > 0 and kwargs == {**base.env_kwargs, "task_options": {}}
