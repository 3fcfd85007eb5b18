"""The first contact with a rig unlike the preset: its excitation trips the leak balance built on
the nominal model, and runs through under the model-free checks (``excite --rig`` without
``--plant``), which still catch a sensor fault."""

from __future__ import annotations

import numpy as np
import pytest

from cepam_gym.identify.excite import schedule
from cepam_gym.plant.params import preset
from cepam_gym.rig.cli import DEFAULT_ENV, _episode
from cepam_gym.rig.emulator import EmulatedPlant, RigImperfections
from cepam_gym.rig.protocol import CHANNELS, Reading
from cepam_gym.rig.supervisor import SafetyLimits, Supervisor

RATE = 500.0  # Hz: the excitation's rate (the closed-loop test's)
SECONDS = 8.0
# a rig far from balloon_v2: valves twice as large, a CPAM dead volume 2.5 times, a slow spool; its
# supply regulated at 175 kPa (at the preset's 250 kPa an excitation squeezes the CPAM past its limit)
UNLIKE = {
    "valve_conductance": 2.0,
    "dead_volume_cpam": 2.5,
    "spool_time_constant": 2.0,
    "damping": 2.0,
    "supply_pressure": 0.7,
}


def _excite(model_based: bool, fault_at: float | None = None):
    """The excitation schedule played on the unlike rig (the plant stepped in place, the sensors'
    noise): the supervisor's trip, or None."""
    base = preset("balloon_v2")
    rig = EmulatedPlant(base.replace(**{k: getattr(base, k) * f for k, f in UNLIKE.items()}), load=0.1)
    _env, model, _tl, _tk = _episode(DEFAULT_ENV, {"control_dt": 1.0 / RATE}, 0, 0, 1)
    cols = schedule(SECONDS, RATE, "valve", (100.0,), 0)
    commands = np.column_stack([cols["command_c"], cols["command_e"]])
    sup = Supervisor(
        SafetyLimits.from_plant(model.nominal), model.control_dt, model=model if model_based else None
    )
    rng, imp = np.random.default_rng(0), RigImperfections()
    for k, command in enumerate(commands):
        if fault_at is not None and k == int(fault_at * RATE):
            rig.inject("frozen_channel", None, CHANNELS.index("pressure_e"))
        reading = Reading(rig.time, *rig.sensed(imp, rng), seq=k + 1)
        sent, trip = sup.filter(reading, tuple(command), now=k / RATE)
        if trip is not None:
            return trip
        rig.command = sent
        rig.tick()
    return None


@pytest.mark.slow
def test_an_unlike_rig_is_excited_under_the_model_free_checks_and_they_still_catch_a_fault():
    nominal = _excite(model_based=True)
    print("on the nominal model:", nominal)
    assert nominal is not None and nominal.reason in ("leak", "valve_fault")
    assert _excite(model_based=False) is None
    fault = _excite(model_based=False, fault_at=4.0)
    assert fault is not None and fault.reason == "frozen_sensor" and fault.rig_time > 4.0
