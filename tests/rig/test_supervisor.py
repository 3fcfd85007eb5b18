"""The safety supervisor: each check trips on its fault, latches the safe command, and its limits
come from the preset and may only be tightened."""

from __future__ import annotations

import math

import pytest

from cepam_gym.errors import InputError
from cepam_gym.plant.params import preset
from cepam_gym.rig.protocol import CHANNELS, FLAG_STOPPED, FLAG_WATCHDOG, SAFE_COMMANDS, Reading
from cepam_gym.rig.supervisor import FILL, REASONS, SafetyLimits, Supervisor

PLANT = preset("balloon_v2")
LIM = SafetyLimits.from_plant(PLANT)
DT = 0.02


def _ok(t: float, **changes) -> Reading:
    v = dict(
        time=t,
        seq=5000 + int(round(t / DT)),
        pressure_c=100e3 + t,
        pressure_e=80e3 - t,
        length=0.17 + 1e-6 * t,
        supply=PLANT.supply_pressure - t,
    )
    v.update(changes)
    return Reading(**v)


def test_limits_come_from_the_preset():
    assert LIM.pressure_max_c == pytest.approx(0.9 * PLANT.burst_pressure)
    assert LIM.length_min < PLANT.min_length and LIM.length_max > PLANT.max_length
    assert LIM.supply_min == pytest.approx(0.5 * PLANT.supply_pressure)


def test_healthy_readings_pass_the_command_through_clipped():
    sup = Supervisor(LIM, DT)
    for k in range(50):
        cmd, trip = sup.filter(_ok(k * DT), (0.3, 1.7), now=k * DT)
        assert trip is None and cmd == (0.3, 1.0)
    assert not sup.tripped


@pytest.mark.parametrize(
    "changes, reason",
    [
        ({"pressure_c": 0.95 * PLANT.burst_pressure}, "pressure_limit"),
        ({"pressure_e": 0.95 * PLANT.burst_pressure}, "pressure_limit"),
        ({"length": PLANT.max_length + 0.005}, "length_limit"),
        ({"length": PLANT.min_length - 0.005}, "length_limit"),
        ({"supply": 0.3 * PLANT.supply_pressure}, "supply_loss"),
        ({"flags": FLAG_STOPPED}, "stopped"),
        ({"flags": FLAG_STOPPED | FLAG_WATCHDOG}, "stopped"),
        ({"supply": 1.3 * PLANT.supply_pressure}, "supply_high"),
        ({"pressure_c": -50e3}, "pressure_floor"),
        ({"pressure_e": -50e3}, "pressure_floor"),
        ({"seq": 0}, "rig_restarted"),  # its packet numbers began again
        ({"time": -1.0}, "rig_restarted"),  # its clock too
    ]
    + [({name: v}, "nonfinite_reading") for name in CHANNELS for v in (math.nan, math.inf, -math.inf)]
    + [({"time": math.nan}, "nonfinite_reading")],
)
def test_each_limit_trips_on_the_step_it_is_seen_and_latches(changes, reason):
    sup = Supervisor(LIM, DT)
    for k in range(5):
        assert sup.filter(_ok(k * DT), (0.5, 0.5), now=k * DT)[1] is None
    cmd, trip = sup.filter(_ok(5 * DT, **changes), (0.5, 0.5), now=5 * DT)
    assert cmd == SAFE_COMMANDS and trip is not None and trip.reason == reason and trip.detail
    assert trip.reason in REASONS
    if "time" not in changes:
        assert trip.rig_time == pytest.approx(5 * DT)
    # healthy readings afterwards do not re-arm it
    cmd, again = sup.filter(_ok(6 * DT), (0.5, 0.5), now=6 * DT)
    assert cmd == SAFE_COMMANDS and again is None and sup.trip is trip


def test_the_watchdog_trips_when_readings_stop_or_freeze():
    sup = Supervisor(LIM, DT)
    sup.filter(_ok(0.0), (0, 0), now=0.0)
    k = 1
    while not sup.tripped:
        sup.filter(None, (0, 0), now=k * DT)
        k += 1
    assert sup.trip.reason == "stale_sensor" and (k - 1) * DT > LIM.stale_after_s
    assert (k - 2) * DT <= LIM.stale_after_s  # on the first step past the limit
    frozen = Supervisor(LIM, DT)
    same = _ok(0.0)
    k = 0
    while not frozen.tripped:  # packets keep coming, the values do not change
        frozen.filter(
            Reading(k * DT, same.pressure_c, same.pressure_e, same.length, same.supply, seq=k), (0, 0), k * DT
        )
        k += 1
    assert frozen.trip.reason == "frozen_sensor"
    assert LIM.frozen_after_s < (k - 1) * DT <= LIM.frozen_after_s + DT


def test_a_chamber_that_does_not_vent_when_told_to_trips_and_one_that_vents_does_not():
    def run(pressure_of_t):
        sup = Supervisor(LIM, DT)
        for k in range(40):
            t = k * DT
            r = _ok(t, pressure_c=pressure_of_t(t))
            sup.filter(r, (-1.0, 0.0), now=t)
        return sup.trip

    stuck = run(lambda t: 240e3 + 10 * t)  # (a sensor's noise moves it: not a frozen channel)
    assert stuck is not None and stuck.reason == "valve_fault" and "CPAM" in stuck.detail
    assert stuck.host_time == pytest.approx(DT + LIM.valve_check_s, abs=DT)
    assert run(lambda t: 200e3 * math.exp(-t / 0.05) + t) is None


def _fill(pressure_of_t, supply=PLANT.supply_pressure):
    sup = Supervisor(LIM, DT)
    for k in range(40):
        t = k * DT
        sup.filter(_ok(t, pressure_e=pressure_of_t(t), supply=supply - t), (0.0, FILL), now=t)
    return sup.trip


def test_a_chamber_told_to_fill_that_still_reads_empty_trips_and_one_that_fills_does_not():
    """A pressure sensor failing low (noisy about 0) while its valve fills the chamber."""
    low = _fill(lambda t: 1e3 * math.sin(100 * t))
    assert low is not None and low.reason == "fill_fault" and "EPAM" in low.detail
    assert low.host_time == pytest.approx(DT + LIM.valve_check_s, abs=DT)
    assert _fill(lambda t: 200e3 * (1 - math.exp(-t / 0.05)) + t) is None
    # without a supply there is nothing to fill from: the supply check speaks instead
    assert (
        _fill(lambda t: 1e3 * math.sin(100 * t), supply=0.3 * PLANT.supply_pressure).reason == "supply_loss"
    )


@pytest.mark.parametrize("channel", range(len(CHANNELS)))
def test_a_single_frozen_channel_trips_and_is_named(channel):
    sup = Supervisor(LIM, DT)
    k = 0
    frozen = _ok(0.0).channels()[channel]
    while not sup.tripped and k < 50:
        sup.filter(_ok(k * DT, **{CHANNELS[channel]: frozen}), (0, 0), now=k * DT)
        k += 1
    assert sup.trip.reason == "frozen_sensor"
    assert sup.trip.detail.startswith(("CPAM pressure", "EPAM pressure", "length", "supply")[channel])
    assert LIM.frozen_after_s < (k - 1) * DT <= LIM.frozen_after_s + DT


def test_a_non_finite_command_trips():
    sup = Supervisor(LIM, DT)
    cmd, trip = sup.filter(_ok(0.0), (math.nan, 0.0), now=0.0)
    assert cmd == SAFE_COMMANDS and trip.reason == "bad_command"


def test_the_rate_limit_clamps_without_tripping():
    lim = LIM.tighten({"command_rate_per_s": 10.0})
    sup = Supervisor(lim, DT)
    sup.filter(_ok(0.0), (0.0, 0.0), now=0.0)
    cmd, trip = sup.filter(_ok(DT), (1.0, -1.0), now=DT)
    assert trip is None and cmd == pytest.approx((0.2, -0.2)) and sup.clamped == 1


def test_a_limits_file_tightens_and_is_refused_when_it_loosens_or_misspells(tmp_path):
    f = tmp_path / "limits.yaml"
    f.write_text("pressure_max_c_kpa: 150\nlength_max_cm: 18.5\nstale_after_s: 0.05\n")
    lim = LIM.tightened(f)
    assert lim.pressure_max_c == pytest.approx(150e3) and lim.length_max == pytest.approx(0.185)
    assert lim.stale_after_s == 0.05 and lim.pressure_max_e == LIM.pressure_max_e
    f.write_text("pressure_max_c_kpa: 400\n")
    with pytest.raises(InputError, match="loosens"):
        LIM.tightened(f)
    f.write_text("pressure_max_kpa: 100\n")
    with pytest.raises(InputError, match="unknown key 'pressure_max_kpa'"):
        LIM.tightened(f)
    f.write_text("length_min_cm: abc\n")
    with pytest.raises(InputError, match="finite number"):
        LIM.tightened(f)
    with pytest.raises(InputError, match="does not exist"):
        LIM.tightened(tmp_path / "nope.yaml")


def test_the_warm_up_before_arming_leaves_the_loops_state_untouched():
    """``deploy.warm_up`` runs the controller and a copy of the supervisor on made-up readings
    (so nothing compiles inside the timed loop); the supervisor itself keeps no trace of them,
    and the controller and observer start afresh."""
    import pickle

    import gymnasium as gym

    from cepam_gym.control import make_controller
    from cepam_gym.envs.model import model_of
    from cepam_gym.rig.deploy import warm_up
    from cepam_gym.rig.observation import RigObserver

    env = gym.make("cepam_gym/CEPAM-v2", action_mode="pwm")
    env.reset(seed=0)
    model = model_of(env)
    sup = Supervisor(LIM, DT, model=model)
    before = pickle.dumps(sup)
    observer = RigObserver(model, model.target_l[0], model.target_k[0])
    calls = []
    controller = make_controller("baseline", env)
    act = controller.act
    controller.act = lambda obs, info=None: calls.append(obs) or act(obs)
    warm_up(controller, observer, sup)
    assert len(calls) >= 5 and not sup.tripped
    assert pickle.dumps(sup) == before
    assert observer._last is None
