"""Instruments for the fault matrix: timed Alpaca clients, a NINA-like state monitor and a reply oracle.

The fault tests judge the server only by what a client or the mount could observe: HTTP status,
latency and ClientTransactionID echo on one side, the bytes the emulated mount really received
and answered on the other. Everything here records; the tests decide.

Limits come from what real clients tolerate (``shared/alpaca/clients.md``): N.I.N.A.'s ASCOM
client and PHD2's control connection give up after 5 s, PHD2's status connection after 3 s, and
a PulseGuide PUT gets its duration plus 5 s. A request slower than that is a failure the user
would see ("Telescope connection lost"), whatever the server eventually answers.
"""

from __future__ import annotations

import os
import re
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from datetime import datetime, timezone
from typing import Any

import pytest

from alpaca_zwo._exceptions import MountReplyError, ProtocolError
from alpaca_zwo.zwo import protocol
from alpaca_zwo.zwo.link import TraceEntry
from tests.support import AlpacaClient, Call, wait_until
from tests.support.alpaca import HANG_CUTOFF_S

__all__ = ["wait_until"]  # re-exported for tests/bridges/stellarium_rig.py

#: The issue's promise: the link is back within this long after the mount is.
RECONNECT_LIMIT_S = 5.0


class Verdict:
    """Collects every broken promise of a scenario, so one run reports all of them, not just the first."""

    def __init__(self, scenario: str) -> None:
        self.scenario = scenario
        self.failures: list[str] = []

    def check(self, condition: object, message: str) -> bool:
        if not condition:
            self.failures.append(message)
        return bool(condition)

    def extend(self, messages: Iterable[str]) -> None:
        self.failures.extend(messages)

    def conclude(self) -> None:
        if self.failures:
            pytest.fail(f"{self.scenario}: {len(self.failures)} broken promise(s):\n  " + "\n  ".join(self.failures),
                        pytrace=False)


_ALPACA_TIME = re.compile(r"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d)(?:\.(\d+))?Z?")


def parse_alpaca_time(text: str) -> datetime:
    """ISO 8601 as Alpaca servers write it (up to 7 fractional digits, trailing Z), as aware UTC."""
    match = _ALPACA_TIME.fullmatch(text.strip())
    if match is None:
        raise ValueError(f"not an Alpaca date: {text!r}")
    base = datetime.fromisoformat(match.group(1)).replace(tzinfo=timezone.utc)
    fraction = (match.group(2) or "0")[:6].ljust(6, "0")
    return base.replace(microsecond=int(fraction))


def rss_bytes(pid: int | None = None) -> int:
    """Resident set size from /proc (Linux, where CI runs); 0 where /proc is absent."""
    path = f"/proc/{pid or os.getpid()}/status"
    try:
        with open(path, encoding="ascii") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        return 0
    return 0


def is_clear_driver_error(call: Call) -> bool:
    """A failed command a user can act on: an ASCOM DriverError (0x500-0xFFF) that says it was the mount."""
    return (call.status == 200 and call.error_number is not None and 0x500 <= call.error_number <= 0xFFF
            and "mount" in call.error_message.lower())


# --- what a N.I.N.A.-like poller sees -------------------------------------------------------------


@dataclass(frozen=True)
class Sample:
    """One poll: Connected and DeviceState, with the emulator's true UTC when it was taken."""

    at: float  # time.monotonic() when the poll started
    truth: datetime  # the emulated universe's UTC right after the DeviceState answer
    connected: bool | None
    state: dict[str, Any] | None

    @property
    def timestamp(self) -> datetime | None:
        if not self.state or "TimeStamp" not in self.state:
            return None
        return parse_alpaca_time(self.state["TimeStamp"])

    @property
    def age(self) -> float | None:
        """How old the position was by the server's own account (truth minus TimeStamp)."""
        stamp = self.timestamp
        return None if stamp is None else (self.truth - stamp).total_seconds()


class Monitor:
    """Polls ``connected`` and ``devicestate`` like N.I.N.A. 3.2 (IV4 path), every ``interval`` seconds."""

    def __init__(self, client: AlpacaClient, truth: Callable[[], datetime], interval: float = 0.25) -> None:
        self.client = client
        self.truth = truth
        self.interval = interval
        self.samples: list[Sample] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="fault-monitor", daemon=True)

    def __enter__(self) -> Monitor:
        self._thread.start()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.stop()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(HANG_CUTOFF_S + 5)

    def _run(self) -> None:
        while not self._stop.is_set():
            started = time.monotonic()
            connected = self.client.get("connected")
            state_call = self.client.get("devicestate")
            truth = self.truth()
            state = None
            if state_call.ok and isinstance(state_call.value, list):
                state = {item["Name"]: item["Value"] for item in state_call.value}
            self.samples.append(Sample(started, truth, connected.value if connected.ok else None, state))
            self._stop.wait(max(0.0, self.interval - (time.monotonic() - started)))

    def between(self, start: float, end: float = float("inf")) -> list[Sample]:
        return [s for s in list(self.samples) if start <= s.at <= end]


# --- the mount's side of every exchange -------------------------------------------------------------


@dataclass(frozen=True)
class MountExchange:
    """A request the emulated mount acted on, and the reply it produced (before any fault touched it)."""

    time: float  # time.time(), the clock the link's trace uses
    body: str
    reply: str | None
    power_ups: int


class MountRecorder:
    """Wraps the emulator's responder to record every exchange it serves: the ground truth of the wire."""

    def __init__(self, emulator_server: Any, maxlen: int = 200_000) -> None:
        self._responder = emulator_server.responder
        self._model = emulator_server.model
        self._original = self._responder.handle
        self._lock = threading.Lock()
        self.exchanges: deque[MountExchange] = deque(maxlen=maxlen)
        self._by_body: dict[str, deque[MountExchange]] = {}

        def handle(body: str) -> str | None:
            reply = self._original(body)
            exchange = MountExchange(time.time(), body, reply, self._model.power_ups)
            with self._lock:
                self.exchanges.append(exchange)
                self._by_body.setdefault(body, deque(maxlen=512)).append(exchange)
            return reply

        self._responder.handle = handle

    def uninstall(self) -> None:
        self._responder.handle = self._original

    def all(self) -> list[MountExchange]:
        with self._lock:
            return list(self.exchanges)

    def matching(self, body: str, start: float, end: float) -> list[MountExchange]:
        with self._lock:
            return [e for e in self._by_body.get(body, ()) if start <= e.time <= end]


def _rejected(request: str, reply: str) -> bool:
    """Would the server have refused to use ``reply`` as the answer to ``request``?"""
    if any(not (" " <= ch <= "~") and ch not in "°ß\xdf" for ch in reply):
        return True  # the link's shape check throws out non-printable bytes
    match = protocol.match_command(request[1:-1])
    if match is None:
        return False
    try:
        protocol.Request(match.command, request).parse(reply)
    except ProtocolError:
        return True
    except MountReplyError:
        return False  # read as a refusal: acted upon
    return False


@dataclass
class TraceAudit:
    """The link's trace checked against what the mount really answered, entry by entry."""

    checked: int = 0
    garbled_rejected: int = 0
    mismatches: list[str] = field(default_factory=list)
    _seen: set[tuple[float, str, float]] = field(default_factory=set)

    def feed(self, trace: list[TraceEntry], recorder: MountRecorder) -> None:
        """Check the entries not checked before; may be called repeatedly while traffic flows."""
        for index, entry in enumerate(trace):
            key = (entry.time, entry.request, entry.duration_ms)
            if key in self._seen:
                continue
            self._seen.add(key)
            if not entry.request or entry.reply is None or entry.reply == "":
                continue  # link events, timeouts and commands without a reply carry nothing to attribute
            self.checked += 1
            body = entry.request[1:-1]
            sent = entry.time - entry.duration_ms / 1000.0 - 0.02
            candidates = recorder.matching(body, sent, entry.time + 0.02)
            if any(c.reply == entry.reply for c in candidates):
                continue
            if _rejected(entry.request, entry.reply):
                # Junk the server refused to use; if it left stale bytes behind, the next reply
                # read would be the wrong one and is flagged on its own.
                self.garbled_rejected += 1
                continue
            following = trace[index + 1] if index + 1 < len(trace) else None
            truth = [c.reply for c in candidates]
            self.mismatches.append(
                f"{entry.request} read {entry.reply!r} but the mount answered {truth or 'nothing in that window'} "
                f"(trace note {entry.note!r}, next {following.note if following else None!r})")
        if len(self._seen) > 50_000:  # keep the de-duplication window bounded in a long soak
            self._seen = {(e.time, e.request, e.duration_ms) for e in trace}


def trace_notes(trace: list[TraceEntry], since: float = 0.0) -> list[str]:
    return [f"{e.request or '-'} {e.reply!r} {e.note}" for e in trace if e.time >= since and e.note]


def report(label: str, **numbers: object) -> None:
    """Print measured outcomes for the README's Reliability section.

    Shown with ``pytest -s``; also kept in a file if asked.

    ``ALPACA_ZWO_RELIABILITY_LOG`` names a file the lines are appended to, so a CI run can keep them.
    """
    shown = ", ".join(f"{k}={v:.2f}" if isinstance(v, float) else f"{k}={v}" for k, v in numbers.items())
    line = f"[reliability] {label}: {shown}"
    print(line)
    path = os.environ.get("ALPACA_ZWO_RELIABILITY_LOG")
    if path:
        with open(path, "a", encoding="utf-8") as f:
            f.write(line + "\n")
