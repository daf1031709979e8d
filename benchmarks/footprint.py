"""Idle footprint: CPU share of one core and resident memory with one N.I.N.A.-like client polling.

    python3 -m benchmarks.footprint [--seconds 45] [--warmup 10]

Two set-ups, each started as a user starts it and measured from /proc (Linux, as on a Pi):

* ``default``: ``alpaca-zwo`` with no --device, so the built-in emulator runs in the same process
  and its work (the simulated mount) is counted too;
* ``mount``: ``alpaca-zwo --device socket://...`` against the emulator in a separate process paced
  at 9600 baud, which is what the server alone costs with a real mount;
* the same with the client connected but silent: the server's own polling of the mount.

The client is N.I.N.A.'s 2 s poll of 21 properties plus its derived re-reads (the sequence in
``benchmarks.loads``), over one keep-alive connection, after ``Connected = true``. CPU is the
server's user+system time over the window divided by the wall time; RSS is read at the end
(VmRSS) together with the peak (VmHWM). Goal on a Raspberry Pi: < 1 % of a core, < 60 MB.
"""

from __future__ import annotations

import argparse
import http.client
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.loads import NINA_DERIVED, NINA_SEQUENCE

POLL_PERIOD_S = 2.0
_TICK = os.sysconf("SC_CLK_TCK")


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / _TICK  # utime, stime


def _memory_mb(pid: int) -> tuple[float, float]:
    values = {}
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        key, _, rest = line.partition(":")
        if key in ("VmRSS", "VmHWM"):
            values[key] = int(rest.split()[0]) / 1024
    return values["VmRSS"], values["VmHWM"]


def _start(cmd: list[str], marker: str, log: Path) -> tuple[subprocess.Popen[str], str]:
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=open(log, "w"), text=True)  # noqa: SIM115
    assert proc.stdout is not None
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if marker in line:
            return proc, line
        if not line and proc.poll() is not None:
            break
    proc.kill()
    raise RuntimeError(f"{cmd[0]} did not start: see {log}")


class NinaPoller:
    """One N.I.N.A.-like client: the 2 s poll over one keep-alive connection."""

    def __init__(self, port: int, polling: bool = True) -> None:
        self.polling = polling
        self.conn = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
        self.tx = 0
        self.requests = 0
        self.errors = 0

    def _call(self, method: str, member: str, body: str = "") -> None:
        self.tx += 1
        path = f"/api/v1/telescope/0/{member}"
        headers = {"Content-Type": "application/x-www-form-urlencoded"} if body else {}
        query = f"?ClientID=7&ClientTransactionID={self.tx}" if method == "GET" else ""
        self.conn.request(method, path + query, body=body or None, headers=headers)
        reply = json.loads(self.conn.getresponse().read())
        self.requests += 1
        self.errors += reply.get("ErrorNumber", 0) != 0

    def connect(self) -> None:
        self._call("PUT", "connected", f"Connected=True&ClientID=7&ClientTransactionID={self.tx + 1}")

    def run(self, seconds: float) -> None:
        if not self.polling:  # connected, then silent: what the server costs on its own
            time.sleep(seconds)
            return
        next_poll = time.monotonic()
        end = next_poll + seconds
        while next_poll < end:
            for member in NINA_SEQUENCE + NINA_DERIVED:
                self._call("GET", member)
            next_poll += POLL_PERIOD_S
            time.sleep(max(0.0, next_poll - time.monotonic()))


def measure(name: str, server_cmd: list[str], seconds: float, warmup: float, workdir: Path,
            polling: bool = True) -> dict[str, float | str]:
    server, line = _start(server_cmd, "Alpaca API:", workdir / f"{name}-server.log")
    try:
        port = int(line.split("127.0.0.1:")[1].split("/")[0])
        client = NinaPoller(port, polling)
        client.connect()
        client.run(warmup)
        cpu0, t0, requests0 = _cpu_seconds(server.pid), time.monotonic(), client.requests
        client.run(seconds)
        cpu1, t1 = _cpu_seconds(server.pid), time.monotonic()
        rss, peak = _memory_mb(server.pid)
        return {"setup": name, "cpu_pct": 100.0 * (cpu1 - cpu0) / (t1 - t0), "rss_mb": rss, "peak_rss_mb": peak,
                "req_per_s": (client.requests - requests0) / (t1 - t0), "errors": client.errors,
                "seconds": t1 - t0}
    finally:
        server.terminate()
        server.wait(timeout=20)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=45.0, help="measured window per set-up")
    parser.add_argument("--warmup", type=float, default=10.0, help="polling before the window starts")
    args = parser.parse_args(argv)
    server = [sys.executable, "-m", "alpaca_zwo", "--host", "127.0.0.1", "--port", "0", "--discovery-port", "0"]
    results = []
    with tempfile.TemporaryDirectory(prefix="footprint-") as tmp:
        work = Path(tmp)
        results.append(measure("default", [*server, "--config", str(work / "a.toml")], args.seconds, args.warmup,
                               work))
        emulator, line = _start([sys.executable, "-m", "alpaca_zwo.emulator", "--port", "0", "--baud", "9600"],
                                "tcp ", work / "emulator.log")
        try:
            device = f"socket://{line.split()[1]}"
            results.append(measure("mount", [*server, "--device", device, "--config", str(work / "b.toml")],
                                   args.seconds, args.warmup, work))
            results.append(measure("mount, client connected but silent",
                                   [*server, "--device", device, "--config", str(work / "c.toml")],
                                   args.seconds, args.warmup, work, polling=False))
        finally:
            emulator.terminate()
            emulator.wait(timeout=20)
    print("| Set-up | CPU % of one core | RSS MB (peak) | client req/s | errors | window s |")
    print("|---|---|---|---|---|---|")
    for r in results:
        print(f"| {r['setup']} | {r['cpu_pct']:.2f} | {r['rss_mb']:.1f} ({r['peak_rss_mb']:.1f}) | "
              f"{r['req_per_s']:.1f} | {r['errors']} | {r['seconds']:.0f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
