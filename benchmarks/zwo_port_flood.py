"""What offenders on the shared ZWO port cost an Alpaca client: ``python -m benchmarks.zwo_port_flood``.

The emulator (paced at 9600 baud) and alpaca-zwo with its ZWO-protocol port on run as separate processes,
as a user starts them. One Alpaca client polls ``rightascension`` on a keep-alive connection, as N.I.N.A.
does, through three windows: alone, while ``tests.support.zwo_client.offend`` plays every offence on the
port again and again (junk between commands, 20 kB of garbage, a 5,000-command flood, garbage dressed with
a command every 4 kB, 100 connections opened and dropped), and alone again. Each offence is checked as in
the test (the offender is closed, the port keeps answering); the figures are the client's request times
per window and the server's CPU. tests/bridges/test_zwo_port.py asserts that only the offender is dropped;
this measures the cost, which depends on the machine, so it is written down (BENCHMARKS.md), not asserted.

    python -m benchmarks.zwo_port_flood               # three 20 s windows, about a minute
    python -m benchmarks.zwo_port_flood --window 60
"""

from __future__ import annotations

import argparse
import os
import random
import re
import shlex
import statistics
import sys
import tempfile
import threading
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from benchmarks.client import AlpacaClient
from benchmarks.procs import Proc, start_alpaca_zwo, start_emulator
from benchmarks.sync_residual import _commit, save
from tests.support.zwo_client import offend

WINDOWS = ("alone", "offences", "alone after")


def _zwo_port(server: Proc, timeout: float = 20.0) -> int:
    """The port the server's ZWO-protocol bridge announced in its log (configured as 0: any free port)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        log = server.stderr.read_text(errors="replace")
        found = re.search(r"ZWO-protocol port listening on 127\.0\.0\.1:(\d+)", log)
        if found:
            return int(found.group(1))
        time.sleep(0.1)
    raise RuntimeError("the ZWO port did not announce itself")


class Poller(threading.Thread):
    """One Alpaca client polling until stopped; each request's time and each failure kept."""

    def __init__(self, port: int) -> None:
        super().__init__(daemon=True)
        self.client = AlpacaClient("127.0.0.1", port)
        self.stop = threading.Event()
        self.latencies_s: list[float] = []
        self.errors: list[str] = []

    def run(self) -> None:
        while not self.stop.is_set():
            try:
                self.client.get("rightascension")
                self.latencies_s.append(self.client.latency)
            except Exception as exc:  # every failure is a figure
                self.errors.append(repr(exc))


def _figures(poller: Poller, seconds: float, cpu_s: float, extra: dict[str, Any]) -> dict[str, Any]:
    ms = sorted(1000.0 * s for s in poller.latencies_s)
    if len(ms) < 2:
        raise RuntimeError(f"{len(ms)} answered requests in the window; failures: {poller.errors[:3]}")
    cuts = statistics.quantiles(ms, n=100)
    return {"requests": len(ms), "errors": len(poller.errors), "first_errors": poller.errors[:3],
            "p50_ms": round(cuts[49], 2), "p95_ms": round(cuts[94], 2), "p99_ms": round(cuts[98], 2),
            "max_ms": round(ms[-1], 2), "server_cpu": round(cpu_s / seconds, 3), **extra}


def _window(server: Proc, zwo_port: int | None, seconds: float, seed: int) -> dict[str, Any]:
    """One window: the poller alone, or beside the offences played back to back (``zwo_port`` given)."""
    poller = Poller(server.port)
    cpu_before = server.cpu_s()
    poller.start()
    rounds = 0
    rng = random.Random(seed)
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if zwo_port is None:
            time.sleep(0.1)  # this window only waits; the poller measures
        else:
            offend(zwo_port, rng)
            rounds += 1
    poller.stop.set()
    poller.join()
    poller.client.close()
    return _figures(poller, seconds, server.cpu_s() - cpu_before, {"offence_rounds": rounds})


def render(results: dict[str, Any]) -> str:
    meta = results["meta"]
    lines = [f"`{meta['command']}` on {meta['commit']}, {meta['started']}, {meta['window_s']:.0f} s windows, "
             f"load average {meta['loadavg_start'][0]:.2f} at the start", "",
             "| window | requests | errors | p50 ms | p95 ms | p99 ms | max ms | server CPU | offence rounds |",
             "|---|---|---|---|---|---|---|---|---|"]
    for name in WINDOWS:
        w = results["windows"][name]
        lines.append(f"| {name} | {w['requests']} | {w['errors']} | {w['p50_ms']} | {w['p95_ms']} | {w['p99_ms']} | "
                     f"{w['max_ms']} | {w['server_cpu']} | {w['offence_rounds'] or ''} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.zwo_port_flood", description=__doc__.splitlines()[0])
    parser.add_argument("--window", type=float, default=20.0, help="seconds per window (default 20)")
    parser.add_argument("--seed", type=int, default=16, help="the offences' random bytes (default 16)")
    args = parser.parse_args(argv)
    argv_used = sys.argv[1:] if argv is None else argv
    meta: dict[str, Any] = {"command": shlex.join(["python", "-m", "benchmarks.zwo_port_flood", *argv_used]),
                            "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                            "window_s": args.window, "commit": _commit(), "loadavg_start": os.getloadavg()}
    with tempfile.TemporaryDirectory(prefix="zwo-port-flood-") as folder:
        run_dir = Path(folder)
        emulator = start_emulator(run_dir, 9600, None)
        (run_dir / "config.toml").write_text('[zwo_port]\nenabled = true\nhost = "127.0.0.1"\nport = 0\n')
        server = start_alpaca_zwo(run_dir, emulator.proc.ports["tcp"], None)
        try:
            zwo_port = _zwo_port(server)
            client = AlpacaClient("127.0.0.1", server.port)
            client.put("connected", Connected=True)  # as a client does first; the pollers then only read
            client.close()
            windows = {name: _window(server, zwo_port if name == "offences" else None, args.window, args.seed)
                       for name in WINDOWS}
        finally:
            server.stop()
            emulator.proc.stop()
    meta["loadavg_end"] = os.getloadavg()
    save(datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ") + "-zwo-port-flood",
         {"meta": meta, "windows": windows}, render)
    return 0


if __name__ == "__main__":
    sys.exit(main())
