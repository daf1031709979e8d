"""The bridges add no serial traffic (issue 16): ``python -m benchmarks.bridges``.

The emulator (paced at 9600 baud, DEBUG log) and alpaca-zwo run as separate processes, alpaca-zwo
with its Stellarium server and shared ZWO-protocol port on (loopback, free ports). The mount line
is counted at the emulator over equal windows, the mount at rest (tracking off, as after power-on):

1. Alpaca pollers only (N.I.N.A.-like clients);
2. the same plus 5 Stellarium clients (``tests/bridges/stellarium_client.py``, written from the
   protocol document), each reading the position messages the server pushes;
3. the same plus one INDI client: ``indiserver`` running ``indi_lx200am5`` (Debian ``indi-bin``)
   connected to the shared ZWO port over TCP, polling the mount as INDI does;
4. Alpaca pollers only again, after every bridge client has gone (drift check).

The clients send no motion commands in these windows, so "no serial traffic beyond their commands"
means: the line carries the same bytes and exchanges in all four. Results:
``benchmarks/results/<stamp>-bridges.json`` and ``.md``; process logs in the folder of that name.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import re
import shutil
import subprocess
import sys
import threading
import time
import urllib.request
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from tests.support.indi import IndiServer

from .loads import ClientSpec, WorkerPool
from .procs import REPO, Emulator, Proc, cycle_aligned, emulator_log_exchanges, start_alpaca_zwo, start_emulator

RESULTS = Path(__file__).resolve().parent / "results"


def _until(condition: Any, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.2)
    raise RuntimeError(f"timed out waiting for {what}")


class StellariumFleet:
    """``n`` Stellarium connections, each drained by its own thread as Stellarium drains it."""

    def __init__(self, port: int, n: int) -> None:
        sys.path.insert(0, str(REPO))
        from tests.bridges.stellarium_client import StellariumClient

        self.clients = [StellariumClient(port) for _ in range(n)]
        self.received = [0] * n
        self.errors: list[str] = []
        self._stop = threading.Event()
        self._threads = [threading.Thread(target=self._drain, args=(i,), daemon=True) for i in range(n)]
        for thread in self._threads:
            thread.start()

    def _drain(self, index: int) -> None:
        client = self.clients[index]
        while not self._stop.is_set():
            try:
                client.read_position(timeout=2.0)
                self.received[index] += 1
            except (TimeoutError, ValueError, ConnectionError, OSError) as exc:
                if not self._stop.is_set():
                    self.errors.append(f"client {index}: {exc!r}")
                return

    def close(self) -> None:
        self._stop.set()
        for client in self.clients:
            client.close()
        for thread in self._threads:
            thread.join(3.0)


def _bridge_ports(proc: Proc, timeout: float = 20.0) -> tuple[int, int]:
    """The ports the server's bridges announced in its log (configured as 0: any free port)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        text = proc.stderr.read_text(errors="replace")
        stel = re.search(r"Stellarium telescope server on 127\.0\.0\.1:(\d+)", text)
        zwo = re.search(r"ZWO-protocol port listening on 127\.0\.0\.1:(\d+)", text)
        if stel and zwo:
            return int(stel.group(1)), int(zwo.group(1))
        time.sleep(0.1)
    raise RuntimeError("the bridges did not announce their ports")


class Bench:
    def __init__(self, run_dir: Path, window_s: float, pollers: int) -> None:
        self.run_dir = run_dir
        self.window_s = window_s
        self.pollers = pollers
        self.procs: list[Proc] = []
        self.emulator: Emulator | None = None
        self.server: Proc | None = None
        self.pool: WorkerPool | None = None
        self.fleet: StellariumFleet | None = None
        self.indi: IndiServer | None = None
        self.ports = (0, 0)

    def log(self, message: str) -> None:
        print(f"[{time.strftime('%H:%M:%S')}] {message}", flush=True)

    def start(self) -> None:
        self.emulator = start_emulator(self.run_dir, 9600, None)
        self.procs.append(self.emulator.proc)
        (self.run_dir / "config.toml").write_text(
            '[stellarium]\nenabled = true\nhost = "127.0.0.1"\nport = 0\n\n'
            '[zwo_port]\nenabled = true\nhost = "127.0.0.1"\nport = 0\n')
        self.server = start_alpaca_zwo(self.run_dir, self.emulator.proc.ports["tcp"], None)
        self.procs.append(self.server)
        self.ports = _bridge_ports(self.server)
        self.log(f"alpaca-zwo port {self.server.port}, Stellarium {self.ports[0]}, ZWO port {self.ports[1]}")
        self.pool = WorkerPool(4, None)
        self._status()  # the setup API answers

    def _status(self) -> dict[str, Any]:
        assert self.server is not None
        url = f"http://127.0.0.1:{self.server.port}/setup/api/telescope/0/status"
        with urllib.request.urlopen(url, timeout=10) as reply:
            return json.load(reply)

    def _bridge_counts(self) -> dict[str, int]:
        bridges = {row.get("name"): row for row in self._status().get("bridges", [])}
        stel = bridges.get("stellarium", {})
        zwo = bridges.get("zwo_port", {})
        return {
            "stellarium_clients": len(stel.get("clients", [])),
            "stellarium_messages": sum(c.get("messages", 0) for c in stel.get("clients", [])),
            "zwo_programs": len(zwo.get("programs", [])),
            "zwo_commands": sum(p.get("commands", 0) for p in zwo.get("programs", [])),
            "zwo_refusals": zwo.get("refusals", 0),
        }

    def phase(self, name: str) -> dict[str, Any]:
        assert self.emulator is not None and self.pool is not None and self.server is not None
        running = self.pool.start("127.0.0.1", self.server.port, [ClientSpec("nina", self.pollers)], warmup=4.0,
                                  duration=self.window_s, seed=len(name))
        _sleep_until(running.measure_from)
        before, counts0 = self.emulator.stats(), self._bridge_counts()
        received0 = sum(self.fleet.received) if self.fleet else 0
        _sleep_until(running.stop_at)
        after, counts1 = self.emulator.stats(), self._bridge_counts()
        received1 = sum(self.fleet.received) if self.fleet else 0
        result = running.wait()
        window = after["time"] - before["time"]
        per_min = 60.0 / window
        commands = collections.Counter(body[:2] if body.startswith(("Sr", "Sd", "Mg")) else body
                                       for _, body, _, _ in emulator_log_exchanges(self.emulator.proc.stderr,
                                                                                   before["time"], after["time"]))
        aligned = cycle_aligned(self.emulator.proc.stderr, before["time"], after["time"]) or {}
        nina = result["labels"].get("nina", {})
        row = {
            "phase": name,
            "window_s": round(window, 2),
            "exchanges_per_min": round((after["exchanges"] - before["exchanges"]) * per_min, 1),
            "bytes_to_mount_per_min": round((after["bytes_in"] - before["bytes_in"]) * per_min, 1),
            "bytes_from_mount_per_min": round((after["bytes_out"] - before["bytes_out"]) * per_min, 1),
            "aligned_bytes_per_min": round(aligned["bytes_per_s"] * 60.0, 1) if aligned else None,
            "aligned_exchanges_per_min": round(aligned["exchanges_per_s"] * 60.0, 1) if aligned else None,
            "poll_period_s": aligned.get("poll_period_s"),
            "commands_per_min": {k: round(v * per_min, 1) for k, v in sorted(commands.items())},
            "stellarium_clients": counts1["stellarium_clients"],
            "stellarium_positions_per_min": round((received1 - received0) * per_min, 1),
            "indi_programs": counts1["zwo_programs"],
            "indi_commands_per_min": round((counts1["zwo_commands"] - counts0["zwo_commands"]) * per_min, 1),
            "indi_refusals": counts1["zwo_refusals"] - counts0["zwo_refusals"],
            "alpaca_get_per_min": round(len(nina.get("latency_ms", [])) * per_min, 1),
            "alpaca_errors": sum(v["errors"] for v in result["labels"].values()),
            "client_errors": list(self.fleet.errors) if self.fleet else [],
        }
        self.log(f"{name}: {row['exchanges_per_min']} exch/min, "
                 f"{row['bytes_to_mount_per_min'] + row['bytes_from_mount_per_min']:.0f} B/min "
                 f"(whole cycles {row['aligned_bytes_per_min']} B/min), Stellarium {row['stellarium_clients']} "
                 f"({row['stellarium_positions_per_min']} positions/min), INDI {row['indi_programs']} "
                 f"({row['indi_commands_per_min']} commands/min), commands {row['commands_per_min']}")
        return row

    def run(self) -> list[dict[str, Any]]:
        rows = [self.phase("Alpaca pollers only")]
        self.fleet = StellariumFleet(self.ports[0], 5)
        _until(lambda: self._bridge_counts()["stellarium_clients"] == 5, 10, "5 Stellarium clients")
        rows.append(self.phase("+ 5 Stellarium clients"))
        if shutil.which("indiserver") and shutil.which("indi_lx200am5"):
            home = self.run_dir / "indi-home"
            home.mkdir(exist_ok=True)
            self.indi = IndiServer(home)
            self.indi.connect(self.ports[1])
            rows.append(self.phase("+ 5 Stellarium + 1 INDI (indi_lx200am5)"))
            self.indi.stop()
            self.indi = None
        else:
            self.log("INDI (Debian indi-bin) is not installed: the INDI phase is skipped")
        self.fleet.close()
        self.fleet = None
        _until(lambda: self._bridge_counts()["stellarium_clients"] == 0, 10, "Stellarium clients to go")
        rows.append(self.phase("Alpaca pollers only, again"))
        return rows

    def stop(self) -> None:
        if self.fleet is not None:
            self.fleet.close()
        if self.indi is not None:
            self.indi.stop()
        if self.pool is not None:
            self.pool.close()
        for proc in reversed(self.procs):
            proc.stop()


def _sleep_until(deadline: float) -> None:
    delay = deadline - time.time()
    if delay > 0:
        time.sleep(delay)


def render(results: dict[str, Any]) -> str:
    meta = results["meta"]
    rows = results["rows"]
    lines = [f"### Bridges and the mount line {meta['started']}", "",
             f"- command: `{meta['command']}` ({meta['duration_s']} s); {meta['pollers']} N.I.N.A.-like pollers "
             f"throughout; mount at rest (tracking off, as after power-on); emulator 9600 baud, 1x",
             f"- commit {meta['commit']}; load average at start {' / '.join(f'{v:.2f}' for v in meta['loadavg_start'])}"
             f", at end {' / '.join(f'{v:.2f}' for v in meta['loadavg_end'])}", "",
             "| Phase | window s | exchanges/min | bytes/min to / from mount | whole cycles: bytes/min, exchanges/min, "
             "poll period s | Stellarium clients (positions/min received) | INDI programs (commands/min at the "
             "ZWO port) | Alpaca GET/min | errors |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        errors = r["alpaca_errors"] + len(r["client_errors"]) + r["indi_refusals"]
        lines.append(
            f"| {r['phase']} | {r['window_s']:.1f} | {r['exchanges_per_min']:.1f} | "
            f"{r['bytes_to_mount_per_min']:.0f} / {r['bytes_from_mount_per_min']:.0f} | "
            f"{r['aligned_bytes_per_min']}, {r['aligned_exchanges_per_min']}, {r['poll_period_s']} | "
            f"{r['stellarium_clients']} ({r['stellarium_positions_per_min']:.0f}) | "
            f"{r['indi_programs']} ({r['indi_commands_per_min']:.0f}) | {r['alpaca_get_per_min']:.0f} | {errors} |")
    names = sorted({k for r in rows for k in r["commands_per_min"]})
    lines += ["", "Commands on the mount line per minute (emulator log):", "",
              "| Phase | " + " | ".join(f"`:{n}#`" for n in names) + " |",
              "|---|" + "---|" * len(names)]
    for r in rows:
        lines.append(f"| {r['phase']} | " + " | ".join(f"{r['commands_per_min'].get(n, 0):.1f}" for n in names) + " |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bridges", description=__doc__.splitlines()[0])
    parser.add_argument("--window", type=float, default=60.0, help="seconds per measured phase (default 60)")
    parser.add_argument("--pollers", type=int, default=10, help="N.I.N.A.-like Alpaca pollers (default 10)")
    args = parser.parse_args(argv)
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ") + "-bridges"
    run_dir = RESULTS / stamp
    run_dir.mkdir(parents=True)
    argv_used = sys.argv[1:] if argv is None else argv
    meta: dict[str, Any] = {"command": " ".join(["python -m benchmarks.bridges", *argv_used]),
                            "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                            "pollers": args.pollers, "loadavg_start": os.getloadavg(),
                            "commit": subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                                                     text=True, cwd=REPO).stdout.strip()}
    started = time.time()
    bench = Bench(run_dir, args.window, args.pollers)
    rows: list[dict[str, Any]] = []
    try:
        bench.start()
        rows = bench.run()
    finally:
        bench.stop()
    meta.update(duration_s=round(time.time() - started, 1), loadavg_end=os.getloadavg())
    results = {"meta": meta, "rows": rows}
    (RESULTS / f"{stamp}.json").write_text(json.dumps(results, indent=1))
    table = render(results)
    (RESULTS / f"{stamp}.md").write_text(table)
    print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
