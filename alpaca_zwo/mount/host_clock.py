"""Does this computer's clock deserve trust? The operating system's own answer, read without root.

A Raspberry Pi has no real-time clock: at a dark site without network it boots with the time it was
last shut down (or 1970), hours or days off, and the kernel knows it. The server sets the mount's
clock from its own only when this module says the host clock is known to be right
(``mount/timekeeping.py`` decides).

- **Linux**: ``adjtimex`` with ``modes = 0`` (a read; no privilege needed). The clock counts as
  synchronised while the kernel's maximum error is below 16 s, the bound at which the kernel itself
  sets ``STA_UNSYNC`` and returns ``TIME_ERROR``. The maximum error, not the flag, decides, as
  ``timedatectl`` does since systemd PR #13245 (github.com/systemd/systemd/pull/13245): chrony
  leaves ``STA_UNSYNC`` set on a clock it disciplines unless ``rtcsync`` is configured.
  systemd-timesyncd's stamp file (``/var/lib/systemd/timesync/clock``, touched at every
  synchronisation) says when the clock was last synchronised, across reboots.
- **Windows**: ``w32tm /query /status`` (Leap Indicator 3 = not synchronised; its first line,
  whatever the language). An error (the Windows Time service stopped, access refused) reads as
  "cannot tell".
- **macOS and others**: cannot tell (macOS's ``ntp_adjtime`` reports UNSYNC whatever the network
  time setting: perfsonar/owamp issue 27), so the clock is trusted, as before this module existed.

"Cannot tell" is trusted: the server then behaves as it always did. For tests (and to try the
behaviour out), the environment variable ``ALPACA_ZWO_HOST_CLOCK`` = ``synchronised`` or
``unsynchronised`` overrides what the operating system says.
"""

from __future__ import annotations

import ctypes
import logging
import os
import re
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

log = logging.getLogger(__name__)

__all__ = ["ENV_OVERRIDE", "HostClockStatus", "HostClockWatch", "read_host_clock_status"]

#: Set to "synchronised" or "unsynchronised" to override the operating system's answer (tests).
ENV_OVERRIDE = "ALPACA_ZWO_HOST_CLOCK"
#: The kernel's NTP_PHASE_LIMIT: at this maximum error (µs) it declares the clock unsynchronised.
MAX_ERROR_LIMIT_US = 16_000_000
TIME_ERROR = 5  # adjtimex's return value for an unsynchronised clock
STA_UNSYNC = 0x0040
TIMESYNCD_STAMP = Path("/var/lib/systemd/timesync/clock")


@dataclass(frozen=True)
class HostClockStatus:
    """What the operating system says about its clock.

    ``synchronised`` is None where the platform cannot tell; the clock is then trusted (``trusted``).
    ``last_synchronised``: when it was last known synchronised, from the platform (timesyncd's stamp),
    or None.
    """

    synchronised: bool | None
    method: str  # how it was read: "adjtimex", "w32tm", "ALPACA_ZWO_HOST_CLOCK", "none"
    detail: str  # one line for the log and the page, in a person's words
    last_synchronised: datetime | None = None
    kernel: str = ""  # the kernel's own words (adjtimex's state and flags), for the log only

    @property
    def trusted(self) -> bool:
        return self.synchronised is not False


class _Timeval(ctypes.Structure):
    _fields_ = [("tv_sec", ctypes.c_long), ("tv_usec", ctypes.c_long)]


class _Timex(ctypes.Structure):
    """Linux's ``struct timex`` (the legacy ABI the ``adjtimex`` symbol takes on every architecture),
    with the spare room at its end the kernel may write."""

    _fields_ = [("modes", ctypes.c_uint), ("offset", ctypes.c_long), ("freq", ctypes.c_long),
                ("maxerror", ctypes.c_long), ("esterror", ctypes.c_long), ("status", ctypes.c_int),
                ("constant", ctypes.c_long), ("precision", ctypes.c_long), ("tolerance", ctypes.c_long),
                ("time", _Timeval), ("tick", ctypes.c_long), ("ppsfreq", ctypes.c_long), ("jitter", ctypes.c_long),
                ("shift", ctypes.c_int), ("stabil", ctypes.c_long), ("jitcnt", ctypes.c_long),
                ("calcnt", ctypes.c_long), ("errcnt", ctypes.c_long), ("stbcnt", ctypes.c_long),
                ("tai", ctypes.c_int), ("_spare", ctypes.c_int * 16)]


def _timesyncd_stamp() -> datetime | None:
    """When systemd-timesyncd last synchronised the clock (its stamp file's modification time)."""
    try:
        return datetime.fromtimestamp(TIMESYNCD_STAMP.stat().st_mtime, timezone.utc)
    except (OSError, ValueError, OverflowError):
        return None


def linux_status(adjtimex: Callable[[_Timex], int] | None = None) -> HostClockStatus:
    """The kernel's view (``adjtimex`` read-only); ``adjtimex`` is replaceable for tests of the reading."""
    timex = _Timex()
    if adjtimex is None:
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            state = int(libc.adjtimex(ctypes.byref(timex)))
        except (OSError, AttributeError) as exc:
            return HostClockStatus(None, "none", f"adjtimex is not available ({exc}): the clock is trusted")
    else:
        state = adjtimex(timex)
    return interpret_timex(state, timex.maxerror, timex.status, _timesyncd_stamp())


def interpret_timex(state: int, maxerror_us: int, status: int, stamp: datetime | None) -> HostClockStatus:
    """adjtimex's answer in words (see the module docstring for why the maximum error decides)."""
    if state < 0:
        return HostClockStatus(None, "none", "adjtimex failed: the clock is trusted", stamp)
    flags = ", STA_UNSYNC set" if status & STA_UNSYNC else ""
    state_text = "TIME_ERROR" if state == TIME_ERROR else f"state {state}"
    kernel = f"adjtimex: {state_text}{flags}, maximum error {maxerror_us / 1000:.0f} ms"
    if maxerror_us < MAX_ERROR_LIMIT_US:
        return HostClockStatus(True, "adjtimex", f"this computer's clock is synchronised to a time server (to within "
                                                 f"{maxerror_us / 1000:.0f} ms)", stamp, kernel)
    return HostClockStatus(False, "adjtimex", f"this computer's clock is not synchronised to a time server (it may be "
                                              f"up to {maxerror_us / 1e6:.0f} s off)", stamp, kernel)


_LEAP = re.compile(r"^[^:\r\n]*:\s*(\d)\s*\(")


def interpret_w32tm(output: str) -> HostClockStatus:
    """``w32tm /query /status``: its first line is the Leap Indicator (``Leap Indicator: 3(not
    synchronized)``), in any language; 3 means not synchronised, 0-2 synchronised."""
    first = output.strip().splitlines()[0] if output.strip() else ""
    match = _LEAP.match(first)
    if match is None:
        return HostClockStatus(None, "none", f"w32tm gave no status ({first[:80]!r}): the clock is trusted")
    leap = int(match.group(1))
    if leap == 3:
        return HostClockStatus(False, "w32tm", "Windows Time reports the clock not synchronised (leap indicator 3)")
    return HostClockStatus(True, "w32tm", f"Windows Time reports the clock synchronised (leap indicator {leap})")


def windows_status() -> HostClockStatus:
    try:
        done = subprocess.run(["w32tm", "/query", "/status"], capture_output=True, text=True, timeout=5.0,
                              creationflags=getattr(subprocess, "CREATE_NO_WINDOW", 0), check=False)
    except (OSError, subprocess.SubprocessError) as exc:
        return HostClockStatus(None, "none", f"w32tm could not run ({exc}): the clock is trusted")
    if done.returncode != 0:
        return HostClockStatus(None, "none", f"w32tm answered {done.returncode}: the clock is trusted")
    return interpret_w32tm(done.stdout)


def override_status(value: str) -> HostClockStatus | None:
    """The test override, or None when unset; an unknown value is said so and ignored."""
    word = value.strip().lower()
    if not word:
        return None
    if word in ("synchronised", "synchronized", "1", "yes"):
        return HostClockStatus(True, ENV_OVERRIDE, f"{ENV_OVERRIDE}={value}: taken as synchronised")
    if word in ("unsynchronised", "unsynchronized", "0", "no"):
        return HostClockStatus(False, ENV_OVERRIDE, f"{ENV_OVERRIDE}={value}: taken as not synchronised")
    log.warning("%s=%r is neither 'synchronised' nor 'unsynchronised': ignored", ENV_OVERRIDE, value)
    return None


def read_host_clock_status() -> HostClockStatus:
    """The host clock's status now; never raises."""
    forced = override_status(os.environ.get(ENV_OVERRIDE, ""))
    if forced is not None:
        return forced
    platform: str = sys.platform  # a plain str: each branch is checked on every platform
    if platform.startswith("linux"):
        return linux_status()
    if platform == "win32":
        return windows_status()
    return HostClockStatus(None, "none", f"this platform ({platform}) does not say whether its clock is "
                                         "synchronised: the clock is trusted")


class HostClockWatch:
    """The status, read at most every ``max_age_s`` (a syscall on Linux, a program on Windows), and
    the last moment this server saw the clock synchronised.

    Lock: ``_lock`` guards the cached status and the moment; the reading itself runs outside it.
    """

    def __init__(self, read: Callable[[], HostClockStatus] = read_host_clock_status, *,
                 max_age_s: float | None = None, clock: Callable[[], datetime] | None = None) -> None:
        self._read = read
        self._max_age_s = max_age_s if max_age_s is not None else (60.0 if sys.platform == "win32" else 2.0)
        self._clock = clock or (lambda: datetime.now(timezone.utc))
        self._lock = threading.Lock()
        self._status: HostClockStatus | None = None
        self._read_at = 0.0
        self._seen_synchronised: datetime | None = None

    def status(self) -> HostClockStatus:
        with self._lock:
            status, fresh = self._status, time.monotonic() - self._read_at < self._max_age_s
        if status is not None and fresh:
            return status
        status = self._read()
        with self._lock:
            self._status, self._read_at = status, time.monotonic()
            if status.synchronised:
                self._seen_synchronised = self._clock()  # a synchronised clock tells the right time
        return status

    def last_synchronised(self) -> datetime | None:
        """When the host clock was last known synchronised: seen by this server, or the platform's record."""
        status = self.status()
        with self._lock:
            seen = self._seen_synchronised
        known = [t for t in (seen, status.last_synchronised) if t is not None]
        return max(known) if known else None
