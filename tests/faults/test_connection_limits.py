"""One host cannot lock the others out (issue 23, item 3), over real sockets.

A second loopback address (127.0.0.2) plays the hostile or broken host: 1,000 idle connections,
then 300 slow-header ("slowloris") connections that trickle a header line every 0.5 s. Before the
fix waitress accepted the first 1,000 (its ``connection_limit``) and then nobody else, for its 60 s
``channel_timeout``: the client on 127.0.0.1 timed out. Now an address holds at most
``server.max_connections_per_address`` (64) connections, one beyond is reset when accepted, and a
request that has not arrived whole within 5 s is closed however it trickles. Judged from both ends:
which of the attacker's sockets the server closed, and what the 127.0.0.1 client's requests cost.
"""

from __future__ import annotations

import http.client
import inspect
import resource
import select
import shutil
import socket
import statistics
import subprocess
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from alpaca_zwo.alpaca.http import MAX_CONNECTIONS_PER_ADDRESS, REQUEST_TIMEOUT_S, HttpServer
from alpaca_zwo.config.file import ConfigError, load_settings
from alpaca_zwo.config.settings import ServerSettings
from alpaca_zwo.service import systemd_unit
from tests.conftest import ServerFactory, make_settings
from tests.faults.harness import Verdict, report
from tests.support import wait_until
from tests.support.alpaca import GET_LIMIT_S

ATTACKER = "127.0.0.2"
IDLE = 1000
SLOW = 300
PROBES = 30
#: The issue's bound: what the attack may add to each request of the client on 127.0.0.1.
COST_LIMIT_S = 0.050
SLOW_REQUEST = b"GET /api/v1/telescope/0/connected?ClientID=9&ClientTransactionID=1 HTTP/1.1\r\nHost: 127.0.0.1\r\n"


@pytest.fixture(autouse=True)
def _descriptors() -> None:
    """1,300 attacker sockets plus the server's own: lift the soft descriptor limit to the hard one."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft != resource.RLIM_INFINITY and (hard == resource.RLIM_INFINITY or soft < hard):
        resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))


class Attacker:
    """Sockets from 127.0.0.2, and which of them the server has closed (EOF or reset)."""

    def __init__(self, port: int) -> None:
        self.port = port
        self.sockets: list[socket.socket] = []
        self.opened: dict[socket.socket, float] = {}
        self.closed: dict[socket.socket, float] = {}  # socket -> when the close was seen

    def open(self, count: int, first: bytes = b"") -> list[socket.socket]:
        batch = []
        for _ in range(count):
            sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            sock.bind((ATTACKER, 0))
            sock.settimeout(5)
            self.opened[sock] = time.monotonic()
            batch.append(sock)
            try:
                sock.connect(("127.0.0.1", self.port))
            except ConnectionResetError:  # the server's reset overtook connect() returning
                self.closed[sock] = time.monotonic()
                continue
            sock.setblocking(False)
            if first:
                self._send(sock, first)
        self.sockets.extend(batch)
        return batch

    def _send(self, sock: socket.socket, data: bytes) -> None:
        try:
            sock.send(data)
        except OSError:  # reset or shut by the server
            self.closed.setdefault(sock, time.monotonic())

    def poll(self) -> None:
        """Note every socket the server has closed since the last look."""
        poller = select.poll()
        alive = {s.fileno(): s for s in self.sockets if s not in self.closed}
        for fd in alive:
            poller.register(fd, select.POLLIN | select.POLLERR | select.POLLHUP)
        for fd, _event in poller.poll(0):
            sock = alive[fd]
            try:
                data = sock.recv(4096)
            except BlockingIOError:
                continue
            except OSError:
                data = b""
            if not data:
                self.closed[sock] = time.monotonic()

    def open_count(self, batch: list[socket.socket]) -> int:
        self.poll()
        return sum(1 for s in batch if s not in self.closed)

    def trickle(self, batch: list[socket.socket], until: float, stop: threading.Event) -> None:
        """One header line every 0.5 s on every open socket: bytes keep coming, the request never ends."""
        while time.monotonic() < until and not stop.wait(0.5):
            for n, sock in enumerate(batch):
                if sock not in self.closed:
                    self._send(sock, f"X-Trickle-{n}: {time.monotonic():.1f}\r\n".encode())

    def close(self) -> None:
        for sock in self.sockets:
            sock.close()


@pytest.fixture
def attacker_port(server_factory: ServerFactory) -> Iterator[Attacker]:
    server = server_factory(make_settings())
    attacker = Attacker(server.port)
    try:
        yield attacker
    finally:
        attacker.close()


def _probe(port: int, count: int, verdict: Verdict) -> list[float]:
    """``count`` GETs from 127.0.0.1, each on a new connection (the case a lock-out hits first):
    their latencies; stops at the first one without an answer within PHD2's 3 s."""
    latencies = []
    for n in range(count):
        started = time.monotonic()
        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=GET_LIMIT_S)
        try:
            conn.request("GET", f"/api/v1/telescope/0/connected?ClientID=1&ClientTransactionID={n + 1}")
            response = conn.getresponse()
            response.read()
            status = response.status
        except OSError as exc:
            verdict.check(False, f"request {n + 1} from 127.0.0.1 got no answer within {GET_LIMIT_S} s: {exc!r}")
            return latencies
        finally:
            conn.close()
        if status != 200:
            verdict.check(False, f"request {n + 1} from 127.0.0.1 got HTTP {status}")
            return latencies
        latencies.append(time.monotonic() - started)
    return latencies


def _ms(values: list[float]) -> str:
    if not values:
        return "none"
    return f"median {statistics.median(values) * 1000:.1f} ms, max {max(values) * 1000:.1f} ms"


def test_one_address_cannot_lock_out_the_others(attacker_port: Attacker) -> None:
    attacker = attacker_port
    port = attacker.port
    verdict = Verdict("one host's connections against a client on 127.0.0.1")
    baseline = _probe(port, PROBES, verdict)

    # 1. 1,000 idle connections: all but 64 are reset at once; the 64 close once 5 s pass without a request.
    idle = attacker.open(IDLE)
    under_idle = _probe(port, PROBES, verdict)
    if verdict.failures:
        verdict.conclude()  # locked out: the rest would only time out
    wait_until(lambda: attacker.open_count(idle) <= MAX_CONNECTIONS_PER_ADDRESS, 5,
               f"the server to close all but {MAX_CONNECTIONS_PER_ADDRESS} of {IDLE} idle connections")
    kept = attacker.open_count(idle)
    verdict.check(kept == MAX_CONNECTIONS_PER_ADDRESS, f"{kept} idle connections kept open, not the limit")
    wait_until(lambda: attacker.open_count(idle) == 0, REQUEST_TIMEOUT_S + 3,
               "the server to close the idle connections that never sent a request")

    # 2. 300 slow-header connections trickling a header line every 0.5 s.
    slow = attacker.open(SLOW, first=SLOW_REQUEST)
    stop = threading.Event()
    trickler = threading.Thread(target=attacker.trickle, args=(slow, time.monotonic() + REQUEST_TIMEOUT_S + 5, stop),
                                daemon=True)
    trickler.start()
    try:
        under_slow = _probe(port, PROBES, verdict)
        wait_until(lambda: attacker.open_count(slow) == 0, REQUEST_TIMEOUT_S + 4,
                   "the server to close every slow-header connection, trickling or not")
    finally:
        stop.set()
        trickler.join(5)
    lived = sorted(attacker.closed[s] - attacker.opened[s] for s in slow)
    verdict.check(sum(1 for t in lived if t > 1.0) <= MAX_CONNECTIONS_PER_ADDRESS,
                  f"{sum(1 for t in lived if t > 1.0)} slow-header connections lived over 1 s")
    verdict.check(lived[-1] <= REQUEST_TIMEOUT_S + 2.5,
                  f"a slow-header connection lived {lived[-1]:.1f} s (request timeout {REQUEST_TIMEOUT_S} s)")

    base = statistics.mean(baseline) if baseline else 0.0
    for label, values in (("1,000 idle", under_idle), ("300 slow-header", under_slow)):
        verdict.check(len(values) == PROBES, f"under {label} connections only {len(values)} of {PROBES} requests "
                                             "from 127.0.0.1 were answered")
        if values:
            cost = statistics.mean(values) - base
            verdict.check(cost < COST_LIMIT_S, f"under {label} connections each request cost {cost * 1000:.1f} ms "
                                                f"more ({_ms(values)}; alone {_ms(baseline)})")
    report("one host's connections", alone=_ms(baseline), under_1000_idle=_ms(under_idle),
           under_300_slow_header=_ms(under_slow), idle_kept=kept,
           slow_header_longest_s=lived[-1] if lived else "none")
    verdict.conclude()


def test_max_connections_per_address_is_a_setting(tmp_path: Path) -> None:
    """``server.max_connections_per_address``: 64 by default, 0 turns the limit off, at most 500."""
    assert ServerSettings().max_connections_per_address == MAX_CONNECTIONS_PER_ADDRESS == 64
    path = tmp_path / "config.toml"
    path.write_text("[server]\nmax_connections_per_address = 0\n")
    assert load_settings(path).server.max_connections_per_address == 0
    for refused in (-1, 501):  # above half of waitress's 1000, one address could fill the server
        path.write_text(f"[server]\nmax_connections_per_address = {refused}\n")
        with pytest.raises(ConfigError, match="max_connections_per_address"):
            load_settings(path)


def test_no_limit_when_set_to_zero(server_factory: ServerFactory) -> None:
    """With the limit off, 100 connections from one address all stay open (waitress's own limits apply)."""
    server = server_factory(make_settings(server=ServerSettings(host="127.0.0.1", port=0, discovery_port=0,
                                                                max_connections_per_address=0)))
    attacker = Attacker(server.port)
    try:
        batch = attacker.open(100)
        wait_until(lambda: server.http.guard.open_count(ATTACKER) == 100, 5, "the server to accept all 100")
        assert attacker.open_count(batch) == 100
    finally:
        attacker.close()


def test_systemd_unit_gives_descriptors_for_every_connection(tmp_path: Path) -> None:
    """The generated unit (and the shipped example) let waitress reach its connection limit with room for
    the bridges, serial port and logs: the usual soft limit of 1024 would fail accept() first."""
    connection_limit = inspect.signature(HttpServer).parameters["connection_limit"].default
    shipped = (Path(__file__).parents[2] / "deploy" / "alpaca-zwo.service").read_text()
    generated = systemd_unit(["--config", str(tmp_path / "config.toml")], user="pi")
    for unit in (shipped, generated):
        limits = [line.removeprefix("LimitNOFILE=") for line in unit.splitlines() if line.startswith("LimitNOFILE=")]
        assert len(limits) == 1 and int(limits[0]) >= connection_limit + 1024, limits
    analyze = shutil.which("systemd-analyze")
    if analyze:  # syntax only here; tests/platform verifies the whole unit on a fresh system
        path = tmp_path / "alpaca-zwo.service"
        path.write_text(generated.replace("User=pi\n", ""))
        verified = subprocess.run([analyze, "verify", str(path)], capture_output=True, text=True, timeout=60)
        assert "LimitNOFILE" not in verified.stdout + verified.stderr


def test_idle_keep_alive_outlives_the_request_deadline(server_factory: ServerFactory) -> None:
    """The 5 s deadline is for a request in progress: a keep-alive connection that waits longer between
    requests (a client polling every 10 s) keeps working, as it did before."""
    server = server_factory(make_settings())
    request = b"GET /api/v1/telescope/0/connected?ClientID=3&ClientTransactionID=1 HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n"
    with socket.create_connection(("127.0.0.1", server.port), timeout=GET_LIMIT_S) as sock:
        for n in range(2):
            if n:
                time.sleep(REQUEST_TIMEOUT_S + 2)  # the scenario itself: a client idle longer than the deadline
            sock.sendall(request)
            reply = b""
            while b"\r\n\r\n" not in reply or not reply.rstrip().endswith(b"}"):
                chunk = sock.recv(4096)
                assert chunk, "the server closed an idle keep-alive connection"
                reply += chunk
            assert reply.startswith(b"HTTP/1.1 200")
