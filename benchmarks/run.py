"""Run the benchmarks: ``python -m benchmarks.run [--quick]``.

One invocation starts the emulator (paced at 9600 baud), alpaca-zwo against it, and the peer
``alpaca-simulators`` telescope, all as separate processes on loopback, then runs the same client
loads against alpaca-zwo and the peer so every comparison is a ratio taken minutes apart on the
same machine. Serial accounting (bytes and exchanges per second on the mount line) is read from
the emulator's own counters. Results: ``benchmarks/results/<stamp>.json`` and ``.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import random
import shlex
import subprocess
import sys
import threading
import time
import urllib.request
import zlib
from dataclasses import asdict, dataclass, replace
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from .client import AlpacaClient, ReplyError
from .loads import ClientSpec, WorkerPool
from .procs import (
    Emulator,
    Proc,
    cycle_aligned,
    emulator_log_exchanges,
    emulator_log_times,
    free_cpus,
    start_alpaca_zwo,
    start_emulator,
    start_peer,
)
from .report import render
from .stats import percentile, slope_per_minute, summarise

RESULTS = Path(__file__).resolve().parent / "results"
ANCHOR_ID = 7  # the orchestrator's own ClientID; PHD2 uses 1 (and 2), NINA-like clients 1000+


@dataclass(frozen=True)
class Plan:
    """Durations and sizes of one run; ``quick`` trims everything to a smoke check."""

    quick: bool
    workers: int
    pin: bool
    baud: int
    serial_window_s: float
    serial_phases: tuple[tuple[str, int], ...]  # (mount state, NINA-like clients)
    saturate_s: float
    saturate_conns: int
    poll_s: float
    http_tests: tuple[str, ...]
    abort_n: int
    soak_s: float
    warmup_s: float  # before each window: clients connect, stagger and settle
    server_threads: int | None = None  # None: the server's configured default
    server_patch: str = ""  # candidate server changes (benchmarks.patched_server), "" = the server as is
    peer: bool = True  # also run every HTTP test against the peer
    abort_phd2: bool = False  # stop-latency rounds with a PHD2-like guider beside the 50 pollers

    @classmethod
    def make(cls, args: argparse.Namespace) -> Plan:
        if args.quick:
            plan = cls(True, args.workers, args.pin, args.baud, 4.0,
                       (("rest", 1), ("rest", 100), ("guiding", 10), ("slewing", 10)), 4.0,
                       args.connections, 4.0, ("sat-tracking", "nina-50", "night"), 6, 0.0, 2.0)
        else:
            phases = tuple((state, clients) for state in ("rest", "guiding", "slewing") for clients in (1, 10, 50, 100))
            plan = cls(False, args.workers, args.pin, args.baud, 20.0, phases, 15.0, args.connections, 20.0,
                       ("sat-tracking", "sat-rightascension", "nina-50", "nina-ds-50", "nina-100", "night",
                        "put-under-50"), 100, args.soak_minutes * 60.0, 3.0)
        if args.tests:
            plan = replace(plan, http_tests=tuple(args.tests.split(",")))
        if args.phases:
            pairs = (item.partition(":") for item in args.phases.split(","))
            phases = tuple((state, int(count)) for state, _, count in pairs)
            plan = replace(plan, serial_phases=phases)
        return replace(plan, server_threads=args.server_threads, peer=not args.no_peer, server_patch=args.server_patch,
                       abort_phd2=args.abort_phd2, abort_n=args.abort_n or plan.abort_n)


def http_specs(test: str, plan: Plan) -> tuple[list[ClientSpec], float]:
    """The client mix of one HTTP test and its measurement window."""
    if test.startswith("sat-"):
        member = test.removeprefix("sat-")
        return [ClientSpec("saturate", plan.saturate_conns, member, {"member": member})], plan.saturate_s
    if test == "nina-50":
        return [ClientSpec("nina", 50)], plan.poll_s
    if test == "nina-ds-50":
        return [ClientSpec("nina-ds", 50)], plan.poll_s
    if test == "nina-100":
        return [ClientSpec("nina", 100)], plan.poll_s
    if test == "night":
        return [ClientSpec("nina", 1), ClientSpec("nina-ds", 1), ClientSpec("phd2", 1, options={"client_id": 1}),
                ClientSpec("planetarium", 2), ClientSpec("tppa", 1)], plan.poll_s
    if test == "put-under-50":
        return [ClientSpec("nina", 50),
                ClientSpec("put", 1, "put:pulseguide", {"member": "pulseguide", "interval": 0.5}),
                ClientSpec("put", 1, "put:targetrightascension",
                           {"member": "targetrightascension", "interval": 0.5})], plan.poll_s
    raise ValueError(test)


class Target:
    """A server under test and the orchestrator's own connection to it."""

    def __init__(self, name: str, proc: Proc) -> None:
        self.name = name
        self.proc = proc
        self.client = AlpacaClient("127.0.0.1", proc.port, client_id=ANCHOR_ID, timeout=30.0)

    def targets(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """Two GOTO targets 5 h of hour angle apart, both well above the horizon at 51.5° N."""
        lst = float(self.client.get("siderealtime"))
        return ((lst + 2.5) % 24.0, 30.0), ((lst - 2.5) % 24.0, 50.0)

    def wait_not_slewing(self, limit_s: float) -> bool:
        deadline = time.time() + limit_s
        while time.time() < deadline:
            if not self.client.get("slewing"):
                return True
            time.sleep(0.1)
        return False


class Slewer(threading.Thread):
    """Keeps the mount in GOTOs between two far targets for as long as the phase lasts."""

    def __init__(self, target: Target, stop: threading.Event) -> None:
        super().__init__(name="slewer", daemon=True)
        self.target = target
        self.stop = stop
        self.client = AlpacaClient("127.0.0.1", target.proc.port, client_id=ANCHOR_ID + 1, timeout=30.0)
        self.gotos = 0
        self.errors: list[str] = []

    def run(self) -> None:
        try:
            self.client.put("connected", Connected="true")
            while not self.stop.is_set():
                if not self.client.get("slewing"):
                    ra, dec = self.target.targets()[self.gotos % 2]
                    self.client.put("slewtocoordinatesasync", RightAscension=round(ra, 6), Declination=dec)
                    self.gotos += 1
                self.stop.wait(0.25)
        except ReplyError as exc:
            self.errors.append(str(exc))
        finally:
            self.client.close()


class Bench:
    def __init__(self, plan: Plan, run_dir: Path) -> None:
        self.plan = plan
        self.run_dir = run_dir
        cpus = free_cpus()
        # With --pin, the processes under test share the first CPU and the generator gets the rest,
        # so a saturated generator cannot steal time from the server (and the other way round).
        self.server_cpus = cpus[:1] if plan.pin and len(cpus) > 1 else None
        self.gen_cpus = cpus[1:] if plan.pin and len(cpus) > 1 else None
        self.results: dict[str, Any] = {"serial": [], "http": [], "abort": [], "soak": None, "rss": []}
        self.procs: list[Proc] = []
        self.emulator: Emulator | None = None
        self.ours: Target | None = None
        self.peer: Target | None = None
        self.pool: WorkerPool | None = None

    # -- lifecycle ------------------------------------------------------------------------------

    def log(self, message: str) -> None:
        print(f"[{time.strftime('%H:%M:%S')}] {message}", flush=True)

    def start(self) -> None:
        self.emulator = start_emulator(self.run_dir, self.plan.baud, self.server_cpus)
        self.procs.append(self.emulator.proc)
        server = start_alpaca_zwo(self.run_dir, self.emulator.proc.ports["tcp"], self.server_cpus,
                                  threads=self.plan.server_threads, patches=self.plan.server_patch)
        self.procs.append(server)
        self.ours = Target("alpaca-zwo", server)
        self.log(f"emulator pid {self.emulator.proc.pid} tcp {self.emulator.proc.ports['tcp']}, alpaca-zwo pid "
                 f"{server.pid} port {server.port}")
        if self.plan.peer:  # --no-peer: the peer is not even started (it need not be installed)
            peer = start_peer(self.run_dir, self.server_cpus)
            self.procs.append(peer)
            self.peer = Target("alpaca-simulators", peer)
            self.log(f"peer pid {peer.pid} port {peer.port}")
        self.pool = WorkerPool(self.plan.workers, self.gen_cpus)
        # The anchor client keeps the mount connected for the whole run, as an imaging app would.
        self.ours.client.put("connected", Connected="true")
        if self.peer is not None:
            self.peer.client.put("connected", Connected="true")
            self.peer.client.put("unpark")  # the peer starts parked; a real mount here is tracking
            self.peer.client.put("tracking", Tracking="true")
        # Start tracking on a real target: a GOTO turns tracking on at arrival (the mount's rule).
        ra, dec = self.ours.targets()[0]
        self.ours.client.put("slewtocoordinatesasync", RightAscension=round(ra, 6), Declination=dec)
        if not self.ours.wait_not_slewing(120.0):
            raise RuntimeError("the initial GOTO did not finish")
        if not self.ours.client.get("tracking"):
            self.ours.client.put("tracking", Tracking="true")
        self.log(f"mount tracking at RA {ra:.3f} Dec {dec:.1f}")

    def stop(self) -> None:
        if self.pool is not None:
            self.pool.close()
        for target in (self.ours, self.peer):
            if target is not None:
                target.client.close()
        for proc in reversed(self.procs):
            proc.stop()

    def rss(self, where: str) -> None:
        entry = {"where": where}
        for target in (self.ours, self.peer):
            if target is not None:
                entry[target.name] = round(target.proc.rss_mb(), 1)
        self.results["rss"].append(entry)

    # -- serial accounting ----------------------------------------------------------------------

    def serial_phases(self) -> None:
        assert self.ours is not None and self.emulator is not None and self.pool is not None
        for state, clients in self.plan.serial_phases:
            self.results["serial"].append(self.serial_phase(state, clients))
            if state == "rest" and clients in (1, 100):
                self.rss(f"rest, {clients} NINA clients")

    def serial_phase(self, state: str, clients: int) -> dict[str, Any]:
        assert self.ours is not None and self.emulator is not None and self.pool is not None
        specs = [ClientSpec("nina", clients), ClientSpec("state-age", 1)]
        if state == "guiding":
            specs.append(ClientSpec("phd2", 1, options={"client_id": 1}))
        stop = threading.Event()
        slewer = Slewer(self.ours, stop) if state == "slewing" else None
        if slewer is not None:
            slewer.start()
        running = self.pool.start("127.0.0.1", self.ours.proc.port, specs, warmup=self.plan.warmup_s,
                                  duration=self.plan.serial_window_s, seed=clients)
        _sleep_until(running.measure_from)
        before, cpu0 = self.emulator.stats(), self.ours.proc.cpu_s()
        _sleep_until(running.stop_at)
        after, cpu1 = self.emulator.stats(), self.ours.proc.cpu_s()
        rss = self.ours.proc.rss_mb()
        stop.set()
        result = running.wait()
        if slewer is not None:
            slewer.join(30.0)
            self.ours.wait_not_slewing(120.0)
        window = after["time"] - before["time"]
        total = (after["bytes_in"] - before["bytes_in"]) + (after["bytes_out"] - before["bytes_out"])
        labels = {label: summarise(entry, window) for label, entry in result["labels"].items()}
        age = labels.get("state-age", {})
        aligned = cycle_aligned(self.emulator.proc.stderr, before["time"], after["time"]) or {}
        row = {
            "state": state,
            "clients": clients,
            "window": (before["time"], after["time"]),
            "window_s": round(window, 2),
            "aligned_bytes_per_s": aligned.get("bytes_per_s"),
            "aligned_line_pct": (round(100.0 * aligned["bytes_per_s"] / (self.plan.baud / 10.0), 2)
                                 if aligned else None),
            "aligned_exchanges_per_s": aligned.get("exchanges_per_s"),
            "poll_period_s": aligned.get("poll_period_s"),
            "poll_cycles": aligned.get("cycles"),
            "bytes_to_mount_per_s": round((after["bytes_in"] - before["bytes_in"]) / window, 1),
            "bytes_from_mount_per_s": round((after["bytes_out"] - before["bytes_out"]) / window, 1),
            "bytes_per_s": round(total / window, 1),
            # One exchange at a time, so request and reply bytes take turns on the line: the share of
            # the line's 960 B/s they occupy is (in + out) / 960.
            "line_pct": round(100.0 * total / window / (self.plan.baud / 10.0), 2),
            "exchanges_per_s": round((after["exchanges"] - before["exchanges"]) / window, 2),
            "age_p50_s": age.get("age_s_p50"),
            "age_max_s": age.get("age_s_max"),
            "http_get_per_s": round(sum(v["rate_per_s"] or 0 for v in labels.values()), 1),
            "nina": labels.get("nina"),
            "labels": labels,
            "errors": sum(v["errors"] for v in labels.values()),
            "rss_mb": round(rss, 1),
            "server_cpu_pct": round(100.0 * (cpu1 - cpu0) / window, 1),
            "gotos": slewer.gotos if slewer else None,
            "slewer_errors": slewer.errors if slewer else None,
        }
        self.log(f"serial {state:8s} {clients:3d} clients: {row['bytes_per_s']:6.1f} B/s ({row['line_pct']:.1f}% "
                 f"of line; whole cycles {row['aligned_bytes_per_s']} B/s, period {row['poll_period_s']} s) "
                 f"{row['exchanges_per_s']:.2f} exch/s, age max {row['age_max_s']} s, "
                 f"{row['http_get_per_s']} GET/s, errors {row['errors']}, rss {row['rss_mb']} MB")
        return row

    # -- HTTP comparison ------------------------------------------------------------------------

    def http_test(self, target: Target, test: str) -> dict[str, Any]:
        assert self.pool is not None
        specs, duration = http_specs(test, self.plan)
        warmup = 1.0 if test.startswith("sat-") else self.plan.warmup_s
        running = self.pool.start("127.0.0.1", target.proc.port, specs, warmup=warmup, duration=duration,
                                  seed=zlib.crc32(test.encode()) % 1000)
        _sleep_until(running.measure_from)
        cpu0, t0 = target.proc.cpu_s(), time.time()
        _sleep_until(running.stop_at)
        cpu1, t1 = target.proc.cpu_s(), time.time()
        rss = target.proc.rss_mb()
        result = running.wait()
        labels = {label: summarise(entry, duration) for label, entry in result["labels"].items()}
        allcalls: list[float] = []
        for entry in result["labels"].values():
            allcalls.extend(entry["latency_ms"])
        allcalls.sort()
        row = {
            "test": test,
            "target": target.name,
            "clients": sum(spec.count for spec in specs),
            "duration_s": duration,
            "requests": len(allcalls),
            "rate_per_s": round(len(allcalls) / duration, 1),
            "errors": sum(v["errors"] for v in labels.values()),
            "p50_ms": _r(percentile(allcalls, 50)),
            "p99_ms": _r(percentile(allcalls, 99)),
            "max_ms": _r(allcalls[-1] if allcalls else None),
            "server_cpu_pct": round(100.0 * (cpu1 - cpu0) / (t1 - t0), 1),
            "generator_cpu_pct": round(100.0 * result["generator_cpu_s"] / (duration + warmup), 1),
            "stuck_threads": result["stuck_threads"],
            "rss_mb": round(rss, 1),
            "labels": labels,
        }
        self.log(f"http {test:22s} {target.name:18s} {row['rate_per_s']:8.1f} req/s p50 {row['p50_ms']} p99 "
                 f"{row['p99_ms']} max {row['max_ms']} ms errors {row['errors']} cpu {row['server_cpu_pct']}% "
                 f"gen {row['generator_cpu_pct']}%")
        for label, summary in labels.items():
            if summary["errors"]:
                self.log(f"   {label}: {summary['errors']} errors, e.g. {summary['error_samples'][:2]}")
        return row

    def http_tests(self) -> None:
        assert self.ours is not None
        targets = (self.ours, self.peer) if self.plan.peer else (self.ours,)
        for test in self.plan.http_tests:
            for target in targets:
                self.results["http"].append(self.http_test(target, test))
            if test == "nina-100":
                self.rss("after nina-100")
        if not self.plan.peer:
            return
        # The peer again without its per-request access log, so the ratio is not the log's doing.
        peer_nolog = start_peer(self.run_dir, self.server_cpus, access_log=False)
        self.procs.append(peer_nolog)
        try:
            target = Target("alpaca-simulators (no access log)", peer_nolog)
            target.client.put("connected", Connected="true")
            target.client.put("unpark")
            for test in self.plan.http_tests:
                if test.startswith("sat-"):
                    self.results["http"].append(self.http_test(target, test))
            target.client.close()
        finally:
            peer_nolog.stop()
            self.procs.remove(peer_nolog)

    # -- abort / stop latency -------------------------------------------------------------------

    def abort_tests(self) -> None:
        assert self.ours is not None
        for target in (self.ours, self.peer) if self.peer is not None else (self.ours,):
            for kind in ("abortslew", "moveaxis0"):
                self.results["abort"].append(self.abort_test(target, kind))

    def abort_test(self, target: Target, kind: str) -> dict[str, Any]:
        """``n`` stops, each during a motion started 0.3-0.9 s earlier, while 50 NINA pollers run
        (and, with ``--abort-phd2``, a PHD2-like guider pulsing whenever the mount is not slewing)."""
        assert self.pool is not None and self.emulator is not None
        # The peer has no mount line, so its number is HTTP only: fewer rounds say enough.
        n = self.plan.abort_n if target is self.ours else max(5, self.plan.abort_n // 3)
        # Slewing now stays true until the mount has braked to rest, so a round takes longer.
        budget = n * 4.0 + 10.0
        stop_file = self.run_dir / f"stop-{target.proc.name}-{kind}"
        specs = [ClientSpec("nina", 50)]
        if self.plan.abort_phd2:
            # Real PHD2 stops guiding while Slewing is true; the server refuses pulses during a GOTO
            # or MoveAxis (0x40B) anyway, so pulses run between the orchestrator's motions.
            specs.append(ClientSpec("phd2", 1, options={"client_id": 1, "allow_slewing": True, "exposure": 1.0}))
        running = self.pool.start("127.0.0.1", target.proc.port, specs, warmup=self.plan.warmup_s,
                                  duration=budget, seed=7, stop_file=str(stop_file))
        _sleep_until(running.measure_from)
        rng = random.Random(42)
        client = target.client
        samples: list[dict[str, Any]] = []
        errors: list[str] = []
        ours = target is self.ours
        for index in range(n):
            if time.time() > running.stop_at - 5.0:
                break
            try:
                if kind == "abortslew":
                    ra, dec = target.targets()[index % 2]
                    client.put("slewtocoordinatesasync", RightAscension=round(ra, 6), Declination=dec)
                else:
                    client.put("moveaxis", Axis=0, Rate=1.0 if index % 2 == 0 else -1.0)
                time.sleep(rng.uniform(0.3, 0.9))
                sent = time.time()
                if kind == "abortslew":
                    client.put("abortslew")
                else:
                    client.put("moveaxis", Axis=0, Rate=0)
                sample: dict[str, Any] = {"sent": sent, "http_ms": client.latency * 1000.0}
                if ours:
                    sample["trace_ms"] = self._trace_latency(target, sent, {"abortslew": {":Q#"}}.get(
                        kind, {":Qe#", ":Qw#"}))
                samples.append(sample)
                if kind == "abortslew":
                    target.wait_not_slewing(10.0)
                time.sleep(0.3)
            except ReplyError as exc:
                errors.append(str(exc))
                time.sleep(0.5)
        running.stop_now()  # the loop is what is measured; the pollers were only its background
        result = running.wait()
        window = result["window"][1] - result["window"][0]
        pollers = summarise(result["labels"]["nina"], window) if "nina" in result["labels"] else {}
        guider = summarise(result["labels"]["phd2"], window) if "phd2" in result["labels"] else {}
        if ours:
            commands = {"Q"} if kind == "abortslew" else {"Qe", "Qw"}
            stamps = [t for t, _ in emulator_log_times(self.emulator.proc.stderr, commands)]
            for index, sample in enumerate(samples):
                limit = samples[index + 1]["sent"] if index + 1 < len(samples) else sample["sent"] + 5.0
                hit = next((t for t in stamps if sample["sent"] <= t < limit), None)
                sample["wire_ms"] = None if hit is None else (hit - sample["sent"]) * 1000.0
                if hit is not None:
                    # The emulator paces bytes in at the line rate and logs on the last one; minus the
                    # command's own transmission time that is when its first byte reached the mount.
                    own = len(":Q#" if kind == "abortslew" else ":Qe#") * 10.0 / self.plan.baud * 1000.0
                    sample["wire_first_ms"] = sample["wire_ms"] - own
        http = [s["http_ms"] for s in samples]
        row: dict[str, Any] = {
            "target": target.name,
            "kind": kind,
            "n": len(samples),
            "errors": len(errors),
            "error_samples": errors[:5],
            "http_p50_ms": _r(percentile(http, 50)),
            "http_p99_ms": _r(percentile(http, 99)),
            "http_max_ms": _r(max(http) if http else None),
            "pollers": {k: pollers.get(k) for k in ("ok", "errors", "p50_ms", "p99_ms", "max_ms")},
            "phd2": {k: guider.get(k) for k in ("ok", "errors", "p50_ms", "p99_ms", "max_ms", "error_samples")},
            "pulses_on_wire": self._pulses_on_wire(samples),
        }
        if ours:
            wire = [s["wire_ms"] for s in samples if s.get("wire_ms") is not None]
            first = [s["wire_first_ms"] for s in samples if s.get("wire_first_ms") is not None]
            trace = [s["trace_ms"] for s in samples if s.get("trace_ms") is not None]
            row.update({
                "wire_p50_ms": _r(percentile(wire, 50)), "wire_p99_ms": _r(percentile(wire, 99)),
                "wire_max_ms": _r(max(wire) if wire else None), "wire_unmatched": len(samples) - len(wire),
                "first_p50_ms": _r(percentile(first, 50)), "first_p99_ms": _r(percentile(first, 99)),
                "first_max_ms": _r(max(first) if first else None),
                "trace_p50_ms": _r(percentile(trace, 50)), "trace_p99_ms": _r(percentile(trace, 99)),
                "trace_max_ms": _r(max(trace) if trace else None), "trace_unmatched": len(samples) - len(trace),
            })
        row["samples"] = [{k: (round(v, 3) if isinstance(v, float) else v) for k, v in s.items()} for s in samples]
        self.log(f"{kind} {target.name}: n={row['n']} http p50 {row['http_p50_ms']} p99 {row['http_p99_ms']} ms"
                 + (f"; to wire (emulator) p50 {row['wire_p50_ms']} p99 {row['wire_p99_ms']} max "
                    f"{row['wire_max_ms']} ms; link write p50 {row['trace_p50_ms']} p99 {row['trace_p99_ms']} ms"
                    if ours else "") + f"; pollers p99 {pollers.get('p99_ms')} ms errors {pollers.get('errors')}")
        return row

    def _pulses_on_wire(self, samples: list[dict[str, Any]]) -> int:
        """Guide pulses (``:Mg...#``) the emulator received during the stop rounds."""
        assert self.emulator is not None
        if not samples:
            return 0
        start, end = samples[0]["sent"] - 1.0, samples[-1]["sent"] + 1.0
        return sum(1 for t, body, _, _ in emulator_log_exchanges(self.emulator.proc.stderr, start, end)
                   if body.startswith("Mg"))

    def _trace_latency(self, target: Target, sent: float, requests: set[str]) -> float | None:
        """When the link began writing the stop, from the server's own serial trace (setup API)."""
        url = f"http://127.0.0.1:{target.proc.port}/setup/api/telescope/0/trace?after={sent - 0.5:.6f}"
        with urllib.request.urlopen(url, timeout=10) as reply:
            entries = json.load(reply)["entries"]
        for entry in entries:
            if entry["request"] in requests and entry["time"] >= sent:
                return (entry["time"] - entry["duration_ms"] / 1000.0 - sent) * 1000.0
        return None

    # -- soak -----------------------------------------------------------------------------------

    def soak(self) -> None:
        assert self.ours is not None and self.pool is not None
        duration = self.plan.soak_s
        specs = [ClientSpec("nina", 10), ClientSpec("nina-ds", 10),
                 ClientSpec("phd2", 1, options={"client_id": 1, "allow_slewing": True}),
                 ClientSpec("planetarium", 2), ClientSpec("tppa", 1), ClientSpec("state-age", 1)]
        self.log(f"soak: {duration / 60:.0f} min of a mixed night load, RSS every 5 s")
        running = self.pool.start("127.0.0.1", self.ours.proc.port, specs, warmup=0.0, duration=duration,
                                  first_client_id=5000, seed=99)
        _sleep_until(running.measure_from)
        points: list[tuple[float, float]] = []
        start = time.time()
        next_goto = start + 30.0
        gotos = 0
        while time.time() < running.stop_at:
            points.append((time.time() - start, self.ours.proc.rss_mb()))
            if time.time() >= next_goto:
                try:
                    ra, dec = self.ours.targets()[gotos % 2]
                    self.ours.client.put("slewtocoordinatesasync", RightAscension=round(ra, 6), Declination=dec)
                    gotos += 1
                except ReplyError as exc:
                    self.log(f"soak goto failed: {exc}")
                next_goto += 90.0
            time.sleep(min(5.0, max(0.0, running.stop_at - time.time())))
        result = running.wait()
        labels = {label: summarise(entry, duration) for label, entry in result["labels"].items()}
        steady = [(t, v) for t, v in points if t >= 120.0]
        first = [v for t, v in steady if t < 180.0]
        last = [v for t, v in steady if t >= points[-1][0] - 60.0]
        self.results["soak"] = {
            "duration_s": duration,
            "gotos": gotos,
            "rss_first_mb": points[0][1] if points else None,
            "rss_after_2min_mb": round(sum(first) / len(first), 2) if first else None,
            "rss_last_min_mb": round(sum(last) / len(last), 2) if last else None,
            "rss_max_mb": round(max(v for _, v in points), 2) if points else None,
            "slope_mb_per_min_after_2min": _r(slope_per_minute(steady), 4),
            "points": [(round(t, 1), round(v, 2)) for t, v in points],
            "errors": sum(v["errors"] for v in labels.values()),
            "labels": labels,
        }
        soak = self.results["soak"]
        self.log(f"soak: rss {soak['rss_first_mb']} -> {soak['rss_last_min_mb']} MB (after 2 min "
                 f"{soak['rss_after_2min_mb']}), slope {soak['slope_mb_per_min_after_2min']} MB/min, "
                 f"errors {soak['errors']}")


def _r(value: float | None, digits: int = 2) -> float | None:
    return None if value is None else round(value, digits)


def _sleep_until(deadline: float) -> None:
    delay = deadline - time.time()
    if delay > 0:
        time.sleep(delay)


def machine_info() -> dict[str, Any]:
    import psutil

    model = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    versions = {}
    from importlib import metadata

    for package in ("falcon", "waitress", "alpaca-simulators", "fastapi", "uvicorn", "starlette", "pydantic"):
        try:
            versions[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            versions[package] = None
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, timeout=10,
                                cwd=Path(__file__).resolve().parent).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        commit = ""
    return {
        "cpu": model,
        "cores": os.cpu_count(),
        "memory_gb": round(psutil.virtual_memory().total / 2**30, 1),
        "os": platform.platform(),
        "python": platform.python_version(),
        "packages": versions,
        "commit": commit,
        "loadavg_start": os.getloadavg(),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.run", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke check, about 2 minutes")
    parser.add_argument("--workers", type=int, default=4, help="load-generator processes (default 4)")
    parser.add_argument("--connections", type=int, default=16,
                        help="concurrent keep-alive connections in the saturation tests (default 16)")
    parser.add_argument("--pin", action="store_true",
                        help="pin the processes under test to the first CPU and the generator to the others")
    parser.add_argument("--baud", type=int, default=9600, help="emulator line rate (default 9600)")
    parser.add_argument("--soak-minutes", type=float, default=10.0, help="memory soak length in full mode")
    parser.add_argument("--only", default="", help="comma list of parts: serial,http,abort,soak (default all)")
    parser.add_argument("--tests", default="", help="comma list of HTTP tests (default: the mode's list)")
    parser.add_argument("--phases", default="", metavar="STATE:N,...",
                        help="serial phases to run, e.g. rest:1,rest:100 (states: rest, guiding, slewing)")
    parser.add_argument("--server-threads", type=int, help="override alpaca-zwo's waitress thread count")
    parser.add_argument("--server-patch", default="", metavar="P[,P]",
                        help="run alpaca-zwo with candidate changes applied: urgent-stop, fixed-rate-poll, "
                             "connection-limit (see benchmarks/patched_server.py)")
    parser.add_argument("--no-peer", action="store_true",
                        help="do not start the peer at all (for sweeps of our own settings)")
    parser.add_argument("--abort-phd2", action="store_true",
                        help="stop-latency rounds with a PHD2-like guider pulsing beside the 50 pollers (issue 13)")
    parser.add_argument("--abort-n", type=int, default=0, help="stops per kind (default: 100, quick mode 6)")
    parser.add_argument("--note", default="", help="free text stored with the results (machine conditions)")
    args = parser.parse_args(argv)
    plan = Plan.make(args)
    parts = set(filter(None, args.only.split(","))) or {"serial", "http", "abort", "soak"}
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ") + ("-quick" if plan.quick else "")
    stamp += f"-t{plan.server_threads}" if plan.server_threads else ""
    stamp += "-patched" if plan.server_patch else ""
    RESULTS.mkdir(parents=True, exist_ok=True)
    run_dir = RESULTS / stamp
    run_dir.mkdir()
    bench = Bench(plan, run_dir)
    started = time.time()
    command = shlex.join(["python", "-m", "benchmarks.run", *(argv if argv is not None else sys.argv[1:])])
    results: dict[str, Any] = {"meta": {"command": command,
                                        "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                                        "plan": asdict(plan), "note": args.note, "machine": machine_info()}}
    try:
        bench.start()
        bench.rss("start")
        if "serial" in parts:
            bench.serial_phases()
        if "http" in parts:
            bench.http_tests()
        if "abort" in parts:
            bench.abort_tests()
        if "soak" in parts and plan.soak_s > 0:
            bench.soak()
        bench.rss("end")
    except KeyboardInterrupt:
        bench.log("interrupted: writing what was measured")
    finally:
        bench.stop()
        results.update(bench.results)
        results["meta"]["duration_s"] = round(time.time() - started, 1)
        results["meta"]["loadavg_end"] = os.getloadavg()
        out = RESULTS / f"{stamp}.json"
        out.write_text(json.dumps(results, indent=1, default=str))
        table = render(results)
        (RESULTS / f"{stamp}.md").write_text(table)
        print(table)
        print(f"results: {out} (process logs in {run_dir})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
