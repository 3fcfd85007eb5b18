"""Every fault a rig can have, made by the emulated rig in its own process and driven through the
deploy loop: each ends in a stop the rig confirmed (or says, with its exit code, that it could not
confirm it), each trip names its check, and a killed run keeps its log."""

from __future__ import annotations

import json
import math
import signal
import subprocess
import sys
import time

import pytest
from test_deploy_e2e import DEFAULT_ENV, Emulator, _deploy, _episode

from cepam_gym.identify.logs import read_log
from cepam_gym.rig.deploy import DeployAborted
from cepam_gym.rig.protocol import CHANNELS, FAULTS, WATCHDOG_S
from cepam_gym.rig.stop import (
    EXIT_CLEAN,
    EXIT_CONNECT,
    EXIT_CRASH,
    EXIT_STOP_NOT_CONFIRMED,
    EXIT_TRIP,
    STOP_DEADLINE_S,
)
from cepam_gym.rig.udp import UdpRig

pytestmark = pytest.mark.slow  # about a minute of real time

DT = 0.02
STATE_EVENTS = ("armed", "watchdog", "stop")  # the emulator's events that arm or stop the rig
AT = 25  # the step a fault is injected on (half a second in: the controller holds a pressure)


@pytest.fixture(scope="module")
def emulator(tmp_path_factory):
    emu = Emulator(tmp_path_factory.mktemp("faults"), "--load-g", "100")
    yield emu
    emu.close()


@pytest.fixture(scope="module")
def episode():
    return _episode(DEFAULT_ENV, {}, 1000, 0, 1)


def _send(emulator, fault: str, size: float = 0.0, channel: int = 0) -> None:
    """A fault packet from a host of its own (the link's faults outlive a deploy's arm)."""
    rig = UdpRig(emulator.address)
    try:
        rig.inject(FAULTS.index(fault), size, channel)
    finally:
        rig.close()
    time.sleep(0.05)


def _baseline(episode):
    from cepam_gym.control import make_controller

    return make_controller("baseline", episode[0])


def _with_fault(emulator, episode, fault, size=0.0, channel=0, steps=AT + 30, tmp_path=None):
    """The baseline deployed with ``fault`` injected on step AT: ``(result, the emulator's events
    of the run)``."""

    def inject(k, rig):
        if k == AT and fault is not None:
            rig.inject(FAULTS.index(fault), size, channel)

    start = len(emulator.events)
    log = None if tmp_path is None else tmp_path / "run.csv"
    result = _deploy(emulator, episode, _baseline(episode), steps, log=log, on_step=inject)
    time.sleep(0.1)
    return result, emulator.events[start:]


@pytest.mark.parametrize(
    "fault, channel, size, reason",
    [
        ("channel_value", "pressure_c", 0.0, "fill_fault"),  # a CPAM sensor failing low, noisy about 0
        ("channel_value", "pressure_c", -50e3, "pressure_floor"),
        ("channel_value", "supply", 400e3, "supply_high"),
        ("channel_value", "length", 0.30, "length_limit"),  # failing high
        ("channel_value", "pressure_e", 400e3, "pressure_limit"),
        ("frozen_channel", "length", 0.0, "frozen_sensor"),  # the length alone frozen
        ("frozen_channel", "supply", 0.0, "frozen_sensor"),
    ]
    + [("channel_value", name, math.nan, "nonfinite_reading") for name in CHANNELS]
    + [("channel_value", "pressure_c", -math.inf, "nonfinite_reading")],
)
def test_each_sensor_fault_trips_its_check_and_the_rig_confirms_its_stop(
    fault, channel, size, reason, emulator, episode
):
    result, events = _with_fault(emulator, episode, fault, size, CHANNELS.index(channel))
    safe = [e for e in events if e["event"] == "safe"]
    print(f"{fault}.{channel}={size}: {result.trip}, safe {safe and safe[0]['after_fault_s'] * 1e3:.0f} ms")
    assert result.trip is not None and result.trip["reason"] == reason, result.trip
    assert result.stop["confirmed"] and not result.stop["by_watchdog"]
    assert result.exit_code == EXIT_TRIP
    assert safe and safe[0]["after_fault_s"] <= 0.4  # (the frozen channel after frozen_after_s)


def test_a_rig_that_ignores_arm_is_told_apart_from_a_silent_one(emulator, episode):
    _send(emulator, "ignore_arm")
    try:
        result, _events = _with_fault(emulator, episode, None, steps=5)
    finally:
        _send(emulator, "clear")
    print(result.summary())
    assert result.stopped_by == "connect" and "answers but stays stopped" in result.error
    assert result.stop["confirmed"] and result.exit_code == EXIT_CONNECT and result.steps == 0


def test_a_rig_that_arms_then_goes_silent_is_stopped_and_the_stop_reported_unconfirmed(emulator, episode):
    """The rig arms, then sends nothing: the host sends its stops, cannot confirm them and says so
    (exit 5); the rig stops on the host's packets. With those lost too, its watchdog stops it."""
    _send(emulator, "silent")
    try:
        result, events = _with_fault(emulator, episode, None, steps=5)
    finally:
        _send(emulator, "clear")
    assert result.stopped_by == "connect" and "no reading" in result.error
    assert not result.stop["confirmed"] and result.exit_code == EXIT_STOP_NOT_CONFIRMED
    assert "STOP NOT CONFIRMED" in result.summary()
    # armed by each arm packet, and between them (every 0.2 s) stopped by its watchdog; at the end
    # stopped by the host's stop packets. Only the events that change the rig's state count: the
    # emulator also reports its own timing ("behind", when a loaded machine delays its ticks),
    # which may come after the stop.
    kinds = [e["event"] for e in events if e["event"] in STATE_EVENTS]
    assert "armed" in kinds and kinds[-1] == "stop"
    _send(emulator, "silent")
    _send(emulator, "lose_stops")
    try:
        result, events = _with_fault(emulator, episode, None, steps=5)
    finally:
        _send(emulator, "clear")
    watchdog = [e for e in events if e["event"] == "watchdog"]
    assert result.exit_code == EXIT_STOP_NOT_CONFIRMED
    kinds = [e["event"] for e in events if e["event"] in STATE_EVENTS]
    assert kinds[-1] == "watchdog" and "stop" not in kinds  # left to the watchdog, which acts
    assert all(WATCHDOG_S <= e["silent_s"] < WATCHDOG_S + 0.1 for e in watchdog)


def test_lost_stops_are_confirmed_by_the_rigs_watchdog(emulator, episode):
    result, events = _with_fault(emulator, episode, "lose_stops", steps=AT + 5)
    _send(emulator, "clear")
    print(result.summary())
    assert result.stopped_by == "end" and result.exit_code == EXIT_CLEAN
    assert result.stop["confirmed"] and result.stop["by_watchdog"]
    assert WATCHDOG_S < result.stop["after_s"] < STOP_DEADLINE_S
    assert "watchdog" in [e["event"] for e in events] and "stop" not in [e["event"] for e in events]


def test_lost_stops_and_no_watchdog_leave_the_stop_unconfirmed(emulator, episode):
    result, events = _with_fault(emulator, episode, "lose_stops", steps=AT + 5)
    assert result.stop["confirmed"]  # (the watchdog, as above)
    _send(emulator, "no_watchdog")
    try:
        result, events = _with_fault(emulator, episode, "lose_stops", steps=AT + 5)
        assert not result.stop["confirmed"] and result.exit_code == EXIT_STOP_NOT_CONFIRMED
        assert result.stopped_by == "end" and "STOP NOT CONFIRMED" in result.summary()
    finally:
        _send(emulator, "clear")
        _send(emulator, "reboot")  # (the rig left live by this test: back to its safe state)


def test_a_rig_that_reboots_mid_run_trips_and_its_stop_is_confirmed(emulator, episode):
    result, events = _with_fault(emulator, episode, "reboot")
    print(result.trip)
    assert result.trip is not None and result.trip["reason"] in ("rig_restarted", "stopped")
    assert result.stop["confirmed"] and result.exit_code == EXIT_TRIP
    assert "reboot" in [e["event"] for e in events]


def test_an_exception_in_the_loop_stops_the_rig_and_keeps_the_summary(emulator, episode, tmp_path):
    controller = _baseline(episode)
    act, calls = controller.act, [0]

    def failing(obs, info=None):
        calls[0] += 1
        if calls[0] == 20:
            raise ZeroDivisionError("a controller's bug")
        return act(obs)

    controller.act = failing
    start = len(emulator.events)
    with pytest.raises(DeployAborted) as caught:
        _deploy(emulator, episode, controller, 50, log=tmp_path / "crash.csv")
    result = caught.value.result
    assert isinstance(caught.value.__cause__, ZeroDivisionError)
    assert result.stopped_by == "exception" and "a controller's bug" in result.error
    assert result.stop["confirmed"] and result.exit_code == EXIT_CRASH
    summary = json.loads((tmp_path / "crash.json").read_text())
    assert summary["stopped_by"] == "exception" and summary["steps"] == result.steps
    assert len(read_log(tmp_path / "crash.csv").time) == result.steps
    emulator.wait_for("stop", after=start)


def _deploy_cli(emulator, log, *extra) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "cepam_gym.cli", "deploy", "--controller", "baseline"]
    cmd += ["--rig", f"127.0.0.1:{emulator.address[1]}", "--log", str(log), *extra]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_a_killed_deploy_keeps_every_step_but_the_last_and_the_rigs_watchdog_stops_it(emulator, tmp_path):
    start = len(emulator.events)
    log = tmp_path / "killed.csv"
    proc = _deploy_cli(emulator, log, "--suite", "nominal-v2")
    armed = emulator.wait_for("armed", after=start, timeout=120)
    time.sleep(2.0)
    proc.send_signal(signal.SIGKILL)
    proc.communicate(timeout=30)
    watchdog = emulator.wait_for("watchdog", after=start)
    applied = watchdog["ack"] - armed["ack"]  # the commands the rig applied (the host numbers all)
    rows = read_log(log).time
    print(f"SIGKILL: {applied} commands applied, {len(rows)} rows logged")
    assert applied >= 50 and applied - 1 <= len(rows) <= applied
    assert json.loads(log.with_suffix(".json").read_text())["stopped_by"] == "running"


@pytest.mark.parametrize(
    "limits, code, words",
    [
        ("stale_after_s: 0.1\n", EXIT_CLEAN, "ended: end"),
        ("length_min_cm: 16.5\n", EXIT_TRIP, "SAFETY TRIP length_limit"),  # the rest is below it
    ],
)
def test_the_exit_codes_of_deploy(limits, code, words, emulator, tmp_path):
    (tmp_path / "limits.yaml").write_text(limits)
    proc = _deploy_cli(
        emulator, tmp_path / "run.csv", "--seconds", "0.5", "--limits", str(tmp_path / "limits.yaml")
    )
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == code, out + err
    assert words in out and "stopped (confirmed at" in out
    assert json.loads((tmp_path / "run.json").read_text())["exit_code"] == code
