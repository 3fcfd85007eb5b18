"""The rig protocol: what a host reads from a CE-PAM rig and what it writes, and the packets that
carry them (docs/deploy.md, "The rig protocol").

A rig offers three things (:class:`Rig`):

* ``read()``: the newest :class:`Reading` (the rig's time, both chambers' gauge pressures, the
  muscle's length, the supply's gauge pressure), or None when nothing new arrived;
* ``write(command_c, command_e)``: the two valve commands, each in [-1, 1] as the env's action
  (spool set-points, PWM duties or pressure set-points by the rig's action mode);
* ``stop()``: the rig goes to its safe state (:data:`SAFE_COMMANDS`, supply shut off) and stays
  there, ignoring commands, until it is armed again;
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
  number ``flags`` of :data:`FAULTS`, of size ``command_c``).

``magic`` is :data:`MAGIC`; ``seq`` counts each side's packets; ``ack_seq`` is the ``seq`` of the
last command packet the rig applied; sensor ``flags`` bit 0 says the rig is stopped (safe state),
bit 1 that a fault was injected (emulator). Pressures are gauge [Pa], the length [m], SI as
everywhere inside the package.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

MAGIC = 0xCE5A
SENSOR = struct.Struct("<HBBIdffffI")
COMMAND = struct.Struct("<HBBIff")
KIND_SENSOR, KIND_COMMAND, KIND_STOP, KIND_ARM, KIND_FAULT = 1, 2, 3, 4, 5
FLAG_STOPPED, FLAG_FAULT = 1, 2
# the commands of the safe state: both chambers vented. In every action mode -1 is exhaust: the
# spool fully to exhaust (valve), the exhaust solenoid held open (pwm), a 0 Pa set-point (pressure)
SAFE_COMMANDS = (-1.0, -1.0)
# the faults an emulated rig can be given (kind 5), by number
FAULTS = ("frozen_sensor", "supply_drop", "leak", "stuck_valve")


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
