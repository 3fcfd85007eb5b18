"""An emulated rig: the plant in its own process behind the rig protocol's UDP transport, with
what a real rig adds (latency, jitter, sensor noise and quantisation, lost packets) and faults to
inject (``cepam-gym rig-emulator``, docs/deploy.md).

The plant (:class:`~cepam_gym.rig.emulated_plant.EmulatedPlant`) advances in ticks of ``n_sub``
sub-steps through its one block kernel (:func:`cepam_gym.plant.advance_block`), in real time: one
tick every ``1 / rate_hz`` seconds of the wall clock. Each tick it sends a sensor packet (the
rig's time, both gauge pressures, the length, the supply's gauge pressure) to the host that last
wrote to it.

It follows the firmware's state machine of docs/deploy.md: it starts in the safe state; an arm
packet (kind 4) restarts the plant at rest, vented, clears the plant's faults and arms it; a stop
packet, or no command or arm packet for :data:`~cepam_gym.rig.protocol.WATCHDOG_S` (its
watchdog), puts it back: both chambers vented and the supply shut off (a dump valve: the supply
line at the atmosphere), flagged in every sensor packet until the next arm.

The faults of the plant and of a sensor channel are :mod:`.emulated_plant`'s; the link's faults
act here: ``silent`` (no more sensor packets), ``ignore_arm``, ``lose_stops`` (every stop packet
lost), ``no_watchdog``, ``reboot`` (the rig restarts in its safe state: its packet numbers and its
clock begin again, it forgets the host until the host writes again) and ``clear`` (the link's
faults removed; an arm clears the plant's).
"""

from __future__ import annotations

import heapq
import json
import math
import signal
import socket
import time

import numpy as np

from ..errors import InputError
from .emulated_plant import DEFAULT_FAULT_SIZE, PLANT_FAULTS, EmulatedPlant, RigImperfections
from .protocol import (
    FAULTS,
    FLAG_FAULT,
    FLAG_STOPPED,
    FLAG_WATCHDOG,
    KIND_ARM,
    KIND_COMMAND,
    KIND_FAULT,
    KIND_STOP,
    WATCHDOG_S,
    PacketError,
    Reading,
    pack_reading,
    unpack_command,
)

__all__ = ["DEFAULT_FAULT_SIZE", "EmulatedPlant", "RigImperfections", "serve", "LINK_FAULTS"]

LINK_FAULTS = ("silent", "ignore_arm", "lose_stops", "no_watchdog")
BEHIND_S = 0.01  # ticks this far behind the wall clock are reported (half a 50 Hz control period)
RESYNC_S = 0.1  # and this far behind, the rig's clock skips ahead to the wall's


def serve(
    plant: EmulatedPlant,
    port: int,
    imp: RigImperfections | None = None,
    seed: int = 0,
    scheduled: list[tuple] = (),
    duration_s: float | None = None,
    events=None,
    host: str = "127.0.0.1",
    link_faults: tuple[str, ...] = (),
) -> int:
    """Run the emulated rig on UDP ``host:port`` until SIGINT/SIGTERM or ``duration_s``.
    ``scheduled``: faults ``(name, seconds after arming, size[, channel])``; ``link_faults``: the
    link's faults active from the start (:data:`LINK_FAULTS`). ``events``: a writable text file
    for one JSON line per event (armed, fault, stop, watchdog, safe, reboot, and ``behind``: the
    ticks fell more than :data:`BEHIND_S` behind the wall clock, so the rig's time ran slow),
    else stdout."""
    for name in link_faults:
        if name not in LINK_FAULTS:
            raise InputError(f"unknown link fault {name!r}; they are {', '.join(LINK_FAULTS)}")
    imp = RigImperfections() if imp is None else imp
    rng = np.random.default_rng(seed)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sock.bind((host, port))
    except OSError as e:
        raise InputError(f"cannot listen on {host}:{port}: {e.strerror}") from None
    sock.setblocking(False)
    rig = _RigServer(plant, sock, imp, rng, scheduled, events, set(link_faults))

    def _quit(signum, frame):
        rig.running = False

    # the caller's handlers come back when the rig stops (a test or a host process calls serve)
    handlers = {sig: signal.signal(sig, _quit) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        return rig.run(duration_s)
    finally:
        sock.close()
        for sig, handler in handlers.items():
            signal.signal(sig, handler)


class _RigServer:
    """The rig's loop (:func:`serve`) on a bound non-blocking socket."""

    def __init__(self, plant, sock, imp, rng, scheduled, events, link: set):
        self.plant, self.sock, self.imp, self.rng, self.events = plant, sock, imp, rng, events
        self.scheduled = sorted(scheduled, key=lambda f: f[1])
        self.link = link  # the link's faults in force
        self.running = True
        self.peer = None
        self.inbox: list = []  # (due time, order, packet) of received command packets (latency)
        self.outbox: list = []  # (due time, order, bytes) of sensor packets
        self.order = self.seq = self.ack = 0
        self.clock_zero = 0.0  # the plant's time when the rig's clock last began (a reboot)
        self.armed_at = None
        self.pending: list = []
        self.fault_time = None
        self.safe_reported = False
        self.by_watchdog = False
        # wall time of the last command or arm packet received (a stall of the emulator itself,
        # when the packets wait in the socket, must not read as a silent host)
        self.last_heard = 0.0
        self.behind = False

    def emit(self, **event) -> None:
        line = json.dumps({"rig_time": round(self.plant.time - self.clock_zero, 6), **event})
        if self.events is None:
            print(line, flush=True)
        else:
            self.events.write(line + "\n")
            self.events.flush()

    def delay(self) -> float:
        return self.imp.latency_s + self.imp.jitter_s * self.rng.random()

    def run(self, duration_s) -> int:
        self.plant.stop()  # a rig starts in its safe state, until it is armed
        start = time.perf_counter()
        next_tick = start
        self.emit(event="listening", port=self.sock.getsockname()[1], tick_s=self.plant.tick_dt)
        while self.running:
            now = time.perf_counter()
            if duration_s is not None and now - start > duration_s:
                break
            self.receive(now)
            while self.inbox and self.inbox[0][0] <= now:
                self.handle(heapq.heappop(self.inbox)[2], now)
            self.watchdog(now)
            self.scheduled_faults()
            if self.fault_time is not None and not self.safe_reported and self.plant.stopped:
                self.safe_reported = True
                self.emit(event="safe", after_fault_s=round(self.plant.time - self.fault_time, 6))
            self.plant.tick()
            self.send_reading(now)
            next_tick = self.keep_time(next_tick)
            self.flush_until(next_tick)
        self.emit(event="exit")
        return 0

    def receive(self, now: float) -> None:
        while True:
            try:
                data, addr = self.sock.recvfrom(256)
            except OSError:  # nothing more (BlockingIOError), or an ICMP error reported here
                return
            try:
                packet = unpack_command(data)
            except PacketError:
                continue
            self.peer = addr
            if self.rng.random() < self.imp.drop and packet[0] == KIND_COMMAND:
                continue
            if packet[0] == KIND_STOP and "lose_stops" in self.link:
                continue
            if packet[0] in (KIND_COMMAND, KIND_ARM):  # heard now, applied after the latency
                self.last_heard = now
            self.order += 1
            heapq.heappush(self.inbox, (now + self.delay(), self.order, packet))

    def handle(self, packet, now: float) -> None:
        kind, flags, pseq, c, e = packet
        plant = self.plant
        if kind == KIND_ARM:
            if "ignore_arm" in self.link:
                return
            if not plant.stopped:  # a repeated arm: the plant is running already
                return
            plant.restart()
            self.clock_zero = 0.0
            self.armed_at, self.fault_time, self.safe_reported, self.by_watchdog = (
                plant.time,
                None,
                False,
                False,
            )
            self.ack = pseq  # a new host numbers its packets from 1: its commands follow its arm
            self.pending = list(self.scheduled)
            self.emit(event="armed", ack=self.ack)
        elif kind == KIND_STOP:
            if not plant.stopped:
                plant.stop()
                self.emit(event="stop")
        elif kind == KIND_FAULT:
            if flags < len(FAULTS):
                channel = int(e) if math.isfinite(e) else 0
                self.inject(
                    FAULTS[flags], c if (c > 0 or FAULTS[flags] == "channel_value") else None, channel
                )
        elif kind == KIND_COMMAND and not plant.stopped and pseq > self.ack:
            plant.command = (max(-1.0, min(1.0, c)), max(-1.0, min(1.0, e)))
            self.ack = pseq

    def inject(self, name: str, size, channel: int = 0) -> None:
        if name in PLANT_FAULTS:
            try:
                self.plant.inject(name, size, channel)
            except InputError:
                return  # a bad fault packet is ignored, as a rig ignores any bad packet
        elif name in LINK_FAULTS:
            self.link.add(name)
        elif name == "clear":
            self.link.clear()
        elif name == "reboot":
            self.plant.stop()
            self.clock_zero = self.plant.time
            self.seq = self.ack = 0
            self.peer, self.inbox, self.outbox, self.link = None, [], [], set()
            self.emit(event="reboot")
        if name != "clear":
            self.fault_time = self.plant.time
        self.emit(event="fault", fault=name)

    def watchdog(self, now: float) -> None:
        """The rig's own watchdog: armed, no command or arm for WATCHDOG_S: the safe state."""
        if self.plant.stopped or "no_watchdog" in self.link or now - self.last_heard <= WATCHDOG_S:
            return
        self.plant.stop()
        self.by_watchdog = True
        self.emit(event="watchdog", silent_s=round(now - self.last_heard, 4), ack=self.ack)

    def scheduled_faults(self) -> None:
        if self.armed_at is None or self.plant.stopped:
            return
        while self.pending and self.plant.time - self.armed_at >= self.pending[0][1]:
            name, _t, size, *channel = self.pending.pop(0)
            self.inject(name, size, *channel)

    def send_reading(self, now: float) -> None:
        if self.peer is None or "silent" in self.link:
            return
        plant = self.plant
        pc, pe, length, supply = plant.sensed(self.imp, self.rng)
        flags = (FLAG_STOPPED if plant.stopped else 0) | (FLAG_FAULT if plant.faults else 0)
        flags |= FLAG_WATCHDOG if plant.stopped and self.by_watchdog else 0
        self.seq += 1
        reading = Reading(plant.time - self.clock_zero, pc, pe, length, supply, self.seq, self.ack, flags)
        if self.rng.random() >= self.imp.drop:
            self.order += 1
            heapq.heappush(self.outbox, (now + self.delay(), self.order, pack_reading(reading)))

    def keep_time(self, next_tick: float) -> float:
        """The next tick's wall time; says when the ticks fell behind the wall clock."""
        lag = time.perf_counter() - next_tick  # how late the tick just run finished
        next_tick += self.plant.tick_dt
        if lag > BEHIND_S and not self.behind:
            # the rig's time runs slow of the wall's: commands apply late, which a supervisor may
            # read as a fault (a stuck valve); said once per stall, until the ticks catch up
            self.behind = True
            self.emit(event="behind", seconds=round(lag, 4))
        elif lag < self.plant.tick_dt:
            self.behind = False
        if lag > RESYNC_S + self.plant.tick_dt:  # far behind (a stalled machine): resynchronise
            next_tick = time.perf_counter()
        return next_tick

    def flush_until(self, next_tick: float) -> None:
        """Until the next tick: send each sensor packet when its latency has passed."""
        while True:
            t = time.perf_counter()
            while self.outbox and self.outbox[0][0] <= t:
                _, _, packet = heapq.heappop(self.outbox)
                try:
                    self.sock.sendto(packet, self.peer)
                except (OSError, TypeError):  # TypeError: no peer (it rebooted)
                    pass
            if t >= next_tick:
                return
            time.sleep(min(next_tick, self.outbox[0][0] if self.outbox else next_tick) - t)
