"""Schedules of plant parameters a task declares (tasks.schedule): planned per episode from the
env's own stream, written into the plant's row before each step, reported in the info, felt by
the plant, and refused by name when they are wrong."""

from __future__ import annotations

import copy
import dataclasses
import pickle

import gymnasium as gym
import numpy as np
import pytest

import cepam_gym  # noqa: F401  (registers the ids)
from cepam_gym.errors import InputError
from cepam_gym.physics import layout as ix
from cepam_gym.tasks.schedule import Schedule
from cepam_gym.tasks.spec import TASKS

ID = "cepam_gym/CEPAMLength-v3"


def supply_drop(rng, row, n_steps, control_dt):
    """Full supply, then a drop to 40-60 % of its gauge value over 0.5 s, starting between 2 and 4 s."""
    atm, full = row[ix.P_ATM], row[ix.P_SUP]
    t = np.arange(n_steps) * control_dt
    t0, frac = rng.uniform(2.0, 4.0), rng.uniform(0.4, 0.6)
    return full - np.clip((t - t0) / 0.5, 0.0, 1.0) * (1.0 - frac) * (full - atm)


SUPPLY = Schedule("supply_abs", "P_SUP", supply_drop)
SPEC = dataclasses.replace(TASKS["length_v3"], name="supply_drop", schedules=(SUPPLY,), pressure_margin=0.4)


def _env(spec=SPEC, num_envs=None, **kw):
    kw = {"sensor_noise": None, **kw}
    if num_envs is None:
        return gym.make(ID, task=spec, **kw)
    return gym.make_vec(ID, num_envs=num_envs, task=spec, **kw)


def test_the_plant_row_and_the_info_follow_the_plan_step_by_step():
    env = _env()
    core = env.unwrapped.core
    _, info = env.reset(seed=3)
    planned = core.planned.values[0, 0].copy()
    assert planned[0] == info["supply_abs"] == core.params[0, ix.P_SUP]
    assert planned[-1] < 0.7 * planned[0]  # it dropped
    atm = core.params[0, ix.P_ATM]
    for t in range(len(planned)):
        obs, _, terminated, truncated, info = env.step(np.zeros(2, np.float32))
        assert info["supply_abs"] == planned[t] == core.params[0, ix.P_SUP]
        # the observation's supply column: the measured gauge supply of the step (ideal sensors)
        supply = core.obs_layout.decode(obs[None])["supply_pressure"][0]
        assert supply == pytest.approx(planned[t] - atm, rel=1e-5)
        if terminated or truncated:
            break
    assert t == len(planned) - 1


def test_a_chamber_fed_from_a_dropped_supply_settles_at_the_supply():
    """Both valves held open for 5 s: each chamber settles at the supply's gauge pressure (ISO 6358
    flow stops at zero pressure difference), the full one or the one the schedule halved."""
    full = TASKS["length_v3"]
    low = _plan_of(lambda rng, row, n, dt: np.full(n, 0.5 * (row[ix.P_SUP] - row[ix.P_ATM]) + row[ix.P_ATM]))
    ends = {}
    for name, spec in (("full", full), ("low", low)):
        env = _env(spec)
        env.reset(seed=0)
        core = env.unwrapped.core
        for _ in range(250):
            _, _, terminated, _, info = env.step(np.ones(2, np.float32))
            assert not terminated
        gauge = core.params[0, ix.P_SUP] - core.params[0, ix.P_ATM]
        for chamber in ("pressure_c", "pressure_e"):
            assert 0.999 * gauge < info[chamber] <= gauge * (1 + 1e-9), (name, chamber)
        ends[name] = gauge
    assert ends["low"] == pytest.approx(0.5 * ends["full"])


def test_the_other_draws_are_those_of_the_task_without_the_schedule():
    """The schedules draw from a stream of their own: targets, loads and sensor noise are the same
    task's without them, step for step."""
    noisy = {"length_mm": 0.03}
    a, b = _env(sensor_noise=noisy), _env(dataclasses.replace(SPEC, schedules=()), sensor_noise=noisy)
    oa, _ = a.reset(seed=11)
    ob, _ = b.reset(seed=11)
    ca, cb = a.unwrapped.core, b.unwrapped.core
    for f in ("target_l", "target_k", "load", "initial", "noise"):
        np.testing.assert_array_equal(getattr(ca, f), getattr(cb, f), err_msg=f)
    # before the drop the plant is the same: the same observations
    for _ in range(50):
        oa, *_ = a.step(np.array([0.3, -0.2], np.float32))
        ob, *_ = b.step(np.array([0.3, -0.2], np.float32))
    np.testing.assert_array_equal(oa, ob)


def test_env_i_of_a_batch_is_the_single_env_of_stream_i():
    """Each env of a batch plans its own drop from its own stream, and steps through it as the
    single env of that stream does (observations and reported supply, step for step)."""
    venv = _env(num_envs=3)
    venv.reset(seed=5)
    batch = venv.unwrapped.core.planned.values.copy()
    assert not np.allclose(batch[0], batch[1])  # each env its own draw
    singles = [_env(stream=i) for i in range(3)]
    for i, env in enumerate(singles):
        env.reset(seed=5)
        np.testing.assert_array_equal(env.unwrapped.core.planned.values[0], batch[i])
    rng = np.random.default_rng(0)
    for t in range(400):
        a = rng.uniform(-1, 1, (3, 2)).astype(np.float32)
        obs, _, _, _, info = venv.step(a)
        np.testing.assert_array_equal(info["supply_abs"], batch[:, 0, t])
        for i, env in enumerate(singles):
            o, *_ = env.step(a[i])
            np.testing.assert_array_equal(o, obs[i])


def test_a_copy_or_a_pickle_continues_the_episode():
    env = _env()
    env.reset(seed=2)
    for _ in range(120):
        env.step(np.array([0.2, 0.1], np.float32))
    for twin in (copy.deepcopy(env), pickle.loads(pickle.dumps(env))):
        for _ in range(100):
            a = np.array([0.5, -0.5], np.float32)
            o1, r1, *_, i1 = env.step(a)
            o2, r2, *_, i2 = twin.step(a)
            assert r1 == r2 and i1["supply_abs"] == i2["supply_abs"]
            np.testing.assert_array_equal(o1, o2)
        env.reset(seed=2)
        for _ in range(120):
            env.step(np.array([0.2, 0.1], np.float32))


def test_the_identification_window_holds_the_first_value():
    spec = dataclasses.replace(SPEC, id_window_s=1.0)
    venv = _env(spec, num_envs=2)
    venv.reset(seed=1)
    values = venv.unwrapped.core.planned.values
    np.testing.assert_array_equal(values[:, :, :50], np.repeat(values[:, :, 50:51], 50, axis=2))
    plain = _env(num_envs=2)
    plain.reset(seed=1)
    np.testing.assert_array_equal(values[:, :, 50:], plain.unwrapped.core.planned.values)


def test_the_envs_pass_gymnasiums_checker():
    from gymnasium.utils.env_checker import check_env

    check_env(_env().unwrapped, skip_render_check=True)


CLASH = Schedule("length", "T_SUP", supply_drop)  # an info key the rig already reports


def _plan_of(fn):
    return dataclasses.replace(SPEC, schedules=(Schedule("supply_abs", "P_SUP", fn),))


@pytest.mark.parametrize(
    "fn, match",
    [
        (lambda rng, row, n, dt: np.zeros(n - 1), r"'supply_abs'.*one value per control step"),
        (lambda rng, row, n, dt: np.full(n, np.nan), r"'supply_abs'.*not finite"),
    ],
)
def test_a_wrong_plan_is_named_at_the_reset(fn, match):
    env = _env(_plan_of(fn))
    with pytest.raises(InputError, match=match):
        env.reset(seed=0)


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: Schedule("supply", "P_SUPPLY", supply_drop), r"physics.layout.NAMES"),
        (lambda: Schedule("supply pressure", "P_SUP", supply_drop), r"identifier"),
        (lambda: Schedule("supply", "P_SUP", 3.0), r"callable"),
        (lambda: dataclasses.replace(SPEC, schedules=(SUPPLY, SUPPLY)), r"at most once"),
        (lambda: dataclasses.replace(SPEC, schedules=SUPPLY), r"tuple"),
        (lambda: _env(dataclasses.replace(SPEC, schedules=(CLASH,))), "'length'.*already reports"),
        (lambda: _env(supply_drift_kpa=5.0), r"supply_drift_kpa.*drop one"),
    ],
)
def test_bad_schedules_are_refused_by_name(make, match):
    with pytest.raises(InputError, match=match):
        make()
