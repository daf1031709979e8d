"""The mount's own clock and site: no RTC (01/01/00 at power-on), a negated time zone, east-positive site.

LST, Alt/Az and the GOTO checks are wrong until a client sets date, time and site, exactly as on
the real mount; ``MountModel.initialize`` does what such a client would.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from datetime import date, datetime, time, timedelta, timezone

from .. import sky
from .flash import FlashSettings
from .state import EPOCH_LOCAL


class ClockAndSite:
    """Date, time, zone, daylight saving, sidereal time and site, as the mount keeps them.

    All of it is volatile (lost at power-off, set again by ``power_up``); the site comes back from
    flash (``flash.persist``): the factory's, or the last one set where the firmware variant keeps it
    (``site_in_flash``). The wall clock runs on the model's emulated seconds: it is
    ``local_ref`` at ``local_ref_t`` and advances with them, so the helpers that read it take ``t``.

    Lock: ``MountModel._lock``, lent as ``lock`` because the responder calls the public methods
    directly; they take it and call ``advance`` (which brings the physics up to the clock's present
    and returns its emulated seconds). The helpers (``power_up``, ``initialize``, ``local_now``,
    ``set_local``, ``mount_utc``, ``lst``, ``initialized``) and the attributes are for callers that
    hold it.
    """

    local_ref: datetime  # the mount's wall clock (naive, local) at emulated second local_ref_t
    local_ref_t: float
    utc_offset_h: float  # true UTC offset in hours (the mount shows it negated)
    dst_on: bool
    lst_offset_h: float  # hours, from :SS#
    date_set: bool
    time_set: bool
    lat_set: bool
    lon_set: bool
    latitude_deg: float
    longitude_deg: float  # east positive; the mount shows it east-negative

    def __init__(
        self,
        *,
        flash: FlashSettings,
        lock: threading.RLock,
        advance: Callable[[], float],
        t: float,
    ) -> None:
        """``t``: the emulated seconds at which the mount powers up."""
        self._flash = flash
        self._lock = lock
        self._advance = advance
        self.power_up(t)

    # ---------------------------------------------------------------- helpers (callers hold the lock)

    def power_up(self, t: float) -> None:
        """No RTC: 01/01/00 00:00:00 at power-on, zone +00:00; the site stored in flash."""
        self.local_ref = EPOCH_LOCAL
        self.local_ref_t = t
        self.utc_offset_h = 0.0
        self.dst_on = False
        self.lst_offset_h = 0.0
        self.date_set = self.time_set = False
        self.lat_set = self.lon_set = False
        self.latitude_deg = self._flash.persist.latitude
        self.longitude_deg = self._flash.persist.longitude

    def initialize(self, utc: datetime, t: float) -> None:
        """Date and time set to ``utc`` (naive), zone +00:00, the stored site marked as set."""
        self.set_local(utc, t)
        self.utc_offset_h = 0.0
        self.date_set = self.time_set = self.lat_set = self.lon_set = True

    def local_now(self, t: float) -> datetime:
        return self.local_ref + timedelta(seconds=t - self.local_ref_t)

    def set_local(self, value: datetime, t: float) -> None:
        self.local_ref = value
        self.local_ref_t = t

    def mount_utc(self, t: float) -> datetime:
        hours = self.utc_offset_h + (1.0 if self.dst_on else 0.0)
        return (self.local_now(t) - timedelta(hours=hours)).replace(tzinfo=timezone.utc)

    def lst(self, t: float) -> float:
        """The mount's local sidereal time: from its own clock and longitude, plus the ``:SS#`` offset."""
        return sky.wrap_hours_24(sky.local_sidereal_time(self.mount_utc(t), self.longitude_deg) + self.lst_offset_h)

    def initialized(self) -> bool:
        """Date, time and site set since power-up."""
        return self.date_set and self.time_set and self.lat_set and self.lon_set

    # ---------------------------------------------------------------- the mount's commands

    def local_datetime(self) -> datetime:
        """The mount's own (naive, local) wall clock."""
        with self._lock:
            return self.local_now(self._advance())

    def set_date(self, day: date) -> bool:
        with self._lock:
            t = self._advance()
            now = self.local_now(t)
            self.set_local(datetime.combine(day, now.time()), t)
            self.date_set = True
            return True

    def set_time(self, clock: time) -> bool:
        with self._lock:
            t = self._advance()
            self.set_local(datetime.combine(self.local_now(t).date(), clock), t)
            self.time_set = True
            return True

    def set_utc_offset(self, utc_offset_hours: float) -> bool:
        """The true offset (``:SG-08#`` means +8); the wire sign is the responder's business."""
        if not -14.0 <= utc_offset_hours <= 14.0:
            return False
        with self._lock:
            self._advance()
            self.utc_offset_h = utc_offset_hours
            return True

    def utc_offset(self) -> float:
        with self._lock:
            return self.utc_offset_h

    def set_date_time_zone(self, day: date, clock: time, utc_offset_hours: float) -> bool:
        if not -14.0 <= utc_offset_hours <= 14.0:
            return False
        with self._lock:
            t = self._advance()
            self.set_local(datetime.combine(day, clock), t)
            self.utc_offset_h = utc_offset_hours
            self.date_set = self.time_set = True
            return True

    def set_dst(self, on: bool) -> bool:
        """Daylight saving: the wall clock stays, UTC moves by an hour (so LST does too)."""
        with self._lock:
            self._advance()
            self.dst_on = on
            return True

    def dst(self) -> bool:
        with self._lock:
            return self.dst_on

    def set_sidereal_time(self, hours: float) -> bool:
        """``:SS#``: make the LST read ``hours`` now, as an offset on the clock-derived LST."""
        with self._lock:
            t = self._advance()
            self.lst_offset_h = 0.0
            self.lst_offset_h = sky.wrap_hours_12(hours - self.lst(t))
            return True

    def sidereal_time(self) -> float:
        with self._lock:
            return self.lst(self._advance())

    def set_latitude(self, degrees: float) -> bool:
        if not -90.0 <= degrees <= 90.0:
            return False
        with self._lock:
            self._advance()
            self.latitude_deg = degrees  # across the equator the axes stay: what they point at changes
            self.lat_set = True
            if self._flash.keeps_site:
                self._flash.persist.latitude = degrees
            return True

    def set_longitude(self, east_degrees: float) -> bool:
        if not -180.0 <= east_degrees <= 180.0:
            return False
        with self._lock:
            self._advance()
            self.longitude_deg = east_degrees
            self.lon_set = True
            if self._flash.keeps_site:
                self._flash.persist.longitude = east_degrees
            return True

    def latitude(self) -> float:
        with self._lock:
            return self.latitude_deg

    def longitude(self) -> float:
        """East-positive longitude the mount currently uses."""
        with self._lock:
            return self.longitude_deg
