"""Simulated Alpaca clients and the worker-process side of the load generator.

Each simulated client is one thread with its own keep-alive connection, doing what the real
application does (research notes: shared/alpaca/clients.md §1.3, §2.1, Appendix A):

* ``nina``: N.I.N.A.'s 2 s poll of 21 properties (InterfaceVersion <= 3 path), through NINA's
  per-property 100 ms cache (``Connected`` 1 s), followed by the derived-value re-reads; at a
  fast server the cache absorbs the re-reads and a poll costs 21 GETs.
* ``nina-ds``: the same poll with DeviceState substitution (NINA >= 3.2 against an IV4 device):
  10 GETs per poll.
* ``phd2``: a guide frame every ``exposure`` s: ``slewing``, ``ispulseguiding``, ``PUT pulseguide``,
  sleep for the pulse, then ``ispulseguiding`` + ``slewing`` every 50 ms until the pulse is over;
  RA then Dec. ``Slewing`` true while guiding is an error (PHD2 aborts guiding on it).
* ``planetarium``: RA, Dec and Slewing once a second (Cartes du Ciel / Stellarium style).
* ``tppa``: the three-point polar alignment plugin, RA + Dec every 100 ms (+20 GET/s).
* ``saturate``: a closed loop of one GET, as fast as replies come back.
* ``put``: one PUT every ``interval`` s, to measure command latency under load.
* ``state-age``: DeviceState every 100 ms, recording how old the position reading is
  (UTCDate - TimeStamp), i.e. how stale the data a client sees can be.

The pool runs in separate processes so that client-side Python never competes with itself for
one GIL; results come back as plain picklable dicts.
"""

from __future__ import annotations

import os
import random
import threading
import time
from array import array
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .client import AlpacaClient, ReplyError, parse_iso_utc

__all__ = [
    "NINA_DERIVED",
    "NINA_SEQUENCE",
    "ClientSpec",
    "Recorder",
    "Running",
    "WorkerPool",
    "WorkerTask",
    "run_task",
]

NINA_SEQUENCE = (
    "connected", "atpark", "athome", "tracking", "cansettracking", "trackingrate", "declinationrate",
    "rightascensionrate", "altitude", "azimuth", "declination", "rightascension", "siderealtime", "sideofpier",
    "slewing", "cansetguiderates", "guideraterightascension", "guideratedeclination", "canpulseguide",
    "ispulseguiding", "utcdate",
)
#: HoursToMeridian, TimeToMeridianFlip and the display strings re-read these; Appendix A's model
#: has 17-20 such re-reads that only reach the network when the 100 ms cache has expired.
NINA_DERIVED = ("rightascension", "siderealtime", "declination", "tracking", "sideofpier") * 4
#: Properties NINA takes from DeviceState when the device has InterfaceVersion 4.
DEVICE_STATE_NAMES = frozenset({
    "altitude", "athome", "atpark", "azimuth", "declination", "ispulseguiding", "rightascension",
    "sideofpier", "siderealtime", "slewing", "tracking", "utcdate",
})
NINA_CACHE_S = 0.1
NINA_CONNECTED_CACHE_S = 1.0


@dataclass(frozen=True)
class ClientSpec:
    """``count`` simulated clients of one kind; ``label`` names their row in the results."""

    kind: str
    count: int = 1
    label: str = ""
    options: dict[str, Any] = field(default_factory=dict)

    @property
    def name(self) -> str:
        return self.label or self.kind


@dataclass(frozen=True)
class WorkerTask:
    """What one worker process runs: its share of the clients, all against one server."""

    host: str
    port: int
    clients: tuple[tuple[ClientSpec, int], ...]  # (spec, ClientID) per simulated client
    start_at: float  # wall clock: clients start (staggered) from here
    measure_from: float  # wall clock: calls started before this are not recorded
    stop_at: float  # wall clock: clients stop issuing calls
    seed: int = 0
    stop_file: str = ""  # if this file appears, stop early


class Recorder:
    """Per-thread tally (no locks on the hot path); merged per label after the run."""

    def __init__(self, client: AlpacaClient, measure_from: float, keep_samples: int = 5) -> None:
        self.client = client
        self.measure_from = measure_from
        self.latency_ms = array("d")
        self.ok = 0
        self.errors = 0
        self.error_samples: list[str] = []
        self.keep_samples = keep_samples
        self.extra: dict[str, array] = {}

    def _failed(self, message: str, counted: bool) -> None:
        if counted:
            self.errors += 1
            if len(self.error_samples) < self.keep_samples:
                self.error_samples.append(message)

    def call(self, fn: Callable[..., Any], *args: Any, always: bool = False, **kwargs: Any) -> tuple[bool, Any]:
        """Run one client call; (True, value) on a valid reply, (False, None) otherwise.

        A call counts if it *ends* inside the window, so one that was stalled across the start of
        the window (e.g. a connection the server did not accept yet) shows up with its full
        latency instead of silently vanishing. ``always`` counts a failure whenever it happens.
        """
        try:
            value = fn(*args, **kwargs)
        except ReplyError as exc:
            self._failed(str(exc), always or time.time() >= self.measure_from)
            return False, None
        if time.time() >= self.measure_from:
            self.ok += 1
            self.latency_ms.append(self.client.latency * 1000.0)
        return True, value

    def fail(self, message: str) -> None:
        """A reply that was valid Alpaca but wrong for the situation (e.g. Slewing while guiding)."""
        self._failed(message, time.time() >= self.measure_from)

    def note(self, name: str, value: float) -> None:
        if time.time() >= self.measure_from:
            self.extra.setdefault(name, array("d")).append(value)


class End:
    """When the clients stop: the planned time, brought forward if the orchestrator asks (stop file)."""

    def __init__(self, at: float) -> None:
        self.at = at

    def watch(self, stop_file: str) -> None:
        while time.time() < self.at:
            if os.path.exists(stop_file):
                self.at = time.time()
                return
            time.sleep(0.2)


def _sleep_until(deadline: float, end: End) -> bool:
    """Sleep to a wall-clock deadline; False if the run ends first."""
    while True:
        delay = min(deadline, end.at) - time.time()
        if delay <= 0:
            break
        time.sleep(min(delay, 0.25))  # short slices, so an early stop is seen promptly
    return deadline < end.at


# -- the client behaviours --------------------------------------------------------------------


def _nina(rec: Recorder, end: End, rng: random.Random, options: dict[str, Any], device_state: bool) -> None:
    client = rec.client
    interval = float(options.get("interval", 2.0))
    cache: dict[str, tuple[float, Any]] = {}
    ds_value: dict[str, Any] = {}

    def read(name: str) -> None:
        now = time.monotonic()
        if device_state and name in DEVICE_STATE_NAMES:
            seen = cache.get("devicestate")
            if seen is None or now - seen[0] > NINA_CACHE_S:
                good, value = rec.call(client.get, "devicestate")
                if good:
                    if not all(isinstance(item, dict) and "Name" in item and "Value" in item for item in value):
                        rec.fail(f"devicestate: malformed items {value!r:.120}")
                        return
                    ds_value.clear()
                    ds_value.update({item["Name"].lower(): item["Value"] for item in value})
                    cache["devicestate"] = (now, None)
            return
        limit = NINA_CONNECTED_CACHE_S if name == "connected" else NINA_CACHE_S
        seen = cache.get(name)
        if seen is not None and now - seen[0] <= limit:
            return
        good, value = rec.call(client.get, name)
        if good:
            cache[name] = (now, value)
            if name == "connected" and value is not True:
                rec.fail("Connected is false for a connected client")

    next_poll = time.time() + rng.uniform(0.0, interval)
    while _sleep_until(next_poll, end):
        started = time.time()
        for name in NINA_SEQUENCE:
            read(name)
        for name in NINA_DERIVED:
            read(name)
        rec.note("poll_ms", (time.time() - started) * 1000.0)
        # NINA's PeriodicTimer: an overrunning poll is followed at once by the next one.
        next_poll = max(next_poll + interval, time.time())


def _phd2(rec: Recorder, end: End, rng: random.Random, options: dict[str, Any]) -> None:
    client = rec.client
    exposure = float(options.get("exposure", 2.0))
    allow_slewing = bool(options.get("allow_slewing", False))

    def check_slewing() -> bool:
        good, value = rec.call(client.get, "slewing")
        if good and value and not allow_slewing:
            rec.fail("Slewing true while pulse guiding (PHD2 would abort guiding)")
        return bool(good and value)

    def wait_pulse(limit_s: float) -> None:
        deadline = time.time() + limit_s
        while time.time() < min(deadline, end.at):
            good, value = rec.call(client.get, "ispulseguiding")
            if not good or not value:
                return
            check_slewing()
            time.sleep(0.05)

    frame = time.time() + rng.uniform(0.0, exposure)
    while _sleep_until(frame, end):
        for directions in ((2, 3), (0, 1)):  # RA (E/W) then Dec (N/S)
            duration = rng.randint(50, 400)
            if check_slewing() and allow_slewing:
                break  # "stop guiding when the mount slews": PHD2 sends no pulse during a GOTO
            wait_pulse(1.0)  # drain a previous pulse
            sent = time.time()
            good, _ = rec.call(client.put, "pulseguide", Direction=rng.choice(directions), Duration=duration)
            if not good:
                continue
            time.sleep(max(0.0, duration / 1000.0 - (time.time() - sent)))
            wait_pulse(2.0)
        frame = max(frame + exposure, time.time())


def _periodic_gets(rec: Recorder, end: End, rng: random.Random, members: tuple[str, ...],
                   interval: float) -> None:
    client = rec.client
    tick = time.time() + rng.uniform(0.0, interval)
    while _sleep_until(tick, end):
        for member in members:
            rec.call(client.get, member)
        tick = max(tick + interval, time.time())


def _saturate(rec: Recorder, end: End, options: dict[str, Any]) -> None:
    member = str(options.get("member", "tracking"))
    get = rec.client.get
    call = rec.call
    while time.time() < end.at:
        call(get, member)


def _put(rec: Recorder, end: End, rng: random.Random, options: dict[str, Any]) -> None:
    member = str(options["member"])
    interval = float(options.get("interval", 0.5))
    tick = time.time() + rng.uniform(0.0, interval)
    while _sleep_until(tick, end):
        if member == "pulseguide":
            fields: dict[str, object] = {"Direction": rng.randint(0, 3), "Duration": 20}
        elif member == "targetrightascension":
            fields = {"TargetRightAscension": round(rng.uniform(0.0, 23.99), 6)}
        else:
            fields = dict(options.get("fields", {}))
        rec.call(rec.client.put, member, **fields)
        tick = max(tick + interval, time.time())


def _state_age(rec: Recorder, end: End, rng: random.Random) -> None:
    tick = time.time() + rng.uniform(0.0, 0.1)
    while _sleep_until(tick, end):
        good, value = rec.call(rec.client.get, "devicestate")
        if good:
            items = {item.get("Name"): item.get("Value") for item in value if isinstance(item, dict)}
            if "TimeStamp" in items and "UTCDate" in items:
                age = parse_iso_utc(items["UTCDate"]) - parse_iso_utc(items["TimeStamp"])
                rec.note("age_s", age)
        tick = max(tick + 0.1, time.time())


def _run_client(spec: ClientSpec, rec: Recorder, end: End, rng: random.Random) -> None:
    kind, options = spec.kind, spec.options
    if kind in ("nina", "nina-ds"):
        _nina(rec, end, rng, options, device_state=kind == "nina-ds")
    elif kind == "phd2":
        _phd2(rec, end, rng, options)
    elif kind == "planetarium":
        _periodic_gets(rec, end, rng, ("rightascension", "declination", "slewing"),
                       float(options.get("interval", 1.0)))
    elif kind == "tppa":
        members = ("devicestate",) if options.get("device_state") else ("rightascension", "declination")
        _periodic_gets(rec, end, rng, members, 0.1)
    elif kind == "saturate":
        _saturate(rec, end, options)
    elif kind == "put":
        _put(rec, end, rng, options)
    elif kind == "state-age":
        _state_age(rec, end, rng)
    else:
        raise ValueError(f"unknown client kind {kind!r}")


# -- the worker process ---------------------------------------------------------------------


def run_task(task: WorkerTask) -> dict[str, Any]:
    """Run this worker's clients to ``stop_at`` and return the merged tallies per label."""
    rng = random.Random(task.seed)
    recorders: list[tuple[ClientSpec, Recorder]] = []
    threads = []
    cpu0 = time.process_time()
    end = End(task.stop_at)
    if task.stop_file:
        threading.Thread(target=end.watch, args=(task.stop_file,), daemon=True).start()
    for spec, client_id in task.clients:
        client = AlpacaClient(task.host, task.port, client_id=client_id)
        rec = Recorder(client, task.measure_from)
        recorders.append((spec, rec))
        thread_rng = random.Random(rng.random())

        def body(spec: ClientSpec = spec, rec: Recorder = rec, thread_rng: random.Random = thread_rng) -> None:
            # Every client application connects first (NINA, PHD2 and the planetariums all do).
            if spec.kind not in ("saturate",):
                _sleep_until(task.start_at - 1.0 + thread_rng.uniform(0.0, 0.8), end)
                rec.call(rec.client.put, "connected", always=True, Connected="true")
            _sleep_until(task.start_at, end)
            try:
                _run_client(spec, rec, end, thread_rng)
            finally:
                rec.client.close()

        threads.append(threading.Thread(target=body, name=f"{spec.name}-{client_id}", daemon=True))
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(max(1.0, task.stop_at - time.time() + 15.0))
    merged: dict[str, dict[str, Any]] = {}
    for spec, rec in recorders:
        entry = merged.setdefault(spec.name, {
            "kind": spec.kind, "clients": 0, "ok": 0, "errors": 0, "error_samples": [], "reconnects": 0,
            "latency_ms": array("d"), "extra": {},
        })
        entry["clients"] += 1
        entry["ok"] += rec.ok
        entry["errors"] += rec.errors
        entry["reconnects"] += rec.client.reconnects
        entry["latency_ms"].extend(rec.latency_ms)
        if len(entry["error_samples"]) < 10:
            entry["error_samples"].extend(rec.error_samples[: 10 - len(entry["error_samples"])])
        for name, values in rec.extra.items():
            entry["extra"].setdefault(name, array("d")).extend(values)
    stuck = sum(1 for thread in threads if thread.is_alive())
    return {"labels": merged, "cpu_s": time.process_time() - cpu0, "stuck_threads": stuck, "pid": os.getpid(),
            "ended": end.at}


@dataclass
class Running:
    """A load in progress: its measurement window (wall clock) and the workers' futures."""

    futures: list[Any]
    start_at: float
    measure_from: float
    stop_at: float
    stop_file: str = ""

    def stop_now(self) -> None:
        """Ask the clients to stop at once (they notice within 0.25 s)."""
        if self.stop_file:
            Path(self.stop_file).touch()

    def wait(self) -> dict[str, Any]:
        results = [future.result(timeout=max(0.0, self.stop_at - time.time()) + 120.0) for future in self.futures]
        merged: dict[str, Any] = {}
        for result in results:
            for label, entry in result["labels"].items():
                into = merged.setdefault(label, {
                    "kind": entry["kind"], "clients": 0, "ok": 0, "errors": 0, "error_samples": [],
                    "reconnects": 0, "latency_ms": array("d"), "extra": {},
                })
                for key in ("clients", "ok", "errors", "reconnects"):
                    into[key] += entry[key]
                into["latency_ms"].extend(entry["latency_ms"])
                into["error_samples"].extend(entry["error_samples"][: max(0, 10 - len(into["error_samples"]))])
                for name, values in entry["extra"].items():
                    into["extra"].setdefault(name, array("d")).extend(values)
        return {
            "labels": merged,
            "window": (self.measure_from, min([self.stop_at, *(r["ended"] for r in results)])),
            "generator_cpu_s": sum(r["cpu_s"] for r in results),
            "stuck_threads": sum(r["stuck_threads"] for r in results),
        }


def _pin(cpus: tuple[int, ...] | None) -> None:
    if cpus and hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, cpus)


class WorkerPool:
    """A fixed set of load-generator processes reused across phases (spawning costs ~0.5 s each)."""

    def __init__(self, processes: int, cpus: tuple[int, ...] | None = None) -> None:
        import multiprocessing

        self.processes = processes
        self._pool = ProcessPoolExecutor(processes, mp_context=multiprocessing.get_context("spawn"),
                                         initializer=_pin, initargs=(cpus,))
        # Start every process now, not inside the first measurement.
        list(self._pool.map(_noop, range(processes)))

    def start(self, host: str, port: int, specs: list[ClientSpec], *, warmup: float, duration: float,
              first_client_id: int = 1000, seed: int = 1, lead: float = 1.5, stop_file: str = "") -> Running:
        """Start ``specs`` spread over the processes; the returned handle knows the window."""
        clients: list[tuple[ClientSpec, int]] = []
        next_id = first_client_id
        for spec in specs:
            for _ in range(spec.count):
                client_id = int(spec.options.get("client_id", next_id))
                clients.append((spec, client_id))
                next_id += 1
        shares: list[list[tuple[ClientSpec, int]]] = [[] for _ in range(self.processes)]
        for index, item in enumerate(clients):
            shares[index % self.processes].append(item)
        start_at = time.time() + lead
        tasks = [WorkerTask(host, port, tuple(share), start_at, start_at + warmup, start_at + warmup + duration,
                            seed=seed * 100 + index, stop_file=stop_file)
                 for index, share in enumerate(shares) if share]
        futures = [self._pool.submit(run_task, task) for task in tasks]
        return Running(futures, start_at, start_at + warmup, start_at + warmup + duration, stop_file)

    def run(self, host: str, port: int, specs: list[ClientSpec], **kwargs: Any) -> dict[str, Any]:
        return self.start(host, port, specs, **kwargs).wait()

    def close(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)


def _noop(_: int) -> int:
    return os.getpid()
