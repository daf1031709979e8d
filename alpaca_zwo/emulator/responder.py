"""Request text -> reply text, with the exact framing of a real ZWO AM mount.

The mount's side of the protocol is ``zwo/dispatch.py``'s one table (what each command asks) over
``zwo/protocol.py``'s rows (each command's argument parser and reply formatter), the same table the
shared ZWO port answers with; here is the emulated mount behind it: :class:`ModelBackend` turns
what a command asks into :class:`MountModel` calls and applies the firmware variant's quirks
(``:hP#``, ``:Gps#``, ``:Gh#``, ``:GT#`` digits, ``:GMZA#`` azimuth, ``:STR#``, ``:SMeq#``/``:SMMC#``,
the meridian commands of older builds).
"""

from __future__ import annotations

import logging
from datetime import date, datetime, time

from ..zwo import dispatch, wire_values
from ..zwo.dispatch import Verbatim
from ..zwo.firmware import ACKS_HELD_WHILE_SLEWING, PARKED_REFUSED, has_feature
from ..zwo.protocol import BY_CODE, CommandMatch, TrackingState, match_command
from ..zwo.wire_values import Direction, MeridianSettings, MountMode, MountStatus, TrackRate
from .model import MountModel

__all__ = ["ModelBackend", "ModelResponder"]

_log = logging.getLogger(__name__)

#: What firmware answers a command it does not know: nothing (field notes §2.9).
_UNKNOWN = Verbatim(None)
#: What a parked 1.8.8 mount answers a motion command (docs/firmware-evidence.md).
_PARKED = Verbatim("e14#")


def _parked_refuses(body: str) -> bool:
    """Whether ``body`` is one of the commands a parked 1.8.8 mount refuses (``Mg…``: every pulse)."""
    return body in PARKED_REFUSED or body.startswith("Mg")


#: 1.8.8 queries with no reply on the USB link: forwarded to the second controller (S2 doc L617).
_FORWARDED = ("GSN", "GVE", "GPT")
#: 1.8.8 aliases (S2 doc L633: "three consecutive paired reads were identical").
_ALIASES = {"GRr": "GR", "GDr": "GD"}
#: The table's argument-less queries that no longer code extends: 1.8.8 answers them whatever text
#: follows (``:GCAL#`` is ``:GC#``, S2 doc L619), while a query other codes extend (``:GA``, ``:GV``)
#: dispatches on the next letter and answers an unknown one with a lone ``#`` (``:GADC#``, ``:GVN#``).
_LEAF_QUERIES = tuple(sorted(
    (code for code, command in BY_CODE.items()
     if code.startswith("G") and command.args is None
     and not any(other != code and other.startswith(code) for other in BY_CODE)),
    key=len, reverse=True,
))
#: The pole's azimuth as the documents' formatter writes it, and as 1.8.8 wrote it at home (S1).
_NORTH, _NORTH_360 = "000*00:00", "360*00:00"


def _leaf_of(body: str) -> str | None:
    return next((code for code in _LEAF_QUERIES if body.startswith(code)), None)


class ModelBackend:
    """A :class:`MountModel` as a ``zwo.protocol.Backend``: the emulated mount, its firmware's quirks included.

    Thread-safe because the model is.
    """

    def __init__(self, model: MountModel) -> None:
        self.model = model

    def intercept(self, match: CommandMatch) -> Verbatim | None:
        """Commands this firmware build does not have: :STa/:GTa before 1.2.4 (field notes §5.6,
        INDIGO), :STR# on real firmware. They get no reply, as any unknown command."""
        code, firmware = match.command.code, self.model.firmware
        if code in ("STa", "GTa") and not has_feature(firmware.version, "meridian_settings"):
            return _UNKNOWN
        if code == "STR" and not firmware.custom_tracking:
            return _UNKNOWN
        return None

    def firmware_reply(self, body: str) -> Verbatim | None:
        """What this build answers before the command table is consulted, known command or not:
        a parked 1.8.8 mount refuses the whole motion class with ``e14#``, even the commands that
        are otherwise silent or unknown to the table (:hU#, :I#, :PO#…; docs/firmware-evidence.md)."""
        firmware = self.model.firmware
        if firmware.park_refusal == "e14" and _parked_refuses(body) and self.model.parked():
            return _PARKED
        if firmware.home_reading == "through_pole" and body in ("GZ", "GMZA"):
            return self._azimuth_360(body)
        if firmware.unknown_query == "1.8.8" and body.startswith("G") and match_command(body) is None:
            return self._unknown_query(body)
        return None

    def _azimuth_360(self, body: str) -> Verbatim:
        """1.8.8 writes the pole's azimuth ``360*00:00`` (read at home, S1), the documents ``000``."""
        reply = dispatch.answer(self, body)
        if reply is not None and reply.startswith(_NORTH):
            reply = _NORTH_360 + reply[len(_NORTH):]
        return Verbatim(reply)

    def _unknown_query(self, body: str) -> Verbatim:
        """A ``:G…#`` the table does not know, answered as 1.8.8 did (``unknown_query``)."""
        if body.startswith("GX") or body in _FORWARDED:
            return _UNKNOWN
        if body == "GAST":  # three #-terminated records in one reply (S2 doc L632)
            return Verbatim("".join(dispatch.answer(self, code) or "" for code in ("GMTI", "GMEQ", "GU")))
        if body == "GVD":
            return Verbatim(self.model.firmware.build_date + "#")
        known = _ALIASES.get(body) or _leaf_of(body)
        return Verbatim(dispatch.answer(self, known) if known is not None else "#")

    # ---------------------------------------------------------------- date, time, site

    def clock(self) -> datetime:
        return self.model.clock_site.local_datetime()

    def utc_offset(self) -> float:
        return self.model.clock_site.utc_offset()

    def set_clock(self, day: date | None, clock: time | None, utc_offset: float | None) -> bool:
        site = self.model.clock_site
        if day is not None and clock is not None and utc_offset is not None:
            return site.set_date_time_zone(day, clock, utc_offset)
        if day is not None:
            return site.set_date(day)
        if clock is not None:
            return site.set_time(clock)
        return utc_offset is not None and site.set_utc_offset(utc_offset)

    def sidereal_time(self) -> float:
        return self.model.clock_site.sidereal_time()

    def set_sidereal_time(self, hours: float) -> bool:
        return self.model.clock_site.set_sidereal_time(hours)

    def daylight_saving(self) -> bool:
        return self.model.clock_site.dst()

    def set_daylight_saving(self, on: bool) -> bool:
        return self.model.clock_site.set_dst(on)

    def site(self) -> tuple[float, float]:
        site = self.model.clock_site
        return site.latitude(), site.longitude()

    def set_site(self, latitude: float | None, longitude: float | None) -> bool:
        site = self.model.clock_site
        if latitude is not None and longitude is not None:  # :SMGE# takes both or neither
            if not (-90.0 <= latitude <= 90.0 and -180.0 <= longitude <= 180.0):
                return False
            return site.set_latitude(latitude) and site.set_longitude(longitude)
        if latitude is not None:
            return site.set_latitude(latitude)
        return longitude is not None and site.set_longitude(longitude)

    # ---------------------------------------------------------------- position and target

    def pier_letter(self) -> str:
        return self.model.pier_letter()

    def target(self) -> tuple[float, float]:
        return self.model.target()

    def set_target(self, ra: float | None, dec: float | None) -> bool:
        ra_taken = ra is None or self.model.set_target_ra(ra)
        dec_taken = dec is None or self.model.set_target_dec(dec)
        return ra_taken and dec_taken

    def position(self) -> tuple[float, float]:
        return self.model.position()

    def horizontal(self, paired: bool) -> tuple[float, float]:
        altitude, azimuth = self.model.horizontal()
        if paired and self.model.firmware.gmza_south_azimuth:
            azimuth += 180.0  # AM5N on 1.6.3 counts :GMZA#'s azimuth from south
        return altitude, azimuth

    # ---------------------------------------------------------------- motion

    def goto(self) -> int:
        return self.model.goto()

    def compound_goto_sync(self) -> bool:
        return self.model.firmware.compound_goto_sync

    def stop(self) -> None:
        self.model.stop()

    def move(self, direction: Direction) -> None:
        self.model.move(direction.value)

    def stop_axis(self, direction: Direction) -> None:
        self.model.stop_axis(direction.value)

    def select_speed(self, index: int) -> None:
        self.model.select_speed(index)

    def set_variable_speed(self, multiple: float, axis: int | None) -> None:
        self.model.set_variable_speed(multiple, axis)

    # ---------------------------------------------------------------- tracking, guiding

    def set_tracking_rate(self, rate: TrackRate) -> None:
        self.model.set_tracking_rate(rate.value)

    def tracking_rate_digit(self) -> str:
        """The model's rate name ("custom" for an :STR rate) as this firmware's :GT# digit."""
        name = self.model.tracking_rate()
        rate = None if name == "custom" else TrackRate(name)
        return wire_values.format_tracking_rate(rate, self.model.firmware.gt_mapping)

    def set_custom_rate(self, multiple: float) -> bool:
        return self.model.set_custom_rate(multiple)

    def set_tracking(self, on: bool) -> bool:
        return self.model.tracking_on() if on else self.model.tracking_off()

    def tracking_state(self) -> TrackingState:
        return TrackingState(*self.model.tracking_state())

    def pulse(self, direction: Direction, milliseconds: int) -> None:
        self.model.pulse(direction.value, milliseconds)

    def set_guide_rate(self, fraction: float) -> None:
        if 0.1 - 1e-9 <= fraction <= 0.9 + 1e-9:  # the mount ignores a rate outside 0.1-0.9
            self.model.set_guide_rate(fraction)

    def guide_rate(self) -> float:
        return self.model.guide_rate()

    # ---------------------------------------------------------------- sync, home, park

    def sync(self) -> int:
        return self.model.sync()

    def clear_alignment(self) -> bool:
        self.model.clear_alignment()
        return True

    def home(self) -> None:
        self.model.home()

    def home_flag(self) -> str:
        variant = self.model.firmware.gh_reply
        if variant == "empty":
            return ""
        if variant == "zero":
            return "0"
        return "1" if self.model.homed() else "0"

    def set_current_as_home(self) -> bool:
        return self.model.set_current_as_home()

    def park(self) -> bool | None:
        accepted = self.model.park()
        return None if self.model.firmware.hp_reply is None else accepted

    def set_park_position(self) -> str:
        return self.model.set_park_position()

    def unpark(self) -> bool:
        return self.model.unpark()

    def park_status(self) -> int | None:
        status = self.model.park_status()
        return None if self.model.firmware.gps_reply == "empty" else status

    # ---------------------------------------------------------------- meridian, limits, flash

    def meridian(self) -> MeridianSettings:
        return self.model.flash.meridian()

    def set_meridian(self, settings: MeridianSettings) -> bool:
        return self.model.flash.set_meridian(settings)

    def limits_enabled(self) -> bool:
        return self.model.flash.limits_enabled()

    def set_limits_enabled(self, on: bool) -> bool:
        self.model.flash.set_limits_enabled(on)
        return True

    def upper_limit(self) -> int:
        return self.model.flash.altitude_limits()[1]

    def set_upper_limit(self, degrees: int) -> bool:
        return self.model.flash.set_upper_limit(degrees)

    def lower_limit(self) -> int:
        return self.model.flash.altitude_limits()[0]

    def set_lower_limit(self, degrees: int) -> bool:
        return self.model.flash.set_lower_limit(degrees)

    def max_speed(self) -> int:
        return self.model.flash.max_speed()

    def set_max_speed(self, multiple: int) -> bool:
        return self.model.flash.set_max_speed(multiple)

    def set_mode(self, mode: MountMode) -> None:
        self.model.flash.request_mode(mode)

    def buzzer(self) -> int:
        return self.model.flash.buzzer()

    def set_buzzer(self, level: int) -> None:
        self.model.flash.set_buzzer(level)

    def status(self) -> MountStatus:
        return self.model.status()

    def firmware_version(self) -> str:
        return self.model.firmware.version

    def model_name(self) -> str:
        return self.model.firmware.model

    def compile_time(self) -> str:
        return self.model.firmware.compile_time

    def ble_name(self) -> str:
        return self.model.flash.ble_name()

    def set_ble_suffix(self, suffix: str) -> bool:
        return self.model.flash.set_ble_suffix(suffix)

    def ble_pair(self, pairing_id: str) -> bool:
        return self.model.flash.ble_pair(pairing_id)


class ModelResponder:
    """Answers request bodies (the text between ``:`` and ``#``) from a :class:`MountModel`.

    Thread-safe because the model is; several connections may share one responder.
    """

    def __init__(self, model: MountModel) -> None:
        self.model = model
        self.backend = ModelBackend(model)

    def held_ack(self, body: str) -> str | None:
        """Asked as a request arrives, before :meth:`handle`: "late" or "never" when this build holds back
        the acknowledgement of ``body`` because a slew runs (``FirmwareVariant.ack_while_slewing``), else
        None. The line, which owns the timing of replies, carries it out."""
        mode = self.model.firmware.ack_while_slewing
        if mode == "prompt" or body not in ACKS_HELD_WHILE_SLEWING or not self.model.slewing():
            return None
        return mode

    def handle(self, body: str) -> str | None:
        """The reply text for ``body``, or None when the mount sends nothing back."""
        try:
            own = self.backend.firmware_reply(body)
            if own is not None:
                return own.reply
            return dispatch.answer(self.backend, body)
        except Exception:  # a bug here must not take the line down; the mount just says nothing
            _log.exception("responder failed on :%s#", body)
            return None
