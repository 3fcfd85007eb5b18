"""The plant option ``pwm_timing: exact``: on/off valves switch at their PWM edges and dead times
inside a sub-step (docs/physics.md, "PWM timing"). Checked against the sampled law refined until
it converges, for continuity in the dead times, and for leaving the released presets alone."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cepam_gym import plant
from cepam_gym.errors import InputError
from cepam_gym.physics import layout as ix
from cepam_gym.physics.valve import spool_step
from cepam_gym.plant.params import PlantParams, preset
from cepam_gym.plant.substep import pwm_spool_interval, valve_command

EXACT = preset("balloon_v2").replace(pwm_timing="exact")


def _sampled_interval(s0, u, t, dt, p, n=4000):
    """End and mean opening over [t, t + dt) from the sampled law read at n midpoints."""
    tau = p[ix.TAU_SWITCH]
    h = dt / n
    decay = math.exp(-h / tau)
    s, total = s0, 0.0
    for j in range(n):
        s_prev = s
        s, _ = spool_step(
            s, 0.0, valve_command(plant.ONOFF, u, 0.0, t + (j + 0.5) * h, p), h, tau, 1, 0.0, decay
        )
        total += 0.5 * (s_prev + s)
    return s, total / n


@pytest.mark.parametrize("seed", range(6))
def test_interval_equals_the_sampled_law_refined(seed):
    """Over one 0.5 ms sub-step, the exact spool (end value and mean opening) is the limit of the
    sampled law (:func:`valve_command` read at t, held) stepped 4000 times finer: random duties,
    phases, starting openings and dead times, either order of the two dead times (so short pulses
    that never open and windows that wrap into the next period are both met)."""
    rng = np.random.default_rng(seed)
    for _ in range(25):
        p = EXACT.replace(
            onoff_open_delay=rng.uniform(0.0, 0.01), onoff_close_delay=rng.uniform(0.0, 0.01)
        ).to_array()
        u = rng.choice([rng.uniform(-1.0, 1.0), rng.uniform(0.95, 1.0), -1.0, 1.0, 0.0])
        t, dt, s0 = rng.uniform(0.0, 2.0), 5e-4, rng.uniform(-1.0, 1.0)
        tau = p[ix.TAU_SWITCH]
        end, mean = pwm_spool_interval(s0, u, t, dt, tau, math.exp(-dt / tau), p)
        ref_end, ref_mean = _sampled_interval(s0, u, t, dt, p)
        assert end == pytest.approx(ref_end, abs=2e-5)
        assert mean == pytest.approx(ref_mean, abs=2e-5)


def test_a_pulse_is_resolved_below_the_substep():
    """A 1.3 ms pulse on a plant without dead times, from a closed spool at a period's start: the
    exact end value after the first sub-step is the unit step's ``1 - exp(-dt/tau)``, and a
    sub-step that the falling edge cuts at 0.3 ms holds the analytic two-piece response."""
    p = EXACT.replace(onoff_open_delay=0.0, onoff_close_delay=0.0).to_array()
    period, tau, dt = p[ix.PWM_PERIOD], p[ix.TAU_SWITCH], 5e-4
    duty = 1.3e-3 / period
    decay = math.exp(-dt / tau)
    s1, _ = pwm_spool_interval(0.0, duty, 0.0, dt, tau, decay, p)
    assert s1 == pytest.approx(1.0 - decay, rel=1e-12)
    s2, _ = pwm_spool_interval(s1, duty, dt, dt, tau, decay, p)
    s3, _ = pwm_spool_interval(s2, duty, 2 * dt, dt, tau, decay, p)
    on = 1.0 + (s2 - 1.0) * math.exp(-0.3e-3 / tau)  # open for 0.3 ms, then closed for 0.2 ms
    assert s3 == pytest.approx(on * math.exp(-0.2e-3 / tau), rel=1e-12)


def _mass_after(params: PlantParams, duty: float, dt: float, seconds: float = 0.1) -> float:
    P = params.replace(leak_conductance=0.0).to_array()[None]
    x = plant.initial_state(P, 0.17, 50e3, 50e3)
    x, _ = plant.step(
        x, np.array([[duty, 0.0, 0.1, 0.0]]), P, mode=plant.ONOFF, dt=dt, n_sub=int(round(seconds / dt))
    )
    return float(x[0, plant.S_MC])


def test_exact_timing_converges_faster_than_sampled():
    """Five PWM periods at 33.3 % duty: at the shipped 0.5 ms sub-step the exact option is within
    0.5 % of the air a 10 us sub-step gives, and at least 5 times closer to it than the sampled
    law, whose pulse is a whole number of sub-steps long."""
    duty = 1.0 / 3.0 + 1e-3
    sampled = EXACT.replace(pwm_timing="substep")
    m0 = plant.initial_state(EXACT.to_array()[None], 0.17, 50e3, 50e3)[0, plant.S_MC]
    fine = _mass_after(EXACT, duty, 1e-5) - m0
    err_exact = abs(_mass_after(EXACT, duty, 5e-4) - m0 - fine)
    err_sampled = abs(_mass_after(sampled, duty, 5e-4) - m0 - fine)
    assert err_exact < 5e-3 * abs(fine)
    assert err_sampled > 5.0 * err_exact
    # the two laws share their limit: refined, the sampled one comes to the exact one
    assert _mass_after(sampled, duty, 1e-5) == pytest.approx(fine + m0, rel=2e-4)


def test_air_is_continuous_in_the_dead_time():
    """The air a PWM train passes, as the opening dead time moves in 0.05 ms steps (a tenth of a
    sub-step): with exact timing it changes by nearly equal increments (a fit can follow its
    slope); sampled, it is a staircase (most increments exactly zero)."""
    delays = 3e-3 + 5e-5 * np.arange(11)
    exact = np.array([_mass_after(EXACT.replace(onoff_open_delay=d), 0.3, 5e-4) for d in delays])
    sampled = np.array(
        [_mass_after(EXACT.replace(onoff_open_delay=d, pwm_timing="substep"), 0.3, 5e-4) for d in delays]
    )
    steps = np.diff(exact)
    assert np.all(steps < 0.0)  # a later opening passes less air
    assert steps.max() / steps.min() < 1.5 and steps.max() / steps.min() > 0.67
    assert np.sum(np.diff(sampled) == 0.0) >= 8


def test_released_presets_keep_the_sampled_timing():
    """Every shipped preset keeps the released law (the golden trajectories hold it bit for bit);
    the option is a key of its own, and a wrong value is refused by name."""
    for name in ("balloon", "balloon_v0", "balloon_v2", "rubber_tube", "rubber_tube_v0"):
        assert preset(name).pwm_timing == "substep"
        assert preset(name).to_array()[ix.PWM_EXACT] == 0.0
    assert PlantParams.from_dict({"pwm_timing": "exact"}).to_array()[ix.PWM_EXACT] == 1.0
    with pytest.raises(InputError, match="pwm_timing"):
        PlantParams(pwm_timing="continuous")
