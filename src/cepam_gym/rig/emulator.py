"""An emulated rig: the plant in its own process behind the rig protocol's UDP transport, with
what a real rig adds (latency, jitter, sensor noise and quantisation, lost packets) and faults to
inject (``cepam-gym rig-emulator``, docs/deploy.md).

The plant advances in ticks of ``n_sub`` sub-steps through its one block kernel
(:func:`cepam_gym.plant.advance_block`; the commands become plant inputs by
:func:`cepam_gym.plant.actions.plant_inputs`, as in the envs), in real time: one tick every
``1 / rate_hz`` seconds of the wall clock. Each tick it sends a sensor packet (the plant's time,
both gauge pressures, the length, the supply's gauge pressure) to the host that last wrote to it.

Faults (:data:`~cepam_gym.rig.protocol.FAULTS`), each with a size:

* ``frozen_sensor``: the pressures and the length stop changing (packets keep coming);
* ``supply_drop``: the supply falls to ``size`` times its nominal gauge pressure (default 0.2);
* ``leak``: each chamber leaks to the atmosphere through ``size`` times the valve's conductance
  (default 0.3);
* ``stuck_valve``: the CPAM's valve stays at command ``size`` (default +1: open to the supply).

It starts in the safe state. A stop packet puts it there: both chambers vented and the supply shut
off (a dump valve: the supply line at the atmosphere), flagged in every sensor packet until an
arm packet (kind 4), which restarts the plant at rest, vented, and clears the faults.
"""

from __future__ import annotations

import heapq
import json
import math
import signal
import socket
import time
from dataclasses import dataclass, field

import numpy as np

from .. import plant as pl
from ..errors import InputError
from ..physics import layout as ix
from ..plant.actions import check_action_mode, plant_inputs
from .protocol import (
    FAULTS,
    FLAG_FAULT,
    FLAG_STOPPED,
    KIND_ARM,
    KIND_COMMAND,
    KIND_FAULT,
    KIND_STOP,
    SAFE_COMMANDS,
    PacketError,
    Reading,
    pack_reading,
    unpack_command,
)

DEFAULT_FAULT_SIZE = {"frozen_sensor": 0.0, "supply_drop": 0.2, "leak": 0.3, "stuck_valve": 1.0}


@dataclass(frozen=True)
class RigImperfections:
    """What stands between the plant and the host: one-way ``latency_s`` plus a uniform
    ``jitter_s`` per packet (each direction), Gaussian sensor noise (sd: ``noise_pressure`` [Pa],
    ``noise_length`` [m]), quantisation steps (``quant_pressure`` [Pa], ``quant_length`` [m]) and
    the fraction ``drop`` of packets lost (each direction)."""

    latency_s: float = 0.001
    jitter_s: float = 0.0005
    noise_pressure: float = 200.0
    noise_length: float = 3e-5
    quant_pressure: float = 50.0
    quant_length: float = 1e-5
    drop: float = 0.0

    def __post_init__(self):
        for f, v in self.__dict__.items():
            if not (math.isfinite(v) and v >= 0):
                raise InputError(f"{f} must be finite and >= 0, got {v!r}")
        if self.drop >= 1:
            raise InputError(f"drop must be below 1, got {self.drop!r}")


@dataclass
class EmulatedPlant:
    """The plant of the emulated rig, one tick at a time (no sockets: :func:`serve` adds them)."""

    params: pl.PlantParams
    mode: str = "valve"
    load: float = 0.1  # the hanging mass [kg]
    rate_hz: float = 500.0
    sub_dt: float = 5e-4
    # pressure mode: the gauge set-point of +1 [Pa]: the env's (``EnvModel.setpoint_max``; the
    # command line's --env), as the controller expects; None: this plant's own pressure cap
    setpoint_max: float | None = None
    faults: dict = field(default_factory=dict)

    def __post_init__(self):
        self._mode = check_action_mode(self.mode)
        if not (math.isfinite(self.load) and self.load >= 0):
            raise InputError(f"the load must be a mass >= 0 kg, got {self.load!r}")
        self.n_sub = max(1, int(round(1.0 / (self.rate_hz * self.sub_dt))))
        self.tick_dt = self.n_sub * self.sub_dt
        self.nominal_row = self.params.to_array()
        pl.check_stability(self.nominal_row, self.sub_dt)
        if self.setpoint_max is None:
            self.setpoint_max = self.params.pressure_cap
        self.W = np.empty(pl.W_SIZE)
        self.restart()

    def restart(self) -> None:
        """At rest at the lower end stop, vented, supply on, no faults, not stopped."""
        self.prow = self.nominal_row.copy()[None]
        self.x = pl.initial_state(self.prow, self.params.min_length)
        self.aux = pl.measure(self.x, self.prow)
        self.inputs = np.zeros((1, pl.N_INPUT))
        self.time = 0.0
        self.command = SAFE_COMMANDS
        self.stopped = False
        self.faults = {}
        self._frozen: tuple | None = None

    def stop(self) -> None:
        self.stopped = True
        self.command = SAFE_COMMANDS
        self.prow[0, ix.P_SUP] = self.prow[0, ix.P_ATM]  # the dump valve: supply line at the atmosphere

    def inject(self, name: str, size: float | None = None) -> None:
        if name not in FAULTS:
            raise InputError(f"unknown fault {name!r}; the faults are {', '.join(FAULTS)}")
        size = DEFAULT_FAULT_SIZE[name] if size is None else float(size)
        self.faults[name] = size
        if name == "supply_drop" and not self.stopped:
            atm = self.prow[0, ix.P_ATM]
            self.prow[0, ix.P_SUP] = atm + size * (self.nominal_row[ix.P_SUP] - atm)
        elif name == "leak":
            self.prow[0, ix.C_LEAK] = size * self.nominal_row[ix.C_PROP]
        elif name == "frozen_sensor":
            self._frozen = self.true_values()

    def true_values(self) -> tuple[float, float, float]:
        return float(self.aux[0, pl.A_PC]), float(self.aux[0, pl.A_PE]), float(self.x[0, pl.S_L])

    def tick(self) -> None:
        a0, a1 = self.command
        if "stuck_valve" in self.faults:
            a0 = self.faults["stuck_valve"]
        plant_inputs(self.inputs[0], self._mode, pl.RIG, a0, a1, self.setpoint_max, self.load)
        pl.advance_block(
            self.x,
            self.inputs,
            self.prow,
            0,
            1,
            self._mode,
            self.sub_dt,
            self.n_sub,
            self.x,
            self.aux,
            self.W,
        )
        self.time += self.tick_dt

    def sensed(self, imp: RigImperfections, rng) -> tuple[float, float, float, float]:
        """``(pressure_c, pressure_e, length, supply)`` as the sensors report them now."""
        if self._frozen is not None:
            pc, pe, length = self._frozen
        else:
            pc, pe, length = self.true_values()
            pc += imp.noise_pressure * rng.standard_normal()
            pe += imp.noise_pressure * rng.standard_normal()
            length += imp.noise_length * rng.standard_normal()
        supply = self.prow[0, ix.P_SUP] - self.prow[0, ix.P_ATM] + imp.noise_pressure * rng.standard_normal()

        def q(v, step):
            return round(v / step) * step if step > 0 else v

        return (
            q(pc, imp.quant_pressure),
            q(pe, imp.quant_pressure),
            q(length, imp.quant_length),
            q(supply, imp.quant_pressure),
        )


BEHIND_S = 0.01  # ticks this far behind the wall clock are reported (half a 50 Hz control period)
RESYNC_S = 0.1  # and this far behind, the rig's clock skips ahead to the wall's


def serve(
    plant: EmulatedPlant,
    port: int,
    imp: RigImperfections = RigImperfections(),
    seed: int = 0,
    scheduled: list[tuple[str, float, float | None]] = (),
    duration_s: float | None = None,
    events=None,
    host: str = "127.0.0.1",
) -> int:
    """Run the emulated rig on UDP ``host:port`` until SIGINT/SIGTERM or ``duration_s``.
    ``scheduled``: faults ``(name, seconds after arming, size)``. ``events``: a writable text file
    for one JSON line per event (armed, fault, safe state, stop, and ``behind``: the ticks fell
    more than :data:`BEHIND_S` behind the wall clock, so the rig's time ran slow), else stdout."""
    rng = np.random.default_rng(seed)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sock.bind((host, port))
    except OSError as e:
        raise InputError(f"cannot listen on {host}:{port}: {e.strerror}") from None
    sock.setblocking(False)
    running = [True]

    def _quit(signum, frame):
        running[0] = False

    # the caller's handlers come back when the rig stops (a test or a host process calls serve)
    handlers = {sig: signal.signal(sig, _quit) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        return _serve(plant, sock, imp, rng, scheduled, duration_s, events, running)
    finally:
        sock.close()
        for sig, handler in handlers.items():
            signal.signal(sig, handler)


def _serve(plant, sock, imp, rng, scheduled, duration_s, events, running) -> int:
    """The rig's loop (:func:`serve`), on a bound non-blocking socket."""

    def emit(**event) -> None:
        line = json.dumps({"rig_time": round(plant.time, 6), **event})
        if events is None:
            print(line, flush=True)
        else:
            events.write(line + "\n")
            events.flush()

    peer = None
    inbox: list = []  # (due time, order, packet) of received command packets, delayed by the latency
    outbox: list = []  # (due time, order, bytes) of sensor packets
    order = 0
    seq = 0
    ack = 0
    armed_at = None
    pending = sorted(scheduled, key=lambda f: f[1])
    fault_time = None
    safe_reported = False
    behind = False
    plant.stop()  # a rig starts in its safe state, until it is armed
    start = time.perf_counter()
    next_tick = start
    emit(event="listening", port=sock.getsockname()[1], tick_s=plant.tick_dt)

    def delay() -> float:
        return imp.latency_s + imp.jitter_s * rng.random()

    while running[0]:
        now = time.perf_counter()
        if duration_s is not None and now - start > duration_s:
            break
        while True:
            try:
                data, addr = sock.recvfrom(256)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:
                break
            try:
                packet = unpack_command(data)
            except PacketError:
                continue
            peer = addr
            if rng.random() < imp.drop and packet[0] == KIND_COMMAND:
                continue
            order += 1
            heapq.heappush(inbox, (now + delay(), order, packet))
        while inbox and inbox[0][0] <= now:
            _, _, (kind, flags, pseq, c, e) = heapq.heappop(inbox)
            if kind == KIND_ARM:
                if not plant.stopped:  # a repeated arm: the plant is running already
                    continue
                plant.restart()
                armed_at, fault_time, safe_reported = plant.time, None, False
                ack = pseq  # a new host numbers its packets from 1: its commands follow its arm
                pending = sorted(scheduled, key=lambda f: f[1])
                emit(event="armed")
            elif kind == KIND_STOP:
                if not plant.stopped:
                    plant.stop()
                    emit(event="stop")
            elif kind == KIND_FAULT:
                name = FAULTS[flags] if flags < len(FAULTS) else None
                if name is not None:
                    plant.inject(name, c if c > 0 else None)
                    fault_time = plant.time
                    emit(event="fault", fault=name)
            elif kind == KIND_COMMAND and not plant.stopped and pseq > ack:
                plant.command = (max(-1.0, min(1.0, c)), max(-1.0, min(1.0, e)))
                ack = pseq
        if armed_at is not None and not plant.stopped:
            while pending and plant.time - armed_at >= pending[0][1]:
                name, _t, size = pending.pop(0)
                plant.inject(name, size)
                fault_time = plant.time
                emit(event="fault", fault=name)
        if fault_time is not None and not safe_reported and plant.stopped:
            safe_reported = True
            emit(event="safe", after_fault_s=round(plant.time - fault_time, 6))
        plant.tick()
        if peer is not None:
            pc, pe, length, supply = plant.sensed(imp, rng)
            flags = (FLAG_STOPPED if plant.stopped else 0) | (FLAG_FAULT if plant.faults else 0)
            seq += 1
            packet = pack_reading(Reading(plant.time, pc, pe, length, supply, seq, ack, flags))
            if rng.random() >= imp.drop:
                order += 1
                heapq.heappush(outbox, (now + delay(), order, packet))
        lag = time.perf_counter() - next_tick  # how late the tick just run finished
        next_tick += plant.tick_dt
        if lag > BEHIND_S and not behind:
            # the rig's time runs slow of the wall's: commands apply late, which a supervisor may
            # read as a fault (a stuck valve); said once per stall, until the ticks catch up
            behind = True
            emit(event="behind", seconds=round(lag, 4))
        elif lag < plant.tick_dt:
            behind = False
        if lag > RESYNC_S + plant.tick_dt:  # far behind (a stalled machine): resynchronise
            next_tick = time.perf_counter()
        # until the next tick: send each sensor packet when its latency has passed
        while True:
            t = time.perf_counter()
            while outbox and outbox[0][0] <= t:
                _, _, packet = heapq.heappop(outbox)
                try:
                    sock.sendto(packet, peer)
                except OSError:
                    pass
            if t >= next_tick:
                break
            time.sleep(min(next_tick, outbox[0][0] if outbox else next_tick) - t)
    emit(event="exit")
    return 0
