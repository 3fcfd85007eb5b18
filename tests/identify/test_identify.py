"""``cepam-gym identify`` and ``excite``: the log format and its one-line errors, the sensor model
and the resampling, recovery of a synthetic truth outside every preset, the YAML into gym.make."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cepam_gym import preset
from cepam_gym.cli import main
from cepam_gym.identify.excite import ANCHOR_S, EXHAUST_S, SEGMENT_S, schedule, simulate_log
from cepam_gym.identify.logs import REQUIRED, read_log, resample, write_log
from cepam_gym.identify.report import fitted_yaml
from cepam_gym.identify.run import identify
from cepam_gym.identify.selfcheck import TRUTH_SENSORS, truth_plant
from cepam_gym.identify.simulate import sensed
from cepam_gym.plant.params import PlantParams
from cepam_gym.validation.fitcore import Scaling, field_param

GOOD = "time_s,command_c,command_e,pressure_c_kpa,pressure_e_kpa,length_cm,load_g\n" + "".join(
    f"{k * 0.002:.3f},0.1,-0.2,50,60,17.0,100\n" for k in range(20)
)


def _one_line(capsys, argv, *needles):
    code = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2, err
    assert len(err) == 1 and "Traceback" not in err[0], err
    for n in needles:
        assert str(n) in err[0], (n, err)


def _bad(text_edit):
    lines = GOOD.splitlines()
    text_edit(lines)
    return "\n".join(lines) + "\n"


BAD_FILES = {
    "not_a_number": (
        lambda ls: ls.__setitem__(5, ls[5].replace("50", "fifty", 1)),
        ("row 6", "pressure_c_kpa", "fifty"),
    ),
    "nan": (lambda ls: ls.__setitem__(3, ls[3].replace("17.0", "nan")), ("row 4", "length_cm", "not finite")),
    "missing_column": (lambda ls: ls.__setitem__(0, ls[0].replace(",load_g", "")), ("row 1", "load_g")),
    "unknown_column": (
        lambda ls: ls.__setitem__(0, ls[0].replace("length_cm", "length_mm")),
        ("row 1", "length_mm"),
    ),
    "short_row": (lambda ls: ls.__setitem__(7, "0.012,0.1"), ("row 8", "2 values for 7 columns")),
    "time_back": (
        lambda ls: ls.__setitem__(9, ls[9].replace("0.016", "0.001", 1)),
        ("row 10", "time_s", "does not increase"),
    ),
    "command_range": (
        lambda ls: ls.__setitem__(2, ls[2].replace("0.1", "3.0", 1)),
        ("row 3", "command_c", "outside [-1, 1]"),
    ),
    "negative_load": (lambda ls: ls.__setitem__(4, ls[4].replace(",100", ",-5")), ("row 5", "load_g")),
    "rate_in_ms": (
        lambda ls: [
            ls.__setitem__(i, ls[i].replace(ls[i].split(",")[0], str(i * 2), 1)) for i in range(1, len(ls))
        ],
        ("time_s", "sample rate"),
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_a_bad_log_is_one_line_naming_file_row_and_column(capsys, tmp_path, case):
    edit, needles = BAD_FILES[case]
    path = tmp_path / f"{case}.csv"
    path.write_text(_bad(edit))
    _one_line(
        capsys, ["identify", "--data", str(path), "--out", str(tmp_path / "x.yaml")], path.name, *needles
    )


def test_a_good_log_reads_in_si(tmp_path):
    path = tmp_path / "good.csv"
    path.write_text(GOOD)
    rec = read_log(path)
    assert rec.measured[0].tolist() == pytest.approx([50e3, 60e3, 0.17])
    assert rec.loads[0] == pytest.approx(0.1) and rec.commands[0].tolist() == [0.1, -0.2]
    assert rec.supply is None
    lines = GOOD.splitlines()
    with_supply = [lines[0] + ",supply_kpa"] + [f"{ln},{300 + i}" for i, ln in enumerate(lines[1:])]
    path.write_text("\n".join(with_supply) + "\n")
    assert read_log(path).supply == pytest.approx((300 + 9.5) * 1e3)  # the mean


def test_resampling_holds_commands_and_interpolates_measurements(tmp_path):
    n = 12
    cols = {c: np.zeros(n) for c in REQUIRED}
    cols["time_s"] = np.arange(n) * 0.004
    cols["command_c"][1] = 1.0
    cols["pressure_c_kpa"] = np.arange(n) * 4.0
    cols["length_cm"] = np.full(n, 17.0)
    rec = resample(read_log(write_log(tmp_path / "r.csv", cols)), 0.002)
    assert rec.commands[:9, 0].tolist() == [0, 0, 1, 1, 0, 0, 0, 0, 0]  # held until the next sample
    assert rec.measured[:, 0] == pytest.approx(np.arange(2 * n - 1) * 2e3)  # interpolated


def test_a_command_stamped_a_little_after_its_step_holds_at_that_step(tmp_path):
    # a deploy loop stamps each step when it wakes, microseconds after the step's release
    n = 10
    cols = {c: np.zeros(n) for c in REQUIRED}
    cols["time_s"] = np.arange(n) * 0.02 + np.random.default_rng(0).uniform(2e-6, 3e-3, n)
    cols["command_c"] = np.arange(n) / n
    cols["length_cm"] = np.full(n, 17.0)
    rec = resample(read_log(write_log(tmp_path / "r.csv", cols)), 0.02)
    assert rec.commands[:, 0].tolist() == pytest.approx(cols["command_c"][: len(rec.time)])


def test_the_sensor_model_delays_scales_and_offsets():
    y = np.zeros((100, 3))
    y[:, 0] = np.arange(100.0)
    out = sensed(y, 0.001, np.array([0.0025, 0.0, 0.0]), np.array([2.0, 1.0, 1.0]), np.array([1.0, 0.0, 5.0]))
    assert out[50, 0] == pytest.approx(2.0 * 47.5 + 1.0)  # 2.5 samples late, interpolated
    assert out[0, 0] == pytest.approx(1.0)  # the first sample held before the start
    assert np.all(out[:, 2] == 5.0)


def test_log_scaling_round_trips_and_spreads_decades_evenly():
    sc = Scaling(
        [field_param("valve_conductance", 0.01, 1.0, "", log=True), field_param("damping", 0.0, 10.0, "")]
    )
    x = np.array([0.1, 2.5])
    assert sc.to_edge(sc.to_z(x)) == pytest.approx(x)
    assert sc.to_z(x) == pytest.approx([0.5, 0.25])


def test_a_schedule_starts_exhausted_and_anchors_every_segment():
    s = schedule(20.0, 500.0, "valve", (0.0, 50.0), seed=3)
    n0 = int(EXHAUST_S * 500)
    assert np.all(s["command_c"][:n0] == -1.0) and np.all(s["command_e"][:n0] == -1.0)
    for i in range(4):
        lo = n0 + int(SEGMENT_S * 500) * i
        a = s["command_c"][lo : lo + int(ANCHOR_S * 500)]
        assert np.all(np.abs(a) == 1.0) and np.ptp(a) == 0.0
    assert set(np.unique(s["load_g"])) == {0.0, 50.0}
    assert np.max(np.abs(s["command_c"])) <= 1.0
    assert not np.array_equal(
        s["command_c"], schedule(20.0, 500.0, "valve", (0.0, 50.0), seed=4)["command_c"]
    )


@pytest.mark.slow
def test_recovery_of_a_truth_outside_every_preset(tmp_path):
    """Two short logs fitted jointly (10 s each), a third held out (10 s), with noise and sensor
    errors: the held-out NRMSE within 2 % on every channel, far below the preset's; every parameter
    the fit calls identifiable within 10 % of the truth; one that the data cannot see (the on/off
    valves' conductance, in valve mode) called not identifiable."""
    truth, values = truth_plant(preset("balloon"), "valve")
    logs = []
    for name, sec, seed in (("fit1", 10.0, 0), ("fit2", 10.0, 2), ("held", 10.0, 1)):
        log = simulate_log(
            schedule(sec, 500.0, "valve", seed=seed), truth, "valve", seed=seed, **TRUTH_SENSORS
        )
        logs.append(write_log(tmp_path / f"{name}.csv", log))
    ident = identify(logs[:2], "balloon", "valve", free=("onoff_conductance",), holdout=logs[2:], starts=1)
    assert [r.role for r in ident.records] == ["fitted", "fitted", "held out"]
    held = [r for r in ident.records if r.role == "held out"][0]
    for ch in ("pressure_c", "pressure_e", "length"):
        assert held.fit[ch]["nrmse"] <= 0.02, (ch, held.fit)
        assert held.base[ch]["nrmse"] > 5 * held.fit[ch]["nrmse"], (ch, held.base)
    names = list(ident.names[: ident.k])
    flagged = dict(zip(names, ident.identifiable))
    assert not flagged["onoff_conductance"]
    assert sum(flagged.values()) >= 6, flagged
    for j, n in enumerate(names):
        if flagged[n]:
            assert abs(ident.values[j] - values[n]) <= 0.1 * abs(values[n]), (n, ident.values[j], values[n])


def test_pwm_logs_are_identified_with_exact_valve_timing(tmp_path):
    """On/off valves: a truth outside every preset whose valves switch at their exact PWM edges,
    simulated at a sub-step 5 times finer than the fit's (a rig is continuous in time). Fitted
    with the plant's exact PWM timing, the held-out NRMSE is within 1 % on every channel, the
    dead times and the switching lag are recovered within 5 %, and the fitted YAML carries the
    timing it was fitted with."""
    truth, values = truth_plant(preset("balloon").replace(pwm_timing="exact"), "pwm")
    logs = []
    for name, sec, seed in (("fit", 20.0, 0), ("held", 10.0, 1)):
        log = simulate_log(
            schedule(sec, 500.0, "pwm", seed=seed), truth, "pwm", sub_dt=1e-4, seed=seed, **TRUTH_SENSORS
        )
        logs.append(write_log(tmp_path / f"{name}.csv", log))
    ident = identify(logs[:1], "balloon", "pwm", holdout=logs[1:], starts=1)
    assert ident.params.pwm_timing == "exact"
    for ch, nrmse in ident.worst("held out").items():
        assert nrmse <= 0.01, (ch, nrmse)
    names = list(ident.names[: ident.k])
    for n in ("onoff_open_delay", "onoff_close_delay", "onoff_switch_time", "onoff_conductance"):
        assert ident.values[names.index(n)] == pytest.approx(values[n], rel=0.05), n
    (tmp_path / "fitted.yaml").write_text(fitted_yaml(ident, "identify"))
    assert PlantParams.from_yaml(tmp_path / "fitted.yaml").pwm_timing == "exact"


@pytest.mark.slow
def test_excite_identify_and_the_yaml_into_gym_make(tmp_path, capsys):
    """The worked example's commands: a simulated log, identify it with a report, train-ready YAML."""
    import gymnasium as gym

    log = tmp_path / "run1.csv"
    assert main(["excite", "--simulate", "--preset", "balloon", "--seconds", "12", "--out", str(log)]) == 0
    lines = log.read_text().splitlines()  # the rig logged its supply pressure too
    log.write_text("\n".join([lines[0] + ",supply_kpa"] + [ln + ",245" for ln in lines[1:]]) + "\n")
    out, rep = tmp_path / "my_rig.yaml", tmp_path / "report"
    argv = [
        "identify",
        "--data",
        str(log),
        "--mode",
        "valve",
        "--out",
        str(out),
        "--report",
        str(rep),
        "--starts",
        "1",
    ]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "held out" in text and "NRMSE" in text
    summary = json.loads((rep / "summary.json").read_text())
    assert {r["role"] for r in summary["recordings"]} == {"fitted", "held out"}
    assert len(list(rep.glob("*.png"))) == 2
    header = [ln for ln in out.read_text().splitlines() if ln.startswith("#")]
    assert any("worst NRMSE on held out data" in ln for ln in header)
    assert "supply_pressure_kpa: 245" in out.read_text()  # the measured supply, not the preset's 250
    env = gym.make("cepam_gym/CEPAM-v1", plant=str(out))
    plant = env.unwrapped.nominal if hasattr(env.unwrapped, "nominal") else None
    env.reset(seed=0)
    env.step(env.action_space.sample())
    if plant is not None:  # the env runs the fitted plant, not the preset
        fitted = [ln.split(":") for ln in out.read_text().splitlines() if ln.startswith("valve_conductance")]
        assert plant.valve_conductance == pytest.approx(float(fitted[0][1]) * 1e-8, rel=1e-5)
    env.close()


@pytest.mark.slow
def test_a_rig_the_model_cannot_describe_gets_no_false_verdicts(tmp_path):
    """A second-order spool (the fit's is first order): the fit stops short of the sensor noise,
    the residuals stay correlated, and the report vouches for no value it has wrong: whatever it
    calls identifiable is within 10 % of the truth, and it says why it calls nothing so."""
    truth, values = truth_plant(preset("balloon"), "valve")
    truth = truth.replace(spool_order=2, spool_damping=0.4)
    logs = []
    for name, sec, seed in (("fit", 20.0, 0), ("held", 10.0, 1)):
        log = simulate_log(
            schedule(sec, 500.0, "valve", seed=seed), truth, "valve", seed=seed, **TRUTH_SENSORS
        )
        logs.append(write_log(tmp_path / f"{name}.csv", log))
    ident = identify([logs[0]], "balloon", "valve", holdout=[logs[1]], starts=1)
    assert ident.inflation > 4.0  # the residuals are model error, not white noise
    assert any("did not reach the sensor noise" in n for n in ident.notes)
    for j, n in enumerate(ident.names[: ident.k]):
        if ident.identifiable[j]:
            assert abs(ident.values[j] - values[n]) <= 0.1 * abs(values[n]), (n, ident.values[j], values[n])


@pytest.mark.parametrize(
    "extra, needle",
    [
        (["--free", "nope"], "unknown fit parameter 'nope'"),
        (["--bounds", "damping=5"], "expected name=lo:hi"),
        (["--bounds", "nope=1:2"], "not fitted"),
        (["--bounds", "damping=5:1"], "lo < hi"),
        (["--mode", "valve", "--preset", "nope"], "unknown preset 'nope'"),
    ],
)
def test_bad_options_are_one_line(capsys, tmp_path, extra, needle):
    path = tmp_path / "good.csv"
    path.write_text(GOOD)  # too short to fit: the options are refused before the data are read
    _one_line(capsys, ["identify", "--data", str(path), "--out", str(tmp_path / "x.yaml"), *extra], needle)


def test_a_replayed_plant_does_not_depend_on_its_batch():
    """The Jacobian's rows run side by side: each must be exactly the plant run alone, whatever
    block or thread it lands in."""
    from cepam_gym import plant as pl
    from cepam_gym.identify.simulate import _splits, replay

    p = np.repeat(preset("balloon").to_array()[None], 13, 0)
    p[:, 20] *= np.linspace(0.5, 1.5, 13)  # valve conductances differ
    cmd = np.repeat(np.random.default_rng(0).uniform(-1, 1, (20, 2)), 25, axis=0)
    loads = np.full(len(cmd), 0.1)
    y = replay(p, cmd, loads, pl.PROPORTIONAL, 5e-4, 4, (0.17, 0.0, 0.0))
    alone = replay(p[7:8], cmd, loads, pl.PROPORTIONAL, 5e-4, 4, (0.17, 0.0, 0.0))
    assert np.array_equal(y[7], alone[0])
    assert not np.array_equal(y[6], y[7])
    for n, threads in ((13, 2), (40, 1), (3, 8)):
        s = _splits(n, threads)
        assert s[0] == 0 and s[-1] == n and np.all(np.diff(s) >= 1) and np.all(np.diff(s) <= pl.BLOCK)
    assert len(_splits(13, 2)) == 3  # one block per thread when there are plants enough
