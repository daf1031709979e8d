"""SafetyWatch: polls the SafetyMonitor and the roof and writes the verdict into the interlock gate.

Rules (docs/guide/observatory.md):

- Every ``poll_s`` the monitor's ``IsSafe`` and the roof's ``ShutterStatus`` are read (one after the
  other, each with a timeout well under ``unreachable_s``). Before the first read of a device the
  server sends it ``Connected=true`` (ASCOM: a SafetyMonitor that is not connected must say unsafe), and
  again whenever it answers unsafe or NotConnected while not connected; it never disconnects a device
  (other programs share it).
- A device's last good answer decides for ``unreachable_s`` after it was given, whatever errors follow;
  older than that it counts as unsafe ("no answer for N s"). Until a device's first answer the state is
  *unknown*, which refuses motion like unsafe but triggers no park (the server may just have started);
  after ``unreachable_s`` without any answer it is unsafe.
- Unsafe if either device says so (the monitor's reason first), else unknown if either is, else safe.
- The verdict is written into the gate first, then the responder is told (``on_change``), so motion is
  refused before the mount is stopped (``motion/interlock.py``'s race rule).
- Changing the monitor or roof URL starts afresh (unknown); emptying both turns the interlock off.
"""

from __future__ import annotations

import collections
import logging
import random
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime, timezone
from typing import Any

from ..alpaca.remote import RemoteDevice, RemoteError
from ..config.settings import SafetySettings, Settings
from ..config.store import SettingsStore
from ..motion.interlock import Interlock, SafetyState, Verdict

__all__ = ["SHUTTER_NAMES", "DeviceReading", "SafetyWatch", "judge"]

log = logging.getLogger(__name__)

#: ASCOM ShutterState: only open lets the mount move.
SHUTTER_NAMES = {0: "open", 1: "closed", 2: "opening", 3: "closing", 4: "error"}
#: Events the page lists (the newest last).
EVENTS_KEPT = 20


def _utc_now() -> datetime:
    return datetime.now(timezone.utc)


@dataclass
class DeviceReading:
    """One polled device: its last good answer and its last error, with their times (monotonic)."""

    role: str  # "monitor" or "roof"
    url: str
    answer: str = ""  # "IsSafe=true", "ShutterStatus=0 (open)"
    ok: bool = False  # that answer allows motion
    answered_at: float | None = None
    answered_utc: datetime | None = None
    error: str = ""  # the last poll's failure ('' when it answered)
    connected_sent: bool = False

    def view(self, now: float) -> dict[str, Any]:
        age = None if self.answered_at is None else round(now - self.answered_at, 1)
        return {"url": self.url, "answer": self.answer, "safe": self.ok if self.answered_at is not None else None,
                "age_s": age, "at": self.answered_utc.isoformat() if self.answered_utc else None,
                "error": self.error}


def judge(reading: DeviceReading, now: float, started: float, unreachable_s: float) -> tuple[SafetyState, str]:
    """One device's say: (state, reason) by its last answer, that answer's age and its errors."""
    if reading.answered_at is not None and now - reading.answered_at <= unreachable_s:
        return (SafetyState.SAFE if reading.ok else SafetyState.UNSAFE), reading.answer
    if reading.answered_at is None and now - started < unreachable_s:
        return SafetyState.UNKNOWN, reading.error or "waiting for its first answer"
    silent = now - (reading.answered_at if reading.answered_at is not None else started)
    return SafetyState.UNSAFE, f"no answer for {silent:.0f} s ({reading.error or 'no reply'})"


class SafetyWatch:
    """The poller (thread ``safety-watch``) and the current readings; ``on_change(previous, new)`` is
    called (on that thread) whenever the verdict's state changes."""

    def __init__(self, store: SettingsStore, interlock: Interlock,
                 on_change: Callable[[Verdict, Verdict], None] | None = None) -> None:
        self.store = store
        self.interlock = interlock
        self._on_change = on_change
        self.client_id = random.randint(1, 65535)  # one ClientID for this server's reads of the devices
        self._lock = threading.Lock()  # guards the readings, the events and the configuration in use
        self._publish_lock = threading.Lock()  # one verdict change at a time (the poller, a settings change)
        self._readings: list[DeviceReading] = []
        self._config: tuple[str, str] = ("", "")
        self._started = time.monotonic()
        self.events: collections.deque[dict[str, str]] = collections.deque(maxlen=EVENTS_KEPT)
        self._wake = threading.Event()
        self._stopped = threading.Event()
        self._thread: threading.Thread | None = None
        store.subscribe(self._settings_changed)
        self._configure(store.settings.safety)
        self._publish(store.settings.safety)  # configured: unknown (motion refused) from now on

    # -- life ------------------------------------------------------------------------------------

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="safety-watch", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stopped.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout=10)

    def _settings_changed(self, settings: Settings) -> None:
        """New devices take effect before the change returns: motion is refused from then until they answer."""
        if self._configure(settings.safety):
            self._publish(settings.safety)
        self._wake.set()

    def _configure(self, safety: SafetySettings) -> bool:
        """Start afresh when the devices changed (True); the verdict follows on the next round."""
        config = (safety.monitor, safety.roof)
        with self._lock:
            if config == self._config and self._readings:
                return False
            self._config = config
            self._readings = [DeviceReading(role, url) for role, url in (("monitor", safety.monitor),
                                                                    ("roof", safety.roof)) if url]
            self._started = time.monotonic()
        if any(config):
            log.info("safety monitor: watching %s", " and ".join(url for url in config if url))
        return True

    def _run(self) -> None:
        while not self._stopped.is_set():
            safety = self.store.settings.safety
            try:
                self.poll_once(safety)
            except Exception:  # the watch must outlive any bug: motion stays refused meanwhile
                log.exception("safety monitor: poll failed")
            self._wake.wait(safety.poll_s)
            self._wake.clear()

    # -- one round ----------------------------------------------------------------------------

    def poll_once(self, safety: SafetySettings | None = None) -> Verdict:
        """Read every configured device once and publish the verdict."""
        safety = safety or self.store.settings.safety
        self._configure(safety)
        with self._lock:
            readings = list(self._readings)
        timeout = min(5.0, max(0.5, safety.unreachable_s / 3.0))
        for reading in readings:
            self._read(reading, timeout)
        return self._publish(safety)

    def _read(self, reading: DeviceReading, timeout: float) -> None:
        device = RemoteDevice(reading.url, client_id=self.client_id, timeout=timeout)
        try:
            if not reading.connected_sent:
                self._connect(device, reading)
            ok, answer = (self._is_safe if reading.role == "monitor" else self._shutter)(device, reading)
        except RemoteError as exc:
            if reading.error != str(exc):
                log.warning("safety monitor: %s %s: %s", reading.role, reading.url, exc)
            reading.error = str(exc)
            return
        if reading.error:
            log.info("safety monitor: %s %s answers again: %s", reading.role, reading.url, answer)
        reading.ok, reading.answer, reading.error = ok, answer, ""
        reading.answered_at, reading.answered_utc = time.monotonic(), _utc_now()

    @staticmethod
    def _connect(device: RemoteDevice, reading: DeviceReading) -> None:
        """Connected=true; a device that refuses it may still answer, so the refusal is only noted."""
        reading.connected_sent = True
        try:
            device.put("connected", Connected=True)
        except RemoteError as exc:
            log.info("safety monitor: %s %s: Connected=true refused (%s)", reading.role, reading.url, exc)

    def _is_safe(self, device: RemoteDevice, reading: DeviceReading) -> tuple[bool, str]:
        safe = device.get_bool("issafe")
        if not safe and not device.get_bool("connected"):  # disconnected (by another program?): unsafe by rule
            self._connect(device, reading)
            safe = device.get_bool("issafe")
        return safe, f"IsSafe={'true' if safe else 'false'}"

    def _shutter(self, device: RemoteDevice, reading: DeviceReading) -> tuple[bool, str]:
        try:
            status = device.get_int("shutterstatus")
        except RemoteError as exc:
            if "0x407" not in str(exc):  # NotConnected: connect and ask again
                raise
            self._connect(device, reading)
            status = device.get_int("shutterstatus")
        return status == 0, f"ShutterStatus={status} ({SHUTTER_NAMES.get(status, 'unknown')})"

    # -- the verdict ----------------------------------------------------------------------------

    def _verdict(self, readings: list[DeviceReading]) -> tuple[SafetyState, str, str]:
        if not readings:
            return SafetyState.OFF, "", ""
        now, started = time.monotonic(), self._started
        unreachable_s = self.store.settings.safety.unreachable_s
        says = [(judge(r, now, started, unreachable_s), r) for r in readings]
        for wanted in (SafetyState.UNSAFE, SafetyState.UNKNOWN):
            for (state, reason), reading in says:
                if state is wanted:
                    return state, reading.url, reason
        return SafetyState.SAFE, readings[0].url, ", ".join(r.answer for r in readings)

    def _publish(self, safety: SafetySettings) -> Verdict:
        """The verdict from the devices configured now (a round polled for replaced ones counts for nothing)."""
        with self._publish_lock:
            with self._lock:
                readings = list(self._readings)
            return self._publish_locked(readings, safety)

    def _publish_locked(self, readings: list[DeviceReading], safety: SafetySettings) -> Verdict:
        state, source, reason = self._verdict(readings)
        previous = self.interlock.verdict
        since = previous.since if previous.state is state else (None if state is SafetyState.OFF else _utc_now())
        verdict = Verdict(state, source, reason, since)
        if verdict != previous:
            self.interlock.set(verdict)
        if previous.state is not state:
            self._log_change(previous, verdict, safety)
            if self._on_change is not None:
                self._on_change(previous, verdict)
        return verdict

    def _log_change(self, previous: Verdict, verdict: Verdict, safety: SafetySettings) -> None:
        if verdict.state is SafetyState.UNSAFE:
            text = f"UNSAFE: {verdict.reason} ({verdict.source}); motion refused, on_unsafe = {safety.on_unsafe}"
            log.warning("safety monitor: %s", text)
        elif verdict.state is SafetyState.SAFE:
            text = f"safe: {verdict.reason} ({verdict.source}); motion allowed (a parked mount stays parked)"
            log.info("safety monitor: %s", text)
        elif verdict.state is SafetyState.UNKNOWN:
            text = f"waiting for an answer from {verdict.source}; motion refused until it answers safe"
            log.info("safety monitor: %s", text)
        else:
            text = "off (no monitor or roof configured): motion allowed"
            log.info("safety monitor: %s", text)
        self.record(verdict.state.value, text)

    def record(self, kind: str, text: str) -> None:
        """An event for the page (the verdict's changes and what the responder did)."""
        with self._lock:
            self.events.append({"time": _utc_now().isoformat(), "kind": kind, "text": text})

    # -- for the page, the status feed and zwo:Safety -----------------------------------------------

    def status(self) -> dict[str, Any]:
        """The verdict, each device's last answer and its age, and the recent events."""
        verdict = self.interlock.verdict
        safety = self.store.settings.safety
        now = time.monotonic()
        with self._lock:
            readings = {r.role: r.view(now) for r in self._readings}
            events = list(self.events)
        return {
            **verdict_view(verdict),
            "on_unsafe": safety.on_unsafe, "poll_s": safety.poll_s, "unreachable_s": safety.unreachable_s,
            "monitor": readings.get("monitor"), "roof": readings.get("roof"), "events": events,
        }


def verdict_view(verdict: Verdict) -> dict[str, Any]:
    """``{"safe", "source", "since", "state", "reason", "message"}``: zwo:Safety's reply, the feed's core."""
    return {"safe": verdict.safe, "source": verdict.source,
            "since": verdict.since.isoformat() if verdict.since else None,
            "state": verdict.state.value, "reason": verdict.reason, "message": verdict.describe()}
