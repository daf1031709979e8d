"""Clocks of the emulated universe.

Everything in the emulator runs on emulated time so a test can jump an hour ahead in a
microsecond (``ManualClock``) and a demo can run ten times faster than real time
(``ScaledClock(speed=10)``). The mount's own wall clock (the one a client sets with ``:SL#``) is
separate: it lives in the model and merely counts emulated seconds.
"""

from __future__ import annotations

import threading
import time
from datetime import datetime, timedelta, timezone
from typing import Protocol

__all__ = ["Clock", "ManualClock", "ScaledClock"]


class Clock(Protocol):
    """What the model needs from a clock: true UTC and a monotonic count of emulated seconds."""

    def now(self) -> datetime:
        """True UTC of the emulated universe (timezone-aware)."""
        ...

    def seconds(self) -> float:
        """Emulated seconds since the clock was made; never goes backwards."""
        ...


def _aware_utc(value: datetime | None) -> datetime:
    if value is None:
        return datetime.now(timezone.utc)
    if value.tzinfo is None:
        return value.replace(tzinfo=timezone.utc)  # naive means UTC, as everywhere in the project
    return value.astimezone(timezone.utc)


class ScaledClock:
    """Real time, optionally sped up: emulated seconds = monotonic elapsed x ``speed``.

    Built on ``time.monotonic`` so a host clock step (NTP) cannot make a slew jump.
    """

    def __init__(self, speed: float = 1.0, start_utc: datetime | None = None) -> None:
        if not speed > 0.0:
            raise ValueError(f"clock speed must be positive, not {speed!r}")
        self.speed = float(speed)
        self._start_utc = _aware_utc(start_utc)
        self._start_mono = time.monotonic()

    def seconds(self) -> float:
        return (time.monotonic() - self._start_mono) * self.speed

    def now(self) -> datetime:
        return self._start_utc + timedelta(seconds=self.seconds())


class ManualClock:
    """A clock that moves only when told to, so physics tests are exact and need no sleeps."""

    def __init__(self, start_utc: datetime | None = None) -> None:
        self._start_utc = _aware_utc(start_utc if start_utc is not None else datetime(2025, 1, 1, 22, 0, 0))
        self._elapsed = 0.0
        self._lock = threading.Lock()

    def advance(self, seconds: float) -> None:
        """Move emulated time forward; negative steps are refused (time is monotonic)."""
        if seconds < 0.0:
            raise ValueError("a clock cannot go backwards")
        with self._lock:
            self._elapsed += seconds

    def seconds(self) -> float:
        with self._lock:
            return self._elapsed

    def now(self) -> datetime:
        return self._start_utc + timedelta(seconds=self.seconds())
