"""Date, time, zone and site on the shared ZWO port: the mount's setters, applied to the server.

A program's ``:SC``/``:SL`` (local date and time) become the Telescope's UTCDate, and ``:St``/``:Sg``
its site, with the same validation as Alpaca, so every client shares one clock and one site. The
zone (``:SG``) only changes how this port reads and shows local times: the mount keeps the zone
the server pushed. A setter within the wire's resolution of what the server already has changes
nothing, so a program pushing the same clock (whole seconds) never truncates the server's.
"""

from __future__ import annotations

import threading
from datetime import datetime, timedelta, timezone
from typing import TYPE_CHECKING

from .._exceptions import AlpacaError, InvalidValue, ProtocolError
from ..zwo import wire_values
from ..zwo.wire_values import format_date, format_time, format_utc_offset

if TYPE_CHECKING:
    from ..telescope.device import Telescope
    from .zwo_session import Session

__all__ = ["ClockAndSite"]

TIME_TOLERANCE_S = 1.5
SITE_TOLERANCE_DEG = 1.5 / 3600.0


def _host_utc_offset_hours() -> float:
    """The zone the Mount pushes at connect (the host's), so ``:GG#`` starts out as the mount's."""
    offset = datetime.now().astimezone().utcoffset()
    return offset.total_seconds() / 3600.0 if offset is not None else 0.0


class ClockAndSite:
    """The port's date/time/zone/site handlers (``handler(session, argument, well_formed)``)."""

    def __init__(self, telescope: Telescope) -> None:
        self.telescope = telescope
        self._lock = threading.Lock()
        self.utc_offset_hours = _host_utc_offset_hours()  # the mount's zone as programs see it

    def local(self) -> datetime:
        return self.telescope.clock.utc_now() + timedelta(hours=self.utc_offset_hours)

    def set_local(self, local: datetime) -> str:
        """Set the server's UTC (the Telescope's UTCDate, pushed to the mount) from a local time."""
        utc = (local - timedelta(hours=self.utc_offset_hours)).replace(tzinfo=timezone.utc)
        if abs((utc - self.telescope.clock.utc_now()).total_seconds()) < TIME_TOLERANCE_S:
            return "1"
        try:
            self.telescope.clock.set_utc_date(utc)
        except InvalidValue:
            return "0"
        return "1"

    def set_date(self, _session: Session, argument: str, well_formed: bool) -> str:
        try:
            day = wire_values.parse_date(argument)
        except ProtocolError:
            return "0"
        return self.set_local(datetime.combine(day, self.local().time())) if well_formed else "0"

    def set_time(self, _session: Session, argument: str, well_formed: bool) -> str:
        try:
            clock = wire_values.parse_time(argument)
        except ProtocolError:
            return "0"
        return self.set_local(datetime.combine(self.local().date(), clock)) if well_formed else "0"

    def set_zone(self, _session: Session, argument: str, well_formed: bool) -> str:
        """The zone only changes how local times are read and shown; the mount keeps the server's."""
        try:
            offset = wire_values.parse_utc_offset(argument)
        except ProtocolError:
            return "0"
        with self._lock:
            self.utc_offset_hours = offset
        return "1" if well_formed else "0"

    def set_date_time_zone(self, session: Session, argument: str, well_formed: bool) -> str:
        try:
            day_text, time_text, zone_text = argument.split("&")
            day, clock = wire_values.parse_date(day_text), wire_values.parse_time(time_text)
            offset = wire_values.parse_utc_offset(zone_text)
        except (ProtocolError, ValueError):
            return "0"
        if not well_formed:
            return "0"
        with self._lock:
            self.utc_offset_hours = offset
        return self.set_local(datetime.combine(day, clock))

    def get_date_time_zone(self, _session: Session, _argument: str, _well_formed: bool) -> str:
        local = self.local()
        return f"{format_date(local.date())}&{format_time(local.time())}&{format_utc_offset(self.utc_offset_hours)}#"

    def update_site(self, latitude: float | None, longitude: float | None) -> str:
        t = self.telescope
        try:
            if latitude is not None and abs(latitude - t.capabilities.site_latitude()) >= SITE_TOLERANCE_DEG:
                t.capabilities.set_site_latitude(latitude)
            if longitude is not None and abs(longitude - t.capabilities.site_longitude()) >= SITE_TOLERANCE_DEG:
                t.capabilities.set_site_longitude(longitude)
        except AlpacaError:  # out of range, or not saved (full disk: SettingsNotSaved): refused, as the mount would
            return "0"
        return "1"

    def set_latitude(self, _session: Session, argument: str, well_formed: bool) -> str:
        try:
            return self.update_site(wire_values.parse_dms(argument), None) if well_formed else "0"
        except ProtocolError:
            return "0"

    def set_longitude(self, _session: Session, argument: str, well_formed: bool) -> str:
        try:
            return self.update_site(None, wire_values.parse_longitude(argument)) if well_formed else "0"
        except ProtocolError:
            return "0"

    def set_site(self, _session: Session, argument: str, well_formed: bool) -> str:
        try:
            lat_text, lon_text = argument.split("&")
            latitude, longitude = wire_values.parse_dms(lat_text), wire_values.parse_longitude(lon_text)
        except (ProtocolError, ValueError):
            return "0"
        return self.update_site(latitude, longitude) if well_formed else "0"
