"""The mount's own clock and site: no RTC (01/01/00 at power-on), a negated time zone, east-positive site.

LST, Alt/Az and the GOTO checks are wrong until a client sets date, time and site, exactly as on
the real mount; ``MountModel.initialize`` does what such a client would.
"""

from __future__ import annotations

from datetime import date, datetime, time, timedelta, timezone

from .. import sky
from .state import ModelBase


class ClockAndSite(ModelBase):
    """Date, time, zone, daylight saving, sidereal time and site, as the mount keeps them."""

    def _local_now(self) -> datetime:
        return self._local_ref + timedelta(seconds=self._t - self._local_ref_t)

    def _set_local(self, value: datetime) -> None:
        self._local_ref = value
        self._local_ref_t = self._t

    def _mount_utc(self) -> datetime:
        hours = self._utc_offset + (1.0 if self._dst else 0.0)
        return (self._local_now() - timedelta(hours=hours)).replace(tzinfo=timezone.utc)

    def _lst(self) -> float:
        return sky.wrap_hours_24(sky.local_sidereal_time(self._mount_utc(), self._longitude) + self._lst_offset)

    def _initialized(self) -> bool:
        return self._date_set and self._time_set and self._lat_set and self._lon_set

    def local_datetime(self) -> datetime:
        """The mount's own (naive, local) wall clock."""
        with self._lock:
            self._advance()
            return self._local_now()

    def set_date(self, day: date) -> bool:
        with self._lock:
            self._advance()
            now = self._local_now()
            self._set_local(datetime.combine(day, now.time()))
            self._date_set = True
            return True

    def set_time(self, clock: time) -> bool:
        with self._lock:
            self._advance()
            self._set_local(datetime.combine(self._local_now().date(), clock))
            self._time_set = True
            return True

    def set_utc_offset(self, utc_offset_hours: float) -> bool:
        """The true offset (``:SG-08#`` means +8); the wire sign is the responder's business."""
        if not -14.0 <= utc_offset_hours <= 14.0:
            return False
        with self._lock:
            self._advance()
            self._utc_offset = utc_offset_hours
            return True

    def utc_offset(self) -> float:
        with self._lock:
            return self._utc_offset

    def set_date_time_zone(self, day: date, clock: time, utc_offset_hours: float) -> bool:
        if not -14.0 <= utc_offset_hours <= 14.0:
            return False
        with self._lock:
            self._advance()
            self._set_local(datetime.combine(day, clock))
            self._utc_offset = utc_offset_hours
            self._date_set = self._time_set = True
            return True

    def set_dst(self, on: bool) -> bool:
        """Daylight saving: the wall clock stays, UTC moves by an hour (so LST does too)."""
        with self._lock:
            self._advance()
            self._dst = on
            return True

    def dst(self) -> bool:
        with self._lock:
            return self._dst

    def set_sidereal_time(self, hours: float) -> bool:
        """``:SS#``: make the LST read ``hours`` now, as an offset on the clock-derived LST."""
        with self._lock:
            self._advance()
            self._lst_offset = 0.0
            self._lst_offset = sky.wrap_hours_12(hours - self._lst())
            return True

    def sidereal_time(self) -> float:
        with self._lock:
            self._advance()
            return self._lst()

    def set_latitude(self, degrees: float) -> bool:
        if not -90.0 <= degrees <= 90.0:
            return False
        with self._lock:
            self._advance()
            self._latitude = degrees
            self._lat_set = True
            return True

    def set_longitude(self, east_degrees: float) -> bool:
        if not -180.0 <= east_degrees <= 180.0:
            return False
        with self._lock:
            self._advance()
            self._longitude = east_degrees
            self._lon_set = True
            return True

    def latitude(self) -> float:
        with self._lock:
            return self._latitude

    def longitude(self) -> float:
        """East-positive longitude the mount currently uses."""
        with self._lock:
            return self._longitude
