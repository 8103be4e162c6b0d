"""The MAVLink boat's datagrams: a UDP socket (``udpout`` to a ground station, or ``udpin`` waiting for one),
every packet sent and received recorded to a .tlog, malformed or flooding input dropped and counted
(:class:`LinkStats`), never raised. Packets that parse go to the boat's handler
(:mod:`boat_twin.link.mavlink_boat`)."""

from __future__ import annotations

import errno
import ipaddress
import select
import socket
import struct
from collections.abc import Callable
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, BinaryIO

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from boat_twin.errors import InputError
from boat_twin.files import OutputClaim

DEFAULT_URL = "udpout:127.0.0.1:14550"
"""Default target: a ground station on this machine (QGroundControl and MAVProxy listen on UDP 14550)."""

MAX_DATAGRAMS_PER_POLL = 1000
"""At most this many datagrams are taken in per poll (a flood cannot starve the simulation)."""
MAX_PACKETS_PER_POLL = 1000
"""At most this many MAVLink packets are taken in per poll, however many each datagram holds (a datagram of a few
hundred packets each would otherwise multiply the work, and the .tlog, per tick): further datagrams wait in the
socket, and the packets of the datagram that crosses the cap beyond it are dropped (``LinkStats.flood_dropped``)."""
UDP_MAX_DATAGRAM = 65535


@dataclass
class LinkStats:
    """Counters of one link; ``dropped`` is everything malformed that was thrown away."""

    datagrams_received: int = 0
    packets_received: int = 0
    """Well-formed packets (valid CRC, known id), whatever their content."""
    commands_applied: int = 0
    """MANUAL_CONTROL and RC_CHANNELS_OVERRIDE packets addressed to this boat and applied."""
    ignored: int = 0
    """Well-formed packets not for this boat or of a type it does not handle."""
    bad_data: int = 0
    """pymavlink BAD_DATA events: bad CRC, bad prefix bytes, wrong length, bad flags."""
    unknown_id: int = 0
    """Well-framed packets whose message id is not in the ardupilotmega dialect."""
    truncated: int = 0
    """Datagrams that ended inside a packet (the partial packet is dropped)."""
    rejected_sender: int = 0
    """Datagrams from a host other than the ground station's (udpout mode)."""
    flood_dropped: int = 0
    """Well-formed packets beyond :data:`MAX_PACKETS_PER_POLL` in one poll, dropped unread (a flood)."""
    packets_sent: int = 0
    """Packets handed to the network."""
    send_errors: int = 0
    packets_logged: int = 0
    """Records written to the .tlog (sent and received packets)."""

    @property
    def dropped(self) -> int:
        """Malformed input thrown away: bad data, unknown ids, truncated packets."""
        return self.bad_data + self.unknown_id + self.truncated

    def as_dict(self) -> dict[str, int]:
        """Plain counters (for --json)."""
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        out["dropped"] = self.dropped
        return out


@dataclass(frozen=True)
class Endpoint:
    """A parsed MAVLink URL: ``mode`` 'udpout' (send to host:port) or 'udpin' (listen on host:port)."""

    mode: str
    host: str
    port: int
    sockaddr: tuple[Any, ...]
    family: int
    loopback: bool


def parse_url(url: str, allow_remote: bool = False) -> Endpoint:
    """Parse ``udpout:HOST:PORT`` / ``udpin:HOST:PORT`` (``udp:`` = udpin, as pymavlink); refuse non-loopback
    hosts unless ``allow_remote``. Raises InputError (one line) on anything else."""
    scheme, sep, rest = url.partition(":")
    scheme = {"udp": "udpin"}.get(scheme, scheme)
    if not sep or scheme not in ("udpout", "udpin"):
        raise InputError(f"MAVLink URL {url!r}: expected udpout:HOST:PORT or udpin:HOST:PORT")
    host, sep, port_text = rest.rpartition(":")
    host = host.strip("[]")
    if not sep or not host:
        raise InputError(f"MAVLink URL {url!r}: expected {scheme}:HOST:PORT")
    try:
        port = int(port_text)
    except ValueError:
        raise InputError(f"MAVLink URL {url!r}: port {port_text!r} is not a number") from None
    lowest = 0 if scheme == "udpin" else 1
    if not lowest <= port <= 65535:
        raise InputError(f"MAVLink URL {url!r}: port must be {lowest}-65535")
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_DGRAM)
    except (socket.gaierror, UnicodeError) as err:
        raise InputError(f"MAVLink URL {url!r}: cannot resolve host {host!r} ({err})") from None
    family, _, _, _, sockaddr = infos[0]
    loopback = all(ipaddress.ip_address(str(info[4][0]).split("%")[0]).is_loopback for info in infos)
    if not loopback and not allow_remote:
        raise InputError(
            f"MAVLink URL {url!r}: {host} is not a loopback address; pass --allow-remote "
            "(mavlink_allow_remote) to expose the twin beyond this machine"
        )
    return Endpoint(scheme, host, port, tuple(sockaddr), family, loopback)



class Transport:
    """The socket of ``endpoint`` (None: no network) and the .tlog at ``tlog`` (None: none), counting into
    ``stats``. pymavlink's encoder writes through :meth:`write`; records are stamped with :attr:`stamp_s`
    (8-byte big-endian µs since the Unix epoch, then the packet, as MAVProxy writes them)."""

    def __init__(self, endpoint: Endpoint | None, stats: LinkStats, tlog: Path | None = None,
                 overwrite: bool = False, stamp_s: float = 0.0) -> None:
        self.endpoint = endpoint
        self.stats = stats
        self.stamp_s = stamp_s
        """Time of the records written now, Unix s (the twin's time)."""
        self._peer: tuple[Any, ...] | None = None
        self._sock: socket.socket | None = None
        self._tlog: BinaryIO | None = None
        self._tlog_claim: OutputClaim | None = None
        if endpoint is not None:
            self._sock = self._open_socket(endpoint)
        if tlog is not None:
            try:
                self._tlog_claim = OutputClaim(Path(tlog), overwrite, "tlog")
                self._tlog = (self._tlog_claim.scratch / Path(tlog).name).open("wb")
            except BaseException:
                self.close(complete=False)
                raise

    def _open_socket(self, ep: Endpoint) -> socket.socket:
        sock = socket.socket(ep.family, socket.SOCK_DGRAM)
        try:
            if ep.mode == "udpin":
                sock.bind(ep.sockaddr)
            else:
                local = "::1" if ep.family == socket.AF_INET6 else "127.0.0.1"
                sock.bind((local, 0) if ep.loopback else ("", 0))
                self._peer = ep.sockaddr
        except OSError as err:
            sock.close()
            raise InputError(f"MAVLink {ep.mode}:{ep.host}:{ep.port}: cannot bind ({err.strerror})") from None
        sock.setblocking(False)
        return sock

    @property
    def has_socket(self) -> bool:
        return self._sock is not None

    @property
    def local_address(self) -> tuple[Any, ...] | None:
        """The bound (host, port) of the socket (e.g. the ephemeral port of ``udpin:127.0.0.1:0``)."""
        return self._sock.getsockname() if self._sock is not None else None

    def write(self, buf: bytes | bytearray) -> None:
        """Called by pymavlink for every packet the boat sends: to the network and to the .tlog."""
        self.log(buf)
        if self._sock is None or self._peer is None:
            return
        try:
            self._sock.sendto(bytes(buf), self._peer)
            self.stats.packets_sent += 1
        except OSError:  # no route, buffer full, ICMP refusal from an earlier send: the next tick retries
            self.stats.send_errors += 1

    def log(self, buf: bytes | bytearray) -> None:
        """One .tlog record of ``buf`` at :attr:`stamp_s`."""
        if self._tlog is not None:
            self._tlog.write(struct.pack(">Q", max(0, round(self.stamp_s * 1e6))) + bytes(buf))
            self.stats.packets_logged += 1

    def flush_log(self) -> None:
        """Flush the .tlog (the partial .tlog of a killed run lags by at most the time between flushes)."""
        if self._tlog is not None:
            self._tlog.flush()

    def close(self, complete: bool = True) -> None:
        """Close the socket and the .tlog (idempotent). The .tlog, written next to its name, is moved into place
        if ``complete``; otherwise it is dropped and an old file of that name stays as it was."""
        if self._sock is not None:
            self._sock.close()
            self._sock = None
        tlog, self._tlog = self._tlog, None
        claim, self._tlog_claim = self._tlog_claim, None
        try:
            if tlog is not None:
                tlog.close()  # flushes: a full disk fails here too
            if claim is not None and complete:
                claim.commit(claim.scratch / claim.path.name)
        finally:
            if claim is not None:
                claim.release()  # the scratch and the lock go, whatever failed

    def poll(self, handle: Callable[[Any], None], timeout_s: float = 0.0) -> int:
        """Take in every pending datagram (waiting up to ``timeout_s`` for the first), each well-formed packet
        logged and given to ``handle``; returns how many datagrams."""
        if self._sock is None:
            return 0
        if timeout_s > 0.0:
            readable, _, _ = select.select([self._sock], [], [], timeout_s)
            if not readable:
                return 0
        count = packets = 0
        for _ in range(MAX_DATAGRAMS_PER_POLL):
            if packets >= MAX_PACKETS_PER_POLL:
                break
            try:
                data, sender = self._sock.recvfrom(UDP_MAX_DATAGRAM)
            except (BlockingIOError, InterruptedError):
                break
            except OSError as err:  # e.g. ECONNREFUSED for an earlier send (ICMP): consumed, not an input
                if err.errno in (errno.ECONNREFUSED, errno.ECONNRESET, errno.EHOSTUNREACH, errno.ENETUNREACH):
                    continue
                break
            count += 1
            self.stats.datagrams_received += 1
            packets += max(1, self._receive_datagram(data, sender, MAX_PACKETS_PER_POLL - packets, handle))
        return count

    def _receive_datagram(self, data: bytes, sender: tuple[Any, ...], budget: int,
                          handle: Callable[[Any], None]) -> int:
        """Parse one datagram and act on at most ``budget`` of its packets (the rest are counted as dropped);
        returns how many packets it held."""
        assert self.endpoint is not None
        if self.endpoint.mode == "udpout" and sender[0] != self.endpoint.sockaddr[0]:
            self.stats.rejected_sender += 1
            return 1
        parser = mavlink2.MAVLink(None)  # one parser per datagram: a bad datagram cannot spoil the next
        parser.robust_parsing = True
        try:
            packets = parser.parse_buffer(data) or []
        except Exception:  # noqa: BLE001 (pymavlink may raise other errors on hostile input)
            self.stats.bad_data += 1
            return 1
        if parser.buf_len() > 0:
            self.stats.truncated += 1
        accepted = False
        self.stats.flood_dropped += max(0, len(packets) - budget)
        for msg in packets[:budget]:
            if isinstance(msg, mavlink2.MAVLink_bad_data):
                self.stats.bad_data += 1
            elif isinstance(msg, mavlink2.MAVLink_unknown):
                self.stats.unknown_id += 1
            else:
                self.stats.packets_received += 1
                accepted = True
                self.log(msg.get_msgbuf())
                handle(msg)
        if accepted and self.endpoint.mode == "udpin":
            self._peer = sender
        return len(packets)
