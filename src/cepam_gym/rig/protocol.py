"""The rig protocol: what a host reads from a CE-PAM rig and what it writes, and the packets that
carry them (docs/deploy.md, "The rig protocol").

A rig offers three things (:class:`Rig`):

* ``read()``: the newest :class:`Reading` (the rig's time, both chambers' gauge pressures, the
  muscle's length, the supply's gauge pressure), or None when nothing new arrived;
* ``write(command_c, command_e)``: the two valve commands, each in [-1, 1] as the env's action
  (spool set-points, PWM duties or pressure set-points by the rig's action mode);
* ``stop()``: asks the rig to go to its safe state (:data:`SAFE_COMMANDS`, supply shut off) and
  stay there, ignoring commands, until it is armed again; one request, which may be lost: the host
  repeats it until a reading carries the stopped flag (:func:`cepam_gym.rig.stop.stop_and_confirm`);
* ``arm()``: the rig leaves its safe state and takes commands.

The packets are fixed-size little-endian C structs (Python's ``struct``), so a microcontroller
implements them with one ``memcpy``:

* sensor packet, rig -> host, :data:`SENSOR` (36 bytes):
  ``u16 magic, u8 kind=1, u8 flags, u32 seq, f64 time_s, f32 pressure_c_pa, f32 pressure_e_pa,
  f32 length_m, f32 supply_pa, u32 ack_seq``;
* command packet, host -> rig, :data:`COMMAND` (16 bytes):
  ``u16 magic, u8 kind, u8 flags, u32 seq, f32 command_c, f32 command_e`` with ``kind`` 2 (valve
  commands), 3 (stop: the commands are ignored) or 4 (arm: leave the safe state, supply on; the
  emulated rig also restarts its plant at rest); the emulated rig also takes kind 5 (inject fault
  number ``flags`` of :data:`FAULTS`, of size ``command_c``, on sensor channel ``command_e`` of
  :data:`CHANNELS` for the faults of one channel).

``magic`` is :data:`MAGIC`; ``seq`` counts each side's packets (modulo 2**32); ``ack_seq`` is the
``seq`` of the last command or arm packet the rig applied (stops are confirmed by the stopped flag,
not by ``ack_seq``); sensor ``flags`` bit 0 says the rig is stopped (safe state), bit 1 that a
fault was injected (emulator), bit 2 that the rig's own watchdog stopped it (no command for
:data:`WATCHDOG_S`). Pressures are gauge [Pa], the length [m], ``time`` [s] on the rig's clock
(it feeds the velocity estimate and the leak balance), SI as everywhere inside the package.

The rig's state machine (docs/deploy.md, "For firmware authors"): *safe* at power-up and after a
reboot; an arm packet takes it to *armed*; a stop packet, or no command or arm packet for
:data:`WATCHDOG_S`, takes it back to *safe*, where it ignores commands until the next arm.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

MAGIC = 0xCE5A
SENSOR = struct.Struct("<HBBIdffffI")
COMMAND = struct.Struct("<HBBIff")
KIND_SENSOR, KIND_COMMAND, KIND_STOP, KIND_ARM, KIND_FAULT = 1, 2, 3, 4, 5
FLAG_STOPPED, FLAG_FAULT, FLAG_WATCHDOG = 1, 2, 4
# the commands of the safe state: both chambers vented. In every action mode -1 is exhaust: the
# spool fully to exhaust (valve), the exhaust solenoid held open (pwm), a 0 Pa set-point (pressure)
SAFE_COMMANDS = (-1.0, -1.0)
# the rig's watchdog: an armed rig that receives no command or arm packet for this long goes to
# its safe state by itself (10 control periods at 50 Hz; the host's stale-sensor check is 0.1 s)
WATCHDOG_S = 0.2
# the sensor channels, by number (kind 5's channel) and by the name of their Reading field
CHANNELS = ("pressure_c", "pressure_e", "length", "supply")
# the faults an emulated rig can be given (kind 5), by number: the plant's (the first four), one
# sensor channel's (``channel_value``: it reads ``size`` plus its noise; ``frozen_channel``), the
# link's (``silent``: no more sensor packets; ``ignore_arm``; ``lose_stops``: every stop packet
# lost; ``no_watchdog``: its watchdog disabled; ``reboot``: it restarts, its packet numbers and
# clock from zero) and ``clear`` (every fault, the link's too, removed)
FAULTS = (
    "frozen_sensor",
    "supply_drop",
    "leak",
    "stuck_valve",
    "channel_value",
    "frozen_channel",
    "silent",
    "ignore_arm",
    "lose_stops",
    "no_watchdog",
    "reboot",
    "clear",
)


# a reading numbered this many packets or more behind the newest is not a late datagram (the
# loopback or a LAN reorders a few) but a rig that restarted and counts from zero again; so is a
# run of RESTART_RUN readings behind it that count up among themselves (a rig restarted recently)
RESTART_GAP = 1000
RESTART_RUN = 3


def seq_newer(seq: int, last: int) -> bool:
    """Whether packet number ``seq`` follows ``last``, modulo 2**32 (so a wrap-around is newer)."""
    return 0 < (seq - last) % 2**32 < 2**31


def seq_restarted(seq: int, last: int) -> bool:
    """Whether ``seq`` is so far behind ``last`` that its sender restarted (a reboot)."""
    return not seq_newer(seq, last) and (last - seq) % 2**32 >= RESTART_GAP


@dataclass(frozen=True)
class Reading:
    """One sensor packet, SI: ``time`` [s] on the rig's clock, gauge pressures [Pa], ``length`` [m];
    ``seq`` the packet's number, ``ack_seq`` the last command the rig applied, ``flags``."""

    time: float
    pressure_c: float
    pressure_e: float
    length: float
    supply: float
    seq: int = 0
    ack_seq: int = 0
    flags: int = 0

    @property
    def stopped(self) -> bool:
        return bool(self.flags & FLAG_STOPPED)

    @property
    def by_watchdog(self) -> bool:
        """Stopped by the rig's own watchdog (no command for :data:`WATCHDOG_S`)."""
        return bool(self.flags & FLAG_WATCHDOG)

    def channels(self) -> tuple[float, float, float, float]:
        """The values of :data:`CHANNELS`, in order."""
        return (self.pressure_c, self.pressure_e, self.length, self.supply)


class PacketError(ValueError):
    """A datagram that is not a packet of this protocol (wrong size or magic)."""


def pack_reading(r: Reading) -> bytes:
    return SENSOR.pack(
        MAGIC,
        KIND_SENSOR,
        r.flags,
        r.seq & 0xFFFFFFFF,
        r.time,
        r.pressure_c,
        r.pressure_e,
        r.length,
        r.supply,
        r.ack_seq & 0xFFFFFFFF,
    )


def unpack_reading(data: bytes) -> Reading:
    if len(data) != SENSOR.size:
        raise PacketError(f"sensor packet of {len(data)} bytes, expected {SENSOR.size}")
    magic, kind, flags, seq, t, pc, pe, length, supply, ack = SENSOR.unpack(data)
    if magic != MAGIC or kind != KIND_SENSOR:
        raise PacketError(f"not a sensor packet (magic {magic:#x}, kind {kind})")
    return Reading(t, pc, pe, length, supply, seq, ack, flags)


def pack_command(
    kind: int, seq: int, command_c: float = 0.0, command_e: float = 0.0, flags: int = 0
) -> bytes:
    return COMMAND.pack(MAGIC, kind, flags, seq & 0xFFFFFFFF, command_c, command_e)


def unpack_command(data: bytes) -> tuple[int, int, int, float, float]:
    """``(kind, flags, seq, command_c, command_e)`` of a command packet."""
    if len(data) != COMMAND.size:
        raise PacketError(f"command packet of {len(data)} bytes, expected {COMMAND.size}")
    magic, kind, flags, seq, c, e = COMMAND.unpack(data)
    if magic != MAGIC or kind not in (KIND_COMMAND, KIND_STOP, KIND_ARM, KIND_FAULT):
        raise PacketError(f"not a command packet (magic {magic:#x}, kind {kind})")
    return kind, flags, seq, c, e


@runtime_checkable
class Rig(Protocol):
    """What the deploy loop needs of a rig (docs/deploy.md)."""

    def read(self) -> Reading | None: ...

    def write(self, command_c: float, command_e: float) -> None: ...

    def stop(self) -> None: ...

    def arm(self) -> None: ...

    def close(self) -> None: ...
