"""A loopback-only, line-based control channel for a running emulator.

Lets a test in another process (or a person with ``nc``) inject faults and read the mount's
state without touching the mount protocol: each request line gets exactly one line of JSON.

    stall MS | drop N | garble N | close | outage SECONDS | reboot [SECONDS] | clear
    pointing-errors TERMS|none | pointing-noise ARCSEC [SEED]
    stats | state | pointing | help
"""

from __future__ import annotations

import ipaddress
import json
import logging
import socket
import socketserver
import threading
from collections.abc import Callable
from typing import Any

from .faults import Faults
from .model import MountModel
from .server import EmulatorServer

__all__ = ["ControlServer", "ask", "execute"]

_log = logging.getLogger(__name__)

HELP = ("stall MS | drop N | garble N | close | outage SECONDS | reboot [SECONDS] | clear | "
        "pointing-errors TERMS|none | pointing-noise ARCSEC [SEED] | stats | state | pointing")


#: Fault commands: name -> (what it does with the arguments), each answering ``{"ok": true, "command": name}``.
_FAULTS: dict[str, Callable[[Faults, list[str]], object]] = {
    "stall": lambda f, a: f.stall(float(a[0])),
    "drop": lambda f, a: f.drop_replies(int(a[0]) if a else 1),
    "garble": lambda f, a: f.garble_replies(int(a[0]) if a else 1),
    "close": lambda f, a: f.close_connections(),
    "outage": lambda f, a: f.outage(float(a[0])),
    "reboot": lambda f, a: f.reboot(float(a[0]) if a else 2.0),
    "clear": lambda f, a: f.clear(),
}


#: Changes to the mount's mechanics, answering like a fault command: ``pointing-errors IH=20,ID=-8`` (or
#: ``none``: new TPOINT terms, the scatter kept), ``pointing-noise ARCSEC [SEED]`` (a new scatter, the terms kept).
_MECHANICS: dict[str, Callable[[MountModel, list[str]], None]] = {
    "pointing-errors": lambda m, a: m.set_imperfection(m.imperfection.with_terms("".join(a))),
    "pointing-noise": lambda m, a: m.set_imperfection(
        m.imperfection.with_noise(float(a[0]), int(a[1]) if len(a) > 1 else m.imperfection.noise.seed)),
}
#: Read-outs: name -> (the answer's key, how to read it).
_READOUTS: dict[str, tuple[str, Callable[[EmulatorServer], object]]] = {
    "stats": ("stats", lambda s: s.stats()),
    "state": ("state", lambda s: s.model.snapshot()),
    "pointing": ("pointing", lambda s: s.model.imperfection.describe()),
    "help": ("help", lambda s: HELP),
}


def execute(server: EmulatorServer, line: str) -> dict[str, Any]:
    """Run one control command; never raises (bad input is an ``ok: false`` answer)."""
    words = line.split()
    if not words:
        return {"ok": False, "error": "empty command", "help": HELP}
    name, args = words[0].lower(), words[1:]
    if name in _READOUTS:
        key, read = _READOUTS[name]
        return {"ok": True, key: read(server)}
    fault = _FAULTS.get(name)
    mechanics = _MECHANICS.get(name)
    if fault is None and mechanics is None:
        return {"ok": False, "error": f"unknown command {name!r}", "help": HELP}
    try:
        if fault is not None:
            fault(server.faults, args)
        elif mechanics is not None:
            mechanics(server.model, args)
    except (IndexError, ValueError) as exc:
        return {"ok": False, "error": f"bad arguments for {name}: {exc}", "help": HELP}
    return {"ok": True, "command": name}


def ask(port: int, command: str, host: str = "127.0.0.1", timeout: float = 5.0) -> dict[str, Any]:
    """The control client: send one command line to a running emulator's control port, return its answer.

    Used by the tests and the benchmarks, which run the emulator as a separate process.
    """
    with socket.create_connection((host, port), timeout=timeout) as sock:
        sock.sendall(command.encode() + b"\n")
        data = b""
        while not data.endswith(b"\n"):
            chunk = sock.recv(65536)
            if not chunk:
                raise ConnectionError(f"the emulator's control port closed before answering {command!r}")
            data += chunk
    answer: dict[str, Any] = json.loads(data)
    return answer


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
