"""Settings that cannot brick the next start (issue 23, item 6), with the real CLI as a process.

- A server killed with SIGKILL while the setup page saves settings as fast as it can leaves
  temporary files beside the settings file; the next start removes them (only ours, only abandoned
  ones) and starts from the last complete file.
- ``server.host`` and ``server.port`` are checked before the setup API saves them: an address of
  this machine, 0.0.0.0 or ::, no control character; a port free to bind or the one in use now.
- A hand-edited file the server cannot listen with still gives one clear line at start, no
  traceback, and a non-zero exit status.
"""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import requests

from alpaca_zwo.config.file import STALE_TEMP_AGE_S, load_settings, remove_stale_temp_files
from alpaca_zwo.web import CSRF_HEADER
from tests.conftest import ServerFactory
from tests.support.emulator import ENV, OutputLines

HEADERS = {CSRF_HEADER: "1", "Content-Type": "application/json"}
TIMEOUT = 10.0
START_TIMEOUT_S = 30.0


def _temp_files(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith(".config.toml.") and p.name.endswith(".tmp"))


class Cli:
    """``python -m alpaca_zwo`` on the built-in emulator, port 0, with a given settings file."""

    def __init__(self, config: Path, *extra: str) -> None:
        self.process = subprocess.Popen(
            [sys.executable, "-m", "alpaca_zwo", "--config", str(config), "--discovery-port", "0",
             "--log-level", "INFO", *extra],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=ENV)
        assert self.process.stdout is not None
        self.lines = OutputLines(self.process.stdout)

    def serving_port(self) -> int:
        return int(self.lines.expect(r"Alpaca API:\s+http://127\.0\.0\.1:(\d+)/", START_TIMEOUT_S).group(1))

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(30)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(10)


@pytest.fixture
def clis() -> Iterator[list[Cli]]:
    started: list[Cli] = []
    yield started
    for cli in started:
        cli.stop()


def _writer(base: str, stop: threading.Event, worker: int, sent: list[str]) -> None:
    """Save settings as fast as the page can: a long location makes each save's write take a while."""
    session = requests.Session()
    n = 0
    while not stop.is_set():
        n += 1
        location = f"w{worker}-{n}-" + "x" * 40000
        try:
            session.post(f"{base}/setup/api/server", json={"location": location}, headers=HEADERS, timeout=5)
            sent.append(location)
        except requests.RequestException:
            return  # the server was killed


def test_kill9_during_rapid_writes_leaves_temp_files_the_next_start_removes(tmp_path: Path,
                                                                             clis: list[Cli]) -> None:
    config = tmp_path / "config.toml"
    config.write_text('[server]\nhost = "127.0.0.1"\nport = 0\nmdns = false\n')
    dead_pids: list[int] = []
    strays: list[str] = []
    for _attempt in range(8):  # SIGKILL must land inside a save; each attempt is a fresh server
        cli = Cli(config)
        clis.append(cli)
        base = f"http://127.0.0.1:{cli.serving_port()}"
        stop = threading.Event()
        sent: list[str] = []
        writers = [threading.Thread(target=_writer, args=(base, stop, i, sent), daemon=True) for i in range(4)]
        for writer in writers:
            writer.start()
        deadline = time.monotonic() + 10.0
        while not _temp_files(tmp_path) and time.monotonic() < deadline:
            pass  # spin: the kill must follow the sight of a temporary file at once
        cli.process.send_signal(signal.SIGKILL)
        cli.process.wait(10)
        stop.set()
        for writer in writers:
            writer.join(10)
        dead_pids.append(cli.process.pid)
        strays = _temp_files(tmp_path)
        if strays:
            break
    assert strays, "no SIGKILL landed inside a save in 8 attempts"
    assert any(f".config.toml.{pid}." in name for name in strays for pid in dead_pids), strays

    # Files that are not abandoned, or not ours, must survive the cleanup.
    live = tmp_path / f".config.toml.{os.getpid()}.keepme01.tmp"  # a save in progress in a live process
    live.write_text("in progress")
    foreign = [tmp_path / "notes.tmp", tmp_path / ".other.toml.123.abcdefgh.tmp", tmp_path / "config.toml.bak"]
    for path in foreign:
        path.write_text("not ours")

    cli = Cli(config)
    clis.append(cli)
    port = cli.serving_port()
    assert _temp_files(tmp_path) == [live.name]
    assert all(path.exists() for path in foreign)
    assert any("removed" in line and "stale temporary settings file" in line for line in cli.lines.seen)
    # The file is a complete save: valid, and a whole location the page sent (or none, had the very
    # first save been the one killed).
    reply = requests.get(f"http://127.0.0.1:{port}/setup/api/server", timeout=TIMEOUT).json()
    assert re.fullmatch(r"(w\d-\d+-x{40000})?", reply["location"]), reply["location"][:60]
    assert load_settings(config).server.location == reply["location"]


def test_cleanup_removes_only_abandoned_files_of_ours(tmp_path: Path) -> None:
    config = tmp_path / "config.toml"
    config.write_text("")
    exited = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                            text=True, check=True)
    dead = int(exited.stdout)
    names = {
        f".config.toml.{dead}.abcd1234.tmp": False,  # its writer is gone: removed
        f".config.toml.{os.getpid()}.abcd1234.tmp": True,  # its writer lives (a second server): kept
        ".config.toml.k3j4h5g6.tmp": True,  # an older version's name, fresh: kept (may be live)
        ".config.toml.z9y8x7w6.tmp": False,  # the same, two minutes old: removed
        ".other.toml.1.abcd1234.tmp": True, "config.toml.tmp": True, "x.tmp": True,
    }
    for name in names:
        (tmp_path / name).write_text("x")
    old = time.time() - 2 * STALE_TEMP_AGE_S
    os.utime(tmp_path / ".config.toml.z9y8x7w6.tmp", (old, old))
    (tmp_path / f".config.toml.{dead}.dir00000.tmp").mkdir()  # not a file: left alone
    removed = {p.name for p in remove_stale_temp_files(config)}
    assert removed == {name for name, kept in names.items() if not kept}
    assert all((tmp_path / name).exists() == kept for name, kept in names.items())
    assert (tmp_path / f".config.toml.{dead}.dir00000.tmp").is_dir()


# ================================================================================================
# server.host / server.port checked before the setup page saves them
# ================================================================================================




def _ipv6() -> bool:
    try:
        with socket.socket(socket.AF_INET6) as sock:
            sock.bind(("::1", 0))
        return True
    except OSError:
        return False


def test_host_and_port_are_checked_before_they_are_saved(server_factory: ServerFactory, tmp_path: Path,
                                                          listener: int) -> None:
    server = server_factory()
    base = f"http://127.0.0.1:{server.port}"
    config = tmp_path / "config.toml"

    def post(body: dict[str, object]) -> requests.Response:
        return requests.post(f"{base}/setup/api/server", json=body, headers=HEADERS, timeout=TIMEOUT)

    assert post({"location": "start"}).status_code == 200
    refused = [
        {"host": "192.0.2.55"},  # TEST-NET-1: never this machine's
        {"host": "8.8.8.8"},
        {"host": "127.0.0.1\n"}, {"host": "local\u0007host"}, {"host": " 127.0.0.1"}, {"host": ""},
        {"host": "no-such-host.invalid"},
        {"host": "x" * 300},
        {"port": listener},  # another program listens there
        {"host": "127.0.0.1", "port": listener},
        {"host": 127}, {"port": "11111"}, {"port": True}, {"port": 70000},
    ]
    for body in refused:
        before = config.read_bytes()
        reply = post(body)
        assert reply.status_code == 400, (body, reply.status_code, reply.text)
        message = reply.json()["error"]
        assert "host" in message or "port" in message, (body, message)
        assert config.read_bytes() == before, body
        assert load_settings(config).server.host == "127.0.0.1", body
    assert "not an address of this machine" in post({"host": "192.0.2.55"}).json()["error"]
    assert f"server.port {listener} is in use" in post({"port": listener}).json()["error"]

    accepted: list[dict[str, object]] = [
        {"host": "0.0.0.0"}, {"host": "localhost"}, {"host": "127.0.0.1"},
        {"port": server.port},  # the one this server holds: a restart frees it
        {"port": 0},
        {"host": socket.gethostname()} if _resolves_locally(socket.gethostname()) else {"host": "127.0.0.1"},
    ]
    if _ipv6():
        accepted += [{"host": "::"}, {"host": "::1"}]
    with socket.socket() as probe:  # a port free right now
        probe.bind(("127.0.0.1", 0))
        free = probe.getsockname()[1]
    accepted.append({"host": "127.0.0.1", "port": free})
    for body in accepted:
        reply = post(body)
        assert reply.status_code == 200, (body, reply.text)
        settings = load_settings(config).server
        for key, value in body.items():
            assert getattr(settings, key) == value, (body, settings)


def _resolves_locally(name: str) -> bool:
    try:
        addresses = {info[4][0] for info in socket.getaddrinfo(name, None, type=socket.SOCK_STREAM)}
    except OSError:
        return False
    for address in addresses:
        try:
            with socket.socket(socket.AF_INET6 if ":" in str(address) else socket.AF_INET) as sock:
                sock.bind((address, 0))
        except OSError:
            return False
    return True


# ================================================================================================
# A hand-edited file the server cannot use: one clear line at start
# ================================================================================================


@pytest.mark.parametrize("case", ["other machine", "port in use", "no such name", "control character"])
def test_an_unusable_file_gives_one_clear_line_at_start(tmp_path: Path, listener: int, case: str) -> None:
    host, port, expected = {
        "other machine": ('"192.0.2.55"', 0, "is not an address of this machine"),
        "port in use": ('"127.0.0.1"', listener, f"server.port {listener} is in use"),
        "no such name": ('"no-such-host.invalid"', 0, "does not resolve"),
        "control character": ('"127.0.0.1\\u0007"', 0, "control character"),
    }[case]
    config = tmp_path / "config.toml"
    config.write_text(f"[server]\nhost = {host}\nport = {port}\nmdns = false\n")
    done = subprocess.run([sys.executable, "-m", "alpaca_zwo", "--config", str(config), "--discovery-port", "0"],
                          capture_output=True, text=True, env=ENV, timeout=60)
    assert done.returncode != 0
    output = [line for line in (done.stdout + done.stderr).splitlines() if line.strip()]
    assert len(output) == 1, output
    assert output[0].startswith("alpaca-zwo: cannot start:") and expected in output[0], output
    assert str(config) in output[0]  # where to fix it
