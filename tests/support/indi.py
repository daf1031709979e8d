"""The one INDI driver: ``indiserver`` running ``indi_lx200am5`` (Debian's indi-bin), driven with
indi_getprop / indi_setprop, pointed at any TCP port that speaks the mount's protocol (the emulator,
or alpaca-zwo's shared ZWO port)."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
from pathlib import Path
from typing import IO

from tests.support.wait import wait_until

DEVICE = "ZWO AM5"


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


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
