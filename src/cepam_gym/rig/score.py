"""A deployment's benchmark score from its log, and the same controller on a simulated rig.

:func:`log_score` scores the steps of a deploy log (:func:`cepam_gym.rig.deploy.run`) as the
benchmark scores an episode (:func:`cepam_gym.bench.metrics.score_traces`): the length each step
ended at (the next step's reading) against the episode's target, the muscle's stiffness at the
measured length and pressures (:func:`cepam_gym.physics.api.stiffness` on a plant, e.g.
``identify``'s fit of the rig) against the target stiffness, and a failure if the supervisor
tripped.

:func:`simulate` runs a controller on a plant the way the deploy loop runs it on a rig, without
the wall clock or the transport: the emulated rig's plant (:class:`~cepam_gym.rig.emulator.EmulatedPlant`)
stepped in place, its sensors' noise and quantisation, each command applied after the
transport's latency and jitter (whole plant ticks) or lost with the drop rate, the supervisor in
between. Its rows are a deploy log's, so both are scored by :func:`log_score`: the score a rig
should give, as an interval over seeds.
"""

from __future__ import annotations

import math

import numpy as np

from ..bench.metrics import score_traces
from ..control.objective import spec_of_core
from ..errors import InputError
from ..physics import api
from .emulator import EmulatedPlant, RigImperfections
from .observation import RigObserver
from .protocol import Reading
from .supervisor import SafetyLimits, Supervisor

APPROACH_S = 1.0  # the rig's approach from its vented rest to the episode's first target, not scored
EMULATOR_DEFAULTS = RigImperfections()  # the emulated rig's, as its command line starts it


def log_score(
    measured,
    model,
    target_l,
    target_k,
    plant,
    tripped: bool,
    times=None,
    approach_s: float = APPROACH_S,
) -> dict:
    """The benchmark's metrics (``score`` among them) of a deploy log's steps: ``measured`` (T, 3)
    pressure_c, pressure_e [Pa], length [m] read at the start of each step and ``times`` [s] the
    steps' times since the loop's start (``Recording.measured`` and ``.time`` of
    :func:`cepam_gym.identify.logs.read_log`; None: one row per step); ``model`` the env's
    :class:`~cepam_gym.envs.model.EnvModel` (how it is scored); ``target_l``, ``target_k`` the
    episode's references; ``plant`` the :class:`~cepam_gym.plant.params.PlantParams` whose
    stiffness is reported; ``tripped`` whether the run ended in a safety trip (a failure).

    A step the loop skipped (it woke a whole period late) has no row, and the step before it no
    end: neither is scored. The first ``approach_s`` seconds are not scored: an env's episode
    starts at rest at its first target, a rig from its vented rest, and its approach is no part
    of the episode's tracking."""
    m = np.asarray(measured, dtype=float).reshape(-1, 3)
    dt = model.control_dt
    # a step's row is stamped when the loop woke for it, a little after its release; the log's
    # times count from the first row's, which woke late by its own amount, so a row may read a
    # few microseconds before its step's release: the nearest step, not the one below (rounding
    # down put two rows on one step and scored neither of them or their neighbours)
    step = np.arange(len(m)) if times is None else np.rint(np.asarray(times) / dt).astype(int)
    grid = np.full((int(step.max()) + 1, 3), np.nan)
    grid[step] = m
    first = int(round(approach_s / dt))
    k = np.arange(first, min(len(grid) - 1, len(target_l)))
    end = grid[k + 1]  # step k ended where step k + 1 read the rig
    keep = np.isfinite(end).all(axis=1)
    k, end = k[keep], end[keep]
    if len(k) < 1:
        raise InputError(
            f"a log of {len(m)} steps leaves nothing to score after the {approach_s:g} s approach"
        )
    row = plant.to_array()
    stiffness = np.array([api.stiffness(L, pc, pe, row) for pc, pe, L in end])
    n = len(k)
    tr = {
        "length": end[:, 2, None],
        "target_length": np.asarray(target_l, dtype=float)[k, None],
        "stiffness": stiffness[:, None],
        "target_stiffness": np.asarray(target_k, dtype=float)[k, None],
        "air_used": np.zeros((n, 1)),
        "reward": np.zeros((n, 1)),
        "alive": np.ones((n, 1), dtype=bool),
        "failed": np.array([bool(tripped)]),
        "dt": dt,
    }
    return score_traces(tr, model.track_stiffness, spec_of_core(model))


def simulate(
    plant,
    controller,
    model,
    target_l,
    target_k,
    load_kg: float,
    n_steps: int,
    seed: int,
    imperfections: RigImperfections = EMULATOR_DEFAULTS,
    compute_s: tuple[float, float] = (0.0, 0.0),
    limits: SafetyLimits | None = None,
) -> tuple[np.ndarray, bool]:
    """``(measured (n_steps, 3), tripped)``: ``controller`` (built on ``model``'s env) run for
    ``n_steps`` control steps on ``plant`` (:class:`~cepam_gym.plant.params.PlantParams`) under
    the supervisor, as :func:`cepam_gym.rig.deploy.run` runs it on a rig: each step reads the
    sensors as they were one transport delay ago, and its command reaches the valves the
    controller's time plus a transport delay later, or never (lost). Steps are released at a
    phase of the rig's ticks drawn once per seed (uniform over a tick). The controller's time is
    drawn each step from ``compute_s = (median, p99)`` (e.g. a deployment's): the median plus an
    exponential tail that reaches the p99 once in a hundred steps."""
    rig = EmulatedPlant(plant, mode=model.action_mode, load=load_kg, setpoint_max=model.setpoint_max)
    rng = np.random.default_rng(seed)
    observer = RigObserver(model, target_l, target_k)
    supervisor = Supervisor(limits or SafetyLimits.from_plant(model.nominal), model.control_dt, model=model)
    ticks = max(1, int(round(model.control_dt / rig.tick_dt)))
    for _ in range(ticks):  # vented, at rest: the deploy loop's first step comes a period after arming
        rig.tick()
    controller.reset()
    imp = imperfections
    median, tail = compute_s[0], max(0.0, compute_s[1] - compute_s[0]) / math.log(100.0)
    # the host's clock and the rig's ticks are not synchronised: each step is released this long
    # after a tick of the rig, the same for a whole deployment, different from one to the next
    phase = rig.tick_dt * rng.random()

    def delay_ticks(extra: float) -> int:  # a command is applied from the first tick after it arrives
        return math.ceil((phase + extra + imp.latency_s + imp.jitter_s * rng.random()) / rig.tick_dt)

    history = [Reading(rig.time, *rig.sensed(imp, rng))] * (ticks + 1)  # the sensor packets of the last ticks
    pending: list[tuple[int, tuple]] = []  # (tick, command) on their way to the rig
    measured = np.empty((n_steps, 3))
    prev = np.zeros(2)
    tick = 0
    for k in range(n_steps):
        # the newest packet that has arrived: sent a whole number of ticks before, each tick's
        # packet telling the state at that tick's end
        age = int(max(0.0, imp.latency_s + imp.jitter_s * rng.random() - phase) / rig.tick_dt)
        reading = history[-1 - min(age, ticks)]
        measured[k] = reading.pressure_c, reading.pressure_e, reading.length
        action = np.asarray(controller.act(observer.observe(reading, k, prev)), dtype=float).reshape(2)
        command, trip = supervisor.filter(
            reading, (float(action[0]), float(action[1])), now=k * model.control_dt
        )
        if trip is not None:
            return measured[: k + 1], True
        prev = np.asarray(command)
        if rng.random() >= imp.drop:
            pending.append((tick + delay_ticks(median + tail * rng.exponential()), command))
        for _ in range(ticks):
            while pending and pending[0][0] <= tick:
                rig.command = pending.pop(0)[1]
            rig.tick()
            tick += 1
            history = history[1:] + [Reading(rig.time, *rig.sensed(imp, rng))]
    return measured, False
