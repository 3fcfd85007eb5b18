"""Episode schedules: the compiled sampler against a plain per-env, per-segment reference written
out here on the former NumPy helpers (``legacy_planner``), including the fallback path."""

from __future__ import annotations

import dataclasses

import legacy_planner as LP
import numpy as np
import pytest

from cepam_gym.physics import layout as ix
from cepam_gym.planning.episodes import episode_schedules
from cepam_gym.plant.params import preset
from cepam_gym.tasks import TASKS


def reference_schedule(rng, spec, p, n_steps, dt):
    """One env, segment by segment: the first feasible of the segment's candidates, else
    sample_target; the same draws in the same order as the batched sampler promises."""
    load, segs, cand_l, cand_u = LP._draw(rng, spec, n_steps, dt)
    w = (p[ix.M_END] + load) * p[ix.GRAV]
    tl, tk = np.empty(n_steps), np.empty(n_steps)
    fallbacks = 0
    for s, (a, b) in enumerate(segs):
        lo, hi = LP.stiffness_interval(cand_l[s], np.full(8, w[a:b].min()), np.full(8, w[a:b].max()), p, spec)
        ok = np.flatnonzero(hi > lo)
        if ok.size:
            c = ok[0]
            target = cand_l[s, c], lo[c] + cand_u[s, c] * (hi[c] - lo[c])
        else:
            fallbacks += 1
            target = LP.sample_target(rng, spec, w[a:b].min(), w[a:b].max(), p)
        if s == len(segs) - 1:
            initial = np.array(target)
        else:
            tl[a:b], tk[a:b] = target
    return tl, tk, load, initial, fallbacks


V0 = preset("balloon_v0")  # the plant of the v0 env ids (its stiffness reaches the narrow band below)


@pytest.mark.parametrize(
    "task,options,per_plant",
    [
        ("cepam", {}, False),
        ("cepam", {"load_range": (0.0, 0.45), "pressure_margin": 0.95}, True),
        ("stiffness", {}, True),
        # a narrow stiffness band: about one segment in five has no feasible candidate (fallback path)
        ("cepam", {"stiffness_range": (1500.0, 2500.0)}, False),
    ],
)
def test_batched_schedules_equal_the_per_env_reference(task, options, per_plant):
    spec = dataclasses.replace(TASKS[task], **options)
    rng = np.random.default_rng(1)
    n = 24
    if per_plant:
        params = np.stack(
            [
                V0.replace(
                    end_mass=rng.uniform(0.015, 0.025), cpam_rest_angle=np.radians(rng.uniform(27.5, 30.0))
                ).to_array()
                for _ in range(n)
            ]
        )
    else:
        params = V0.to_array()[None]
    tl, tk, load, initial = episode_schedules(
        [np.random.default_rng(50 + i) for i in range(n)], spec, params, 500, 0.02
    )
    fallbacks = 0
    for i in range(n):
        ref = reference_schedule(
            np.random.default_rng(50 + i), spec, params[i if per_plant else 0], 500, 0.02
        )
        for got, want in zip((tl[i], tk[i], load[i], initial[i]), ref[:4]):
            np.testing.assert_array_equal(got, want)
        fallbacks += ref[4]
    if "stiffness_range" in options:
        assert fallbacks > 0  # the fallback path was taken, and matched
    assert np.all(np.isfinite(tl)) and np.all(np.isfinite(tk))
