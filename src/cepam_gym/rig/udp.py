"""The reference transport of the rig protocol: UDP datagrams (:mod:`cepam_gym.rig.protocol`).

The rig streams sensor packets to the address the last command packet came from; the host sends
one command packet per control step. UDP keeps the newest value moving when a packet is lost
(nothing is retransmitted late), which is what a control loop wants; the supervisor's watchdog
(:mod:`cepam_gym.rig.supervisor`) notices when readings stop coming.
"""

from __future__ import annotations

import socket

from ..errors import InputError
from .protocol import (
    KIND_ARM,
    KIND_COMMAND,
    KIND_FAULT,
    KIND_STOP,
    RESTART_RUN,
    SAFE_COMMANDS,
    PacketError,
    Reading,
    pack_command,
    seq_newer,
    seq_restarted,
    unpack_reading,
)


def parse_address(text: str) -> tuple[str, int]:
    """``(host, port)`` of ``host:port`` (``InputError`` naming the text otherwise)."""
    host, sep, port = str(text).rpartition(":")
    try:
        if not sep or not host:
            raise ValueError
        p = int(port)
        if not 0 < p < 65536:
            raise ValueError
    except ValueError:
        raise InputError(f"rig address must be host:port (e.g. 127.0.0.1:9870), got {text!r}") from None
    return host, p


class UdpRig:
    """A rig at ``address`` (``(host, port)`` or ``"host:port"``) over UDP. :meth:`read` returns the
    newest sensor packet that arrived since the last call (older ones are dropped), or None."""

    def __init__(self, address, local_port: int = 0):
        self.address = parse_address(address) if isinstance(address, str) else tuple(address)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(
            ("0.0.0.0" if self.address[0] not in ("127.0.0.1", "localhost") else "127.0.0.1", local_port)
        )
        self.sock.setblocking(False)
        self.seq = 0
        self.bad_packets = 0
        self.received = 0
        self.restarts = 0  # times the rig's packet numbers began again (a reboot)
        self._last_seq: int | None = None
        self._behind: list[int] = []  # the numbers of the readings just dropped as behind the newest

    def _send(self, kind: int, c: float = 0.0, e: float = 0.0, flags: int = 0) -> None:
        self.seq += 1
        try:
            self.sock.sendto(pack_command(kind, self.seq, c, e, flags), self.address)
        except OSError:
            pass  # an unreachable rig shows as missing readings (the watchdog), not as an exception here

    def read(self) -> Reading | None:
        newest = None
        while True:
            try:
                data = self.sock.recv(256)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:  # e.g. ICMP port unreachable reported on the next recv
                break
            try:
                r = unpack_reading(data)
            except PacketError:
                self.bad_packets += 1
                continue
            self.received += 1
            last = self._last_seq
            if last is not None and not seq_newer(r.seq, last):
                if not self._restarted(r.seq, last):
                    continue  # a late datagram older than one already read is dropped
                self.restarts += 1
            self._last_seq, self._behind = r.seq, []
            newest = r
        return newest

    def _restarted(self, seq: int, last: int) -> bool:
        """Whether a reading numbered ``seq``, behind the newest ``last``, comes from a rig that
        restarted: far behind, or the last of a run of readings behind that count up."""
        if seq_restarted(seq, last):
            return True
        if self._behind and not seq_newer(seq, self._behind[-1]):
            self._behind = []
        self._behind.append(seq)
        return len(self._behind) >= RESTART_RUN

    def write(self, command_c: float, command_e: float) -> None:
        self._send(KIND_COMMAND, float(command_c), float(command_e))

    def stop(self) -> None:
        """One stop packet (:func:`~cepam_gym.rig.stop.stop_and_confirm` repeats it until the rig's
        readings say it is stopped)."""
        self._send(KIND_STOP, *SAFE_COMMANDS)

    def arm(self) -> None:
        """Leave the safe state (the emulated rig also restarts its plant at rest)."""
        self._send(KIND_ARM)

    def inject(self, fault: int, size: float = 0.0, channel: int = 0) -> None:
        """Emulated rig: inject fault number ``fault`` (:data:`~cepam_gym.rig.protocol.FAULTS`) of
        ``size`` (0: its default) on sensor channel ``channel`` (the faults of one channel)."""
        self._send(KIND_FAULT, float(size), float(channel), flags=int(fault))

    def close(self) -> None:
        self.sock.close()
