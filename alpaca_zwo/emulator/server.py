"""Serve an emulated mount over TCP (like its WiFi port 4030) and a pseudo-terminal (like USB).

Each TCP connection and the pty is a "line" with its own request framer, its own baud-rate
pacing and its own counters; all lines talk to the same mount, as several apps on the mount's
WiFi do. Pacing models a 8N1 serial line (10 bits per byte): a request is acted on only when its
last byte would have arrived, and reply bytes leave one at a time at the line rate, so an
exchange costs (len(request) + len(reply)) x 10 / baud seconds, as on the real USB port. Line
timing is real time, not emulated time: ``--speed 10`` speeds up the sky, not the UART.
"""

from __future__ import annotations

import contextlib
import errno
import itertools
import logging
import os
import queue
import select
import socket
import struct
import sys
import threading
import time
from typing import Any

from ..zwo.request_framer import RequestFramer
from .faults import FaultEvent, Faults
from .model import MountModel
from .responder import ModelResponder

__all__ = ["EmulatorServer", "pty_support_error"]

_log = logging.getLogger(__name__)

_BITS_PER_BYTE = 10  # start + 8 data + stop
_POLL_S = 0.1  # how often idle loops look at the stop flag


def pty_support_error() -> str | None:
    """Why this interpreter cannot serve a pseudo-terminal, or None when it can.

    The pty is the only POSIX-only part of the emulator (Windows has no ``os.openpty``, ``fcntl``
    or ``tty``), so those modules are imported here, on demand, and never on the TCP-only path.
    """
    if not hasattr(os, "openpty"):
        return "a pseudo-terminal (--pty) needs a POSIX system (Linux, macOS); use the TCP port instead"
    try:
        import fcntl  # noqa: F401
        import tty  # noqa: F401
    except ImportError as exc:
        return f"a pseudo-terminal (--pty) needs the POSIX modules fcntl and tty ({exc}); use the TCP port instead"
    return None


def _sleep_until(deadline: float, cancelled: threading.Event | None = None) -> None:
    """Sleep to an absolute ``time.monotonic()`` deadline (absolute, so per-byte errors don't add up)."""
    while True:
        remaining = deadline - time.monotonic()
        if remaining <= 0.0:
            return
        if cancelled is not None:
            if cancelled.wait(min(remaining, _POLL_S)):
                return
        else:
            time.sleep(remaining)


class _Line:
    """One serial line's worth of framing, pacing, reply queue and counters.

    Subclasses supply the byte transport (a TCP socket or the pty master).
    """

    kind = "line"

    def __init__(self, server: EmulatorServer, line_id: int, peer: str) -> None:
        self.server = server
        self.id = line_id
        self.peer = peer
        self.framer = RequestFramer()
        self.closed = threading.Event()
        self._replies: queue.Queue[bytes | None] = queue.Queue()
        self._rx_free = 0.0  # when the incoming wire is free again
        self._tx_free = 0.0  # when the outgoing wire is free again
        #: When (time.monotonic) the bytes of the last read reached this host, if the transport can
        #: tell (the kernel's receive stamp): the reader thread may wake a fraction of a millisecond
        #: later, more after a long idle than a short one, which at 5x would make a stop written after
        #: 250 ms of quiet act later than the move written right after a reply.
        self._rx_stamp: float | None = None
        self._counter_lock = threading.Lock()
        self.bytes_in = 0
        self.bytes_out = 0
        self.exchanges = 0  # requests acted on (with or without a reply)
        self.replies = 0  # replies produced by the mount (before drop/garble faults)
        self.opened = time.time()
        self._threads: list[threading.Thread] = []

    # transport hooks
    def _recv(self) -> bytes | None:
        """Bytes from the client; b"" when idle (poll again), None when the line is gone."""
        raise NotImplementedError

    def _send(self, data: bytes) -> None:
        raise NotImplementedError

    def _shutdown_transport(self) -> None:
        """Wake the reader (any thread may call this); the reader then releases the transport."""
        raise NotImplementedError

    def _release_transport(self) -> None:
        """Close the descriptors; only the reader calls it, so no fd is reused under its feet."""
        raise NotImplementedError

    # lifecycle
    def start(self) -> None:
        for target, name in ((self._read_loop, "rx"), (self._write_loop, "tx")):
            thread = threading.Thread(target=target, name=f"emulator-{self.kind}{self.id}-{name}", daemon=True)
            self._threads.append(thread)
            thread.start()

    def close(self) -> None:
        if self.closed.is_set():
            return
        self.closed.set()
        self._replies.put(None)
        with contextlib.suppress(OSError):
            self._shutdown_transport()

    def join(self, timeout: float = 2.0) -> None:
        for thread in self._threads:
            if thread is not threading.current_thread():
                thread.join(timeout)

    # the two loops
    def _read_loop(self) -> None:
        try:
            while not self.closed.is_set():
                data = self._recv()
                if data is None:
                    break
                if data:
                    self._take(data, time.monotonic() if self._rx_stamp is None else self._rx_stamp)
        except Exception:  # never let a line take the server down
            if not self.closed.is_set():
                _log.exception("line %s reader failed", self.id)
        finally:
            self.close()
            with contextlib.suppress(OSError):
                self._release_transport()
            self.server._line_closed(self)

    def _take(self, data: bytes, received: float) -> None:
        with self._counter_lock:
            self.bytes_in += len(data)
        baud = self.server.baud
        if not baud:
            for body in self.framer.feed(data):
                self._process(body)
            return
        byte_time = _BITS_PER_BYTE / baud
        start = max(self._rx_free, received)
        self._rx_free = start + len(data) * byte_time
        for index in range(len(data)):
            for body in self.framer.feed(data[index : index + 1]):
                _sleep_until(start + (index + 1) * byte_time, self.closed)
                if self.closed.is_set():
                    return
                self._process(body)

    def _process(self, body: str) -> None:
        held = self.server.responder.held_ack(body)  # judged as the request arrives, before it acts
        reply = self.server.responder.handle(body)
        if _log.isEnabledFor(logging.DEBUG):
            _log.debug("line %s :%s# -> %r", self.id, body, reply)
        with self._counter_lock:
            self.exchanges += 1
            if reply is not None:
                self.replies += 1
        if reply is None:
            return
        out = self.server.faults.apply_to_reply(reply.encode("latin-1"))
        if not out or held == "never":
            return
        if held == "late":
            self._send_after_slew(out)
            return
        self._replies.put(out)

    def _send_after_slew(self, reply: bytes) -> None:
        """A busy mount's late acknowledgement: queued once the slew has ended, while the replies to
        later requests (position reads) go out meanwhile (``FirmwareVariant.ack_while_slewing``)."""
        def release() -> None:
            while self.server.model.slewing():
                if self.closed.wait(0.005):
                    return
            self._replies.put(reply)

        threading.Thread(target=release, name=f"emulator-{self.kind}{self.id}-late-ack", daemon=True).start()

    def _write_loop(self) -> None:
        faults = self.server.faults
        try:
            while True:
                item = self._replies.get()
                if item is None or self.closed.is_set():
                    return
                baud = self.server.baud
                chunks = [item] if not baud else [item[i : i + 1] for i in range(len(item))]
                for chunk in chunks:
                    _sleep_until(faults.stall_until(), self.closed)  # a WiFi stall: nothing leaves
                    if self.closed.is_set():
                        return
                    if baud:
                        due = max(self._tx_free, time.monotonic()) + _BITS_PER_BYTE / baud
                        _sleep_until(due, self.closed)
                        self._tx_free = due
                    self._send(chunk)
                    with self._counter_lock:
                        self.bytes_out += len(chunk)
        except OSError:
            self.close()
        except Exception:
            _log.exception("line %s writer failed", self.id)
            self.close()

    def stats(self) -> dict[str, Any]:
        with self._counter_lock:
            return {
                "id": self.id,
                "kind": self.kind,
                "peer": self.peer,
                "open": not self.closed.is_set(),
                "bytes_in": self.bytes_in,
                "bytes_out": self.bytes_out,
                "exchanges": self.exchanges,
                "replies": self.replies,
            }


#: SO_TIMESTAMPNS: Python's socket module does not name it; 35 on Linux (x86, ARM, RISC-V).
_SO_TIMESTAMPNS = getattr(socket, "SO_TIMESTAMPNS", 35 if sys.platform == "linux" else None)


def _kernel_stamp(ancdata: list[tuple[int, int, bytes]]) -> float | None:
    """The SO_TIMESTAMPNS receive stamp in ``ancdata`` (wall-clock seconds, as ``time.time()``), or None."""
    for level, kind, payload in ancdata:
        if level == socket.SOL_SOCKET and kind == _SO_TIMESTAMPNS and len(payload) >= 16:
            seconds, nanoseconds = struct.unpack("qq", payload[:16])  # type: tuple[int, int]
            return seconds + nanoseconds / 1e9
    return None


#: A receive stamp older than this is taken for a step of the wall clock, not a late reader.
_STAMP_MAX_AGE_S = 30.0


def _monotonic_arrival(wall_stamp: float | None) -> float:
    """A kernel receive stamp as a time.monotonic() instant. However late the reader got to the bytes
    (a stalled machine), the stamp says when they came; only a wall-clock step (the stamp in the future,
    or older than any stall) falls back to the reader's own clock."""
    now = time.monotonic()
    if wall_stamp is None:
        return now
    age = time.time() - wall_stamp
    return now - age if 0.0 <= age < _STAMP_MAX_AGE_S else now


class _TcpLine(_Line):
    kind = "tcp"

    def __init__(self, server: EmulatorServer, line_id: int, sock: socket.socket, peer: str) -> None:
        super().__init__(server, line_id, peer)
        self.sock = sock
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._stamped = False  # kernel receive stamps (Linux); elsewhere the reader's clock
        if _SO_TIMESTAMPNS is not None and hasattr(sock, "recvmsg"):
            with contextlib.suppress(OSError):
                sock.setsockopt(socket.SOL_SOCKET, _SO_TIMESTAMPNS, 1)
                self._stamped = True

    def _recv(self) -> bytes | None:
        try:
            if self._stamped:
                data, ancdata, _flags, _address = self.sock.recvmsg(4096, socket.CMSG_SPACE(16))
                self._rx_stamp = _monotonic_arrival(_kernel_stamp(ancdata))
            else:
                data = self.sock.recv(4096)
        except OSError:
            return None
        return data or None

    def _send(self, data: bytes) -> None:
        self.sock.sendall(data)

    def _shutdown_transport(self) -> None:
        self.sock.shutdown(socket.SHUT_RDWR)

    def _release_transport(self) -> None:
        self.sock.close()


class _PtyLine(_Line):
    """The pty master; the slave end (``pty_path``) is what a client opens with pyserial."""

    kind = "pty"

    def __init__(self, server: EmulatorServer, line_id: int) -> None:
        import fcntl  # POSIX-only, so imported only when a pty is really wanted
        import tty

        master, slave = os.openpty()
        tty.setraw(slave)  # no echo, no line discipline: bytes pass as on a CDC-ACM port
        flags = fcntl.fcntl(master, fcntl.F_GETFL)
        fcntl.fcntl(master, fcntl.F_SETFL, flags | os.O_NONBLOCK)
        self.master = master
        self.slave = slave  # held open so the master never sees EIO between clients
        self.path = os.ttyname(slave)
        self._fd_lock = threading.Lock()
        super().__init__(server, line_id, self.path)

    def _recv(self) -> bytes | None:
        with self._fd_lock:
            fd = self.master
        if fd < 0:
            return None
        try:
            ready, _, _ = select.select([fd], [], [], _POLL_S)
            if not ready:
                return b""
            return os.read(fd, 4096) or b""
        except BlockingIOError:
            return b""
        except OSError as exc:
            if exc.errno == errno.EIO:  # no slave open right now
                time.sleep(_POLL_S)
                return b""
            return None
        except ValueError:  # fd closed under us
            return None

    def _send(self, data: bytes) -> None:
        with self._fd_lock:
            fd = self.master
        if fd < 0:
            return
        # Nobody reads the port and its buffer is full: the bytes are lost, as on USB.
        with contextlib.suppress(BlockingIOError):
            os.write(fd, data)

    def _shutdown_transport(self) -> None:
        pass  # the reader polls the closed flag every _POLL_S and then releases the fds

    def _release_transport(self) -> None:
        with self._fd_lock:
            fds = (self.master, self.slave)
            self.master = self.slave = -1
        for fd in fds:
            if fd >= 0:
                with contextlib.suppress(OSError):
                    os.close(fd)


class EmulatorServer:
    """TCP (and optionally pty) front end of a :class:`MountModel`.

    ``port=0`` picks a free port (read it back from ``.port``); ``baud=0`` disables pacing.
    ``pty_link`` names a symlink kept pointing at the current pty, which changes after a
    hang-up fault (like a USB device that re-enumerates under a stable udev name).
    """

    def __init__(
        self,
        model: MountModel,
        host: str = "127.0.0.1",
        port: int = 4030,
        baud: int = 9600,
        pty: bool = False,
        *,
        pty_link: str | None = None,
        tcp: bool = True,
    ) -> None:
        if baud < 0:
            raise ValueError("baud must be >= 0")
        if pty and (reason := pty_support_error()):
            raise OSError(errno.ENOSYS, reason)
        self.model = model
        self.responder = ModelResponder(model)
        self.host = host
        self.baud = int(baud)
        self._want_port = port
        self._want_pty = pty
        self._want_tcp = tcp
        self._pty_link = pty_link
        self._listener: socket.socket | None = None
        self._lines: dict[int, _Line] = {}
        self._closed_totals = {"bytes_in": 0, "bytes_out": 0, "exchanges": 0, "replies": 0, "connections": 0}
        self._lock = threading.Lock()
        self._accept_lock = threading.Lock()
        self._ids = itertools.count(1)
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._pty_line: _PtyLine | None = None
        self.refused = 0
        self._started = False

    # ---------------------------------------------------------------- lifecycle

    @property
    def faults(self) -> Faults:
        return self.model.faults

    @property
    def port(self) -> int:
        """The bound TCP port (0 before ``start()`` or without TCP)."""
        return self._listener.getsockname()[1] if self._listener is not None else 0

    @property
    def pty_path(self) -> str | None:
        """Device name of the current pty slave, openable with ``serial.Serial(path)``."""
        line = self._pty_line
        return line.path if line is not None else None

    @property
    def pty_link(self) -> str | None:
        return self._pty_link

    def start(self) -> EmulatorServer:
        if self._started:
            return self
        self._started = True
        self._stop.clear()
        self.faults.add_listener(self._on_fault)
        if self._want_tcp:
            listener = socket.socket(socket.AF_INET6 if ":" in self.host else socket.AF_INET)
            listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            listener.bind((self.host, self._want_port))
            listener.listen(16)
            listener.setblocking(False)  # the accept loop waits in select()
            self._listener = listener
            self._spawn(self._accept_loop, "emulator-accept")
        if self._want_pty:
            self._open_pty()
            self._spawn(self._pty_supervisor, "emulator-pty")
        _log.info("emulator serving tcp %s:%s pty %s baud %s", self.host, self.port, self.pty_path, self.baud)
        return self

    def stop(self) -> None:
        if not self._started:
            return
        self._started = False
        self._stop.set()
        self.faults.remove_listener(self._on_fault)
        if self._listener is not None:
            with contextlib.suppress(OSError):
                self._listener.shutdown(socket.SHUT_RDWR)  # wakes the accept loop's select() at once
        with self._accept_lock:  # no line can be half-registered past this point
            self._close_lines(include_pty=True)
        for thread in self._threads:
            thread.join(2.0)
        self._threads.clear()
        if self._listener is not None:
            self._listener.close()
            self._listener = None
        with self._lock:
            lines = list(self._lines.values())
        for line in lines:
            line.join()
        if self._pty_link:
            with contextlib.suppress(OSError):
                os.unlink(self._pty_link)

    def __enter__(self) -> EmulatorServer:
        return self.start()

    def __exit__(self, *_exc: object) -> None:
        self.stop()

    def _spawn(self, target: Any, name: str) -> None:
        thread = threading.Thread(target=target, name=name, daemon=True)
        self._threads.append(thread)
        thread.start()

    # ---------------------------------------------------------------- TCP

    def _accept_loop(self) -> None:
        listener = self._listener
        assert listener is not None
        while not self._stop.is_set():
            try:
                ready, _, _ = select.select([listener], [], [], _POLL_S)
            except (OSError, ValueError):
                return  # the listener was closed under us: the server is stopping
            if not ready:
                continue
            # Under the accept lock, so a close fault cannot slip between accept and registration.
            with self._accept_lock:
                if self._stop.is_set():
                    return
                try:
                    sock, address = listener.accept()
                except BlockingIOError:
                    continue  # a close fault drained it first
                except OSError:
                    if self._stop.is_set():
                        return
                    time.sleep(_POLL_S)
                    continue
                try:
                    if self.faults.refusing():
                        self._reset(sock)  # outage or reboot: nobody home
                        self.refused += 1
                        continue
                    sock.setblocking(True)
                    line = _TcpLine(self, next(self._ids), sock, f"{address[0]}:{address[1]}")
                    with self._lock:
                        self._lines[line.id] = line
                    line.start()
                except Exception:
                    _log.exception("accepting a connection failed")
                    with contextlib.suppress(OSError):
                        sock.close()

    @staticmethod
    def _reset(sock: socket.socket) -> None:
        """Close with RST rather than a polite FIN, as a vanished peer looks to the client."""
        with contextlib.suppress(OSError):
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        sock.close()

    def _drop_pending(self) -> None:
        """Reset connections the kernel completed but the accept loop has not picked up yet.

        Without this a client that connected a moment before a close fault would survive it
        (its handshake finished in the backlog), which a real WiFi drop or reboot would not allow.
        """
        listener = self._listener
        if listener is None:
            return
        while True:
            try:
                sock, _ = listener.accept()
            except (BlockingIOError, OSError):
                return
            self._reset(sock)

    # ---------------------------------------------------------------- pty

    def _open_pty(self) -> None:
        line = _PtyLine(self, next(self._ids))
        with self._lock:
            self._lines[line.id] = line
        self._pty_line = line
        if self._pty_link:
            temp = f"{self._pty_link}.{os.getpid()}.tmp"
            with contextlib.suppress(OSError):
                os.unlink(temp)
            os.symlink(line.path, temp)
            os.replace(temp, self._pty_link)
        line.start()

    def _pty_supervisor(self) -> None:
        """Re-create the pty after a hang-up once any outage is over (the USB device returns)."""
        while not self._stop.wait(_POLL_S):
            line = self._pty_line
            if line is not None and not line.closed.is_set():
                continue
            if self.faults.refusing():
                continue
            try:
                self._open_pty()
            except OSError:
                _log.exception("could not re-create the pty")

    def wait_pty(self, timeout: float = 5.0) -> str | None:
        """Block until a pty line is open (after a hang-up) and return its path."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            line = self._pty_line
            if line is not None and not line.closed.is_set():
                return line.path
            time.sleep(0.01)
        return None

    # ---------------------------------------------------------------- faults and bookkeeping

    def _on_fault(self, event: FaultEvent) -> None:
        if event.kind in ("close", "outage", "reboot"):
            self.close_connections()

    def close_connections(self) -> None:
        """Drop every line now, including connections still in the listen backlog."""
        with self._accept_lock:
            self._drop_pending()
            self._close_lines(include_pty=True)

    def _close_lines(self, include_pty: bool) -> None:
        with self._lock:
            lines = list(self._lines.values())
        for line in lines:
            if include_pty or line.kind != "pty":
                line.close()

    def _line_closed(self, line: _Line) -> None:
        with self._lock:
            if self._lines.pop(line.id, None) is None:
                return
            stats = line.stats()
            for key in ("bytes_in", "bytes_out", "exchanges", "replies"):
                self._closed_totals[key] += stats[key]
            self._closed_totals["connections"] += 1

    def connection_count(self) -> int:
        """Open TCP connections (the pty is not counted)."""
        with self._lock:
            return sum(1 for line in self._lines.values() if line.kind == "tcp" and not line.closed.is_set())

    def stats(self) -> dict[str, Any]:
        """Counters for benchmarks: totals since start and one entry per open line."""
        with self._lock:
            lines = [line.stats() for line in self._lines.values()]
            totals = dict(self._closed_totals)
        for entry in lines:
            for key in ("bytes_in", "bytes_out", "exchanges", "replies"):
                totals[key] += entry[key]
        totals["connections"] += len(lines)
        return {
            "total": totals,
            "connections": lines,
            "refused": self.refused,
            "baud": self.baud,
            "faults": self.faults.pending(),
        }
