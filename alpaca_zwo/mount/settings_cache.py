"""The settings stored in the mount as last read, and when they are due to be read again.

The setup page shows them and the status feed uses them (flip countdown, the mount's altitude
limits on the sky plot), so a GET must not cost the serial line eight queries: every reader gets
this copy. It is refreshed

- by whoever changes a setting and needs the result at once (the page's POST and the ``zwo:*``
  Actions read the settings back after writing, which stores them here);
- by the poller, at low priority and only at rest, when a command that changes a stored setting
  passed through the server (``mark_stale``: from any path, the ZWO-port bridge's raw commands
  included), after the link is (re)initialised, and every ``refresh_s`` seconds (default 60),
  because the mount also listens on WiFi and Bluetooth: ZWO's app or an ASIAIR can change a
  setting while we hold the serial line, and nothing on our line would tell us.

A read never clears a mark made while it was under way (a generation counter), so a write that
races a refresh is read again on the next poll.
"""

from __future__ import annotations

import threading
import time
from dataclasses import fields

from .state import MountSettings

#: Seconds between periodic re-reads: how late a change made by another program (WiFi) may show.
DEFAULT_REFRESH_S = 60.0


class SettingsCache:
    """Thread-safe: the poller stores, HTTP threads read, any thread may mark it stale."""

    def __init__(self, refresh_s: float = DEFAULT_REFRESH_S) -> None:
        self.refresh_s = refresh_s
        self._lock = threading.Lock()
        self._value: MountSettings | None = None
        self._read_at: float | None = None  # time.monotonic() of the last complete read
        self._generation = 0  # bumped by mark_stale
        self._stored_generation = -1  # the generation the value is known to be current for

    @property
    def value(self) -> MountSettings | None:
        """The last settings read (kept while the mount is away); None until the first read."""
        return self._value

    @property
    def generation(self) -> int:
        """Take this before a read and hand it to :meth:`store`."""
        return self._generation

    def mark_stale(self) -> None:
        """A setting may have changed: the poller re-reads at its next tick at rest."""
        with self._lock:
            self._generation += 1

    def due(self, now: float | None = None) -> bool:
        """Stale, never read, or older than ``refresh_s``."""
        now = time.monotonic() if now is None else now
        with self._lock:
            return (self._stored_generation != self._generation or self._read_at is None
                    or now - self._read_at >= self.refresh_s)

    def store(self, settings: MountSettings, generation: int, now: float | None = None) -> None:
        """Keep a read begun at ``generation``. A read where every query failed keeps the previous values
        and is not retried before ``refresh_s`` (a lost link marks the cache stale when it comes back)."""
        failed = all(getattr(settings, f.name) is None for f in fields(settings))
        with self._lock:
            if not failed:
                self._value = settings
            self._read_at = time.monotonic() if now is None else now
            self._stored_generation = generation
