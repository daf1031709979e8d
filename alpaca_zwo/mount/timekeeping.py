"""The server's one time reference for a mount, and the rules that choose it.

Everything that needs "now" (UTCDate, SiderealTime, Alt/Az, the motion checks, the setup page, the
Stellarium and ZWO-port bridges) reads :meth:`TimeKeeper.now`. It is the host's clock, unless there
is a better one:

- **client**: a client's UTCDate write, a program's ``:SC``/``:SL`` on the ZWO port, or the page's
  "Use this device's time" button. The strongest source: it is pushed to the mount and kept.
- **mount**: the host clock is not known to be right (``host_clock.py``), the mount's clock is set
  (not its power-up date of 2000) and the two disagree by more than :data:`TOLERANCE_S`. The
  mount's time is adopted and the mount's clock is not written. ``time.source = "mount"`` adopts
  it whenever the mount has one.
- **host**: otherwise (the host clock synchronised or its status unknowable, ``time.source =
  "host"``, the mount without time, or the two within 2 s): pushed to the mount at connect, as before.

A client or mount reference is anchored on the mount's monotonic clock (``utc`` at instant ``t``,
then ``utc + (monotonic() - t)``), so it survives the host clock being stepped by NTP or chrony
meanwhile. When the host clock becomes synchronised later, a mount reference gives way to it
(:meth:`TimeKeeper.host_regained`): the server then sets the mount's clock.

Lock: ``_lock`` guards the source, its anchor and reason; it is never held while reading a clock
callable that might block (none do) or across I/O.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone
from enum import Enum

from .host_clock import HostClockStatus, HostClockWatch

log = logging.getLogger(__name__)

__all__ = ["TOLERANCE_S", "ClockView", "TimeKeeper", "TimeSource", "describe_difference"]

#: Host and mount clocks closer than this agree: the host's is pushed (it carries sub-second phase).
TOLERANCE_S = 2.0
POLICIES = ("auto", "host", "mount")


class TimeSource(Enum):
    HOST = "host"
    MOUNT = "mount"
    CLIENT = "client"


@dataclass(frozen=True)
class ClockView:
    """The reference as the page shows it: which source, why, and the host clock's standing."""

    source: TimeSource
    reason: str
    policy: str
    offset_s: float  # reference minus the host clock, seconds
    host: HostClockStatus
    host_last_synchronised: datetime | None
    decided_at: datetime | None  # the reference time when the source was last chosen


@dataclass(frozen=True)
class _Anchor:
    utc: datetime
    t: float  # the mount's monotonic instant ``utc`` refers to


def describe_difference(seconds: float) -> str:
    """``3 h 0 min``, ``12 min 5 s``, ``4.2 s``: a clock difference in words, without its sign, rounded
    to its last unit (10,799.6 s is "3 h 0 min", not "2 h 59 min"); the page's fieldline.js words it alike."""
    s = abs(seconds)
    if s < 59.95:
        return f"{s:.1f} s"
    total = round(s)
    if total < 3600:
        return f"{total // 60} min {total % 60} s"
    hours, minutes = divmod(round(s / 60), 60)
    if hours < 48:
        return f"{hours} h {minutes} min"
    days, hours = divmod(round(s / 3600), 24)
    return f"{days} d {hours} h"


def _utc(value: datetime) -> datetime:
    return value.astimezone(timezone.utc) if value.tzinfo else value.replace(tzinfo=timezone.utc)


class TimeKeeper:
    """One mount's time reference: :meth:`now`, and the decisions of when to set the mount's clock.

    ``host_clock``: the host's UTC (an embedded emulator's universe for the built-in mount);
    ``monotonic``: the mount's monotonic seconds (``Mount.monotonic``); ``policy``: the
    ``time.source`` setting, read at each decision.
    """

    def __init__(self, host_clock: Callable[[], datetime], monotonic: Callable[[], float], *,
                 watch: HostClockWatch | None = None, policy: Callable[[], str] = lambda: "auto") -> None:
        self.host_clock = host_clock
        self.monotonic = monotonic
        self.watch = watch or HostClockWatch()
        self._policy = policy
        self._lock = threading.Lock()
        self._source = TimeSource.HOST
        self._anchor: _Anchor | None = None
        self._reason = "the host's clock, until a mount is connected"
        self._decided_at: datetime | None = None

    # -- reading -----------------------------------------------------------------------------

    def now(self) -> datetime:
        with self._lock:
            anchor = self._anchor
        if anchor is None:
            return self.host_clock()
        return anchor.utc + timedelta(seconds=self.monotonic() - anchor.t)

    @property
    def source(self) -> TimeSource:
        return self._source

    def policy(self) -> str:
        policy = self._policy()
        return policy if policy in POLICIES else "auto"

    def view(self) -> ClockView:
        status = self.watch.status()
        with self._lock:
            source, reason, decided = self._source, self._reason, self._decided_at
        offset = (self.now() - self.host_clock()).total_seconds()
        return ClockView(source, reason, self.policy(), offset, status, self.watch.last_synchronised(), decided)

    # -- decisions ---------------------------------------------------------------------------

    def _set(self, source: TimeSource, anchor: _Anchor | None, reason: str) -> None:
        with self._lock:
            self._source, self._anchor, self._reason = source, anchor, reason
        self._decided_at = self.now()

    def wants_mount_clock(self) -> bool:
        """Is the mount's clock worth reading before deciding? Not when the server will set it anyway."""
        if self._source is TimeSource.CLIENT or self.policy() == "host":
            return False
        return self.policy() == "mount" or not self.watch.status().trusted

    def mount_without_time(self) -> None:
        """The mount has no time (power-up, date 2000): it gets the reference, whatever its source."""
        if self._source is TimeSource.HOST:
            status = self.watch.status()
            self._set(TimeSource.HOST, None, "the mount had no time (just powered up): it was given the server's"
                      + ("" if status.trusted else "; the host clock is not known to be right either"))
        elif self._source is TimeSource.MOUNT:
            with self._lock:
                self._reason += "; given back to the mount after it restarted"

    def at_connect(self, mount_utc: datetime | None, at: float) -> bool:
        """Decide at connect; True: keep the mount's clock (adopted, not written), False: set it.

        ``mount_utc``: the mount's UTC at the mount-monotonic instant ``at`` (None when not read,
        see :meth:`wants_mount_clock`).
        """
        policy = self.policy()
        if self._source is TimeSource.CLIENT:
            return False  # a client or person set the time: the mount gets it
        if policy == "host":
            self._set(TimeSource.HOST, None, "time.source is \"host\": the server sets the mount's clock")
            return False
        status = self.watch.status()
        if mount_utc is None or (policy == "auto" and status.trusted):
            self._set(TimeSource.HOST, None, status.detail if status.synchronised else
                      "the host clock's status is unknown here, so it is trusted: " + status.detail)
            return False
        mount_utc = _utc(mount_utc)
        host_then = self.host_clock() - timedelta(seconds=self.monotonic() - at)
        difference = (mount_utc - host_then).total_seconds()
        if policy == "auto" and abs(difference) <= TOLERANCE_S:
            self._set(TimeSource.HOST, None, f"{status.detail}, but it agrees with the mount's clock within "
                                             f"{TOLERANCE_S:g} s: the server sets the mount's clock")
            return False
        self._adopt(mount_utc, at, difference, status, policy)
        return True

    def _adopt(self, mount_utc: datetime, at: float, difference: float, status: HostClockStatus, policy: str) -> None:
        relation = "ahead of" if difference > 0 else "behind"
        words = f"the mount's clock is {describe_difference(difference)} {relation} the host's"
        if policy == "mount":
            reason = f"time.source is \"mount\": the mount's clock is kept ({words})"
        else:
            reason = f"{status.detail}, and {words}: the mount's time is kept and the mount's clock is not written"
        previous = self.now() if self._source is TimeSource.MOUNT else None
        self._set(TimeSource.MOUNT, _Anchor(mount_utc, at), reason)
        if previous is None or abs((self.now() - previous).total_seconds()) > TOLERANCE_S:
            log.warning("time: %s (%s)", reason, status.kernel or status.method)  # once per adoption

    def set_by_client(self, utc: datetime, who: str) -> None:
        """A client or a person set the time: the strongest source, kept until another sets it."""
        utc = _utc(utc)
        self._set(TimeSource.CLIENT, _Anchor(utc, self.monotonic()),
                  f"set by {who} at {utc:%Y-%m-%d %H:%M:%S} UTC")
        log.info("time set by %s: %s UTC (%+.3f s from the host clock)", who, f"{utc:%Y-%m-%d %H:%M:%S.%f}"[:-3],
                 (utc - self.host_clock()).total_seconds())

    def host_regained(self) -> bool:
        """The host clock became synchronised while the mount's time was kept: the host's becomes the
        reference again. True when that happened now (the caller then sets the mount's clock)."""
        if self._source is not TimeSource.MOUNT or self.policy() != "auto":
            return False
        status = self.watch.status()
        if not status.synchronised:
            return False
        difference = (self.now() - self.host_clock()).total_seconds()
        self._set(TimeSource.HOST, None, f"{status.detail}: the server sets the mount's clock again")
        log.warning("time: the host clock is synchronised now (%s); the mount's clock, %s %s it, is set from it",
                    status.detail, describe_difference(difference), "ahead of" if difference > 0 else "behind")
        return True
