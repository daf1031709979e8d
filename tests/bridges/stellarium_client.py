"""A Stellarium telescope-protocol client for tests, written from the protocol document only.

Source: shared/stellarium/telescope-protocol.md ("Stellarium Telescope Protocol version 1.0" and
Stellarium's TelescopeTCP). Every message: LENGTH uint16 (whole message), TYPE uint16, all
little-endian. Server -> client type 0 (24 bytes): TIME int64 us since 1970 UT, RA uint32
(0x100000000 = 24 h), DEC int32 (0x40000000 = +90 deg), STATUS int32 (0 ok). Client -> server
type 0 (20 bytes): TIME int64, RA uint32, DEC int32. Stellarium encodes an angle as
floor(0.5 + rad * 0x80000000 / pi). This deliberately shares no code with the server.
"""

from __future__ import annotations

import math
import socket
import struct
import time
from dataclasses import dataclass


@dataclass(frozen=True)
class Position:
    """One current-position message as received."""

    length: int
    kind: int
    server_time_us: int
    ra_raw: int
    dec_raw: int
    status: int
    received: float  # time.monotonic() when it arrived

    @property
    def ra_hours(self) -> float:
        return self.ra_raw * math.pi / 0x80000000 * 12.0 / math.pi

    @property
    def dec_degrees(self) -> float:
        return self.dec_raw * math.pi / 0x80000000 * 180.0 / math.pi


def encode_angle(radians: float) -> int:
    """Stellarium's rounding: floor(0.5 + rad * 2^31 / pi)."""
    return math.floor(0.5 + radians * 0x80000000 / math.pi)


def goto_message(ra_hours: float, dec_degrees: float, client_time_us: int | None = None) -> bytes:
    """The 20-byte goto Stellarium sends for "slew to" (RA wrapped into 0..2^32)."""
    now_us = client_time_us if client_time_us is not None else time.time_ns() // 1000
    ra = encode_angle(math.radians(ra_hours * 15.0)) % 0x100000000
    dec = encode_angle(math.radians(dec_degrees))
    return struct.pack("<HHqIi", 20, 0, now_us, ra, dec)


class StellariumClient:
    """One connection as Stellarium makes it (IPv4, Nagle off); reads whole messages by length."""

    def __init__(self, port: int, host: str = "127.0.0.1", timeout: float = 5.0) -> None:
        self.sock = socket.create_connection((host, port), timeout=timeout)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._buf = b""
        self.other_messages: list[tuple[int, bytes]] = []

    def _fill(self, n: int, deadline: float) -> None:
        """Wait until the buffer holds n bytes (nothing is consumed, so a timeout loses nothing)."""
        while len(self._buf) < n:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise TimeoutError("no complete message in time")
            self.sock.settimeout(remaining)
            chunk = self.sock.recv(4096)
            if not chunk:
                raise ConnectionError("the server closed the connection")
            self._buf += chunk

    def read_position(self, timeout: float = 5.0) -> Position:
        """The next type-0 message; other types are kept aside, as Stellarium skips them."""
        deadline = time.monotonic() + timeout
        while True:
            self._fill(4, deadline)
            length, kind = struct.unpack_from("<HH", self._buf)
            if length < 4:
                raise ValueError(f"message length {length} < 4")
            self._fill(length, deadline)
            message, self._buf = self._buf[:length], self._buf[length:]
            if kind != 0:
                self.other_messages.append((kind, message))
                continue
            if length != 24:
                raise ValueError(f"position message of {length} bytes")
            server_time, ra, dec, status = struct.unpack_from("<qIii", message, 4)
            return Position(length, kind, server_time, ra, dec, status, time.monotonic())

    def latest_position(self, timeout: float = 5.0) -> Position:
        """The freshest position: everything already queued is read past, else the next one is awaited."""
        self.sock.setblocking(False)
        try:
            while chunk := self.sock.recv(65536):
                self._buf += chunk
        except BlockingIOError:
            pass
        finally:
            self.sock.settimeout(timeout)
        latest = self.read_position(timeout)
        while True:
            try:
                latest = self.read_position(timeout=0.0)
            except TimeoutError:
                return latest

    def goto(self, ra_hours: float, dec_degrees: float) -> None:
        self.sock.sendall(goto_message(ra_hours, dec_degrees))

    def send_raw(self, data: bytes) -> None:
        self.sock.sendall(data)

    def closed_by_server(self, timeout: float = 5.0) -> bool:
        """True once the server has closed this connection (positions already queued are read past)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.sock.settimeout(max(0.01, deadline - time.monotonic()))
            try:
                if not self.sock.recv(65536):
                    return True
            except TimeoutError:
                return False
            except ConnectionError:
                return True
        return False

    def close(self) -> None:
        self.sock.close()
