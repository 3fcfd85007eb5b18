"""The loop closed on the loopback: an emulated rig in its own process (a plant whose parameters
the deploy side does not know), a registered controller and an exported policy deployed on it, each
injected fault ending in the safe state, and a clean stop on SIGTERM."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from cepam_gym.identify.logs import read_log
from cepam_gym.plant.params import preset
from cepam_gym.rig.cli import DEFAULT_ENV, _episode, noise_free_warning
from cepam_gym.rig.deploy import connect, run
from cepam_gym.rig.emulator import RigImperfections
from cepam_gym.rig.observation import RigObserver
from cepam_gym.rig.protocol import FAULTS
from cepam_gym.rig.supervisor import SafetyLimits, Supervisor
from cepam_gym.rig.udp import UdpRig

pytestmark = pytest.mark.slow  # about half a minute of real time

DT = 0.02
EXCITE_S = 20.0  # the excitation's length (real time), at 500 Hz: the spool's lag is seen
# what identify fits (with the sensors): the rig's hidden differences from the preset, a 4 s fit
IDENTIFIED = ("valve_conductance", "dead_volume_cpam", "damping", "spool_time_constant")
SCORED_STEPS = 400  # the deployment (real time: 8 s), scored after its first second (the approach)
SEEDS = 20  # simulations on the identified plant
AGENT_STEPS = 500_000  # PPO's training on the identified plant (fast_ppo: about 15 s on 2 cores)
# trained without sensor noise, a policy fell apart on the rig's 0.2 kPa of pressure noise (length
# errors of 6 mm where the env gave 0.4): it trains with about twice the rig's noise
TRAIN_NOISE = {"pressure_kpa": 0.5, "length_mm": 0.05, "velocity_mm_s": 2.0}
AGENT_VS_BASELINE = 3.0  # the brief agent's deployed score within this factor of the baseline's
RIG = RigImperfections(drop=0.02)  # the emulator's (its command line's defaults and --drop)
# the rig's plant: the deploy side builds its env on the nominal preset and never sees these
# (a supply regulated below the preset's: an excitation at the preset's 250 kPa squeezes the CPAM past
# the supervisor's 270 kPa limit)
HIDDEN = {
    "valve_conductance": 1.15,
    "dead_volume_cpam": 1.3,
    "damping": 1.5,
    "spool_time_constant": 0.8,
    "supply_pressure": 0.7,
}


class Emulator:
    """``cepam-gym rig-emulator`` in a subprocess; its events (JSON lines on stdout) collected."""

    def __init__(self, tmp: Path, *extra: str):
        base = preset("balloon_v2")
        hidden = base.replace(**{k: getattr(base, k) * f for k, f in HIDDEN.items()})
        plant = tmp / "hidden_plant.yaml"
        plant.write_text(yaml.safe_dump(hidden.to_dict()))
        cmd = [sys.executable, "-m", "cepam_gym.cli", "rig-emulator", "--plant", str(plant), "--port", "0"]
        self.proc = subprocess.Popen(
            [*cmd, *extra], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        self.events: list[dict] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        first = self.wait_for("listening", timeout=120)
        self.address = ("127.0.0.1", first["port"])

    def _read(self):
        for line in self.proc.stdout:
            if line.startswith("{"):
                self.events.append(json.loads(line))

    def wait_for(self, event: str, after: int = 0, timeout: float = 5.0) -> dict:
        end = time.time() + timeout
        while time.time() < end:
            found = [e for e in self.events[after:] if e["event"] == event]
            if found:
                return found[0]
            if self.proc.poll() is not None:
                raise AssertionError(f"the emulator exited: {self.proc.stderr.read()}")
            time.sleep(0.01)
        raise AssertionError(f"no {event!r} event within {timeout} s: {self.events[after:]}")

    def close(self):
        self.proc.send_signal(signal.SIGTERM)
        assert self.proc.wait(timeout=10) == 0
        self.wait_for("exit")


@pytest.fixture(scope="module")
def emulator(tmp_path_factory):
    emu = Emulator(tmp_path_factory.mktemp("rig"), "--drop", str(RIG.drop), "--load-g", "100")
    yield emu
    emu.close()


@pytest.fixture(scope="module")
def episode():
    return _episode(DEFAULT_ENV, {}, 1000, 0, 1)


def _deploy(emulator, episode, controller, steps, log=None, on_step=None, limits=None):
    _env, model, tl, tk = episode
    limits = limits or SafetyLimits.from_plant(model.nominal)
    rig = UdpRig(emulator.address)
    try:
        return run(
            rig,
            controller,
            RigObserver(model, tl, tk),
            Supervisor(limits, model.control_dt, model=model),
            0.1,
            n_steps=steps,
            log_path=log,
            on_step=on_step if on_step is None else (lambda k: on_step(k, rig)),
        )
    finally:
        rig.close()


def test_the_baseline_runs_on_the_emulated_rig_in_real_time_and_logs_for_identify(
    emulator, episode, tmp_path
):
    from cepam_gym.control import make_controller

    env = episode[0]
    start = len(emulator.events)
    result = _deploy(emulator, episode, make_controller("baseline", env), 150, log=tmp_path / "base.csv")
    print(result.summary())
    # the loop's timing is measured by benchmarks/deploy_loop.py, not asserted here: a busy machine
    # (the test suite's other worker) may make it skip a step, which it must then account for
    assert result.stopped_by == "end" and result.trip is None
    assert result.steps + result.skipped == 150 and result.skipped <= result.deadline_misses
    assert result.steps >= 100 and result.length_rmse_mm < 10.0  # it tracks a plant it does not know
    emulator.wait_for("stop", after=start)  # the rig was left in its safe state
    rec = read_log(tmp_path / "base.csv")  # identify reads the deployment log, a row per step run
    assert len(rec.time) == result.steps and np.all(rec.loads == pytest.approx(0.1))
    assert json.loads((tmp_path / "base.json").read_text())["steps"] == result.steps


def test_an_exported_policy_runs_on_the_emulated_rig(emulator, episode, tmp_path):
    pytest.importorskip("stable_baselines3")
    pytest.importorskip("onnxruntime")
    import gymnasium as gym
    from stable_baselines3 import PPO

    from cepam_gym.rig.onnx_policy import OnnxPolicy
    from cepam_gym_agents.export import export

    PPO("MlpPolicy", gym.make(DEFAULT_ENV), policy_kwargs={"net_arch": [64, 64]}, seed=0).save(
        str(tmp_path / "agent.zip")
    )
    with pytest.warns(UserWarning, match="no VecNormalize statistics"):  # a bare model: raw observations
        export(tmp_path / "agent.zip", tmp_path / "policy.onnx")
    policy = OnnxPolicy(tmp_path / "policy.onnx")
    policy.check_env(episode[1].obs_dim, episode[1].action_mode)
    result = _deploy(emulator, episode, policy, 100)
    print(result.summary())
    # an untrained policy may well trip a limit: what matters is that the loop ends in the safe state
    assert result.steps >= 1 and result.stopped_by in ("end", "trip")
    assert result.trip is None or result.trip["reason"] != "leak"  # the rig has none
    assert result.compute_p50 < DT  # an exported MLP computes well within a control period


@pytest.mark.parametrize(
    "fault, reasons",
    [
        ("frozen_sensor", {"frozen_sensor"}),
        ("supply_drop", {"supply_loss"}),
        ("stuck_valve", {"valve_fault", "pressure_limit"}),
        ("leak", {"leak"}),  # caught even while the controller compensates it
    ],
)
def test_each_injected_fault_ends_in_the_safe_state(fault, reasons, emulator, episode):
    from cepam_gym.control import make_controller

    code = FAULTS.index(fault)
    at = 50

    def inject(k, rig):
        if k == at:
            rig.inject(code)

    start = len(emulator.events)
    result = _deploy(emulator, episode, make_controller("baseline", episode[0]), at + 40, on_step=inject)
    trip = result.trip["reason"] if result.trip else None
    emulator.wait_for("fault", after=start)
    safe = emulator.wait_for("safe", after=start)
    detail = result.trip["detail"] if result.trip else "none"
    print(f"{fault}: trip {trip} ({detail}), safe state {safe['after_fault_s'] * 1e3:.0f} ms after the fault")
    assert trip in reasons
    if trip is not None:
        # on the step the supervisor can tell: within one control period of the fault becoming
        # detectable (a frozen sensor after frozen_after_s, a valve after valve_check_s)
        lim = SafetyLimits.from_plant(episode[1].nominal)
        window = {
            "frozen_sensor": lim.frozen_after_s,
            "valve_fault": lim.valve_check_s,
            "leak": lim.leak_window_s,
        }.get(trip, 0.0)
        assert safe["after_fault_s"] <= window + 2 * DT + 0.4  # the stuck valve first has to overfill


def test_each_new_host_drives_the_rig_from_its_first_command(emulator):
    for commands in (40, 20):  # the second host's packet numbers start again below the first's
        start = len(emulator.events)
        rig = UdpRig(emulator.address)
        try:
            connect(rig)
            for _ in range(commands):
                rig.write(-1.0, -1.0)
                time.sleep(0.004)
            ack, end = -1, time.time() + 2.0  # (a busy machine may hold the emulator back a while)
            while not rig.seq - 5 < ack <= rig.seq and time.time() < end:
                time.sleep(0.01)
                newest = rig.read()
                ack = newest.ack_seq if newest is not None else ack
            assert rig.seq - 5 < ack <= rig.seq  # the rig applies this host's commands
            rig.stop()
            emulator.wait_for("stop", after=start)  # stopped before the next host arms it
        finally:
            rig.close()


def test_deploy_stops_cleanly_on_sigterm_and_leaves_the_rig_safe(emulator, tmp_path):
    start = len(emulator.events)
    log = tmp_path / "sig.csv"
    cmd = [
        sys.executable,
        "-m",
        "cepam_gym.cli",
        "deploy",
        "--controller",
        "baseline",
        "--rig",
        f"127.0.0.1:{emulator.address[1]}",
        "--suite",
        "nominal-v2",
        "--log",
        str(log),
    ]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=os.environ)
    emulator.wait_for("armed", after=start, timeout=120)
    time.sleep(3.0)  # past the controller's warm-up, into the timed loop
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    summary = json.loads(log.with_suffix(".json").read_text())
    assert summary["stopped_by"] == "signal" and 10 <= summary["steps"] < summary["planned_steps"]
    assert "stopped (confirmed at" in out
    assert summary["stop"]["confirmed"] and summary["exit_code"] == 0
    emulator.wait_for("stop", after=start)


@pytest.fixture(scope="module")
def identified(emulator, tmp_path_factory):
    """Excite the rig (its parameters hidden) through the deploy loop and identify the parameters
    it may differ in on that log: ``(fitted plant YAML, excite seconds, identify seconds)``."""
    from cepam_gym.plant.params import PlantParams

    tmp = tmp_path_factory.mktemp("identified")
    cli = [sys.executable, "-m", "cepam_gym.cli"]
    log, fit = tmp / "excite.csv", tmp / "fit.yaml"
    t0 = time.perf_counter()
    excite = [*cli, "excite", "--rig", f"127.0.0.1:{emulator.address[1]}", "--out", str(log)]
    out = subprocess.run(
        [*excite, "--rate", "500", "--seconds", str(EXCITE_S), "--loads-g", "100"],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    t_excite = time.perf_counter() - t0
    identify = [
        *cli,
        "identify",
        "--data",
        str(log),
        "--preset",
        "balloon_v2",
        "--starts",
        "1",
        "--out",
        str(fit),
    ]
    out = subprocess.run(
        [*identify, *(a for name in IDENTIFIED for a in ("--only", name))], capture_output=True, text=True
    )
    assert out.returncode == 0, out.stdout + out.stderr
    fitted, base = PlantParams.from_yaml(fit), preset("balloon_v2")
    for name in IDENTIFIED:
        hidden, found = getattr(base, name) * HIDDEN[name], getattr(fitted, name)
        print(f"{name}: hidden {hidden:.4g}, identified {found:.4g} ({100 * (found / hidden - 1):+.1f} %)")
        assert found == pytest.approx(hidden, rel=0.25)
    return fit, t_excite, time.perf_counter() - t0 - t_excite


def _deployed_against_simulated(emulator, episode, make, fit, log):
    """Deploy ``make()`` (a fresh controller) for SCORED_STEPS steps, score its log, and simulate
    it on the identified plant over SEEDS seeds of the sensors' noise, the lost packets, the phase
    of the rig's ticks and the host's delay from each step's release to its command (drawn from
    the deployment's median and p99 of its wake-up lateness and compute time):
    ``(deployed metrics, simulated scores, the deployment's result)``."""
    from cepam_gym.plant.params import PlantParams
    from cepam_gym.rig.score import log_score, simulate

    _env, model, tl, tk = episode
    fitted = PlantParams.from_yaml(fit)
    result = _deploy(emulator, episode, make(), SCORED_STEPS, log=log)
    print(result.summary(), f"missing readings {result.missing_readings}")
    rec = read_log(log)
    deployed = log_score(rec.measured, model, tl, tk, fitted, result.trip is not None, rec.time)
    compute = (result.lateness_p50 + result.compute_p50, result.lateness_p99 + result.compute_p99)
    sims = []
    for seed in range(SEEDS):
        measured, tripped = simulate(fitted, make(), model, tl, tk, 0.1, SCORED_STEPS, seed, RIG, compute)
        sims.append(log_score(measured, model, tl, tk, fitted, tripped)["score"])
    lo, hi = np.percentile(sims, [2.5, 97.5])
    print(
        f"deployed score {deployed['score']:.4f} (length {deployed['length_rmse_mm']:.3f} mm, stiffness "
        f"{deployed['stiffness_rmse_pct']:.2f} %); simulated on the identified plant {np.mean(sims):.4f}, "
        f"95 % interval [{lo:.4f}, {hi:.4f}] over {SEEDS} seeds (host delay {compute[0] * 1e3:.2f}-"
        f"{compute[1] * 1e3:.2f} ms)"
    )
    return deployed, np.array(sims), result


# the test's bound: a deployed score the simulations predict falls outside their 95 % interval one
# time in 20 (and outside the range of 20 seeds about one time in ten), so the assertion asks for
# the 99.9 % prediction interval (Student's t over the seeds); the 95 % one is printed, the goal's
PREDICTION = 0.999


def _prediction_interval(sims: np.ndarray, coverage: float) -> tuple[float, float]:
    """Where a new draw from the simulations' distribution falls with probability ``coverage``
    (normal, its mean and spread estimated from the ``n`` seeds: ``t * s * sqrt(1 + 1/n)``)."""
    from scipy.stats import t

    n = len(sims)
    half = t.ppf(0.5 + coverage / 2, n - 1) * np.std(sims, ddof=1) * np.sqrt(1 + 1 / n)
    return float(np.mean(sims) - half), float(np.mean(sims) + half)


def _check_prediction(deployed: float, sims: np.ndarray) -> None:
    lo95, hi95 = _prediction_interval(sims, 0.95)
    inside = "inside" if lo95 <= deployed <= hi95 else "outside"
    print(f"deployed {deployed:.4f}: {inside} the 95 % prediction interval [{lo95:.4f}, {hi95:.4f}]")
    lo, hi = _prediction_interval(sims, PREDICTION)
    assert lo <= deployed <= hi, (deployed, lo, hi)


def test_the_loop_closed_excite_identify_deploy_and_the_score_the_identified_plant_predicts(
    emulator, episode, identified, tmp_path
):
    """The baseline deployed on the rig scores within the prediction interval of its simulations
    on the identified plant."""
    from cepam_gym.control import make_controller

    fit, t_excite, t_identify = identified
    deployed, sims, result = _deployed_against_simulated(
        emulator, episode, lambda: make_controller("baseline", episode[0]), fit, tmp_path / "dep.csv"
    )
    print(f"excite {t_excite:.1f} s, identify {t_identify:.1f} s")
    assert result.trip is None
    _check_prediction(deployed["score"], sims)


def test_an_agent_trained_on_the_identified_plant_scores_on_the_rig_what_its_simulation_predicts(
    emulator, identified, tmp_path
):
    """The researcher's path from the fit to the rig: PPO trained briefly on the identified plant
    (the shipped ``fast_ppo`` config, its env given the fitted YAML and sensor noise), exported to
    ONNX, deployed through onnxruntime on the rig; its deployed score within the prediction
    interval of the exported policy simulated on the identified plant, and within a factor of the
    baseline's
    simulated score on the same episode (it learnt to track, not merely to stay safe)."""
    pytest.importorskip("stable_baselines3")
    pytest.importorskip("onnxruntime")
    from cepam_gym.control import make_controller
    from cepam_gym.plant.params import PlantParams
    from cepam_gym.rig.onnx_policy import OnnxPolicy
    from cepam_gym.rig.score import log_score, simulate
    from cepam_gym_agents.config.files import EnvConfig, EvalConfig, load_config
    from cepam_gym_agents.export import export
    from cepam_gym_agents.train import train

    fit = identified[0]
    # fast_ppo's id: the bound AGENT_VS_BASELINE was measured with that config on v2 (its learning
    # rate is too high for v3's reward: fast_ppo_v3 uses 5e-4)
    env_id = "cepam_gym/CEPAM-v2"
    cfg = load_config("fast_ppo")
    cfg = cfg.replace(
        env=EnvConfig.parse(
            {
                "id": env_id,
                "num_envs": cfg.env.num_envs,
                "kwargs": {"plant": str(fit), "sensor_noise": TRAIN_NOISE},
            }
        ),
        eval=EvalConfig(10**9, 8, None, 12345),  # one evaluation, at the end, on the fitted plant
        total_timesteps=AGENT_STEPS,
        time_limit_minutes=None,
        # one core, as any test worker takes: a second thread starved the emulated rig of another
        # worker's real-time test (its valves then lagged their commands, and its supervisor read a
        # stuck valve)
        torch_threads=1,
    )
    t0 = time.perf_counter()
    assert train(cfg, tmp_path / "run", quiet=True) == 0
    export(tmp_path / "run", tmp_path / "policy.onnx")
    t_train = time.perf_counter() - t0
    episode = _episode(env_id, {"plant": str(fit)}, 1000, 0, 1)
    OnnxPolicy(tmp_path / "policy.onnx").check_env(episode[1].obs_dim, episode[1].action_mode)
    assert noise_free_warning(OnnxPolicy(tmp_path / "policy.onnx")) is None  # trained with noise
    deployed, sims, result = _deployed_against_simulated(
        emulator, episode, lambda: OnnxPolicy(tmp_path / "policy.onnx"), fit, tmp_path / "agent.csv"
    )
    _env, model, tl, tk = episode
    fitted = PlantParams.from_yaml(fit)
    baseline = np.mean(
        [
            log_score(
                *simulate(
                    fitted, make_controller("baseline", _env), model, tl, tk, 0.1, SCORED_STEPS, seed, RIG
                )[:1],
                model,
                tl,
                tk,
                fitted,
                False,
            )["score"]
            for seed in range(3)
        ]
    )
    print(
        f"trained and exported in {t_train:.1f} s; the baseline simulated on the same episode {baseline:.4f}"
    )
    assert result.trip is None
    _check_prediction(deployed["score"], sims)
    assert deployed["score"] < AGENT_VS_BASELINE * baseline


@pytest.mark.parametrize("mode", ["pressure", "pwm"])
def test_the_other_valve_modes_deploy_and_a_leak_ends_in_the_safe_state(mode, tmp_path):
    """The emulated rig in pressure mode (set-points held by the rig's own regulator, following the
    env's action map) and in PWM mode (on/off solenoid valves): the baseline of the env in that
    mode tracks on it from a vented rest without a trip, and an injected leak trips the
    supervisor's energy balance and leaves the rig in its safe state."""
    from cepam_gym.control import make_controller

    emu = Emulator(tmp_path, "--mode", mode, "--load-g", "100")
    try:
        episode = _episode(DEFAULT_ENV, {"action_mode": mode}, 1000, 0, 1)
        start = len(emu.events)
        result = _deploy(emu, episode, make_controller("baseline", episode[0]), 150, log=tmp_path / "run.csv")
        print(mode, result.summary())
        assert result.stopped_by == "end" and result.trip is None, result.trip
        assert result.length_rmse_mm < 10.0
        emu.wait_for("stop", after=start)
        rec = read_log(tmp_path / "run.csv")
        assert len(rec.time) == result.steps and np.all(np.abs(rec.commands) <= 1.0)

        start = len(emu.events)

        def inject(k, rig):
            if k == 50:
                rig.inject(FAULTS.index("leak"))

        result = _deploy(emu, episode, make_controller("baseline", episode[0]), 90, on_step=inject)
        print(mode, "leak:", result.trip)
        assert result.trip is not None and result.trip["reason"] == "leak"
        safe = emu.wait_for("safe", after=start)
        lim = SafetyLimits.from_plant(episode[1].nominal)
        assert safe["after_fault_s"] <= lim.leak_window_s + 2 * DT + 0.4
    finally:
        emu.close()
