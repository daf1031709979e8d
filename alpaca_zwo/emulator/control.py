"""A loopback-only, line-based control channel for a running emulator.

Lets a test in another process (or a person with ``nc``) inject faults and read the mount's
state without touching the mount protocol: each request line gets exactly one line of JSON.

    stall MS | drop N | garble N | close | outage SECONDS | reboot [SECONDS] | clear
    stats | state | help
"""

from __future__ import annotations

import ipaddress
import json
import logging
import socketserver
import threading
from typing import Any

from .server import EmulatorServer

__all__ = ["ControlServer", "execute"]

_log = logging.getLogger(__name__)

HELP = "stall MS | drop N | garble N | close | outage SECONDS | reboot [SECONDS] | clear | stats | state"


def execute(server: EmulatorServer, line: str) -> dict[str, Any]:
    """Run one control command; never raises (bad input is an ``ok: false`` answer)."""
    words = line.split()
    if not words:
        return {"ok": False, "error": "empty command", "help": HELP}
    name, args = words[0].lower(), words[1:]
    faults = server.faults
    try:
        if name == "stall":
            faults.stall(float(args[0]))
        elif name == "drop":
            faults.drop_replies(int(args[0]) if args else 1)
        elif name == "garble":
            faults.garble_replies(int(args[0]) if args else 1)
        elif name == "close":
            faults.close_connections()
        elif name == "outage":
            faults.outage(float(args[0]))
        elif name == "reboot":
            faults.reboot(float(args[0]) if args else 2.0)
        elif name == "clear":
            faults.clear()
        elif name == "stats":
            return {"ok": True, "stats": server.stats()}
        elif name == "state":
            return {"ok": True, "state": server.model.snapshot()}
        elif name == "help":
            return {"ok": True, "help": HELP}
        else:
            return {"ok": False, "error": f"unknown command {name!r}", "help": HELP}
    except (IndexError, ValueError) as exc:
        return {"ok": False, "error": f"bad arguments for {name}: {exc}", "help": HELP}
    return {"ok": True, "command": name}


class _Handler(socketserver.StreamRequestHandler):
    server: _ThreadingServer

    def handle(self) -> None:
        for raw in self.rfile:
            line = raw.decode("utf-8", "replace").strip()
            if not line:
                continue
            try:
                answer = execute(self.server.emulator, line)
            except Exception as exc:  # the control channel must survive anything
                _log.exception("control command %r failed", line)
                answer = {"ok": False, "error": str(exc)}
            self.wfile.write((json.dumps(answer, default=str) + "\n").encode())
            self.wfile.flush()


class _ThreadingServer(socketserver.ThreadingTCPServer):
    daemon_threads = True
    allow_reuse_address = True
    emulator: EmulatorServer


class ControlServer:
    """Serves :func:`execute` on ``host:port`` (loopback only: it can reboot the mount)."""

    def __init__(self, server: EmulatorServer, host: str = "127.0.0.1", port: int = 0) -> None:
        if not ipaddress.ip_address(host).is_loopback:
            raise ValueError(f"the control port only listens on loopback, not {host}")
        self._server = _ThreadingServer((host, port), _Handler)
        self._server.emulator = server
        self._thread: threading.Thread | None = None

    @property
    def port(self) -> int:
        return int(self._server.server_address[1])

    def start(self) -> ControlServer:
        self._thread = threading.Thread(target=self._server.serve_forever, args=(0.1,), daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._server.shutdown()
        self._server.server_close()
        if self._thread is not None:
            self._thread.join(2.0)
