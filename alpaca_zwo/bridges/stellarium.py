"""Stellarium telescope server: the Telescope Control plugin's "External software" connection.

Stellarium (every build, every OS) connects over TCP and speaks a tiny binary protocol: it
receives the telescope's position (message type 0, 24 bytes) and sends gotos (type 0, 20 bytes).
All integers are little-endian; RA is an unsigned 32-bit fraction of 24 h, Dec a signed 32-bit
fraction of 90 degrees (see ``shared/stellarium/telescope-protocol.md``).

Design:
- One selector thread accepts connections, reads and frames messages and writes the position
  stream (a few times per second, one message computed per tick and queued to every client).
  Sockets are non-blocking, so a stalled or hostile client can never hold up the others.
- One worker thread does everything that may wait on the mount: holding the Telescope connected
  while any Stellarium is connected (as one Alpaca-style client, :data:`BRIDGE_CLIENT`) and
  starting gotos through ``Telescope.slew_to_coordinates_async``, so limits, parking rules and
  aborts apply exactly as for Alpaca. Gotos coalesce: only the newest pending one is kept.
- The mount works in apparent topocentric coordinates of date (JNow). In J2000 mode positions are
  converted with ERFA (precession-nutation, annual and diurnal aberration, light deflection) both
  ways; in JNow mode they pass unchanged.
- At the door: a connection from outside ``stellarium.allowed_networks`` is closed unread
  (:mod:`.admission`). An accepted connection is only *pending* until its first valid message: it
  is not a client (not shown, not counted, no position stream, the Telescope not connected for it)
  and bytes that cannot begin a Stellarium message (an HTTP request from a web page: "GE", "PO"
  make a length of thousands) close it, logged at most once a minute. Stellarium itself sends
  nothing until its first goto, so its opening message is silence: a pending connection that has
  sent no byte for :data:`QUIET_OPENING_S` becomes a client, as one that sent a whole valid message.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import selectors
import socket
import struct
import threading
import time
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from datetime import datetime, timezone
from typing import TYPE_CHECKING, Any

try:
    import erfa
except ImportError:  # pyerfa has no wheel for 32-bit ARM (armv7 Pis): J2000 needs it, JNow does not
    erfa = None

from .._exceptions import AlpacaError
from ..clients import ClientKey, current_client
from .admission import DoorLog, Network, NetworkAllowlist

if TYPE_CHECKING:
    from ..config.settings import SiteSettings, StellariumSettings
    from ..telescope.device import Telescope

log = logging.getLogger(__name__)

# A goto dated 2099 (UTCDate can be set) only makes ERFA warn that its leap-second table may be
# out of date; the few tenths of a second at stake do not matter here.
if erfa is not None:
    warnings.filterwarnings("ignore", message=".*dubious year.*", category=erfa.ErfaWarning)

#: How the bridge appears among the Telescope's connected clients.
BRIDGE_CLIENT = ClientKey("stellarium", 0)

HEADER = struct.Struct("<HH")  # length (whole message), type
POSITION = struct.Struct("<HHqIii")  # header, time (us since 1970 UT), RA, Dec, status
GOTO = struct.Struct("<HHqIi")  # header, client time, RA, Dec
MSG_POSITION = 0
MSG_GOTO = 0
MAX_MESSAGE_BYTES = 64  # Stellarium's longest message is 24 bytes; anything much longer is garbage
MAX_PENDING_OUTPUT = 64 * 1024  # a client that stops reading for this long is dropped
HOLD_RETRY_S = 5.0  # how soon to retry connecting the Telescope after a failure
#: A pending connection silent this long is Stellarium (it sends nothing until a goto; a browser
#: writes its request at once).
QUIET_OPENING_S = 1.0
#: A pending connection that began a message but did not finish it in this time is closed.
OPENING_TIMEOUT_S = 5.0

_WIRE_TURN = 1 << 32  # 24 h of RA, 360 degrees
_DEC_QUARTER = 1 << 30  # 90 degrees of Dec


# --- wire encoding ------------------------------------------------------------------------------


def ra_to_wire(hours: float) -> int:
    """RA in hours as Stellarium's unsigned fraction of 24 h (0x80000000 = 12 h)."""
    return round(hours / 24.0 * _WIRE_TURN) % _WIRE_TURN


def dec_to_wire(degrees: float) -> int:
    """Dec in degrees as Stellarium's signed fraction of 90 degrees (0x40000000 = +90)."""
    return max(-_DEC_QUARTER, min(_DEC_QUARTER, round(degrees / 90.0 * _DEC_QUARTER)))


def ra_from_wire(value: int) -> float:
    return value * 24.0 / _WIRE_TURN


def dec_from_wire(value: int) -> float:
    return value * 90.0 / _DEC_QUARTER


# --- equinox conversion -------------------------------------------------------------------------


def _astrometry(when: datetime, site: SiteSettings) -> tuple[Any, float]:
    """ERFA's star-independent parameters for this moment and site (no refraction: pressure 0)."""
    t = when.astimezone(timezone.utc)
    seconds = t.second + t.microsecond / 1e6
    utc1, utc2 = erfa.dtf2d("UTC", t.year, t.month, t.day, t.hour, t.minute, seconds)
    astrom, eo = erfa.apco13(utc1, utc2, 0.0, math.radians(site.longitude), math.radians(site.latitude),
                             site.elevation, 0.0, 0.0, 0.0, 0.0, 0.0, 0.55)
    return astrom, float(eo)


def apparent_to_j2000(ra_hours: float, dec_deg: float, when: datetime, site: SiteSettings) -> tuple[float, float]:
    """The mount's apparent topocentric RA/Dec of date -> J2000 (ICRS astrometric) RA/Dec.

    Apparent RA is counted from the true equinox; ERFA works from the CIO, the two differing by
    the equation of the origins ``eo`` (CIRS RA = apparent RA + eo).
    """
    astrom, eo = _astrometry(when, site)
    ri = erfa.anp(math.radians(ra_hours * 15.0) + eo)
    rc, dc = erfa.aticq(ri, math.radians(dec_deg), astrom)
    return math.degrees(float(rc)) / 15.0 % 24.0, math.degrees(float(dc))


def j2000_to_apparent(ra_hours: float, dec_deg: float, when: datetime, site: SiteSettings) -> tuple[float, float]:
    """J2000 (ICRS astrometric) RA/Dec -> the mount's apparent topocentric RA/Dec of date."""
    astrom, eo = _astrometry(when, site)
    ri, di = erfa.atciq(math.radians(ra_hours * 15.0), math.radians(dec_deg), 0.0, 0.0, 0.0, 0.0, astrom)
    ra = math.degrees(float(erfa.anp(float(ri) - eo))) / 15.0
    return ra % 24.0, math.degrees(float(di))


# --- the server ---------------------------------------------------------------------------------


class _BadInput(Exception):
    """A client sent something no Stellarium sends; the message says what, the client is dropped."""


@dataclass
class _Client:
    """One connected Stellarium: its socket, framing buffer and queued output."""

    sock: socket.socket
    address: str
    since: float  # wall-clock seconds
    inbuf: bytearray = field(default_factory=bytearray)
    outbuf: bytearray = field(default_factory=bytearray)
    messages: int = 0
    accepted: float = field(default_factory=time.monotonic)  # when the connection was accepted
    pending: bool = True  # not a client until its first valid message (or Stellarium's opening silence)


@dataclass(frozen=True)
class _Goto:
    address: str
    ra_hours: float  # as Stellarium sent it, in the configured equinox
    dec_deg: float
    received: float  # wall-clock seconds


def _iso(seconds: float) -> str:
    return datetime.fromtimestamp(seconds, timezone.utc).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def disabled_status(settings: StellariumSettings) -> dict[str, Any]:
    """What :meth:`StellariumBridge.status` would say when the bridge is not running."""
    return {"enabled": False, "host": settings.host, "port": settings.port, "equinox": settings.equinox,
            "clients": [], "last_command": None, "last_error": None, "turned_away": 0, "last_turned_away": None}


class StellariumBridge:
    """Serves Stellarium's telescope protocol for one Telescope; ``start``/``stop`` bracket its life."""

    def __init__(self, telescope: Telescope, host: str = "0.0.0.0", port: int = 10001, equinox: str = "J2000",
                 *, rate_hz: float = 4.0, max_clients: int = 64,
                 local_networks: Callable[[], Iterable[Network]] | None = None) -> None:
        if equinox not in ("J2000", "JNow"):
            raise ValueError(f"equinox must be 'J2000' or 'JNow', not {equinox!r}")
        if equinox == "J2000" and erfa is None:
            raise ValueError("equinox J2000 needs the pyerfa package, which has no wheel for this CPU on PyPI: "
                             "install it from piwheels (pip install pyerfa), or set [stellarium] equinox = \"JNow\" "
                             "and choose JNow in Stellarium")
        self.telescope = telescope
        self.host = host
        self.equinox = equinox
        self.period_s = 1.0 / rate_hz
        self.max_clients = max_clients
        self._requested_port = port
        self._listener: socket.socket | None = None
        self._bound_port = 0
        self._selector = selectors.DefaultSelector()
        self._wake_r, self._wake_w = socket.socketpair()
        self._clients: dict[int, _Client] = {}  # clients and pending connections, by descriptor
        self._lock = threading.Lock()  # guards _clients (for status) and the records below
        #: ``stellarium.allowed_networks``, read live; ``local_networks`` says what "local" means.
        self.allowlist = NetworkAllowlist(lambda: telescope.settings.stellarium.allowed_networks, local_networks)
        self._door_log = DoorLog(log)
        self._turned_away = 0
        self._last_turned_away: dict[str, Any] | None = None
        self._last_command: dict[str, Any] | None = None
        self._last_error: dict[str, Any] | None = None
        self._stopping = threading.Event()
        self._work = threading.Condition()
        self._want_hold = False
        self._held = False
        self._hold_failed_at: float | None = None
        self._pending_goto: _Goto | None = None
        self._serve_thread: threading.Thread | None = None
        self._work_thread: threading.Thread | None = None
        self._no_position_logged = False

    # -- life cycle ----------------------------------------------------------------------------

    @property
    def port(self) -> int:
        """The bound port (differs from the requested one when that was 0)."""
        return self._bound_port or self._requested_port

    def start(self) -> None:
        """Listen (IPv4: Stellarium only uses its host's first IPv4 address) and start both threads."""
        listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            if os.name != "nt":  # restarts rebind at once; on Windows the option would let a second server share it
                listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            listener.bind((self.host, self._requested_port))
            listener.listen(64)
        except OSError as exc:
            listener.close()
            raise OSError(exc.errno, f"Stellarium server cannot listen on {self.host}:{self._requested_port}: "
                                     f"{exc.strerror or exc}") from exc
        listener.setblocking(False)
        self._listener = listener
        self._bound_port = listener.getsockname()[1]
        self._wake_r.setblocking(False)
        self._selector.register(listener, selectors.EVENT_READ, "accept")
        self._selector.register(self._wake_r, selectors.EVENT_READ, "wake")
        self._work_thread = threading.Thread(target=self._work_loop, name="stellarium-work", daemon=True)
        self._serve_thread = threading.Thread(target=self._serve_loop, name="stellarium", daemon=True)
        self._work_thread.start()
        self._serve_thread.start()
        log.info("Stellarium telescope server on %s:%d (%s)", self.host, self.port, self.equinox)

    def stop(self) -> None:
        """Close every connection and the listener, release the Telescope; safe to call twice."""
        with self._work:
            if self._stopping.is_set():
                return
            self._stopping.set()
            self._pending_goto = None
            self._work.notify_all()
        with contextlib.suppress(OSError):
            self._wake_w.send(b"x")
        if self._serve_thread is not None:
            self._serve_thread.join(timeout=5.0)
        if self._work_thread is not None:
            self._work_thread.join(timeout=15.0)
        for client in list(self._clients.values()):
            self._drop(client, "server stopping", level=logging.INFO)
        with contextlib.suppress(KeyError, ValueError):
            if self._listener is not None:
                self._selector.unregister(self._listener)
        if self._listener is not None:
            self._listener.close()
        self._selector.close()
        self._wake_r.close()
        self._wake_w.close()

    # -- status for the setup page -------------------------------------------------------------

    def status(self) -> dict[str, Any]:
        """Enabled, where it listens, who is connected since when, the last goto and the last error."""
        with self._lock:
            clients = [{"address": c.address, "since": _iso(c.since), "messages": c.messages}
                       for c in self._clients.values() if not c.pending]
            last_command = dict(self._last_command) if self._last_command else None
            last_error = dict(self._last_error) if self._last_error else None
            turned_away = self._turned_away
            last_turned_away = dict(self._last_turned_away) if self._last_turned_away else None
        return {"enabled": True, "host": self.host, "port": self.port, "equinox": self.equinox,
                "clients": clients, "last_command": last_command, "last_error": last_error,
                # Connections closed at the door: from a network not allowed, or not Stellarium's protocol.
                "turned_away": turned_away, "last_turned_away": last_turned_away,
                "allowed_networks": [str(n) for n in self.allowlist.networks()]}

    def _turn_away(self, kind: str, address: str, reason: str) -> None:
        """Count and record a connection closed at the door; log it at most once a minute per kind."""
        with self._lock:
            self._turned_away += 1
            self._last_turned_away = {"time": _iso(time.time()), "client": address, "message": reason}
        self._door_log.refused(kind, f"Stellarium port: connection from {address} closed: {reason}")

    def _record_error(self, address: str, message: str) -> None:
        with self._lock:
            self._last_error = {"time": _iso(time.time()), "client": address, "message": message}

    # -- selector thread -----------------------------------------------------------------------

    def _serve_loop(self) -> None:
        next_tick = time.monotonic()
        while not self._stopping.is_set():
            try:
                timeout = max(0.0, next_tick - time.monotonic())
                for key, events in self._selector.select(timeout):
                    self._dispatch(key, events)
                if time.monotonic() >= next_tick:
                    next_tick = max(next_tick + self.period_s, time.monotonic())
                    self._judge_pending()
                    self._broadcast_position()
            except Exception:  # a bug must not silently end the server for every Stellarium
                log.exception("Stellarium server: unexpected error; carrying on")
                self._stopping.wait(self.period_s)

    def _dispatch(self, key: selectors.SelectorKey, events: int) -> None:
        if key.data == "accept":
            self._accept()
        elif key.data == "wake":
            with contextlib.suppress(OSError):
                self._wake_r.recv(64)
        else:
            client: _Client = key.data
            if events & selectors.EVENT_READ:
                self._read(client)
            if events & selectors.EVENT_WRITE and client.sock.fileno() in self._clients:
                self._flush(client)

    def _accept(self) -> None:
        assert self._listener is not None
        while True:
            try:
                sock, peer = self._listener.accept()
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:  # e.g. out of file descriptors: keep serving the others
                log.warning("Stellarium server: accept failed: %s", exc)
                return
            address = f"{peer[0]}:{peer[1]}"
            if not self.allowlist.allows(peer[0]):
                self._turn_away("network", address, f"{peer[0]} is not in stellarium.allowed_networks "
                                                    f"(add its network on the setup page)")
                sock.close()
                continue
            if len(self._clients) >= self.max_clients:
                log.warning("Stellarium %s refused: already %d connected", address, len(self._clients))
                sock.close()
                continue
            sock.setblocking(False)
            with contextlib.suppress(OSError):
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            client = _Client(sock, address, time.time())  # pending: a client after its first valid message
            with self._lock:
                self._clients[sock.fileno()] = client
            self._selector.register(sock, selectors.EVENT_READ, client)

    def _promote(self, client: _Client) -> None:
        """A pending connection proved to be Stellarium: a client from now on."""
        with self._lock:
            client.pending = False
            connected = sum(1 for c in self._clients.values() if not c.pending)
        log.info("Stellarium connected from %s (%d connected)", client.address, connected)
        self._set_hold(True)
        self._send_position_to(client)

    def _judge_pending(self) -> None:
        """Promote pending connections that stayed silent (Stellarium's opening); close stalled ones."""
        now = time.monotonic()
        for client in [c for c in self._clients.values() if c.pending]:
            if not client.inbuf and now - client.accepted >= QUIET_OPENING_S:
                self._promote(client)
            elif client.inbuf and now - client.accepted >= OPENING_TIMEOUT_S:
                self._close_pending(client, f"an unfinished first message ({len(client.inbuf)} bytes) "
                                            f"after {OPENING_TIMEOUT_S:.0f} s")

    def _read(self, client: _Client) -> None:
        try:
            data = client.sock.recv(4096)
        except (BlockingIOError, InterruptedError):
            return
        except OSError as exc:
            self._drop(client, f"connection error: {exc}", level=logging.INFO)
            return
        if not data:
            if client.pending:
                self._close_pending(client, None)
                return
            reason = f"closed the connection in mid-message ({len(client.inbuf)} bytes)" if client.inbuf else \
                "disconnected"
            self._drop(client, reason, level=logging.WARNING if client.inbuf else logging.INFO)
            return
        client.inbuf += data
        try:
            self._parse(client)
        except _BadInput as exc:
            if client.pending:
                self._close_pending(client, f"not Stellarium's protocol ({exc}; an HTTP request from a web "
                                            f"browser, or another program)")
                return
            self._record_error(client.address, f"dropped: {exc}")
            self._drop(client, f"dropped: {exc}", level=logging.WARNING)

    def _parse(self, client: _Client) -> None:
        """Frame and handle every complete message in the client's buffer; raise _BadInput on garbage.

        The length is judged from its two bytes alone, so a connection written a byte at a time
        is refused as soon as the first two bytes are in.
        """
        buf = client.inbuf
        while len(buf) >= 2:
            length = int.from_bytes(buf[:2], "little")
            if length < HEADER.size or length > MAX_MESSAGE_BYTES:
                raise _BadInput(f"message length {length} (allowed {HEADER.size}..{MAX_MESSAGE_BYTES})")
            if len(buf) < HEADER.size:
                return
            kind = HEADER.unpack_from(buf)[1]
            if kind == MSG_GOTO and length != GOTO.size:
                raise _BadInput(f"goto message of {length} bytes instead of {GOTO.size}")
            if len(buf) < length:
                return
            message = bytes(buf[:length])
            del buf[:length]
            goto = self._goto(client, message) if kind == MSG_GOTO else None  # checked before it counts
            if client.pending:
                self._promote(client)
            with self._lock:
                client.messages += 1
            if goto is not None:
                self._queue_goto(goto)
            else:
                log.debug("Stellarium %s: skipped a message of unknown type %d (%d bytes)",
                          client.address, kind, length)

    @staticmethod
    def _goto(client: _Client, message: bytes) -> _Goto:
        _, _, client_us, ra_raw, dec_raw = GOTO.unpack(message)
        if abs(dec_raw) > _DEC_QUARTER:
            raise _BadInput(f"goto declination {dec_from_wire(dec_raw):.3f} is beyond +-90 degrees")
        log.debug("Stellarium %s: goto message time=%d ra=0x%08x dec=%d", client.address, client_us, ra_raw, dec_raw)
        return _Goto(client.address, ra_from_wire(ra_raw), dec_from_wire(dec_raw), time.time())

    def _queue_goto(self, goto: _Goto) -> None:
        with self._work:
            if self._pending_goto is not None:
                log.info("Stellarium goto from %s replaced by a newer one before it started",
                         self._pending_goto.address)
            self._pending_goto = goto
            self._work.notify_all()

    def _queue(self, client: _Client, data: bytes) -> None:
        if len(client.outbuf) + len(data) > MAX_PENDING_OUTPUT:
            self._drop(client, "dropped: not reading its position messages", level=logging.WARNING)
            return
        was_empty = not client.outbuf
        client.outbuf += data
        self._flush(client)
        if was_empty and client.outbuf and client.sock.fileno() in self._clients:
            self._selector.modify(client.sock, selectors.EVENT_READ | selectors.EVENT_WRITE, client)

    def _flush(self, client: _Client) -> None:
        try:
            sent = client.sock.send(client.outbuf)
        except (BlockingIOError, InterruptedError):
            return
        except OSError as exc:
            self._drop(client, f"connection error: {exc}", level=logging.INFO)
            return
        del client.outbuf[:sent]
        if not client.outbuf:
            with contextlib.suppress(KeyError, ValueError):
                self._selector.modify(client.sock, selectors.EVENT_READ, client)

    def _remove(self, client: _Client) -> int | None:
        """Forget a connection (the caller closes it): the clients still connected, or None if already gone."""
        with self._lock:
            if self._clients.get(client.sock.fileno()) is not client:
                return None
            del self._clients[client.sock.fileno()]
            remaining = sum(1 for c in self._clients.values() if not c.pending)
        with contextlib.suppress(KeyError, ValueError):
            self._selector.unregister(client.sock)
        return remaining

    def _close_pending(self, client: _Client, reason: str | None) -> None:
        """Close a connection that never became a client; ``reason`` None: it simply went away."""
        if self._remove(client) is None:
            return
        if reason is None:
            log.debug("Stellarium port: %s closed before its first message", client.address)
        else:
            self._turn_away("protocol", client.address, reason)
        client.sock.close()

    def _drop(self, client: _Client, reason: str, *, level: int) -> None:
        if client.pending:
            self._close_pending(client, None)
            return
        remaining = self._remove(client)
        if remaining is None:
            return
        log.log(level, "Stellarium %s %s (%d still connected)", client.address, reason, remaining)
        client.sock.close()
        if remaining == 0:
            self._set_hold(False)

    # -- the position stream -------------------------------------------------------------------

    def _position_message(self) -> bytes | None:
        """The current position in the configured equinox, or None while the mount has none."""
        try:
            ra, dec = self.telescope.right_ascension(), self.telescope.declination()
            when = self.telescope.clock.utc_now()
        except AlpacaError as exc:
            if not self._no_position_logged:
                log.debug("Stellarium: no position to send: %s", exc.message)
                self._no_position_logged = True
            return None
        self._no_position_logged = False
        if self.equinox == "J2000":
            ra, dec = apparent_to_j2000(ra, dec, when, self.telescope.settings.site)
        # TIME is Stellarium's clock (the wall clock), not the mount's: it interpolates with it.
        now_us = time.time_ns() // 1000
        message = POSITION.pack(POSITION.size, MSG_POSITION, now_us, ra_to_wire(ra), dec_to_wire(dec), 0)
        log.debug("Stellarium position %s: RA %.6f h Dec %+.5f deg", self.equinox, ra, dec)
        return message

    def _send_position_to(self, client: _Client) -> None:
        message = self._position_message()
        if message is not None:
            self._queue(client, message)

    def _broadcast_position(self) -> None:
        clients = [c for c in self._clients.values() if not c.pending]
        if not clients:
            return
        message = self._position_message()
        if message is None:
            return
        for client in clients:
            self._queue(client, message)

    # -- worker thread: telescope hold and gotos -----------------------------------------------

    def _set_hold(self, wanted: bool) -> None:
        with self._work:
            self._want_hold = wanted
            self._work.notify_all()

    def _work_loop(self) -> None:
        current_client.set(BRIDGE_CLIENT)  # the Telescope reference-counts callers by this key
        while True:
            with self._work:
                while not self._work_due():
                    self._work.wait(timeout=1.0)
                stopping = self._stopping.is_set()
                want, goto = self._want_hold and not stopping, self._pending_goto
                self._pending_goto = None
            self._reconcile_hold(want)
            if stopping:
                return  # released above; the Telescope itself is shut down after the bridges
            if goto is not None:
                self._run_goto(goto)

    def _work_due(self) -> bool:
        if self._pending_goto is not None or self._stopping.is_set():
            return True
        if self._held and BRIDGE_CLIENT not in self.telescope.connection.clients():
            self._held = False  # let go of by the Telescope (e.g. reset): take it again if still wanted
        if self._want_hold == self._held:
            return False
        retry_at = (self._hold_failed_at or 0.0) + HOLD_RETRY_S
        return not self._want_hold or time.monotonic() >= retry_at

    def _reconcile_hold(self, want: bool) -> None:
        if want == self._held:
            return
        try:
            self.telescope.connection.set_connected(want)
        except AlpacaError as exc:
            self._hold_failed_at = time.monotonic()
            log.warning("Stellarium: cannot connect the telescope: %s", exc.message)
            self._record_error("", f"cannot connect the telescope: {exc.message}")
            return
        self._held = want
        self._hold_failed_at = None

    def _run_goto(self, goto: _Goto) -> None:
        summary = f"goto {goto.ra_hours:.4f} h {goto.dec_deg:+.3f}° {self.equinox}"  # the setup page shows it
        record: dict[str, Any] = {"time": _iso(goto.received), "client": goto.address, "command": summary,
                                  "equinox": self.equinox, "ra_hours": goto.ra_hours, "dec_degrees": goto.dec_deg}
        try:
            ra, dec = goto.ra_hours, goto.dec_deg
            if self.equinox == "J2000":
                ra, dec = j2000_to_apparent(ra, dec, self.telescope.clock.utc_now(), self.telescope.settings.site)
            record.update(mount_ra_hours=ra, mount_dec_degrees=dec)
            log.info("Stellarium goto from %s: RA %.5f h Dec %+.4f deg %s (mount RA %.5f h Dec %+.4f deg)",
                     goto.address, goto.ra_hours, goto.dec_deg, self.equinox, ra, dec)
            self.telescope.slew_to_coordinates_async(ra, dec)
            record["result"] = "slewing"
        except AlpacaError as exc:
            record["result"] = f"refused: {exc.message}"
            log.warning("Stellarium goto from %s refused: %s", goto.address, exc.message)
            self._record_error(goto.address, f"goto refused: {exc.message}")
        except Exception as exc:  # a bug here must not end the worker for everyone
            record["result"] = f"failed: {exc}"
            log.exception("Stellarium goto from %s failed", goto.address)
            self._record_error(goto.address, f"goto failed: {exc}")
        with self._lock:
            self._last_command = record
