"""Who may come through a bridge's door: the networks it accepts, and the ZWO port's first bytes.

A bridge port has no password, and the ZWO protocol is plain text, so two things keep a stranger
off the mount before any command is read:

* :class:`NetworkAllowlist`: a connection is accepted only from the networks in the bridge's
  ``allowed_networks`` (CIDRs; the entry ``"local"``, the default, means loopback and the networks
  of this machine's own interfaces, read by the caller's provider), judged on the peer address the
  kernel reports, before a byte is read.
* :class:`ZwoOpening`: a web page in any browser can open a TCP connection to any port and write
  an HTTP request into it, and a no-cors POST carries a body of the page's choosing: a port that
  skipped the request line as noise would then run ``:MS#``. Every browser-made connection begins
  with an HTTP method (letters) or a TLS record (0x16); every ZWO/LX200 driver begins with ``:``,
  perhaps after the bytes drivers send between commands (``#``, CR, LF, space, tab, ACK 0x06: INDI's
  generic LX200 handshake is an ACK). So the first command must come before any letter, before
  a TLS record, and within a few bytes of noise; anything else closes the connection unexecuted.

:class:`DoorLog` keeps a refused flood down to one log line a minute per kind of refusal.
"""

from __future__ import annotations

import ipaddress
import logging
import threading
import time
from collections.abc import Callable, Iterable, Sequence

__all__ = ["LOCAL", "DoorLog", "NetworkAllowlist", "NotZwo", "ZwoOpening", "peer_ip"]

Network = ipaddress.IPv4Network | ipaddress.IPv6Network
Address = ipaddress.IPv4Address | ipaddress.IPv6Address

#: The ``allowed_networks`` entry for loopback plus this machine's own interface networks.
LOCAL = "local"
_LOOPBACK: tuple[Network, ...] = (ipaddress.ip_network("127.0.0.0/8"), ipaddress.ip_network("::1/128"))


def peer_ip(host: str) -> Address | None:
    """The peer's address as judged: an IPv4 client of a dual-stack socket (``::ffff:a.b.c.d``) is IPv4."""
    try:
        ip = ipaddress.ip_address(host)
    except ValueError:
        return None
    if isinstance(ip, ipaddress.IPv6Address) and ip.ipv4_mapped is not None:
        return ip.ipv4_mapped
    return ip


class NetworkAllowlist:
    """The networks a bridge accepts connections from, following its live setting.

    ``local_networks`` says what ``"local"`` means now (the server passes this machine's loopback and
    interface networks; without it, loopback alone). Entries are parsed once per distinct setting.
    """

    def __init__(self, entries: Callable[[], Sequence[str]],
                 local_networks: Callable[[], Iterable[Network]] | None = None) -> None:
        self._entries = entries
        self._local = local_networks or (lambda: _LOOPBACK)
        self._parsed: tuple[tuple[str, ...], tuple[Network, ...], bool] = ((), (), False)

    def _current(self) -> tuple[tuple[Network, ...], bool]:
        entries = tuple(self._entries())
        if entries != self._parsed[0]:
            networks = tuple(ipaddress.ip_network(e, strict=False) for e in entries if e != LOCAL)
            self._parsed = (entries, networks, LOCAL in entries)
        return self._parsed[1], self._parsed[2]

    def networks(self) -> list[Network]:
        """Every network accepted now, ``"local"`` expanded (the setup page shows them)."""
        listed, local = self._current()
        return list(dict.fromkeys([*(self._local() if local else ()), *listed]))

    def allows(self, host: str) -> bool:
        ip = peer_ip(host)
        if ip is None:
            return False
        listed, local = self._current()
        if any(ip in network for network in listed):
            return True
        return local and any(ip in network for network in self._local())


class DoorLog:
    """Logs a refusal at most once per ``interval_s`` per kind, with how many were not logged since."""

    def __init__(self, logger: logging.Logger, interval_s: float = 60.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self._log = logger
        self._interval = interval_s
        self._clock = clock
        self._lock = threading.Lock()
        self._last: dict[str, float] = {}
        self._quiet: dict[str, int] = {}

    def refused(self, kind: str, message: str) -> bool:
        """Log ``message`` at WARNING unless ``kind`` was logged within the interval; True if logged."""
        with self._lock:
            now = self._clock()
            last = self._last.get(kind)
            if last is not None and now - last < self._interval:
                self._quiet[kind] = self._quiet.get(kind, 0) + 1
                return False
            self._last[kind] = now
            quiet = self._quiet.pop(kind, 0)
        more = f" ({quiet} more like it in the last {self._interval:.0f} s were not logged)" if quiet else ""
        self._log.warning("%s%s", message, more)
        return True


class NotZwo(Exception):
    """A connection's first bytes are not the ZWO/LX200 protocol; the message says what they looked like."""


#: What drivers send between commands (and so may send before the first): ``#``, CR, LF, space, tab, ACK.
_IDLE_BYTES = frozenset(b"#\r\n \t\x06")
_TLS_RECORD = 0x16  # a TLS handshake record: https:// (or any TLS client) on a plain port
_PREAMBLE, _COLON, _BODY, _ACCEPTED = range(4)


class ZwoOpening:
    """Judges a connection's bytes until its first command is complete: accepted, or :class:`NotZwo`.

    The rule (what a driver may send before its first ``#``-terminated command):

    * up to :data:`MAX_IDLE` bytes of ``#``, CR, LF, space, tab and ACK (0x06);
    * up to :data:`MAX_NOISE` other bytes that are neither letters nor a TLS record (line noise);
    * then ``:``, a letter (every command code begins with one), printable ASCII, ``#``, within
      the mount's 62-character command length.

    An ASCII letter before the first ``:`` (an HTTP method, any text protocol), a TLS record byte
    (0x16), a fourth noise byte, a control or non-ASCII byte inside the first command, or a first
    command longer than the mount takes raises :class:`NotZwo` at that very byte, so a request
    written a byte at a time is refused as early as one written at once. Nothing is executed before
    acceptance: the caller buffers the bytes and hands them to the command framer only then.
    """

    MAX_IDLE = 32
    MAX_NOISE = 3
    MAX_COMMAND = 62

    def __init__(self) -> None:
        self._state = _PREAMBLE
        self._idle = 0
        self._noise = 0
        self._length = 0

    @property
    def accepted(self) -> bool:
        return self._state == _ACCEPTED

    def feed(self, data: bytes) -> bool:
        """Judge more bytes: True once the first command is complete; raises :class:`NotZwo`."""
        for byte in data:
            if self._state == _ACCEPTED:
                break
            self._step(byte)
        return self._state == _ACCEPTED

    def _step(self, byte: int) -> None:
        if self._state == _BODY:
            self._body(byte)
        elif self._state == _COLON:
            if _is_letter(byte):
                self._state, self._length = _BODY, 1
                return
            self._noisy(":")  # a colon not followed by a command code was noise
            self._state = _PREAMBLE
            self._preamble(byte)
        else:
            self._preamble(byte)

    def _preamble(self, byte: int) -> None:
        if byte == ord(":"):
            self._state = _COLON
        elif byte in _IDLE_BYTES:
            self._idle += 1
            if self._idle > self.MAX_IDLE:
                raise NotZwo(f"more than {self.MAX_IDLE} line endings or '#' and no command")
        elif _is_letter(byte):
            raise NotZwo(f"text that is not a ZWO command (it began {chr(byte)!r}, not ':'): an HTTP request "
                         "from a web browser or another protocol")
        elif byte == _TLS_RECORD and self._noise == 0:
            raise NotZwo("a TLS handshake (an https:// or other encrypted client), not the ZWO protocol")
        else:
            self._noisy(f"0x{byte:02x}")

    def _body(self, byte: int) -> None:
        if byte == ord("#"):
            self._state = _ACCEPTED
        elif 0x20 <= byte < 0x7F:
            self._length += 1
            if self._length > self.MAX_COMMAND:
                raise NotZwo(f"a first command longer than the mount's {self.MAX_COMMAND} characters")
        else:
            raise NotZwo(f"byte 0x{byte:02x} inside the first command (binary data, not the ZWO protocol)")

    def _noisy(self, what: str) -> None:
        self._noise += 1
        if self._noise > self.MAX_NOISE:
            raise NotZwo(f"more than {self.MAX_NOISE} bytes of noise before the first command (last {what})")


def _is_letter(byte: int) -> bool:
    return 0x41 <= byte <= 0x5A or 0x61 <= byte <= 0x7A
