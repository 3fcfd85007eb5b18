"""The emulated rig's plant is the plant's own kernel, its faults act, and the commands' usage
errors are one line."""

from __future__ import annotations

import numpy as np
import pytest

from cepam_gym import cli
from cepam_gym import plant as pl
from cepam_gym.errors import InputError
from cepam_gym.plant.params import preset
from cepam_gym.rig.emulator import EmulatedPlant, RigImperfections
from cepam_gym.rig.protocol import COMMAND, KIND_ARM, KIND_COMMAND, SAFE_COMMANDS
from cepam_gym.rig.stop import EXIT_STOP_NOT_CONFIRMED

PLANT = preset("balloon_v2")


def test_the_emulated_plant_ticks_are_the_plant_kernels_control_step():
    e = EmulatedPlant(PLANT, load=0.1, rate_hz=500.0)
    assert e.n_sub == 4 and e.tick_dt == pytest.approx(0.002)
    e.command = (0.5, 0.2)
    for _ in range(25):
        e.tick()
    row = PLANT.to_array()[None]
    inputs = np.zeros((1, pl.N_INPUT))
    inputs[0, [pl.I_CMD_C, pl.I_CMD_E, pl.I_LOAD]] = (0.5, 0.2, 0.1)
    x, _aux = pl.step(pl.initial_state(row, PLANT.min_length), inputs, row, pl.PROPORTIONAL, 5e-4, 100)
    np.testing.assert_array_equal(e.x, x)  # 25 ticks of 4 sub-steps = one call of 100, bit for bit


def test_faults_change_what_the_rig_does_and_a_stop_vents_and_shuts_the_supply():
    rng = np.random.default_rng(0)
    quiet = RigImperfections(noise_pressure=0, noise_length=0, quant_pressure=0, quant_length=0)
    e = EmulatedPlant(PLANT, load=0.1)
    e.command = (1.0, 1.0)
    for _ in range(100):
        e.tick()
    at_injection = e.true_values()
    e.inject("frozen_sensor")
    for _ in range(10):
        e.tick()
    assert e.sensed(quiet, rng)[:3] == at_injection and e.true_values() != at_injection
    e.inject("supply_drop")
    assert e.sensed(quiet, rng)[3] == pytest.approx(0.2 * PLANT.supply_pressure)
    e.restart()
    e.inject("stuck_valve")
    e.command = SAFE_COMMANDS
    for _ in range(200):
        e.tick()
    assert e.aux[0, pl.A_PC] > 0.9 * PLANT.supply_pressure and e.aux[0, pl.A_PE] < 5e3
    e.stop()
    for _ in range(500):
        e.tick()
    assert e.aux[0, pl.A_PC] < 5e3 and e.stopped  # the supply shut off: even the stuck chamber empties
    with pytest.raises(InputError, match="unknown fault"):
        e.inject("gremlins")


@pytest.mark.parametrize(
    "argv, match",
    [
        (["rig-emulator", "--fault", "gremlins@1"], "--fault must be NAME[.CHANNEL]@SECONDS"),
        (["rig-emulator", "--fault", "leak@-1"], "--fault must be NAME[.CHANNEL]@SECONDS"),
        (["rig-emulator", "--fault", "channel_value.torque@1:0"], "CHANNEL in pressure_c"),
        (["rig-emulator", "--link-fault", "gremlins"], "unknown link fault 'gremlins'"),
        (["rig-emulator", "--drop", "1.5"], "drop must be below 1"),
        (["deploy", "--controller", "baseline", "--rig", "nohost"], "host:port"),
        (["deploy", "--controller", "baseline", "--suite", "nope"], "unknown suite 'nope'"),
        (["deploy", "--controller", "baseline", "--limits", "/no/such.yaml"], "does not exist"),
        (["deploy", "--controller", "baseline", "--realtime", "0"], "priority must lie in [1, 99]"),
        (["excite", "--out", "x.csv", "--rig", "127.0.0.1:1", "--simulate"], "exclude each other"),
        (["excite", "--out", "x.csv", "--rig", "127.0.0.1:1", "--loads-g", "0,100"], "one load"),
        (["excite", "--out", "x.csv", "--rig", "127.0.0.1:1"], "--rig needs --loads-g"),
        (
            ["excite", "--out", "x.csv", "--rig", "127.0.0.1:1", "--loads-g", "1", "--rate", "20"],
            "--rate must",
        ),
        (["excite", "--out", "x.csv", "--rig", "nohost", "--loads-g", "100"], "host:port"),
    ],
)
def test_usage_errors_are_one_line(argv, match, capsys):
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert match in err and "Traceback" not in err


def test_deploy_without_a_rig_answering_says_so_and_that_its_stop_is_not_confirmed(capsys, tmp_path):
    """A port that is bound but never answers: no reading to arm on, none to confirm the stop with
    (the rig may be live for all the host knows): exit code 5, in words, no traceback."""
    import json
    import socket

    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    try:
        argv = [
            "deploy",
            "--controller",
            "zero",
            "--rig",
            f"127.0.0.1:{s.getsockname()[1]}",
            "--seconds",
            "1",
        ]
        assert cli.main([*argv, "--log", str(tmp_path / "run.csv")]) == EXIT_STOP_NOT_CONFIRMED
        kinds = [COMMAND.unpack(s.recv(64))[1] for _ in range(16)]  # what the host sent, in order
    finally:
        s.close()
    out, err = capsys.readouterr()
    assert "no reading from the rig" in out and "STOP NOT CONFIRMED" in out and "Traceback" not in err
    assert kinds[:15] == [KIND_ARM] * 15 and kinds[15] == KIND_COMMAND  # then the safe command, then stops
    summary = json.loads((tmp_path / "run.json").read_text())
    assert summary["stopped_by"] == "connect" and not summary["stop"]["confirmed"]
    assert summary["exit_code"] == EXIT_STOP_NOT_CONFIRMED


def test_the_emulated_rig_maps_a_pressure_command_as_the_env_does_not_by_its_own_supply():
    import gymnasium as gym

    from cepam_gym.envs.model import model_of
    from cepam_gym.rig.cli import DEFAULT_ENV, env_setpoint_max

    setpoint_max = env_setpoint_max(DEFAULT_ENV)
    assert setpoint_max == model_of(gym.make(DEFAULT_ENV, action_mode="pressure")).setpoint_max
    rig = PLANT.replace(supply_pressure=0.7 * PLANT.supply_pressure)  # a supply regulated lower
    assert rig.pressure_cap < setpoint_max
    e = EmulatedPlant(rig, mode="pressure", load=0.1, setpoint_max=setpoint_max)
    e.command = (-0.2, -0.6)  # set-points of 40 % and 20 % of the env's setpoint_max
    for _ in range(1000):
        e.tick()
    assert e.aux[0, pl.A_PC] == pytest.approx(0.4 * setpoint_max, rel=0.05)
    assert e.aux[0, pl.A_PE] == pytest.approx(0.2 * setpoint_max, rel=0.05)


def test_deploy_warns_of_a_policy_trained_without_sensor_noise(tmp_path):
    """Deploy warns of a policy whose file does not show sensor noise in its training env (such
    policies fell apart on the emulated rig); for a registered controller (no file) it is silent."""
    pytest.importorskip("stable_baselines3")
    pytest.importorskip("onnxruntime")
    import gymnasium as gym
    from stable_baselines3 import PPO

    from cepam_gym.control import make_controller
    from cepam_gym.rig.cli import noise_free_warning
    from cepam_gym.rig.onnx_policy import OnnxPolicy
    from cepam_gym_agents.export import export

    env = gym.make("cepam_gym/CEPAM-v2")
    PPO("MlpPolicy", env, policy_kwargs={"net_arch": [8]}, seed=0).save(str(tmp_path / "agent.zip"))
    with pytest.warns(UserWarning, match="no VecNormalize statistics"):
        export(tmp_path / "agent.zip", tmp_path / "bare.onnx")
    # a bare model's file does not say what it was trained on (a run's file does:
    # tests/agents/test_export.py); deploy says so rather than guess
    warning = noise_free_warning(OnnxPolicy(tmp_path / "bare.onnx"))
    assert warning and "bare.onnx does not record its training env's sensor noise" in warning
    assert noise_free_warning(make_controller("baseline", env)) is None
    env.close()


def test_an_emulated_rig_that_falls_behind_real_time_says_so(monkeypatch):
    """A stalled tick (here: one that takes 50 ms of a 2 ms period) puts the rig's time behind the
    wall's; the emulator reports it, once, as an event, instead of applying commands late in
    silence. It gives the caller its signal handlers back when it stops."""
    import io
    import json
    import signal
    import time

    from cepam_gym.rig.emulator import serve

    EmulatedPlant(PLANT, load=0.1, rate_hz=500.0).tick()  # the kernels compiled or loaded first
    plant = EmulatedPlant(PLANT, load=0.1, rate_hz=500.0)
    ticks = [0]
    tick = plant.tick

    def slow_tick():
        ticks[0] += 1
        if ticks[0] == 20:
            time.sleep(0.05)
        tick()

    monkeypatch.setattr(plant, "tick", slow_tick)
    before = signal.getsignal(signal.SIGTERM)
    out = io.StringIO()
    assert serve(plant, 0, duration_s=0.5, events=out) == 0
    assert signal.getsignal(signal.SIGTERM) is before
    events = [json.loads(line) for line in out.getvalue().splitlines()]
    behind = [e for e in events if e["event"] == "behind"]
    # the stall is reported (a loaded machine may add stalls of its own, each said once, not once
    # per late tick: the 50 ms stall alone leaves 25 ticks late)
    assert any(0.04 < e["seconds"] < 0.1 for e in behind), events
    assert len(behind) < 5, events
    assert ticks[0] > 50  # it kept ticking after the stall
