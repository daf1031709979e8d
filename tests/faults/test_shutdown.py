"""Server shutdown leaves the mount safe: the real CLI, a real signal, and the mount asked afterwards.

The mount runs as a separate emulator process, so after the server has exited the test can still
ask the mount (over the emulator's control port) whether its axes are still. A SIGKILLed server
(no chance to clean up) is the control experiment: it shows the emulated mount keeps moving when
nobody stops it, exactly as a real one does, so a still mount after SIGTERM is the server's doing.
"""

from __future__ import annotations

import json
import os
import queue
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import pytest

from tests.faults.harness import AlpacaClient, Verdict, report, wait_until

START_TIMEOUT_S = 20.0
EXIT_TIMEOUT_S = 30.0
ENV = {**os.environ, "PYTHONUNBUFFERED": "1"}


class _Lines:
    """Lines of a child's stdout, readable with a deadline (a blocking readline could hang the test)."""

    def __init__(self, stream: IO[str]) -> None:
        self.seen: list[str] = []
        self._queue: queue.Queue[str | None] = queue.Queue()
        threading.Thread(target=self._pump, args=(stream,), daemon=True).start()

    def _pump(self, stream: IO[str]) -> None:
        for line in stream:
            self._queue.put(line.rstrip("\n"))
        self._queue.put(None)

    def expect(self, pattern: str, timeout: float = START_TIMEOUT_S) -> re.Match[str]:
        deadline = time.monotonic() + timeout
        regex = re.compile(pattern)
        while True:
            for line in self.seen:
                match = regex.search(line)
                if match:
                    return match
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                pytest.fail(f"no line matching {pattern!r} within {timeout} s; saw {self.seen}")
            try:
                line = self._queue.get(timeout=remaining)
            except queue.Empty:
                continue
            if line is None:
                pytest.fail(f"the process ended before printing {pattern!r}; saw {self.seen}")
            self.seen.append(line)


@dataclass
class Emulator:
    process: subprocess.Popen[str]
    tcp_port: int
    control_port: int

    def control(self, command: str) -> dict[str, Any]:
        with socket.create_connection(("127.0.0.1", self.control_port), timeout=5) as sock:
            sock.sendall(command.encode() + b"\n")
            data = b""
            while not data.endswith(b"\n"):
                chunk = sock.recv(65536)
                if not chunk:
                    break
                data += chunk
        answer = json.loads(data)
        assert answer["ok"], answer
        return answer

    def state(self) -> dict[str, Any]:
        return self.control("state")["state"]


@pytest.fixture
def emulator() -> Iterator[Emulator]:
    """A separate emulated mount (its own process), unpaced, at real-time speed."""
    process = subprocess.Popen(
        [sys.executable, "-m", "alpaca_zwo.emulator", "--port", "0", "--control-port", "0", "--baud", "0"],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=ENV)
    try:
        assert process.stdout is not None
        lines = _Lines(process.stdout)
        tcp = int(lines.expect(r"^tcp 127\.0\.0\.1:(\d+)").group(1))
        control = int(lines.expect(r"^control 127\.0\.0\.1:(\d+)").group(1))
        yield Emulator(process, tcp, control)
    finally:
        process.terminate()
        try:
            process.wait(10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(10)


@dataclass
class Server:
    process: subprocess.Popen[str]
    port: int
    lines: _Lines
    log_path: Path

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")


def _start_server(tmp_path: Path, emulator: Emulator, on_shutdown: str) -> Server:
    config = tmp_path / "config.toml"
    config.write_text(f'[server]\nmdns = false\n\n[safety]\non_shutdown = "{on_shutdown}"\n')
    log_path = tmp_path / "server.log"
    with open(log_path, "w") as log_file:
        process = subprocess.Popen(
            [sys.executable, "-m", "alpaca_zwo", "--port", "0", "--discovery-port", "0", "--config", str(config),
             "--host", "127.0.0.1", "--device", f"socket://127.0.0.1:{emulator.tcp_port}", "--log-level", "INFO"],
            stdout=subprocess.PIPE, stderr=log_file, text=True, env=ENV)
    assert process.stdout is not None
    lines = _Lines(process.stdout)
    port = int(lines.expect(r"Alpaca API:\s+http://127\.0\.0\.1:(\d+)/").group(1))
    return Server(process, port, lines, log_path)


@pytest.fixture
def servers() -> Iterator[list[Server]]:
    """Servers started by a test; any still running at the end are killed."""
    started: list[Server] = []
    yield started
    for server in started:
        if server.process.poll() is None:
            server.process.kill()
            server.process.wait(10)


def _start_moving(server: Server, emulator: Emulator) -> AlpacaClient:
    client = AlpacaClient(server.port, 99)
    client.command("connected", Connected="true")
    client.command("moveaxis", Axis=0, Rate=2.0)
    client.command("moveaxis", Axis=1, Rate=-1.0)
    wait_until(lambda: all(v is not None for v in emulator.state()["moves_deg_s"]), 10, "both axes to move")
    time.sleep(0.5)
    return client


def _stop(server: Server, sig: signal.Signals) -> tuple[int, float]:
    sent = time.monotonic()
    server.process.send_signal(sig)
    try:
        code = server.process.wait(EXIT_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        pytest.fail(f"the server did not exit within {EXIT_TIMEOUT_S} s of {sig.name}; log:\n{server.log()}")
    return code, time.monotonic() - sent


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "Ctrl-C"])
def test_shutdown_stops_manual_motion(tmp_path: Path, emulator: Emulator, servers: list[Server],
                                      sig: signal.Signals) -> None:
    server = _start_server(tmp_path, emulator, "stop")
    servers.append(server)
    verdict = Verdict(f"{sig.name} during MoveAxis")
    client = _start_moving(server, emulator)
    client.close()
    code, took = _stop(server, sig)
    verdict.check(code == 0, f"exit code {code}")
    server.lines.expect(r"alpaca-zwo stopped", timeout=5)
    state = emulator.state()
    verdict.check(state["moves_deg_s"] == [None, None], f"the mount was left moving: {state['moves_deg_s']}")
    wait_until(lambda: emulator.state()["velocity_deg_s"] == [0.0, 0.0], 10, "the axes to come to rest")
    log = server.log()
    verdict.check("stopping manual motion: the server is shutting down" in log,
                  f"no log line saying why motion was stopped:\n{log}")
    report(f"{sig.name} during MoveAxis", exit_code=code, exit_s=took, axes_after=state["moves_deg_s"])
    verdict.conclude()


def test_shutdown_parks_when_configured(tmp_path: Path, emulator: Emulator, servers: list[Server]) -> None:
    server = _start_server(tmp_path, emulator, "park")
    servers.append(server)
    verdict = Verdict("SIGTERM with on_shutdown = park")
    client = _start_moving(server, emulator)
    client.command("tracking", Tracking="true")
    client.close()
    code, took = _stop(server, signal.SIGTERM)
    verdict.check(code == 0, f"exit code {code}")
    state = emulator.state()
    verdict.check(state["moves_deg_s"] == [None, None] and state["slew"] is None,
                  f"the mount still moves after the server exited: moves {state['moves_deg_s']}, slew {state['slew']}")
    verdict.check(state["at_home"], f"the mount is not at its park position (home): pier {state['pier']}, "
                                    f"axes {state['primary_deg']:.3f}/{state['secondary_deg']:.3f}")
    verdict.check(state["tracking"] is False, "the mount still tracks after parking")
    log = server.log()
    verdict.check("parking on shutdown" in log and "parked" in log, f"no log of the park:\n{log}")
    report("SIGTERM with on_shutdown=park", exit_code=code, exit_s=took, at_home=state["at_home"],
           tracking=state["tracking"])
    verdict.conclude()


def test_a_killed_server_leaves_the_mount_moving(tmp_path: Path, emulator: Emulator, servers: list[Server]) -> None:
    """Control experiment: SIGKILL gives the server no chance, and the emulated mount keeps going."""
    server = _start_server(tmp_path, emulator, "stop")
    servers.append(server)
    _start_moving(server, emulator).close()
    server.process.kill()
    server.process.wait(10)
    time.sleep(0.5)
    assert all(v is not None for v in emulator.state()["moves_deg_s"]), emulator.state()["moves_deg_s"]
