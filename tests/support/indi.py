"""The one INDI driver: ``indiserver`` running ``indi_lx200am5`` (Debian's indi-bin), driven with
indi_getprop / indi_setprop, pointed at any TCP port that speaks the mount's protocol (the emulator,
or alpaca-zwo's shared ZWO port).

``indi_getprop`` reads a property's state *now*. Some states are momentary: a refused GOTO sets
``EQUATORIAL_EOD_COORD`` to Alert, and the driver's next once-a-second poll sets it back to Ok or
Idle, so a test polling with a subprocess under load can miss it. ``IndiServer.watch`` records
every update the driver sends instead, as an INDI client does.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import threading
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from tests.support.wait import wait_until

DEVICE = "ZWO AM5"


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


@dataclass(frozen=True)
class Update:
    """One vector the driver sent: ``defNumberVector``/``setNumberVector``/… with its state."""

    kind: str
    name: str
    state: str


class PropertyWatcher:
    """An INDI client on its own socket that records every property update of ``DEVICE``.

    Updates arrive on the socket in the order the driver sent them, so a state the driver held for
    a moment is recorded however busy the machine is.
    """

    def __init__(self, port: int) -> None:
        self._sock = socket.create_connection(("127.0.0.1", port), timeout=10)
        self._sock.settimeout(None)
        self._updates: list[Update] = []
        self._lock = threading.Lock()
        # A client that has asked for properties is sent every later update (INDI protocol 1.7).
        self._sock.sendall(f'<getProperties version="1.7" device="{DEVICE}"/>'.encode())
        self._thread = threading.Thread(target=self._read, name="indi-watch", daemon=True)
        self._thread.start()

    def _read(self) -> None:
        parser = ET.XMLPullParser(events=("start", "end"))
        parser.feed("<stream>")  # the INDI stream is a sequence of top-level elements: give them a root
        depth = 0
        while True:
            try:
                data = self._sock.recv(65536)
            except OSError:
                return
            if not data:
                return
            parser.feed(data)
            for event, element in parser.read_events():
                if event == "start":
                    depth += 1
                    continue
                depth -= 1
                if depth != 1:  # a member (oneNumber, …) of a vector: kept inside its parent
                    continue
                if element.get("device") == DEVICE and element.get("name"):
                    update = Update(element.tag, element.get("name", ""), element.get("state", ""))
                    with self._lock:
                        self._updates.append(update)
                element.clear()

    def received_any(self) -> bool:
        with self._lock:
            return bool(self._updates)

    def updates(self, name: str) -> list[Update]:
        """Every update of property ``name`` received so far, oldest first."""
        with self._lock:
            return [update for update in self._updates if update.name == name]

    def states(self, name: str) -> list[str]:
        return [update.state for update in self.updates(name)]

    def close(self) -> None:
        with suppress(OSError):
            self._sock.shutdown(socket.SHUT_RDWR)
        self._sock.close()
        self._thread.join(5)


class IndiServer:
    """One ``indiserver`` with ``indi_lx200am5``; ``home`` holds the driver's config and its socket."""

    def __init__(self, home: Path, stderr: IO[bytes] | None = None) -> None:
        self.port = free_port()
        env = dict(os.environ, HOME=str(home))  # the driver's config files go to a temp dir
        self.proc = subprocess.Popen(
            # -u: its own local socket, so suites running side by side cannot collide on /tmp/indiserver
            ["indiserver", "-p", str(self.port), "-u", str(home / "indiserver.sock"), "indi_lx200am5"],
            stdout=subprocess.DEVNULL, stderr=stderr if stderr is not None else subprocess.DEVNULL, env=env,
            start_new_session=True)

    def get(self, *specs: str) -> dict[str, str]:
        result = subprocess.run(["indi_getprop", "-p", str(self.port), "-t", "2",
                                 *[f"{DEVICE}.{spec}" for spec in specs]],
                                capture_output=True, text=True, timeout=15)
        values = {}
        for line in result.stdout.splitlines():
            name, _, value = line.partition("=")
            values[name.removeprefix(DEVICE + ".")] = value
        return values

    def set(self, spec: str) -> None:
        subprocess.run(["indi_setprop", "-p", str(self.port), f"{DEVICE}.{spec}"], check=True,
                       capture_output=True, timeout=15)

    def coords(self) -> tuple[float, float, str]:
        values = self.get("EQUATORIAL_EOD_COORD.*", "EQUATORIAL_EOD_COORD._STATE")
        return (float(values["EQUATORIAL_EOD_COORD.RA"]), float(values["EQUATORIAL_EOD_COORD.DEC"]),
                values["EQUATORIAL_EOD_COORD._STATE"])

    @contextmanager
    def watch(self) -> Iterator[PropertyWatcher]:
        """Record every property update from now on (see ``PropertyWatcher``)."""
        watcher = PropertyWatcher(self.port)
        try:
            # The driver's answer to getProperties: indiserver now sends this client every update.
            wait_until(watcher.received_any, 20, "the INDI watcher's first property", interval=0.02)
            yield watcher
        finally:
            watcher.close()

    def connect(self, port: int, host: str = "127.0.0.1") -> None:
        """Point the driver at ``host:port`` and wait until it has run its start-up queries."""
        wait_until(lambda: self.get("CONNECTION.CONNECT"), 20, "the INDI driver to start", interval=0.1)
        self.set(f"DEVICE_ADDRESS.ADDRESS;PORT={host};{port}")
        self.set("CONNECTION.CONNECT=On")
        wait_until(lambda: self.get("CONNECTION.CONNECT").get("CONNECTION.CONNECT") == "On", 20, "connection",
                   interval=0.1)
        wait_until(lambda: "GUIDE_RATE.RATE" in self.get("GUIDE_RATE.RATE"), 20, "the driver's start-up queries",
                   interval=0.1)

    def stop(self) -> None:
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGTERM)  # indiserver and the driver it started
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait(5)
