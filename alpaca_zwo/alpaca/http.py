"""The HTTP server: waitress in a background thread, startable and stoppable from tests and the CLI.

waitress's own ``serve()`` blocks and only stops on a signal; the server and the tests need a
handle that binds first (port 0 -> a free port, known before any client connects), runs in a
daemon thread, and shuts down cleanly and promptly on ``close()``.

One host must not lock the others out (issue 23, item 3): waitress stops accepting at
``connection_limit`` open connections, and keeps an idle or slowly trickling one for
``channel_timeout``. So each remote address may hold ``max_connections_per_address`` connections
(one beyond that is reset the moment it is accepted), and a request must arrive whole within
``request_timeout`` of its first byte (of the connection, for the first request), or the
connection is closed: a slow-header ("slowloris") sender cannot keep a slot by trickling bytes.
Idle keep-alive between requests keeps waitress's ``channel_timeout``.
"""

from __future__ import annotations

import contextlib
import logging
import socket
import struct
import threading
import time
from typing import Any

from waitress import wasyncore
from waitress.channel import HTTPChannel
from waitress.server import BaseWSGIServer, create_server
from waitress.trigger import trigger

log = logging.getLogger("alpaca_zwo.alpaca.http")


class _ExpectContinueChannel(HTTPChannel):
    """waitress 3.0 sends "100 Continue" for a request that is already complete (no body) and then
    waits for a body that never comes, so the client hangs. A complete request needs no Continue."""

    def send_continue(self) -> None:
        if self.request is not None and self.request.completed:
            self.request.expect_continue = False
            return
        super().send_continue()


#: How long a request's headers and body may take to arrive; real clients send them at once (and give
#: up on a reply after 5 s themselves).
REQUEST_TIMEOUT_S = 5.0
#: The default number of open connections one remote address may hold (``server.max_connections_per_address``).
MAX_CONNECTIONS_PER_ADDRESS = 64
#: At most one warning about refused connections per this many seconds (a flood must not flood the log).
_WARN_EVERY_S = 60.0


class _ConnectionGuard:
    """Open connections per remote address for one server; ``limit`` 0 counts but never refuses."""

    def __init__(self, limit: int, request_timeout: float) -> None:
        self.limit = limit
        self.request_timeout = request_timeout
        self._open: dict[str, int] = {}
        self._lock = threading.Lock()  # admit/release run on the loop thread; close() may not
        self._refused = 0
        self._warned_at = -_WARN_EVERY_S

    def admit(self, address: str) -> bool:
        """Count one more connection from ``address``, or refuse it (False) when it holds ``limit``."""
        with self._lock:
            count = self._open.get(address, 0)
            if not self.limit or count < self.limit:
                self._open[address] = count + 1
                return True
            self._refused += 1
            refused, now = self._refused, time.monotonic()
            warn = now - self._warned_at >= _WARN_EVERY_S
            if warn:
                self._warned_at, self._refused = now, 0
        if warn:
            log.warning("refused %d connection(s): %s already holds %d (server.max_connections_per_address)",
                        refused, address, self.limit)
        return False

    def release(self, address: str) -> None:
        with self._lock:
            count = self._open.get(address, 0) - 1
            if count > 0:
                self._open[address] = count
            else:
                self._open.pop(address, None)

    def open_count(self, address: str) -> int:
        with self._lock:
            return self._open.get(address, 0)


def _peer(addr: object) -> str:
    """The remote address a limit applies to: the IP, IPv4-mapped IPv6 written as IPv4."""
    host = addr[0] if isinstance(addr, tuple) and addr else str(addr)
    return host.removeprefix("::ffff:") if isinstance(host, str) else str(host)


class _GuardedChannel(_ExpectContinueChannel):
    """A channel that counts itself against its address's limit and times out a request that never
    finishes. ``guard`` is set on a per-server subclass (see ``HttpServer``)."""

    guard: _ConnectionGuard
    will_close: bool  # waitress's flag (untyped there): the loop closes the channel at its next look
    _peer_address = ""
    _counted = False
    #: When the request being received began (its first byte; the accept for the first request),
    #: ``None`` while idle between requests.
    request_started: float | None = None

    def __init__(self, server: Any, sock: socket.socket, addr: Any, adj: Any, map: Any = None) -> None:
        self.request_started = time.monotonic()
        super().__init__(server, sock, addr, adj, map)
        self._peer_address = _peer(addr)
        if self.guard.admit(self._peer_address):
            self._counted = True
            return
        with contextlib.suppress(OSError):  # reset rather than close: no TIME_WAIT per refused connection
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        self.handle_close()

    def del_channel(self, map: Any = None) -> None:
        super().del_channel(map)
        if self._counted:
            self._counted = False
            self.guard.release(self._peer_address)

    def received(self, data: bytes) -> bool:
        if self.request_started is None and data:
            self.request_started = time.monotonic()
        partial = self.request
        done: bool = super().received(data)
        if self.request is None:
            self.request_started = None  # every request received whole: idle until the next byte
        elif partial is not None and self.request is not partial:
            self.request_started = time.monotonic()  # one finished and the next began in these bytes
        return done

    def writable(self) -> bool:
        # The loop asks every channel this at least once a second (asyncore_loop_timeout): the
        # place to close one whose request stalls. A request being served (self.requests) is exempt.
        started = self.request_started
        if (started is not None and not self.requests and not self.will_close
                and time.monotonic() - started > self.guard.request_timeout):
            log.debug("closing %s: request not received within %.0f s", self._peer_address,
                      self.guard.request_timeout)
            self.will_close = True
        return bool(super().writable())


class HttpServer:
    """A waitress server bound at construction; ``start()`` serves, ``close()`` stops and joins."""

    def __init__(self, app: Any, host: str = "0.0.0.0", port: int = 0, *, threads: int = 8,
                 channel_timeout: int = 60, connection_limit: int = 1000,
                 max_request_body_size: int = 1 << 20,
                 max_connections_per_address: int = MAX_CONNECTIONS_PER_ADDRESS,
                 request_timeout: float = REQUEST_TIMEOUT_S) -> None:
        self._map: dict[int, Any] = {}
        options: dict[str, Any] = {
            "host": host,
            "port": port,
            "threads": threads,
            # Idle keep-alive connections are dropped after this long; clients poll far more often.
            "channel_timeout": channel_timeout,
            "cleanup_interval": 10,  # how often waitress looks for idle channels (default 30 s)
            "connection_limit": connection_limit,
            # No reverse proxy is trusted, so X-Forwarded-* cannot spoof a client's address.
            "clear_untrusted_proxy_headers": True,
            "ident": "alpaca-zwo",
            # waitress buffers a whole body (to disk past 512 KiB) before the app sees it; Alpaca
            # bodies are a few hundred bytes, so refuse big ones at the door (413).
            "max_request_body_size": max_request_body_size,
            # poll(), not select(): select() fails outright once a descriptor number passes 1023.
            "asyncore_use_poll": True,
        }
        self._server = create_server(app, map=self._map, **options)
        self.guard = _ConnectionGuard(max_connections_per_address, request_timeout)
        channel_class = type("GuardedChannel", (_GuardedChannel,), {"guard": self.guard})
        for listener in self._map.values():
            if isinstance(listener, BaseWSGIServer):
                listener.channel_class = channel_class
        # One wake-up pipe per listener (a host name may resolve to several); any reaches the loop.
        self._triggers: list[trigger] = [d for d in self._map.values() if isinstance(d, trigger)]
        self._thread: threading.Thread | None = None
        self._closed = False
        self.host = host

    @property
    def port(self) -> int:
        """The bound port (the real one when constructed with port 0)."""
        server = self._server
        if hasattr(server, "effective_port"):
            return int(server.effective_port)
        return int(server.effective_listen[0][1])

    def start(self) -> None:
        """Serve in a daemon thread so a hung client can never keep the process alive."""
        if self._thread is not None:
            raise RuntimeError("HttpServer already started")
        self._thread = threading.Thread(target=self._server.run, name=f"http-{self.port}", daemon=True)
        self._thread.start()
        log.info("Alpaca HTTP server listening on %s:%d", self.host, self.port)

    def close(self, timeout: float = 5.0) -> None:
        """Stop accepting, close every connection, stop the worker threads; idempotent."""
        if self._closed:
            return
        self._closed = True
        thread = self._thread
        if thread is not None and thread.is_alive():
            # Sockets belong to the loop thread: it closes them itself, and an empty map ends its loop.
            try:
                self._triggers[0].pull_trigger(self._close_connections)
            except OSError:
                # A wake-up already in progress ran a close first and the trigger is gone: the loop is
                # ending on its own, so there is nothing left to wake.
                log.debug("HTTP loop trigger already closed")
            thread.join(timeout)
            if thread.is_alive():
                log.warning("HTTP server loop did not stop within %.1f s", timeout)
        else:
            self._close_connections()
        self._server.task_dispatcher.shutdown(timeout=timeout)
        # The trigger pipes outlive the workers: they pull them after each request, and a pipe closed
        # under them fails (or, once its number is reused, writes into someone else's descriptor).
        # Closing it from the loop thread would also race pull_trigger(), which queues the thunk
        # before it writes the wake-up byte.
        for wake in self._triggers:
            wake.close()

    def _close_connections(self) -> None:
        for dispatcher in list(self._map.values()):
            if isinstance(dispatcher, trigger):
                dispatcher.del_channel()  # out of the loop, but still open for the workers
            elif isinstance(dispatcher, BaseWSGIServer):
                # The listening socket only: BaseWSGIServer.close() would close the trigger too.
                wasyncore.dispatcher.close(dispatcher)
            elif isinstance(dispatcher, HTTPChannel):
                dispatcher.handle_close()  # also wakes a worker waiting to write into a full buffer
            else:
                dispatcher.close()
        self._map.clear()

    def __enter__(self) -> HttpServer:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
