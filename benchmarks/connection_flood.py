"""What one host's connections cost another client (issue 23, item 3), measured over real sockets.

``python -m benchmarks.connection_flood`` starts ``python -m alpaca_zwo`` (the built-in emulator) from
this tree, or from ``--tree DIR`` (e.g. an older checkout, to compare), or measures a running server
with ``--port``. From 127.0.0.2 it opens 1,000 idle connections, then 300 slow-header connections
trickling one header line every 0.5 s; meanwhile a client on 127.0.0.1 sends GETs, each on a new
connection (what a locked-out client needs first). Prints each phase's latencies and what the server
did with the attacker's sockets. Linux (any 127.0.0.0/8 address is loopback there).
"""

from __future__ import annotations

import argparse
import contextlib
import http.client
import re
import resource
import select
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ATTACKER = "127.0.0.2"
REQUEST = b"GET /api/v1/telescope/0/connected?ClientID=9&ClientTransactionID=1 HTTP/1.1\r\nHost: 127.0.0.1\r\n"
GET_LIMIT_S = 3.0  # PHD2's status connection gives up after this


def probe(port: int, count: int) -> tuple[list[float], int]:
    """``count`` GETs from 127.0.0.1 on fresh connections: latencies of the answered ones, and failures."""
    latencies, failed = [], 0
    for n in range(count):
        started = time.monotonic()
        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=GET_LIMIT_S)
        try:
            conn.request("GET", f"/api/v1/telescope/0/connected?ClientID=1&ClientTransactionID={n + 1}")
            response = conn.getresponse()
            response.read()
            if response.status == 200:
                latencies.append(time.monotonic() - started)
            else:
                failed += 1
        except OSError:
            failed += 1
            if failed >= 3:  # locked out: three 3 s timeouts say enough
                return latencies, failed
        finally:
            conn.close()
    return latencies, failed


def open_from_attacker(port: int, count: int, first: bytes = b"") -> list[socket.socket]:
    socks = []
    for _ in range(count):
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.bind((ATTACKER, 0))
        sock.settimeout(5)
        try:
            sock.connect(("127.0.0.1", port))
            if first:
                sock.send(first)
        except OSError:
            pass  # refused or reset at once: counts as closed below
        sock.setblocking(False)
        socks.append(sock)
    return socks


def still_open(socks: list[socket.socket]) -> int:
    """How many of ``socks`` the server has not closed (EOF or reset)."""
    by_fd = {sock.fileno(): sock for sock in socks}
    poller = select.poll()
    for fd in by_fd:
        poller.register(fd, select.POLLIN | select.POLLERR | select.POLLHUP)
    closed = 0
    for fd, _event in poller.poll(0):
        try:
            closed += not by_fd[fd].recv(1, socket.MSG_PEEK)
        except BlockingIOError:
            continue
        except OSError:
            closed += 1
    return len(socks) - closed


def trickle(socks: list[socket.socket], stop: threading.Event) -> None:
    while not stop.wait(0.5):
        for n, sock in enumerate(socks):
            with contextlib.suppress(OSError):  # closed by the server: counted by still_open
                sock.send(f"X-Trickle-{n}: {time.monotonic():.1f}\r\n".encode())


def summary(label: str, latencies: list[float], failed: int) -> str:
    if not latencies:
        return f"{label:<34} no answer: {failed} requests in a row got none within {GET_LIMIT_S:.0f} s, gave up"
    ms = sorted(x * 1000 for x in latencies)
    p95 = ms[min(len(ms) - 1, int(0.95 * len(ms)))]
    return (f"{label:<34} mean {statistics.mean(ms):6.1f} ms  median {statistics.median(ms):6.1f}  "
            f"p95 {p95:6.1f}  max {ms[-1]:6.1f}  failed {failed}")


def start_server(tree: Path) -> tuple[subprocess.Popen[str], int]:
    config = Path(tempfile.mkdtemp()) / "config.toml"
    proc = subprocess.Popen([sys.executable, "-m", "alpaca_zwo", "--host", "127.0.0.1", "--port", "0",
                             "--discovery-port", "0", "--config", str(config)],
                            cwd=tree, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    assert proc.stdout is not None
    for line in proc.stdout:
        match = re.search(r"Alpaca API:\s+http://127\.0\.0\.1:(\d+)/", line)
        if match:
            threading.Thread(target=proc.stdout.read, daemon=True).start()  # keep its pipe drained
            return proc, int(match.group(1))
    raise RuntimeError("the server did not print its URL")


def run(port: int, probes: int, idle: int, slow: int) -> None:
    print(summary("alone", *probe(port, probes)))
    idle_socks = open_from_attacker(port, idle)
    print(summary(f"{idle} idle from {ATTACKER}", *probe(port, probes)))
    print(f"  the server kept {still_open(idle_socks)} of {idle} idle connections open after the probes")
    for sock in idle_socks:
        sock.close()
    time.sleep(1.0)  # let the server see the closes before the next phase (a benchmark, not a test)
    slow_socks = open_from_attacker(port, slow, REQUEST)
    stop = threading.Event()
    threading.Thread(target=trickle, args=(slow_socks, stop), daemon=True).start()
    started = time.monotonic()
    print(summary(f"{slow} slow-header from {ATTACKER}", *probe(port, probes)))
    while still_open(slow_socks) and time.monotonic() - started < 90:
        time.sleep(0.1)
    print(f"  the last slow-header connection was closed after {time.monotonic() - started:.1f} s "
          f"({still_open(slow_socks)} still open)")
    stop.set()
    for sock in slow_socks:
        sock.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--port", type=int, help="measure a server already listening on 127.0.0.1:PORT")
    parser.add_argument("--tree", type=Path, default=Path(__file__).parents[1],
                        help="the alpaca-zwo source tree to start (default: this one)")
    parser.add_argument("--probes", type=int, default=100)
    parser.add_argument("--idle", type=int, default=1000)
    parser.add_argument("--slow", type=int, default=300)
    args = parser.parse_args()
    _soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
    proc = None
    port = args.port
    if port is None:
        proc, port = start_server(args.tree)
    try:
        run(port, args.probes, args.idle, args.slow)
    finally:
        if proc is not None:
            proc.terminate()
            proc.wait(30)


if __name__ == "__main__":
    main()
