"""The compiled reset against NumPy's generator draw for draw, and against the per-env NumPy
planning of ``tests/planning/legacy_planner.py`` episode for episode, bit for bit, on many
seeds, tasks, plants and the fallback paths; the generators end in the same state."""

from __future__ import annotations

import dataclasses

import legacy_planner as LP
import numpy as np
import pytest
from numba import njit

from cepam_gym.envs.hinge_task import JOINT_TASKS
from cepam_gym.planning import references as RF
from cepam_gym.planning import rng as R
from cepam_gym.planning import schedules as S
from cepam_gym.planning.episodes import plan, planned_schedules
from cepam_gym.planning.joint import joint_planned_schedules
from cepam_gym.plant.params import preset
from cepam_gym.tasks import TASKS
from cepam_gym.tasks.joint import JointGeometry

DT = 0.02


def _rngs(n, base):
    return [np.random.default_rng(base + i) for i in range(n)]


def _states(rngs):
    return [r.bit_generator.state for r in rngs]


def _assert_same(got, want):
    assert len(got) == len(want)
    for a, b in zip(got, want):
        np.testing.assert_array_equal(a, b)


@njit
def _draws(states, ops, out):
    for k in range(ops.shape[0]):
        s = states[0]
        if ops[k] == 0:
            out[k] = R.next_double(s)
        elif ops[k] == 1:
            out[k] = R.uniform(s, 0.155, 0.19)
        else:
            out[k] = R.integers(s, ops[k] - 1)


@pytest.mark.parametrize("seed", range(40))
def test_compiled_draws_are_numpys(seed):
    """random(), uniform() and integers(n) (n = 1..6: Lemire rejection on buffered 32-bit halves)
    interleaved, then the generator's whole state, including the buffered half."""
    ops = np.random.default_rng(seed + 999).integers(0, 8, 300)
    ref, want = np.random.default_rng(seed), []
    for o in ops:
        want.append(
            ref.random() if o == 0 else ref.uniform(0.155, 0.19) if o == 1 else float(ref.integers(o - 1))
        )
    gen = np.random.default_rng(seed)
    st = R.pack([gen])
    got = np.empty(len(ops))
    _draws(st, ops, got)
    R.unpack([gen], st)
    np.testing.assert_array_equal(got, want)
    assert gen.bit_generator.state == ref.bit_generator.state


PLANTS = ("balloon", "balloon_v0", "balloon_v2", "rubber_tube")


@pytest.mark.parametrize("plant", PLANTS)
@pytest.mark.parametrize("task", ["cepam_v1", "length_v1", "stiffness_v1", "cepam", "length", "stiffness"])
def test_planned_episodes_equal_the_former_numpy_code(plant, task):
    """Every reference kind and load kind on each plant: 48 envs (the parallel kernel), then 5
    (the serial one), bit for bit, and the generators end alike."""
    P = preset(plant).to_array()
    for n in (48 + 32, 5):
        new, old = _rngs(n, 100 * n), _rngs(n, 100 * n)
        _assert_same(
            planned_schedules(new, TASKS[task], P, 500, DT),
            LP.planned_schedules(old, TASKS[task], P, 500, DT),
        )
        assert _states(new) == _states(old)


def _randomized_rows(n, seed, plant="balloon"):
    rng = np.random.default_rng(seed)
    base = preset(plant)
    return np.stack(
        [
            base.replace(
                end_mass=rng.uniform(0.015, 0.03),
                supply_pressure=base.supply_pressure * rng.uniform(0.8, 1.1),
                valve_conductance=base.valve_conductance * rng.uniform(0.3, 1.5),
            ).to_array()
            for _ in range(n)
        ]
    )


def _outcome(fn, rngs, *args):
    try:
        return fn(rngs, *args)
    except RuntimeError as e:
        return str(e)


@pytest.mark.parametrize(
    "task,options,plant",
    [
        ("cepam_v1", {}, "balloon"),
        ("cepam_v1", {"load_range": (0.0, 0.45), "pressure_margin": 0.95}, "balloon"),
        # a narrow band: sample_target fallbacks, unreachable references and their fallbacks
        ("cepam_v1", {"stiffness_range": (1500.0, 2500.0)}, "balloon_v0"),
        ("cepam_v1", {"references": ("step", "sine"), "load_kinds": ("random",), "move_s": 0.2}, "balloon"),
        ("stiffness_v1", {"stiffness_range": (1200.0, 2500.0), "load_kinds": ("ramp", "sine")}, "balloon_v0"),
        ("length_v1", {"segment_duration": (0.5, 1.0), "load_range": (0.2, 0.4)}, "balloon"),
    ],
)
def test_planned_episodes_per_plant_rows_and_edges(task, options, plant):
    """Per-env plant rows, fallbacks, short episodes; a batch that finds no target for some env
    fails alike (same message)."""
    spec = dataclasses.replace(TASKS[task], **options)
    rows = _randomized_rows(70, 5, plant)
    for n, steps in ((70, 500), (8, 60)):
        new, old = _rngs(n, 3), _rngs(n, 3)
        got = _outcome(planned_schedules, new, spec, rows[:n], steps, DT)
        want = _outcome(LP.planned_schedules, old, spec, rows[:n], steps, DT)
        if isinstance(want, str):
            assert got == want
        else:
            _assert_same(got, want)
            assert _states(new) == _states(old)


@pytest.mark.parametrize("name", list(JOINT_TASKS))
@pytest.mark.parametrize("plant", ["balloon", "balloon_v2"])
def test_joint_episodes_equal_the_former_numpy_code(name, plant):
    geom, nominal = JointGeometry(), preset(plant).to_array()
    for rows in (nominal, _randomized_rows(70, 9, plant)):
        task = JOINT_TASKS[name]
        new, old = _rngs(70, 11), _rngs(70, 11)
        _assert_same(
            joint_planned_schedules(new, task, geom, rows, nominal, 500, DT),
            LP.joint_planned_schedules(old, task, geom, rows, nominal, 500, DT),
        )
        assert _states(new) == _states(old)


def test_a_failed_plan_advances_the_generator_as_before():
    """No reachable target: RuntimeError, and the env's generator has made the draws the former
    code made before it raised (the env then redraws its plant from there)."""
    spec = dataclasses.replace(TASKS["cepam_v1"], load_range=(0.0, 6.0))  # holds 3 kg, not 6
    P = preset("balloon").to_array()
    for seed in range(5):
        new, old = _rngs(1, seed), _rngs(1, seed)
        got = _outcome(plan, new, spec, P, 500, DT)
        assert "found no reachable target" in got
        assert got == _outcome(LP.planned_schedules, old, spec, P, 500, DT)
        assert _states(new) == _states(old)


def test_python_faces_equal_the_former_numpy_code():
    P = preset("balloon").to_array()
    spec = TASKS["cepam"]
    rng = np.random.default_rng(0)
    L, w1, w2 = rng.uniform(0.15, 0.195, 3000), rng.uniform(0.0, 5.0, 3000), rng.uniform(0.0, 5.0, 3000)
    _assert_same(
        S.stiffness_interval(L, w1, np.maximum(w1, w2), P, spec),
        LP.stiffness_interval(L, w1, np.maximum(w1, w2), P, spec),
    )
    _assert_same(
        S.stiffness_interval(0.17, 2.0, 2.5, P, spec), LP.stiffness_interval(0.17, 2.0, 2.5, P, spec)
    )
    rows = _randomized_rows(50, 1)
    _assert_same(
        S.stiffness_interval(L[:50], w1[:50], w1[:50], rows, spec),
        LP.stiffness_interval(L[:50], w1[:50], w1[:50], rows, spec),
    )
    for seed in range(30):
        a, b = np.random.default_rng(seed), np.random.default_rng(seed)
        np.testing.assert_array_equal(S.load_profile(a, spec, 500, DT), LP.load_profile(b, spec, 500, DT))
        assert S.segments(a, spec, 500, DT) == LP.segments(b, spec, 500, DT)
        assert S.sample_target(a, spec, 1.0, 3.0, P) == LP.sample_target(b, spec, 1.0, 3.0, P)
        assert _states([a]) == _states([b])
    tl, tk, load, _ = LP.episode_schedules([np.random.default_rng(2)], spec, P, 500, DT)
    tl, tk, load = tl[0], tk[0], load[0]
    _assert_same(RF.project(tl, tk, load, P, spec), LP.project(tl, tk, load, P, spec))
    np.testing.assert_array_equal(
        RF.pressure_rate_ratio(tl, tk, load, P, DT), LP.pressure_rate_ratio(tl, tk, load, P, DT)
    )
    np.testing.assert_array_equal(RF.smooth_steps(tl, DT, 0.4), LP.smooth_steps(tl, DT, 0.4))
    both = np.stack([tl, tk], axis=1)
    np.testing.assert_array_equal(RF.smooth_steps(both, DT, 0.6), LP.smooth_steps(both, DT, 0.6))
    _assert_same(
        RF.smooth_reference(tl, tk, load, P, spec, DT), LP.smooth_reference(tl, tk, load, P, spec, DT)
    )
    _assert_same(
        RF.stiffness_ramp(tk, load, P, TASKS["stiffness"], DT, 0.175),
        LP.stiffness_ramp(tk, load, P, TASKS["stiffness"], DT, 0.175),
    )
    for kind in ("sine", "chirp"):
        a, b = np.random.default_rng(3), np.random.default_rng(3)
        _assert_same(
            RF.periodic_length(a, spec, load, P, 500, DT, kind),
            LP.periodic_length(b, spec, load, P, 500, DT, kind),
        )
        assert _states([a]) == _states([b])
