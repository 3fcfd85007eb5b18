"""The task layer owns the interface: observation layouts (named columns), reward terms,
termination reasons; controllers and envs read it by name."""

import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401
from cepam_gym.control import InverseStaticController
from cepam_gym.envs import step_kernel as tk
from cepam_gym.envs.step import reward_terms
from cepam_gym.plant.params import PlantParams, pressure_cap_of
from cepam_gym.tasks import OBS_FIELDS, TASKS, TERMINATION_REASONS, ObsColumn, ObsLayout, rig_layout
from cepam_gym.tasks.reward import MAX_TERMS


def _si_values(rng, n):
    """Random SI values of the rig's OBS_FIELDS, inside the default layout's clip."""
    return np.stack(
        [
            rng.uniform(0.15, 0.195, n),
            rng.uniform(-0.5, 0.5, n),
            rng.uniform(0, 250e3, n),
            rng.uniform(0, 250e3, n),
            rng.uniform(200e3, 300e3, n),
            rng.uniform(0.155, 0.19, n),
            rng.uniform(200, 2500, n),
            rng.uniform(-1, 1, n),
            rng.uniform(-1, 1, n),
        ],
        axis=1,
    )


@pytest.mark.parametrize("task", ["cepam", "length"])
def test_layout_encode_decode_round_trip(task):
    layout = rig_layout(TASKS[task], PlantParams())
    assert layout.size == (9 if task == "cepam" else 8)
    assert layout.has("target_stiffness") == (task == "cepam")
    values = _si_values(np.random.default_rng(0), 200)
    obs = layout.encode(values)
    assert obs.dtype == np.float32 and obs.shape == (200, layout.size)
    back = layout.decode(obs)
    for name in layout.names:
        true = values[:, OBS_FIELDS.index(name)]
        scale = layout.scale(name)
        # float32 observation: exact up to its rounding, ~6e-8 of the scaled value
        assert np.allclose(back[name], true, rtol=0, atol=1e-6 * scale), name
        assert np.array_equal(layout.value(obs, name), back[name])


def test_layout_clips_and_refuses_bad_layouts():
    layout = rig_layout(TASKS["cepam"], PlantParams())
    v = _si_values(np.random.default_rng(1), 1)[0]
    v[OBS_FIELDS.index("velocity")] = 1e6
    v[OBS_FIELDS.index("pressure_c")] = np.nan
    obs = layout.encode(v)
    assert obs[layout.column("velocity")] == layout.clip
    assert obs[layout.column("pressure_c")] == 0.0
    with pytest.raises(KeyError, match="target_angle"):
        layout.column("target_angle")
    with pytest.raises(ValueError, match="not among the measured fields"):
        ObsLayout((ObsColumn("angle"),))
    with pytest.raises(ValueError, match="distinct"):
        ObsLayout((ObsColumn("length"), ObsColumn("length")))
    with pytest.raises(ValueError, match="scale"):
        ObsColumn("length", scale=0.0)
    with pytest.raises(ValueError, match="columns"):
        layout.decode(np.zeros(3))


@pytest.mark.parametrize("env_id", ["cepam_gym/CEPAM-v0", "cepam_gym/CEPAMLength-v0"])
def test_compiled_encoder_matches_the_layout(env_id):
    """The step kernel encodes by the task vector's copy of the layout: its observation after a
    reset equals the Python encoder on the true (noise-free) quantities, bit for bit."""
    env = gym.make(env_id)
    obs, info = env.reset(seed=3)
    core = env.unwrapped.core
    p = core.params[0]
    from cepam_gym.physics import layout as ix

    values = [
        info["length"],
        info["velocity"],
        info["pressure_c"],
        info["pressure_e"],
        p[ix.P_SUP] - p[ix.P_ATM],
        info["target_length"],
        info["target_stiffness"],
        0.0,
        0.0,
    ]
    assert np.array_equal(obs, core.obs_layout.encode(values))


def test_baseline_reads_columns_by_name():
    """Permute the observation columns and the layout alike: the baseline acts the same."""
    venv = gym.make_vec("cepam_gym/CEPAM-v0", num_envs=3)
    obs, info = venv.reset(seed=2)
    ref = InverseStaticController(venv)
    a_ref = ref.act(obs)
    perm = np.random.default_rng(0).permutation(obs.shape[1])
    assert not np.array_equal(perm, np.arange(obs.shape[1]))
    ctl = InverseStaticController(venv)
    layout = ctl.layout
    ctl.layout = ObsLayout(tuple(layout.columns[j] for j in perm), layout.fields, layout.clip)
    assert np.array_equal(ctl.act(obs[:, perm]), a_ref)
    # and the state it keeps is readable and restorable without touching its internals
    state = ctl.get_state()
    a1 = ctl.act(obs[:, perm])
    ctl.set_state(state)
    assert np.array_equal(ctl.act(obs[:, perm]), a1)


def test_rig_reward_terms_are_the_shared_function():
    env = gym.make("cepam_gym/CEPAM-v0")
    env.reset(seed=4)
    core = env.unwrapped.core
    a = np.array([0.3, -0.7])
    _, r, _, _, info = env.step(a)
    terms = np.zeros(MAX_TERMS)
    total = reward_terms(
        info["length"],
        info["target_length"],
        info["velocity"],
        info["stiffness"],
        info["target_stiffness"],
        a[0],
        a[1],
        info["air_used"],
        False,
        True,
        core.task_params,
        terms,
    )
    assert terms[:5].tolist() == [info[f"reward_{t}"] for t in core.task.reward_terms] and not terms[5:].any()
    assert total == r


def test_termination_codes_have_names():
    """The package's compiled terminations: a burst ends an episode with its code; the step's own
    code for a non-finite state follows the declared ones."""
    from cepam_gym.envs import step
    from cepam_gym.envs.core import CEPAMBatch

    core = CEPAMBatch(1, task="cepam_v3")

    def code(burst):
        return step.terminated(0.17, 0.17, 0.0, 800.0, 800.0, 0.0, 0.0, 0.0, burst, True, core.task_params)

    assert TERMINATION_REASONS[code(False)] == "none"
    assert TERMINATION_REASONS[code(True)] == "burst"
    assert TERMINATION_REASONS[step.NONFINITE] == "non_finite_state"


def test_pressure_mode_maps_actions_to_the_pressure_cap():
    params = PlantParams(supply_pressure=350e3)  # above burst: the cap is the burst pressure
    assert params.pressure_cap == params.burst_pressure
    assert pressure_cap_of(params.to_array()) == pytest.approx(params.pressure_cap, rel=1e-15)
    from cepam_gym import plant as pl

    assert tk.valve_commands(pl.PRESSURE, 1.0, -1.0, params.pressure_cap) == (params.pressure_cap, 0.0)
    assert tk.valve_commands(pl.PROPORTIONAL, 0.25, -0.5, params.pressure_cap) == (0.25, -0.5)


def test_array_wrappers_are_used_module_qualified():
    """physics.api reuses the kernels' names (its documented convention): nobody imports them
    unqualified, so ``chamber_volumes`` never means two things in one module."""
    src = Path(__file__).resolve().parents[2] / "src" / "cepam_gym"
    offenders = [
        str(f.relative_to(src))
        for f in src.rglob("*.py")
        if re.search(r"^\s*from\s+(\S*physics\.api|\.api)\s+import", f.read_text(), re.M)
    ]
    assert offenders == []
