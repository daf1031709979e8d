"""The Telescope's clock: UTCDate and the local sidereal time at the configured site.

"Now" is the mount's time reference (``mount/timekeeping.py``'s TimeKeeper: the host's clock, the mount's
or a client's); this part reads it for every member that needs the time, and takes a client's UTCDate as
the strongest source. No lock: the TimeKeeper guards its own state.
"""

from __future__ import annotations

from collections.abc import Callable
from datetime import datetime, timezone

from .. import sky
from .._exceptions import InvalidValue, mount_errors
from ..clients import current_client
from ..config.settings import Settings
from ..mount.operations import Mount

#: The mount's clock keeps a two-digit year; a day of margin either side for the UTC offset.
MOUNT_EPOCH_FIRST = datetime(2000, 1, 2, tzinfo=timezone.utc)
MOUNT_EPOCH_LAST = datetime(2099, 12, 30, tzinfo=timezone.utc)


def _utc(t: datetime) -> datetime:
    return t.astimezone(timezone.utc) if t.tzinfo else t.replace(tzinfo=timezone.utc)


class SiteClock:
    """UTCDate, SiderealTime and the time every other part of the Telescope reads (``utc_now``, ``lst``).

    ``settings`` gives the site's longitude; ``require_connected`` is the owner's connection check
    (raises NotConnected), called by the members that report the mount's time.
    """

    def __init__(self, *, mount: Mount, settings: Callable[[], Settings],
                 require_connected: Callable[[], None]) -> None:
        self.mount = mount
        self._settings = settings
        self._require_connected = require_connected

    def utc_now(self) -> datetime:
        """The server's time reference for this mount (mount/timekeeping.py): what every reading uses."""
        return self.mount.time.now()

    def lst(self, now: datetime | None = None) -> float:
        """Local sidereal time, hours, at the configured longitude, ``now`` or at the reference's now."""
        return sky.local_sidereal_time(now or self.utc_now(), self._settings().site.longitude)

    # -- members -------------------------------------------------------------------------------

    def sidereal_time(self) -> float:
        self._require_connected()
        return self.lst()

    def utc_date(self) -> datetime:
        self._require_connected()
        return self.utc_now()

    def set_utc_date(self, value: datetime) -> None:
        self._require_connected()
        caller = current_client.get()
        who = f"client {caller.address} #{caller.client_id} (UTCDate)" if caller else "a client (UTCDate)"
        self.set_time(value, who)

    def set_time(self, value: datetime, who: str) -> bool:
        """The strongest time source (a client's UTCDate, a program on the ZWO port, a person on the page):
        the server's reference from now on, and the mount's clock when the link is up (True: it was set)."""
        value = _utc(value)
        if not MOUNT_EPOCH_FIRST <= value <= MOUNT_EPOCH_LAST:
            raise InvalidValue(
                f"UTCDate {value.isoformat()} is outside 2000-2099, the years the mount's clock can hold")
        self.mount.time.set_by_client(value, who)
        if not (self.mount.running and self.mount.link.status.connected):
            return False  # the mount gets it when it is connected (a client's time is pushed at connect)
        with mount_errors("setting the mount clock"):
            self.mount.push_time()
        return True
