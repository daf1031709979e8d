"""A small test client for the emulator over a real TCP socket, and motion helpers.

Synchronisation without sleeps: requests on one connection are handled in order, so the client
follows a request with a sentinel query (``:GVT#``, whose reply is unique) and reads until the
sentinel's reply arrives. Whatever came before it is exactly the reply of the request, and once
it is there the request has certainly been acted on (no race with ``clock.advance``).
"""

from __future__ import annotations

import socket
import time
from collections.abc import Callable
from datetime import datetime, timedelta, timezone

from alpaca_zwo import sky
from alpaca_zwo.emulator import ManualClock, MountModel
from alpaca_zwo.zwo import protocol

#: True UTC at the start of every test: a March afternoon in UTC, evening in China.
START_UTC = datetime(2025, 3, 20, 14, 0, 0, tzinfo=timezone.utc)
SENTINEL = ":GVT#"
SENTINEL_REPLY = b"10:24:36#"
TIMEOUT_S = 3.0
#: Short window used only to assert that NOTHING arrives (a bounded recv on a real socket).
SILENCE_S = 0.25


class MountClient:
    """A test client speaking the mount protocol over a real TCP socket."""

    def __init__(self, port: int, host: str = "127.0.0.1", compile_time: str | None = None) -> None:
        """``compile_time`` is the firmware's :GVT# text when it is not the default's (the sentinel's reply)."""
        self.sock = socket.create_connection((host, port), timeout=TIMEOUT_S)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._pending = b""
        self._sentinel_reply = SENTINEL_REPLY if compile_time is None else f"{compile_time}#".encode()

    def close(self) -> None:
        self.sock.close()

    def write(self, data: bytes | str) -> None:
        self.sock.sendall(data.encode("latin-1") if isinstance(data, str) else data)

    def read_until(self, done: Callable[[bytes], bool], timeout: float = TIMEOUT_S) -> bytes:
        """Bytes read until ``done(bytes)``; fails the test after ``timeout`` real seconds."""
        deadline = time.monotonic() + timeout
        data = self._pending
        self._pending = b""
        while not done(data):
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise AssertionError(f"incomplete reply after {timeout}s: {data!r}")
            self.sock.settimeout(remaining)
            try:
                chunk = self.sock.recv(4096)
            except TimeoutError as exc:
                raise AssertionError(f"incomplete reply after {timeout}s: {data!r}") from exc
            if not chunk:
                raise ConnectionError(f"connection closed, got {data!r}")
            data += chunk
        return data

    def ask(self, request: str, kind: protocol.ReplyKind | None = None) -> str:
        """Send one request and read its reply by kind (``protocol.reply_complete``)."""
        if kind is None:
            kind = _kind_of(request)
        self.write(request)
        if kind is protocol.ReplyKind.NONE:
            return ""
        reply = self.read_until(lambda d: protocol.reply_complete(kind, d))
        if kind in (protocol.ReplyKind.CHAR, protocol.ReplyKind.GOTO) and not reply.startswith(b"e"):
            self._pending, reply = reply[1:], reply[:1]
        elif b"#" in reply:
            cut = reply.index(b"#") + 1
            self._pending, reply = reply[cut:], reply[:cut]
        return reply.decode("latin-1")

    def exact(self, request: str | bytes) -> str:
        """The exact bytes a request produces (possibly none), delimited by a sentinel query.

        Also guarantees the request has been handled when it returns.
        """
        raw = request if isinstance(request, bytes) else request.encode("latin-1")
        self.write(raw)
        if SENTINEL.encode() in raw:  # asking :GVT# itself: delimit with :GMGE#, the one '&' reply here
            self.write(":GMGE#")
            data = self.read_until(lambda d: b"&" in d and d.endswith(b"#"))
            return data[: data.rindex(b"#", 0, len(data) - 1) + 1].decode("latin-1")
        self.write(SENTINEL)
        data = self.read_until(lambda d: d.endswith(self._sentinel_reply))
        return data[: -len(self._sentinel_reply)].decode("latin-1")

    def send(self, request: str) -> None:
        """A no-reply command: assert it answers nothing, and that it has been acted on."""
        reply = self.exact(request)
        assert reply == "", f"{request} unexpectedly answered {reply!r}"

    def assert_silent(self, request: str | bytes, window: float = SILENCE_S) -> None:
        """Nothing at all may come back within ``window`` seconds of ``request``."""
        self.write(request)
        self.sock.settimeout(window)
        try:
            data = self.sock.recv(4096)
        except TimeoutError:
            return
        finally:
            self.sock.settimeout(TIMEOUT_S)
        raise AssertionError(f"{request!r} answered {data!r}")


def _kind_of(request: str) -> protocol.ReplyKind:
    body = request.strip(":#")
    match = protocol.match_command(body)
    return match.command.kind if match is not None else protocol.ReplyKind.NONE


def initialize(client: MountClient, clock: ManualClock, utc_offset_hours: float = 0.0) -> None:
    """Set date, time, zone and the factory site the way INDI does, each answering a bare 1."""
    local = clock.now() + timedelta(hours=utc_offset_hours)
    assert client.exact(protocol.set_utc_offset(utc_offset_hours).text) == "1"
    assert client.exact(f":SL{local:%H:%M:%S}#") == "1"
    assert client.exact(f":SC{local:%m/%d/%y}#") == "1"
    assert client.exact(":St+31*15:41#") == "1"
    assert client.exact(":Sg-120*43:11#") == "1"


def target_at(model: MountModel, ha_hours: float) -> float:
    """RA of the point at ``ha_hours`` right now by the mount's own sidereal time."""
    return sky.ra_from_hour_angle(model.clock_site.sidereal_time(), ha_hours)


def slew(client: MountClient, clock: ManualClock, ra_hours: float, dec_deg: float, step: float = 0.5) -> float:
    """GOTO and advance emulated time until ``:GU#`` shows N again; returns the slew's duration."""
    assert client.exact(protocol.set_target_ra(ra_hours).text) == "1"
    assert client.exact(protocol.set_target_dec(dec_deg).text) == "1"
    reply = client.exact(":MS#")
    assert reply == "0", f"GOTO refused: {reply!r}"
    return wait_slew(client, clock, step)


def wait_slew(client: MountClient, clock: ManualClock, step: float = 0.5, limit_s: float = 300.0) -> float:
    elapsed = 0.0
    while "N" not in client.ask(":GU#").rstrip("#").rstrip("0123456789"):
        assert elapsed < limit_s, "slew did not end"
        clock.advance(step)
        elapsed += step
    return elapsed


def flags(client: MountClient) -> str:
    """The letters of ``:GU#`` (the digits stripped)."""
    return client.ask(":GU#").rstrip("#").rstrip("0123456789")
