"""Request text -> reply text, with the exact framing of a real ZWO AM mount.

The model deals in numbers and codes; the reply forms come from ``zwo/protocol.py`` (its command
table's reply kinds and its formatters), the same ones the driver reads replies with. Framing rules
(field notes §2-§4): setters answer one bare ``1``/``0`` with no ``#`` (a handler answers True or
False and ``protocol.flag_reply`` frames it by the command's kind); a successful GOTO a bare
``0``; errors ``eN#``; queries and ``N/A#`` end in ``#``; motion commands and unknown commands
get no reply at all. Firmware-variant switches that change
framing (``:hP#``, ``:Gps#``, ``:Gh#``, ``:STR#``, ``:SMeq#``/``:SMMC#``) are applied here.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from .._exceptions import ProtocolError
from ..zwo import protocol, wire_values
from ..zwo.firmware import has_feature
from ..zwo.protocol import error_reply
from ..zwo.wire_values import (
    MountMode,
    format_azimuth,
    format_date,
    format_dms,
    format_hms,
    format_latitude,
    format_longitude,
    format_meridian,
    format_status,
    format_time,
    format_utc_offset,
    parse_date,
    parse_dms,
    parse_hms,
    parse_longitude,
    parse_meridian,
    parse_time,
    parse_utc_offset,
)
from .model import MountModel
from .state import DEC, RA

__all__ = ["Responder"]

_log = logging.getLogger(__name__)

#: A handler's answer: reply text, None for silence, or a yes/no that ``protocol.flag_reply`` frames
#: as the command's reply kind says (a setter's bare ``1``/``0``, a query's ``1#``/``0#``).
Handler = Callable[[str, bool], "str | bool | None"]


def _gt_digit(rate_name: str, mapping: str) -> str:
    """The model's rate name ("custom" for an :STR rate) as this firmware's :GT# digit."""
    rate = None if rate_name == "custom" else wire_values.TrackRate(rate_name)
    return wire_values.format_tracking_rate(rate, mapping)


def _two_digits(argument: str) -> int | None:
    """The unsigned two-digit argument of ``:SLH``/``:SLL`` (a sign makes the mount refuse)."""
    if len(argument) == 2 and argument.isdigit():
        return int(argument)
    return None


class Responder:
    """Answers request bodies (the text between ``:`` and ``#``) from a :class:`MountModel`.

    Thread-safe because the model is; several connections may share one responder.
    """

    def __init__(self, model: MountModel) -> None:
        self.model = model
        self._handlers: dict[str, Handler] = self._build_table()
        missing = {c.code for c in protocol.COMMANDS} - set(self._handlers)
        if missing:  # the shared command table grew: fail loudly rather than go silent
            raise RuntimeError(f"responder has no handler for {sorted(missing)}")

    def handle(self, body: str) -> str | None:
        """The reply text for ``body``, or None when the mount sends nothing back."""
        match = protocol.match_command(body)
        if match is None:
            return None  # unknown or miscased: a real mount stays silent
        try:
            reply = self._handlers[match.command.code](match.argument, match.well_formed)
            return protocol.flag_reply(match.command, reply) if isinstance(reply, bool) else reply
        except Exception:  # a bug here must not take the line down; the mount just says nothing
            _log.exception("responder failed on :%s#", body)
            return None

    # ------------------------------------------------------------------------------------------

    def _build_table(self) -> dict[str, Handler]:
        m = self.model
        flash, site = m.flash, m.clock_site
        silent = self._silent

        table: dict[str, Handler] = {
            # Date, time, site
            "SC": self._set_date,
            "GC": lambda a, w: format_date(site.local_datetime().date()) + "#",
            "SL": self._set_time,
            "GL": lambda a, w: format_time(site.local_datetime().time()) + "#",
            "SS": self._set_sidereal,
            "GS": lambda a, w: format_hms(site.sidereal_time()) + "#",
            "GH": lambda a, w: site.dst(),
            "SH": lambda a, w: w and site.set_dst(a == "1"),
            "SG": self._set_zone,
            "GG": lambda a, w: format_utc_offset(site.utc_offset()) + "#",
            "St": self._set_latitude,
            "Gt": lambda a, w: format_latitude(site.latitude()) + "#",
            "Sg": self._set_longitude,
            "Gg": lambda a, w: format_longitude(site.longitude()) + "#",
            "SMTI": self._set_date_time_zone,
            "GMTI": self._get_date_time_zone,
            "SMGE": self._set_site,
            "GMGE": lambda a, w: f"{format_latitude(site.latitude())}&{format_longitude(site.longitude())}#",
            # Position and target
            "Gm": lambda a, w: m.pier_letter() + "#",
            "Sr": self._set_target_ra,
            "Gr": lambda a, w: format_hms(m.target()[0]) + "#",
            "Sd": self._set_target_dec,
            "Gd": lambda a, w: format_dms(m.target()[1]) + "#",
            "GR": lambda a, w: format_hms(m.position()[0]) + "#",
            "GD": lambda a, w: format_dms(m.position()[1]) + "#",
            "GZ": lambda a, w: format_azimuth(m.horizontal()[1]) + "#",
            "GA": lambda a, w: format_dms(m.horizontal()[0]) + "#",
            "GMeq": lambda a, w: f"{format_hms(m.target()[0])}&{format_dms(m.target()[1])}#",
            "GMEQ": self._get_position,
            "GMZA": self._get_horizontal,
            # Motion
            "MS": lambda a, w: protocol.goto_reply(m.goto()),
            "SMeq": self._set_and_goto,
            "Q": silent(m.stop),
            "Me": silent(lambda: m.move("e")),
            "Mw": silent(lambda: m.move("w")),
            "Mn": silent(lambda: m.move("n")),
            "Ms": silent(lambda: m.move("s")),
            "Qe": silent(lambda: m.stop_axis("e")),
            "Qw": silent(lambda: m.stop_axis("w")),
            "Qn": silent(lambda: m.stop_axis("n")),
            "Qs": silent(lambda: m.stop_axis("s")),
            "R": self._select_speed,
            "RG": silent(lambda: m.select_speed(1)),
            "RC": silent(lambda: m.select_speed(2)),
            "RM": silent(lambda: m.select_speed(8)),
            "RS": silent(lambda: m.select_speed(9)),
            "Rv": lambda a, w: self._variable_speed(a, w, None),
            "Rvr": lambda a, w: self._variable_speed(a, w, RA),
            "Rvd": lambda a, w: self._variable_speed(a, w, DEC),
            # Tracking
            "TQ": silent(lambda: m.set_tracking_rate("sidereal")),
            "TS": silent(lambda: m.set_tracking_rate("solar")),
            "TL": silent(lambda: m.set_tracking_rate("lunar")),
            "GT": lambda a, w: _gt_digit(m.tracking_rate(), m.firmware.gt_mapping) + "#",
            "STR": self._custom_rate,
            "Te": lambda a, w: m.tracking_on(),
            "Td": lambda a, w: m.tracking_off(),
            "GAT": self._tracking_state,
            # Guiding
            "Mg": self._pulse,
            "Rg": self._guide_rate,
            "Ggr": lambda a, w: f"{m.guide_rate():.2f}#",
            # Sync and alignment
            "CM": lambda a, w: protocol.sync_reply(m.sync()),
            "SMMC": self._set_and_sync,
            "NSC": self._always_one(m.clear_alignment),
            # Home, park
            "hC": silent(m.home),
            "Gh": self._homed,
            "SOa": lambda a, w: m.set_current_as_home(),
            "hP": self._park,
            "Sp01": lambda a, w: m.set_park_position(),
            "Spu": lambda a, w: m.unpark(),
            "Gps": self._park_status,
            # Meridian and limits
            "STa": self._meridian_firmware(self._set_meridian),
            "GTa": self._meridian_firmware(lambda a, w: format_meridian(flash.meridian()) + "#"),
            "SLE": self._always_one(lambda: flash.set_limits_enabled(True)),
            "SLD": self._always_one(lambda: flash.set_limits_enabled(False)),
            "GLC": lambda a, w: flash.limits_enabled(),
            "SLH": self._set_upper_limit,
            "GLH": lambda a, w: f"{flash.altitude_limits()[1]}#",
            "SLL": self._set_lower_limit,
            "GLL": lambda a, w: f"{flash.altitude_limits()[0]}#",
            "SRl": lambda a, w: w and flash.set_max_speed(int(a)),
            "GRl": lambda a, w: f"{flash.max_speed()}#",
            # Mode, buzzer, identity
            "AP": silent(lambda: flash.request_mode(MountMode.EQUATORIAL)),
            "AA": silent(lambda: flash.request_mode(MountMode.ALTAZ)),
            "SBu": self._buzzer,
            "GBu": lambda a, w: f"{flash.buzzer()}#",
            "GU": lambda a, w: format_status(m.status()) + "#",
            "GV": lambda a, w: m.firmware.version + "#",
            "GVP": lambda a, w: m.firmware.model + "#",
            "GVT": lambda a, w: m.firmware.compile_time + "#",
            "GBl": lambda a, w: flash.ble_name() + "#",
            "SBl": lambda a, w: w and flash.set_ble_suffix(a),
            "BS": lambda a, w: "OK#" if w and flash.ble_pair(a) else "NO#",
        }
        return table

    @staticmethod
    def _always_one(action: Callable[[], object]) -> Handler:
        """A setter that cannot fail: act, answer a bare ``1``."""

        def handler(_argument: str, _well_formed: bool) -> bool:
            action()
            return True

        return handler

    @staticmethod
    def _silent(action: Callable[[], object]) -> Handler:
        """A no-reply command: act (only when well formed), answer nothing."""

        def handler(_argument: str, well_formed: bool) -> None:
            if well_formed:
                action()
            return None

        return handler

    def _meridian_firmware(self, handler: Handler) -> Handler:
        """:STa/:GTa exist only from firmware 1.2.4 (field notes §5.6, INDIGO); older builds answer
        nothing, as for any command they do not know (field notes §2.9)."""

        def gated(argument: str, well_formed: bool) -> str | bool | None:
            if not has_feature(self.model.firmware.version, "meridian_settings"):
                return None
            return handler(argument, well_formed)

        return gated

    def _buzzer(self, argument: str, well_formed: bool) -> None:
        if well_formed:
            self.model.flash.set_buzzer(int(argument))
        return None  # :SBu# answers nothing (INDI and INDIGO read no reply)

    # ---------------------------------------------------------------- date, time, site

    def _set_date(self, argument: str, well_formed: bool) -> bool:
        try:
            return well_formed and self.model.clock_site.set_date(parse_date(argument))
        except ProtocolError:
            return False

    def _set_time(self, argument: str, well_formed: bool) -> bool:
        try:
            return well_formed and self.model.clock_site.set_time(parse_time(argument))
        except ProtocolError:
            return False

    def _set_sidereal(self, argument: str, well_formed: bool) -> str | bool:
        try:
            if well_formed and self.model.clock_site.set_sidereal_time(parse_hms(argument)):
                return True
        except ProtocolError:
            pass
        return error_reply(2)

    def _set_zone(self, argument: str, well_formed: bool) -> bool:
        try:
            return well_formed and self.model.clock_site.set_utc_offset(parse_utc_offset(argument))
        except ProtocolError:
            return False

    def _set_latitude(self, argument: str, well_formed: bool) -> bool:
        try:
            return well_formed and self.model.clock_site.set_latitude(parse_dms(argument))
        except ProtocolError:
            return False

    def _set_longitude(self, argument: str, well_formed: bool) -> bool:
        try:
            return well_formed and self.model.clock_site.set_longitude(parse_longitude(argument))
        except ProtocolError:
            return False

    def _set_date_time_zone(self, argument: str, well_formed: bool) -> bool:
        if not well_formed:
            return False
        try:
            day_text, time_text, zone_text = argument.split("&")
            day, clock, offset = parse_date(day_text), parse_time(time_text), parse_utc_offset(zone_text)
        except (ProtocolError, ValueError):
            return False
        return self.model.clock_site.set_date_time_zone(day, clock, offset)

    def _get_date_time_zone(self, _argument: str, _well_formed: bool) -> str:
        local = self.model.clock_site.local_datetime()
        zone = format_utc_offset(self.model.clock_site.utc_offset())
        return f"{format_date(local.date())}&{format_time(local.time())}&{zone}#"

    def _set_site(self, argument: str, well_formed: bool) -> bool:
        if not well_formed:
            return False
        try:
            lat_text, lon_text = argument.split("&")
            latitude, longitude = parse_dms(lat_text), parse_longitude(lon_text)
        except (ProtocolError, ValueError):
            return False
        if not (-90.0 <= latitude <= 90.0 and -180.0 <= longitude <= 180.0):
            return False
        return self.model.clock_site.set_latitude(latitude) and self.model.clock_site.set_longitude(longitude)

    # ---------------------------------------------------------------- position and target

    def _set_target_ra(self, argument: str, well_formed: bool) -> str | bool:
        try:
            if well_formed and self.model.set_target_ra(parse_hms(argument)):
                return True
        except ProtocolError:
            pass
        return error_reply(2)  # seconds or minutes of 60, or a bad format (PYAM5)

    def _set_target_dec(self, argument: str, well_formed: bool) -> str | bool:
        try:
            if well_formed and self.model.set_target_dec(parse_dms(argument)):
                return True
        except ProtocolError:
            pass
        return error_reply(2)

    def _get_position(self, _argument: str, _well_formed: bool) -> str:
        ra, dec = self.model.position()
        return f"{format_hms(ra)}&{format_dms(dec)}#"

    def _get_horizontal(self, _argument: str, _well_formed: bool) -> str:
        alt, az = self.model.horizontal()
        if self.model.firmware.gmza_south_azimuth:
            az += 180.0
        return f"{format_azimuth(az)}&{format_dms(alt)}#"

    # ---------------------------------------------------------------- motion

    def _parse_pair(self, argument: str) -> tuple[float, float] | None:
        try:
            ra_text, dec_text = argument.split("&")
            ra, dec = parse_hms(ra_text), parse_dms(dec_text)
        except (ProtocolError, ValueError):
            return None
        return (ra, dec) if -90.0 <= dec <= 90.0 else None

    def _set_and_goto(self, argument: str, well_formed: bool) -> str:
        pair = self._parse_pair(argument) if well_formed else None
        if not self.model.firmware.compound_goto_sync or pair is None:
            return error_reply(2)  # what real firmware answers (PYAM5)
        self.model.set_target_ra(pair[0])
        self.model.set_target_dec(pair[1])
        return protocol.goto_reply(self.model.goto())

    def _select_speed(self, argument: str, well_formed: bool) -> None:
        if well_formed:
            self.model.select_speed(int(argument))
        return None

    def _variable_speed(self, argument: str, well_formed: bool, axis: int | None) -> None:
        if well_formed:
            self.model.set_variable_speed(float(argument.strip()), axis)
        return None

    # ---------------------------------------------------------------- tracking, guiding

    def _custom_rate(self, argument: str, well_formed: bool) -> bool | None:
        if not self.model.firmware.custom_tracking:
            return None  # not a command on real firmware: silence
        return well_formed and self.model.set_custom_rate(int(argument) / 10.0)

    def _tracking_state(self, _argument: str, _well_formed: bool) -> str:
        return protocol.format_tracking_state(*self.model.tracking_state())

    def _pulse(self, argument: str, well_formed: bool) -> None:
        if well_formed:
            self.model.pulse(argument[0], int(argument[1:]))
        return None

    def _guide_rate(self, argument: str, well_formed: bool) -> None:
        """``:Rg0.nn#`` (real clients) or the V1.1 document's x15 form ``:Rg1.5#``..``:Rg13.5#``."""
        if not well_formed:
            return None
        value = float(argument)
        if 0.1 - 1e-9 <= value <= 0.9 + 1e-9:
            self.model.set_guide_rate(value)
        elif 1.5 - 1e-9 <= value <= 13.5 + 1e-9:
            self.model.set_guide_rate(value / 15.0)
        return None

    # ---------------------------------------------------------------- sync, home, park

    def _set_and_sync(self, argument: str, well_formed: bool) -> str:
        pair = self._parse_pair(argument) if well_formed else None
        if not self.model.firmware.compound_goto_sync or pair is None:
            return error_reply(2)
        self.model.set_target_ra(pair[0])
        self.model.set_target_dec(pair[1])
        code = self.model.sync()
        if code:
            return error_reply(code)
        return self._get_position("", True)  # V1.1: the synced RA&Dec

    def _homed(self, _argument: str, _well_formed: bool) -> str | bool:
        variant = self.model.firmware.gh_reply
        if variant == "empty":
            return "#"
        if variant == "zero":
            return "0#"
        return self.model.homed()

    def _park(self, _argument: str, _well_formed: bool) -> str | None:
        accepted = self.model.park()
        if self.model.firmware.hp_reply is None:
            return None
        return "1#" if accepted else "0#"

    def _park_status(self, _argument: str, _well_formed: bool) -> str:
        status = self.model.park_status()
        return "#" if self.model.firmware.gps_reply == "empty" else f"{status}#"

    # ---------------------------------------------------------------- meridian and limits

    def _set_meridian(self, argument: str, well_formed: bool) -> bool:
        if not well_formed:
            return False
        try:
            return self.model.flash.set_meridian(parse_meridian(argument))
        except ProtocolError:
            return False

    def _set_upper_limit(self, argument: str, _well_formed: bool) -> bool:
        value = _two_digits(argument)
        return value is not None and self.model.flash.set_upper_limit(value)

    def _set_lower_limit(self, argument: str, _well_formed: bool) -> bool:
        value = _two_digits(argument)
        return value is not None and self.model.flash.set_lower_limit(value)
