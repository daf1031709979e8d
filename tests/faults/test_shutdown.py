"""Server shutdown leaves the mount safe: the real CLI, a real signal, and the mount asked afterwards.

The mount runs as a separate emulator process, so after the server has exited the test can still
ask the mount (over the emulator's control port) whether its axes are still. A SIGKILLed server
(no chance to clean up) is the control experiment: it shows the emulated mount keeps moving when
nobody stops it, exactly as a real one does, so a still mount after SIGTERM is the server's doing.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.faults.harness import Verdict, report
from tests.support import AlpacaClient, EmulatorProcess, wait_until
from tests.support.emulator import ENV, OutputLines

EXIT_TIMEOUT_S = 30.0


@pytest.fixture
def emulator() -> Iterator[EmulatorProcess]:
    """A separate emulated mount (its own process), unpaced, at real-time speed."""
    process = EmulatorProcess("--control-port", "0", "--baud", "0")
    try:
        yield process
    finally:
        process.terminate()


@dataclass
class Server:
    process: subprocess.Popen[str]
    port: int
    lines: OutputLines
    log_path: Path

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")


def _start_server(tmp_path: Path, emulator: EmulatorProcess, on_shutdown: str) -> Server:
    config = tmp_path / "config.toml"
    config.write_text(f'[server]\nmdns = false\n\n[safety]\non_shutdown = "{on_shutdown}"\n')
    log_path = tmp_path / "server.log"
    with open(log_path, "w") as log_file:
        process = subprocess.Popen(
            [sys.executable, "-m", "alpaca_zwo", "--port", "0", "--discovery-port", "0", "--config", str(config),
             "--host", "127.0.0.1", "--device", f"socket://127.0.0.1:{emulator.port()}", "--log-level", "INFO"],
            stdout=subprocess.PIPE, stderr=log_file, text=True, env=ENV)
    assert process.stdout is not None
    lines = OutputLines(process.stdout)
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


def _start_moving(server: Server, emulator: EmulatorProcess) -> AlpacaClient:
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
def test_shutdown_stops_manual_motion(tmp_path: Path, emulator: EmulatorProcess, servers: list[Server],
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


def test_shutdown_parks_when_configured(tmp_path: Path, emulator: EmulatorProcess, servers: list[Server]) -> None:
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


def test_a_killed_server_leaves_the_mount_moving(tmp_path: Path, emulator: EmulatorProcess,
                                                 servers: list[Server]) -> None:
    """Control experiment: SIGKILL gives the server no chance, and the emulated mount keeps going."""
    server = _start_server(tmp_path, emulator, "stop")
    servers.append(server)
    _start_moving(server, emulator).close()
    server.process.kill()
    server.process.wait(10)
    time.sleep(0.5)
    assert all(v is not None for v in emulator.state()["moves_deg_s"]), emulator.state()["moves_deg_s"]
