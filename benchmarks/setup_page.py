"""Open setup pages and PulseGuide latency at 9600 baud (issue 23 item 7): ``python -m benchmarks.setup_page``.

The emulator (paced at 9600 baud, DEBUG log) and alpaca-zwo run as separate processes, as in
``benchmarks.run``. One guider sends a 20 ms ``PUT pulseguide`` every 0.5 s (alternating north and
south) while 0, then N, setup pages are open. A page makes the requests ``static/app.js`` makes:
``/status`` every second (``POLL_MS``), ``/trace`` and ``/log`` every other round (their panels
open), and also ``/settings`` every round. The shipped page reads ``/settings`` only when it opens
and when the mount comes up; reading it every second is the worst a page does (a tab reloaded, tabs
opened and closed). ``--interval 0`` runs each page's rounds back to back (a closed loop), the
heaviest load a page's requests can put on the server.

Measured per phase: the PUT's round trip at the guider (request written to last reply byte), the
:Mg arrival at the emulator after the PUT was sent (its DEBUG log, ms stamps), and the line's
exchanges per second from the emulator's own counters. Results: ``benchmarks/results/<stamp>-setup-page.json``
and the table on stdout.
"""

from __future__ import annotations

import argparse
import http.client
import json
import re
import threading
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from .client import AlpacaClient
from .procs import Emulator, start_alpaca_zwo, start_emulator
from .stats import percentile

RESULTS = Path(__file__).resolve().parent / "results"
PAGE_GETS_1S = ("/setup/api/telescope/0/status", "/setup/api/telescope/0/settings")
PAGE_GETS_2S = ("/setup/api/telescope/0/trace?after=0", "/setup/api/log?after=0")
_MG = re.compile(r"^(\d{4}-\d\d-\d\d \d\d:\d\d:\d\d),(\d{3}) DEBUG alpaca_zwo\.emulator\.server: line \d+ :Mg[ns]")


class Page(threading.Thread):
    """One open setup page: its polls on its own keep-alive connection, as a browser tab has."""

    def __init__(self, port: int, stop: threading.Event, offset: float, interval: float) -> None:
        super().__init__(daemon=True)
        self.port, self.stop, self.offset, self.interval = port, stop, offset, interval
        self.requests = 0
        self.errors: list[str] = []

    def _get(self, conn: http.client.HTTPConnection, path: str) -> None:
        conn.request("GET", path)
        response = conn.getresponse()
        body = response.read()
        if response.status != 200:
            self.errors.append(f"{path}: HTTP {response.status} {body[:80]!r}")
        self.requests += 1

    def run(self) -> None:
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=30)
        tick = time.monotonic() + self.offset
        n = 0
        while not self.stop.wait(max(0.0, tick - time.monotonic())):
            try:
                for path in PAGE_GETS_1S + (PAGE_GETS_2S if n % 2 == 0 else ()):
                    self._get(conn, path)
            except (OSError, http.client.HTTPException) as exc:
                self.errors.append(repr(exc))
                conn.close()
                conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=30)
            n += 1
            tick += self.interval
        conn.close()


def _mg_arrivals(log: Path) -> list[float]:
    found = []
    with log.open(errors="replace") as lines:
        for line in lines:
            match = _MG.match(line)
            if match:
                stamp = datetime.strptime(match.group(1), "%Y-%m-%d %H:%M:%S").timestamp()
                found.append(stamp + int(match.group(2)) / 1000.0 + 0.0005)
    return found


def phase(port: int, emulator: Emulator, log: Path, pages: int, pulses: int, interval: float) -> dict[str, Any]:
    """``pulses`` guide pulses with ``pages`` pages open, each polling every ``interval`` s; latencies in ms."""
    stop = threading.Event()
    fleet = [Page(port, stop, i * interval / max(1, pages), interval) for i in range(pages)]
    for page in fleet:
        page.start()
    time.sleep(3.0)  # every page has made its first round
    guider = AlpacaClient("127.0.0.1", port, client_id=1, timeout=30.0)
    before = emulator.stats()
    sent_at: list[float] = []
    round_trips: list[float] = []
    for i in range(pulses):
        sent_at.append(time.time())
        guider.put("pulseguide", Direction=i % 2, Duration=20)
        round_trips.append(guider.latency * 1000.0)
        time.sleep(0.5)
    after = emulator.stats()
    stop.set()
    for page in fleet:
        page.join(10)
    guider.close()
    time.sleep(0.5)  # the emulator's log has been flushed
    arrivals = _mg_arrivals(log)
    wire = []
    for sent in sent_at:
        first = next((t for t in arrivals if t >= sent - 0.001), None)
        if first is not None and first - sent < 5.0:
            wire.append((first - sent) * 1000.0)
    span = after["time"] - before["time"]

    def summary(values: list[float]) -> dict[str, float]:
        ordered = sorted(values)
        return {"median": round(percentile(ordered, 50) or 0.0, 1), "p90": round(percentile(ordered, 90) or 0.0, 1),
                "max": round(ordered[-1], 1)}

    return {"pages": pages, "interval_s": interval, "pulses": pulses, "page_requests": sum(p.requests for p in fleet),
            "page_errors": [e for p in fleet for e in p.errors][:5],
            "put_ms": summary(round_trips), "mg_arrival_ms": summary(wire) if wire else None,
            "exchanges_per_s": round((after["exchanges"] - before["exchanges"]) / span, 2),
            "bytes_per_s": round((after["bytes_in"] + after["bytes_out"] - before["bytes_in"] - before["bytes_out"])
                                 / span, 1)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pages", default="0,4", help="page counts, one phase each (default 0,4)")
    parser.add_argument("--pulses", type=int, default=60, help="pulses per phase (default 60)")
    parser.add_argument("--interval", type=float, default=1.0,
                        help="seconds between a page's polls (default 1, the page's POLL_MS); 0: back to back")
    parser.add_argument("--baud", type=int, default=9600)
    parser.add_argument("--note", default="", help="stored with the results (e.g. the commit measured)")
    args = parser.parse_args(argv)
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    run_dir = RESULTS / f"{stamp}-setup-page"
    run_dir.mkdir(parents=True, exist_ok=True)
    emulator = start_emulator(run_dir, args.baud, None)
    server = start_alpaca_zwo(run_dir, emulator.proc.ports["tcp"], None)
    rows = []
    try:
        anchor = AlpacaClient("127.0.0.1", server.port, client_id=7, timeout=30.0)
        anchor.put("connected", Connected="true")
        deadline = time.monotonic() + 60
        while not anchor.get("connected") and time.monotonic() < deadline:
            time.sleep(0.2)
        time.sleep(2.0)  # the poller's first cycles and the connect-time settings read are over
        for pages in (int(n) for n in args.pages.split(",")):
            rows.append(phase(server.port, emulator, emulator.proc.stderr, pages, args.pulses, args.interval))
            print(json.dumps(rows[-1]), flush=True)
    finally:
        server.stop()
        emulator.proc.stop()
    result = {"stamp": stamp, "baud": args.baud, "interval_s": args.interval, "note": args.note, "phases": rows}
    (RESULTS / f"{stamp}-setup-page.json").write_text(json.dumps(result, indent=2))
    print("| pages | PUT pulseguide median / p90 / max ms | :Mg arrival median / p90 ms | line exchanges/s |")
    for r in rows:
        put, mg = r["put_ms"], r["mg_arrival_ms"] or {"median": None, "p90": None}
        print(f"| {r['pages']} | {put['median']} / {put['p90']} / {put['max']} | {mg['median']} / {mg['p90']} "
              f"| {r['exchanges_per_s']} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
