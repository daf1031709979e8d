"""alpaca-zwo with candidate server changes applied at run time, to measure them before anyone edits the server.

``python -m benchmarks.patched_server --patch urgent-stop,fixed-rate-poll,connection-limit -- <alpaca-zwo args>``
(or ``python -m benchmarks.run --server-patch ...``). Each patch is the smallest change that tests
one suggestion from BENCHMARKS.md; none of them is product code, and the real fix belongs in
``alpaca_zwo/`` with its tests.

* ``urgent-stop``: stop commands (``:Q#``, ``:Qe#`` ...) have no reply, so they cannot put the
  reply stream out of step. They are written at once, even while another exchange waits for its
  reply, instead of queueing behind it on the arbiter (a write lock keeps the bytes of two
  writes from interleaving). Removes the wait for the exchange in flight (up to 27 ms for
  ``:GMEQ#`` at 9600 baud) from AbortSlew and MoveAxis(0).
* ``fixed-rate-poll``: the poller waits the poll interval from the *start* of the last poll, not
  from its end, so the rate of polls (and so bytes per second) no longer stretches when a busy
  server makes each poll cycle take longer.
* ``connection-limit``: waitress's connection limit 100 -> 1000, so the 101st keep-alive client
  (100 NINAs plus PHD2, say) is served instead of waiting unaccepted.
"""

from __future__ import annotations

import sys
import threading
import time
from typing import Any

PATCHES = ("urgent-stop", "fixed-rate-poll", "connection-limit")


def _urgent_stop() -> None:
    import serial

    from alpaca_zwo.zwo import protocol
    from alpaca_zwo.zwo.link import Link, LinkState, Priority

    stop_codes = {"Q", "Qe", "Qw", "Qn", "Qs"}
    original_open = Link._open_port
    original_exchange = Link.exchange

    def open_port(self: Any) -> None:
        original_open(self)
        port = self._port
        lock = threading.Lock()
        raw_write = port.write

        def write(data: bytes) -> Any:
            with lock:
                return raw_write(data)

        port.write = write

    def exchange(self: Any, req: Any, priority: Any = Priority.COMMAND) -> str:
        port = self._port
        if (priority is Priority.COMMAND and req.kind is protocol.ReplyKind.NONE and req.command.code in stop_codes
                and self._status.state is LinkState.CONNECTED and port is not None):
            started = time.monotonic()
            try:
                port.write(req.wire)
            except (serial.SerialException, OSError):
                return original_exchange(self, req, priority)  # the normal path handles a lost port
            self.counters.bytes_out += len(req.wire)
            self.counters.exchanges += 1
            self._record(req.text, "", started, "urgent: written ahead of the exchange in flight")
            return ""
        return original_exchange(self, req, priority)

    Link._open_port = open_port  # type: ignore[method-assign]
    Link.exchange = exchange  # type: ignore[method-assign]


def _fixed_rate_poll() -> None:
    from alpaca_zwo.mount.operations import Mount

    class FixedRateEvent(threading.Event):
        """``wait(period)`` counts the period from the start of the last poll."""

        last_start: float | None = None

        def wait(self, timeout: float | None = None) -> bool:
            if timeout is not None and self.last_start is not None:
                timeout = max(0.0, self.last_start + timeout - time.monotonic())
            return super().wait(timeout)

    original_init = Mount.__init__
    original_poll = Mount.poll_once

    def init(self: Any, *args: Any, **kwargs: Any) -> None:
        original_init(self, *args, **kwargs)
        self._poll_wake = FixedRateEvent()

    def poll_once(self: Any) -> Any:
        wake = self._poll_wake
        if isinstance(wake, FixedRateEvent):
            wake.last_start = time.monotonic()
        return original_poll(self)

    Mount.__init__ = init  # type: ignore[method-assign]
    Mount.poll_once = poll_once  # type: ignore[method-assign]


def _connection_limit() -> None:
    from alpaca_zwo.alpaca.http import HttpServer

    defaults = HttpServer.__init__.__kwdefaults__
    if defaults is None or "connection_limit" not in defaults:
        raise RuntimeError("HttpServer has no connection_limit keyword any more: update this patch")
    defaults["connection_limit"] = 1000


def main(argv: list[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    if len(args) < 2 or args[0] != "--patch":
        print(__doc__, file=sys.stderr)
        return 2
    names = [name for name in args[1].split(",") if name]
    rest = args[2:]
    if rest and rest[0] == "--":
        rest = rest[1:]
    for name in names:
        if name not in PATCHES:
            print(f"unknown patch {name!r}; known: {', '.join(PATCHES)}", file=sys.stderr)
            return 2
        {"urgent-stop": _urgent_stop, "fixed-rate-poll": _fixed_rate_poll,
         "connection-limit": _connection_limit}[name]()
    print(f"patched: {', '.join(names) or 'nothing'}", flush=True)
    from alpaca_zwo.cli import server_main

    return server_main(rest)


if __name__ == "__main__":
    sys.exit(main())
