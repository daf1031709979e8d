"""The shared ZWO-protocol TCP port: the mount's WiFi port (4030), served by alpaca-zwo.

INDI's ``indi_lx200am5`` and other ZWO/LX200 drivers that can reach a mount over TCP connect here
instead of to the mount, and share it with every Alpaca client: what they ask is answered from the
server's state snapshot, what they command goes through the Telescope (:mod:`.zwo_backend`, behind
``zwo/dispatch.py``'s command table).

Each program gets a thread, its own :class:`~alpaca_zwo.zwo.request_framer.RequestFramer` (so junk from one
program is resynchronised without touching the others) and its own target and move speeds. While
any program is connected the bridge holds the Telescope connected as one client; each program also
appears in the client registry under its own key, so the MoveAxis watchdog stops a move whose
program went silent, and a program that disconnects has the moves it started stopped. A program
that floods commands, sends a long run of garbage or does not read its replies is dropped alone.

At the door (:mod:`.admission`): a connection from outside ``zwo_port.allowed_networks`` is closed
unread, and one whose first bytes are not the ZWO/LX200 protocol (an HTTP request from a web page,
TLS, noise) is closed before anything runs. Until its first command a connection is not a program:
it is not shown, does not connect the Telescope and is not logged as connected.
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import socket
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from datetime import datetime, timezone
from typing import TYPE_CHECKING, Any

from .._exceptions import AlpacaError, AlpacaZwoError
from ..clients import ClientKey, current_client
from ..zwo import dispatch
from ..zwo.dispatch import Refusal
from ..zwo.protocol import match_command
from ..zwo.request_framer import RequestFramer
from .admission import DoorLog, Network, NetworkAllowlist, NotZwo, ZwoOpening
from .zwo_backend import Session, SharedZone, TelescopeBackend

if TYPE_CHECKING:
    from ..telescope.device import Telescope

__all__ = ["ZwoPortBridge"]

log = logging.getLogger(__name__)

#: The Telescope sees the whole port as this one client.
BRIDGE_KEY = ClientKey("zwo-port", 0)
RECV_BYTES = 4096
#: Garbage (bytes that make no known command) tolerated since the last known command.
MAX_JUNK_BYTES = 8192
#: Token bucket: a driver sends a handful of commands a second, a burst of ~20 at connect.
COMMAND_RATE = 200.0
COMMAND_BURST = 400.0
#: Bytes: a driver sends ~100 B/s; anything near this is garbage however it is dressed up.
BYTE_RATE = 16384.0
BYTE_BURST = 65536.0
#: A program that does not read its replies for this long is dropped.
SEND_TIMEOUT_S = 5.0
POLL_S = 0.5
#: A connection that has not sent its first command by then is closed (a person typing into nc has a minute).
OPENING_TIMEOUT_S = 60.0


@dataclass
class _Bucket:
    """A token bucket: ``rate`` per second sustained, ``burst`` at once."""

    rate: float
    burst: float
    tokens: float = 0.0
    refilled: float = field(default_factory=time.monotonic)

    def __post_init__(self) -> None:
        self.tokens = self.burst

    def take(self, amount: float = 1.0) -> bool:
        now = time.monotonic()
        self.tokens = min(self.burst, self.tokens + (now - self.refilled) * self.rate)
        self.refilled = now
        if self.tokens < amount:
            return False
        self.tokens -= amount
        return True


@dataclass
class _Program:
    """One connected program, as the setup page shows it."""

    sock: socket.socket
    address: str
    backend: TelescopeBackend  # its session: its own target and move speeds
    since: float = field(default_factory=time.time)
    commands: int = 0
    refusals: int = 0
    last_command: str = ""
    command_budget: _Bucket = field(default_factory=lambda: _Bucket(COMMAND_RATE, COMMAND_BURST))
    byte_budget: _Bucket = field(default_factory=lambda: _Bucket(BYTE_RATE, BYTE_BURST))
    junk: int = 0
    thread: threading.Thread | None = None
    #: False until its first command: until then it is only a connection, not a program.
    identified: bool = False

    @property
    def session(self) -> Session:
        return self.backend.session


class _Drop(Exception):
    """End this program's connection, with the reason logged."""


def _iso(stamp: float) -> str:
    return datetime.fromtimestamp(stamp, timezone.utc).isoformat(timespec="seconds")


class ZwoPortBridge:
    """Listens on ``host:port`` and serves the ZWO protocol on top of ``telescope`` (Telescope 0)."""

    def __init__(self, telescope: Telescope, host: str = "0.0.0.0", port: int = 4030, *,
                 local_networks: Callable[[], Iterable[Network]] | None = None) -> None:
        self.telescope = telescope
        self.host = host
        self._requested_port = port
        self.zone = SharedZone()  # the time zone programs set, one for the whole port as on the mount
        #: ``zwo_port.allowed_networks``, read live; ``local_networks`` says what "local" means.
        self.allowlist = NetworkAllowlist(lambda: telescope.settings.zwo_port.allowed_networks, local_networks)
        self._door_log = DoorLog(log)
        self._turned_away = 0
        self._last_turned_away: dict[str, Any] | None = None
        self._listener: socket.socket | None = None
        self._accept_thread: threading.Thread | None = None
        self._stopping = threading.Event()
        self._lock = threading.Lock()  # guards _programs and the counters below
        self._hold_lock = threading.Lock()  # serialises taking and releasing the Telescope connection
        self._holding = 0
        self._programs: dict[int, _Program] = {}
        self._ids = itertools.count(1)
        self._last_command: dict[str, Any] | None = None
        self._last_refusal: dict[str, Any] | None = None
        self._refusals = 0
        self._dropped = 0

    @property
    def port(self) -> int:
        """The bound port (the configured one, or the free port picked for 0)."""
        if self._listener is None:
            return self._requested_port
        return int(self._listener.getsockname()[1])

    @property
    def max_clients(self) -> int:
        return self.telescope.settings.zwo_port.max_clients

    # -- lifecycle -------------------------------------------------------------------------------

    def start(self) -> ZwoPortBridge:
        family = socket.AF_INET6 if ":" in self.host else socket.AF_INET
        listener = socket.socket(family, socket.SOCK_STREAM)
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            listener.bind((self.host, self._requested_port))
            listener.listen(32)
        except OSError:
            listener.close()
            raise
        listener.settimeout(POLL_S)
        self._listener = listener
        self._accept_thread = threading.Thread(target=self._accept_loop, name="zwo-port-accept", daemon=True)
        self._accept_thread.start()
        log.info("ZWO-protocol port listening on %s:%d (Telescope %d)", self.host, self.port,
                 self.telescope.device_index)
        return self

    def stop(self) -> None:
        """Close the port and every program's connection; the Telescope is released. Idempotent."""
        if self._stopping.is_set():
            return
        self._stopping.set()
        if self._listener is not None:
            self._listener.close()
        if self._accept_thread is not None:
            self._accept_thread.join(timeout=5)
        with self._lock:
            programs = list(self._programs.values())
        for program in programs:
            _shutdown(program.sock, close=False)  # its thread wakes up, cleans up and closes it
        for program in programs:
            if program.thread is not None:
                program.thread.join(timeout=5)
        log.info("ZWO-protocol port closed")

    # -- status for the setup page -----------------------------------------------------------------

    def status(self) -> dict[str, Any]:
        """Enabled, address, connected programs, the last command and the refusals, as plain JSON values."""
        with self._lock:
            programs = [
                {"address": p.address, "since": _iso(p.since), "commands": p.commands,
                 "refusals": p.refusals, "last_command": p.last_command}
                for p in self._programs.values() if p.identified
            ]
            return {
                "enabled": not self._stopping.is_set() and self._listener is not None,
                "host": self.host,
                "port": self.port,
                "programs": programs,
                "last_command": dict(self._last_command) if self._last_command else None,
                "refusals": self._refusals,
                "last_refusal": dict(self._last_refusal) if self._last_refusal else None,
                "dropped": self._dropped,
                # Connections closed at the door: from a network not allowed, or not the ZWO protocol.
                "turned_away": self._turned_away,
                "last_turned_away": dict(self._last_turned_away) if self._last_turned_away else None,
                "allowed_networks": [str(n) for n in self.allowlist.networks()],
            }

    # -- accepting -----------------------------------------------------------------------------------

    def _accept_loop(self) -> None:
        assert self._listener is not None
        while not self._stopping.is_set():
            try:
                sock, peer = self._listener.accept()
            except TimeoutError:
                continue
            except OSError:
                if self._stopping.is_set():
                    return
                time.sleep(0.05)  # e.g. out of descriptors: do not spin
                continue
            address = f"{peer[0]}:{peer[1]}"
            if not self.allowlist.allows(peer[0]):
                self._turn_away("network", address, f"{peer[0]} is not in zwo_port.allowed_networks "
                                                    f"(add its network on the setup page)")
                _shutdown(sock)
                continue
            self._admit(sock, address)

    def _turn_away(self, kind: str, address: str, reason: str) -> None:
        """Count and record a connection closed at the door; log it at most once a minute per kind."""
        with self._lock:
            self._turned_away += 1
            self._last_turned_away = {"address": address, "at": _iso(time.time()), "reason": reason}
        self._door_log.refused(kind, f"ZWO port: connection from {address} closed: {reason}")

    def _admit(self, sock: socket.socket, address: str) -> None:
        with self._lock:
            if len(self._programs) >= self.max_clients:
                self._dropped += 1
                full = True
            else:
                full = False
                ident = next(self._ids)
                # One client key per host, not per connection: a connection storm must not
                # crowd real clients out of the bounded client registry.
                host = address.rsplit(":", 1)[0]
                session = Session(ClientKey(f"zwo-port {host}", 0))
                program = _Program(sock, address, TelescopeBackend(self.telescope, session, self.zone))
                self._programs[ident] = program
        if full:
            log.warning("ZWO port: %s refused: %d programs already connected (zwo_port.max_clients)",
                        address, self.max_clients)
            _shutdown(sock)
            return
        program.thread = threading.Thread(target=self._serve, args=(ident, program), name=f"zwo-port-{ident}",
                                          daemon=True)
        program.thread.start()

    # -- one program -----------------------------------------------------------------------------------

    def _serve(self, ident: int, program: _Program) -> None:
        current_client.set(program.session.key)
        sock = program.sock
        held = False
        try:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            sock.settimeout(POLL_S)
            opening = self._opening(program)
            if opening is None:
                return
            held = self._hold()
            with self._lock:
                program.identified = True
            log.info("ZWO port: program %s connected (%d connected)", program.address, self._connected())
            self._read_loop(program, opening)
        except NotZwo as exc:
            self._turn_away("protocol", program.address, f"{exc}")
        except _Drop as exc:
            with self._lock:
                self._dropped += 1
            log.warning("ZWO port: program %s dropped: %s", program.address, exc)
        except AlpacaError as exc:
            log.warning("ZWO port: program %s refused: the mount cannot be connected: %s", program.address,
                        exc.message)
        except OSError as exc:
            log.info("ZWO port: program %s connection error: %s", program.address, exc)
        finally:
            self._stop_moves(program)
            _shutdown(sock)
            with self._lock:
                self._programs.pop(ident, None)
            if held:
                self._release()
            if program.identified:
                log.info("ZWO port: program %s disconnected (%d still connected)", program.address,
                         self._connected())

    def _connected(self) -> int:
        """Programs connected: connections that have sent their first command."""
        with self._lock:
            return sum(1 for p in self._programs.values() if p.identified)

    def _opening(self, program: _Program) -> bytes | None:
        """Read until the first command is complete: its bytes, or None when the connection ended first.

        Raises :class:`NotZwo` the moment the bytes cannot be a driver's (nothing has run by then).
        """
        judge = ZwoOpening()
        received = bytearray()
        deadline = time.monotonic() + OPENING_TIMEOUT_S
        while not self._stopping.is_set():
            if time.monotonic() > deadline:
                raise NotZwo(f"no command within {OPENING_TIMEOUT_S:.0f} s")
            try:
                data = program.sock.recv(RECV_BYTES)
            except TimeoutError:
                continue
            if not data:
                return None
            received += data
            if judge.feed(data):
                return bytes(received)
        return None

    def _read_loop(self, program: _Program, opening: bytes) -> None:
        framer = RequestFramer()
        self._take(program, framer, opening)
        while not self._stopping.is_set():
            try:
                data = program.sock.recv(RECV_BYTES)
            except TimeoutError:
                continue
            if not data:
                return  # the program closed its end
            self._take(program, framer, data)

    def _take(self, program: _Program, framer: RequestFramer, data: bytes) -> None:
        if not program.byte_budget.take(len(data)):
            raise _Drop(f"flooding (more than {BYTE_RATE / 1024:.0f} KiB/s)")
        program.junk += len(data)
        for body in framer.feed(data):
            self._command(program, body)
        if program.junk > MAX_JUNK_BYTES:
            raise _Drop(f"{program.junk} bytes without a known command")

    def _command(self, program: _Program, body: str) -> None:
        if not program.command_budget.take():
            raise _Drop(f"flooding (more than {COMMAND_RATE:.0f} commands/s)")
        self.telescope.registry.touch(program.session.key, "ZWO protocol")
        try:
            reply = dispatch.answer(program.backend, body)
            refused = None
        except Refusal as refusal:
            reply, refused = refusal.reply, refusal.reason
        except AlpacaZwoError as exc:  # the mount link failed under a command: a missing mount says nothing
            log.info("ZWO port :%s# failed: %s", body, exc)
            reply, refused = None, None
        except Exception:  # a bug must not end the program's connection; the mount would just be silent
            log.exception("ZWO port: %s :%s# failed", program.address, body)
            reply, refused = None, None
        known = reply is not None or refused is not None or match_command(body) is not None
        if known:
            program.junk = 0
        self._record(program, body, reply, refused)
        if reply:
            program.sock.settimeout(SEND_TIMEOUT_S)
            try:
                program.sock.sendall(reply.encode("latin-1"))
            except TimeoutError as exc:
                raise _Drop(f"it has not read its replies for {SEND_TIMEOUT_S:.0f} s") from exc
            finally:
                program.sock.settimeout(POLL_S)

    def _record(self, program: _Program, body: str, reply: str | None, refused: str | None) -> None:
        text = f":{body}#"
        stamp = time.time()
        with self._lock:
            program.commands += 1
            program.last_command = text
            self._last_command = {"command": text, "address": program.address, "at": _iso(stamp)}
            if refused is not None:
                program.refusals += 1
                self._refusals += 1
                self._last_refusal = {"command": text, "address": program.address, "at": _iso(stamp),
                                      "reason": refused}
        if refused is not None:
            log.info("ZWO port: %s %s refused (%s): %r", program.address, text, refused, reply)
        else:
            log.debug("ZWO port: %s %s -> %r", program.address, text, reply)

    # -- the Telescope connection and the moves a program leaves behind ------------------------------------

    def _hold(self) -> bool:
        """Count this program; the first one connects the Telescope (as the bridge's single client)."""
        with self._hold_lock:
            if self._holding == 0:
                token = current_client.set(BRIDGE_KEY)
                try:
                    self.telescope.connection.set_connected(True)
                finally:
                    current_client.reset(token)
            self._holding += 1
        return True

    def _release(self) -> None:
        with self._hold_lock:
            self._holding -= 1
            if self._holding == 0:
                token = current_client.set(BRIDGE_KEY)
                try:
                    self.telescope.connection.set_connected(False)
                except AlpacaError as exc:
                    log.warning("ZWO port: releasing the telescope failed: %s", exc.message)
                finally:
                    current_client.reset(token)

    def _stop_moves(self, program: _Program) -> None:
        """A program that goes away must not leave an axis moving (the mount itself never stops)."""
        moving = self.telescope.mount.state.moving_axes
        for axis in sorted(program.session.moved_axes & set(moving)):
            try:
                self.telescope.move_axis(axis, 0.0)
                log.info("ZWO port: stopped axis %d that %s left moving", axis, program.address)
            except AlpacaError as exc:
                log.warning("ZWO port: could not stop axis %d after %s left: %s", axis, program.address,
                            exc.message)
        program.session.moved_axes.clear()


def _shutdown(sock: socket.socket, close: bool = True) -> None:
    """Shut a program's socket down so its blocked recv returns at once; close it unless its thread will."""
    with contextlib.suppress(OSError):
        sock.shutdown(socket.SHUT_RDWR)
    if close:
        sock.close()
