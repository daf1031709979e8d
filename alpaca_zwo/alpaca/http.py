"""The HTTP server: waitress in a background thread, startable and stoppable from tests and the CLI.

waitress's own ``serve()`` blocks and only stops on a signal; the server and the tests need a
handle that binds first (port 0 -> a free port, known before any client connects), runs in a
daemon thread, and shuts down cleanly and promptly on ``close()``.
"""

from __future__ import annotations

import logging
import threading
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


class HttpServer:
    """A waitress server bound at construction; ``start()`` serves, ``close()`` stops and joins."""

    def __init__(self, app: Any, host: str = "0.0.0.0", port: int = 0, *, threads: int = 8,
                 channel_timeout: int = 60, connection_limit: int = 1000,
                 max_request_body_size: int = 1 << 20) -> None:
        self._map: dict[int, Any] = {}
        options: dict[str, Any] = {
            "host": host,
            "port": port,
            "threads": threads,
            # Idle keep-alive connections are dropped after this long; clients poll far more often.
            "channel_timeout": channel_timeout,
            "connection_limit": connection_limit,
            # No reverse proxy is trusted, so X-Forwarded-* cannot spoof a client's address.
            "clear_untrusted_proxy_headers": True,
            "ident": "alpaca-zwo",
            # waitress buffers a whole body (to disk past 512 KiB) before the app sees it; Alpaca
            # bodies are a few hundred bytes, so refuse big ones at the door (413).
            "max_request_body_size": max_request_body_size,
        }
        self._server = create_server(app, map=self._map, **options)
        for listener in self._map.values():
            if isinstance(listener, BaseWSGIServer):
                listener.channel_class = _ExpectContinueChannel
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
