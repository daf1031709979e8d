"""Fault switches: the ways a real mount link misbehaves, on demand.

Faults are shared by the model (a reboot resets the mount) and the server (the line effects).
The reply-level faults (drop, garble, stall) are consumed by whichever connection sends the next
reply; the connection-level ones (close, outage, reboot) are broadcast to listeners. Times here
are REAL seconds: a WiFi stall or a USB unplug happens on the line, not in the emulated sky.
"""

from __future__ import annotations

import logging
import random
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

__all__ = ["FaultEvent", "Faults"]

_log = logging.getLogger(__name__)

# Junk that looks like line noise but never contains ':' (which would start a command in a
# client's own framer) and never '#' (so a garbled reply still ends where the real one ends).
_JUNK = bytes(b for b in range(0x01, 0x100) if b not in (ord(":"), ord("#")))


@dataclass(frozen=True)
class FaultEvent:
    """A connection-level fault broadcast to listeners: ``kind`` is close, outage or reboot."""

    kind: str
    seconds: float = 0.0


class Faults:
    """Thread-safe fault switches; every method may be called at any time from any thread."""

    def __init__(self, seed: int = 4030) -> None:
        self._lock = threading.Lock()
        self._drop = 0
        self._garble = 0
        self._garble_replace = False
        self._stall_until = 0.0
        self._refuse_until = 0.0
        self._random = random.Random(seed)
        self._listeners: list[Callable[[FaultEvent], None]] = []
        self.dropped = 0  # replies swallowed so far
        self.garbled = 0  # replies garbled so far

    # -- switches ---------------------------------------------------------------------------

    def drop_replies(self, n: int = 1) -> None:
        """Swallow the next ``n`` replies (the command still takes effect, like a lost packet)."""
        with self._lock:
            self._drop = max(0, int(n))

    def garble_replies(self, n: int = 1, replace: bool = False) -> None:
        """Precede (or with ``replace`` replace) the next ``n`` replies with junk bytes."""
        with self._lock:
            self._garble = max(0, int(n))
            self._garble_replace = replace

    def stall(self, ms: float) -> None:
        """Silence the line for ``ms`` real milliseconds; queued reply bytes follow afterwards."""
        with self._lock:
            self._stall_until = max(self._stall_until, time.monotonic() + max(0.0, ms) / 1000.0)

    def close_connections(self) -> None:
        """Drop every TCP connection and hang up the pty, like pulling the USB cable."""
        self._emit(FaultEvent("close"))

    def outage(self, seconds: float) -> None:
        """Drop every connection and refuse new ones for ``seconds`` (the WiFi AP went away)."""
        with self._lock:
            self._refuse_until = max(self._refuse_until, time.monotonic() + max(0.0, seconds))
        self._emit(FaultEvent("outage", seconds))

    def reboot(self, seconds: float = 2.0) -> None:
        """Power-cycle the mount: connections drop, it is unreachable for ``seconds``, then
        answers in its power-up state (persistent settings kept)."""
        with self._lock:
            self._refuse_until = max(self._refuse_until, time.monotonic() + max(0.0, seconds))
        self._emit(FaultEvent("reboot", seconds))

    def clear(self) -> None:
        """Cancel every pending reply fault, stall and refusal."""
        with self._lock:
            self._drop = self._garble = 0
            self._stall_until = self._refuse_until = 0.0

    # -- what the server and model consult -------------------------------------------------

    def add_listener(self, listener: Callable[[FaultEvent], None]) -> None:
        with self._lock:
            self._listeners.append(listener)

    def remove_listener(self, listener: Callable[[FaultEvent], None]) -> None:
        with self._lock:
            if listener in self._listeners:
                self._listeners.remove(listener)

    def apply_to_reply(self, reply: bytes) -> bytes | None:
        """The bytes to send instead of ``reply``: ``None`` when dropped, junk when garbled."""
        with self._lock:
            if self._drop > 0:
                self._drop -= 1
                self.dropped += 1
                return None
            if self._garble > 0:
                self._garble -= 1
                self.garbled += 1
                junk = bytes(self._random.choice(_JUNK) for _ in range(self._random.randint(1, 4)))
                return junk if self._garble_replace else junk + reply
        return reply

    def stall_until(self) -> float:
        """``time.monotonic()`` instant before which no reply byte may leave."""
        with self._lock:
            return self._stall_until

    def refusing(self) -> bool:
        """True while an outage or reboot keeps new connections out."""
        with self._lock:
            return time.monotonic() < self._refuse_until

    def refuse_until(self) -> float:
        with self._lock:
            return self._refuse_until

    def pending(self) -> dict[str, float]:
        """What is armed right now, for the control port's ``state`` and ``stats``."""
        now = time.monotonic()
        with self._lock:
            return {
                "drop": self._drop,
                "garble": self._garble,
                "stall_s": max(0.0, self._stall_until - now),
                "refuse_s": max(0.0, self._refuse_until - now),
                "dropped": self.dropped,
                "garbled": self.garbled,
            }

    def _emit(self, event: FaultEvent) -> None:
        with self._lock:
            listeners = list(self._listeners)
        for listener in listeners:
            try:
                listener(event)
            except Exception:  # a fault must never take the emulator down
                _log.exception("fault listener failed on %s", event)
