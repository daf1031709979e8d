"""The ZWO AM mount command language: one table of commands, request builders, reply parsers.

Pure functions and small value types, no I/O, shared by the driver (link, mount) and by the mount
side (``dispatch``, which the emulator and the shared ZWO port answer with). Each row of
:data:`COMMANDS` is the whole command: what the driver sends, what the mount side parses and asks of
its backend, how either side writes and reads the reply, and what it changes (:class:`Effect`).
Where ZWO's V1.1 document and real mounts disagree, this module follows the real mounts
(``shared/zwo/field-notes.md``): setters answer one bare character, a GOTO answers a bare ``0`` or
``eN#``, the time-zone sign is negated, longitude is east-negative, and unknown commands get no
reply at all.

Text on the wire is ASCII except the degree mark, which some firmware sends as ``°`` or the
LX200 ``0xDF``; callers decode bytes as latin-1 so every byte maps to one character.

The values themselves (angles, dates, status flags) and their text forms live in
``wire_values``; cutting a byte stream into command bodies, mount-side, in ``request_framer``.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from datetime import date, datetime, time
from enum import Enum, Flag, auto
from typing import Any, Protocol

from .._exceptions import MountReplyError, ProtocolError
from .wire_values import (
    DEGREE_MARKS,
    Direction,
    MeridianSettings,
    MountMode,
    MountStatus,
    TrackRate,
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
    parse_status,
    parse_time,
    parse_utc_offset,
)

# --------------------------------------------------------------------------------------------
# Reply kinds and the reading rule
# --------------------------------------------------------------------------------------------


class ReplyKind(Enum):
    """How a command's reply is framed; the reader must know it before it reads."""

    NONE = "none"  # motion, rates, guide, home, unknown commands: nothing comes back
    CHAR = "char"  # setters: one bare '1'/'0' (no '#'); an 'e' starts an 'eN#' error
    GOTO = "goto"  # :MS#-style: a bare '0' on success, 'eN#' on failure
    TEXT = "text"  # queries, N/A#, eN#: everything up to and including '#'


def reply_complete(kind: ReplyKind, data: bytes) -> bool:
    """True once ``data`` holds the whole reply of a command of ``kind``.

    The reader feeds it what has arrived so far; it never asks for a ``#`` that a bare-character
    reply will not send (the classic multi-second stall of LX200 drivers on ZWO mounts).
    """
    if kind is ReplyKind.NONE:
        return True
    if not data:
        return False
    if kind in (ReplyKind.CHAR, ReplyKind.GOTO) and data[:1] != b"e":
        return True
    return data.endswith(b"#")


# --------------------------------------------------------------------------------------------
# Error codes
# --------------------------------------------------------------------------------------------

#: ``eN#`` codes (ZWO protocol v2.1 table, field notes §4.1).
ERROR_CODES: dict[int, str] = {
    1: "parameter out of range",
    2: "parameter format error",
    3: "GOTO refused: the mount is homing, slewing or in a GOTO",
    4: "the mount is moving",
    5: "target is below the horizon",
    6: "target is below the altitude limit",
    7: "time and site have not been set",
    8: "tracking passed the meridian limit and stopped",
    9: "sync point is on the other side of the meridian",
    10: "alt-az mode: altitude inverted",
    11: "sync is not allowed at the home position (near the pole)",
    12: "sync point is too far from the current position",
    14: "the mount is parked (its own park; :Spu# releases it)",  # every motion while parked (S1, 1.8.8)
}

#: Failure bytes of ``:Sp01#`` (store custom park position), field notes §4.2.
PARK_SET_CODES: dict[str, str] = {
    "1": "ok",
    "2": "park position already set",
    "3": "too many park positions",
    "4": "not in equatorial mode",
    "5": "the mount has not been homed yet",
    "6": "bad name",
    "7": "bad id",
    "8": "bad parameter",
    "9": "the mount is moving",
}


def error_reply(code: int) -> str:
    """The wire text of mount error ``code``."""
    return f"e{code}#"


def char_reply(ok: bool) -> str:
    """A setter's bare one-character answer (``ReplyKind.CHAR``): ``1`` accepted, ``0`` refused."""
    return "1" if ok else "0"


def goto_reply(code: int) -> str:
    """A GOTO's answer (``ReplyKind.GOTO``): a bare ``0`` when it starts, else ``eN#``."""
    return "0" if code == 0 else error_reply(code)


def sync_reply(code: int) -> str:
    """``:CM#``'s answer: ``N/A#`` when the sync is taken, else ``eN#``."""
    return SYNC_ACK + "#" if code == 0 else error_reply(code)


#: The text of a taken ``:CM#`` sync (``:SMMC#`` answers the synced coordinates instead).
SYNC_ACK = "N/A"


def _raise_if_error(request: str, reply: str) -> None:
    match = re.fullmatch(r"e(\d{1,2})#?", reply)
    if match:
        code = int(match.group(1))
        raise MountReplyError(request, reply, code, ERROR_CODES.get(code, "unknown error"))


# --------------------------------------------------------------------------------------------
# Tracking state
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TrackingState:
    """``:GAT#``: tracking on/off, and why it stopped when the mount says (``eN#``)."""

    on: bool
    error: int | None = None

    @property
    def reason(self) -> str:
        return ERROR_CODES.get(self.error, "") if self.error is not None else ""


# --------------------------------------------------------------------------------------------
# The command table
# --------------------------------------------------------------------------------------------


def _text(reply: str) -> str:
    return reply[:-1] if reply.endswith("#") else reply


#: A model name as ``:GVP#`` gives it (``AM5``, ``AM5N``, ``AM3``, ``AM7``): what the link's probe
#: expects, and the one shape a model reply may have, so noise in front of it is never a model.
MODEL_NAME_RE = re.compile(r"[A-Z]{2}\d{1,2}[A-Z]{0,2}")


def _model_name(reply: str) -> str:
    text = _text(reply)
    if not MODEL_NAME_RE.fullmatch(text):
        raise ProtocolError(f"not a model name: {reply!r}")
    return text


def _pair(first: Callable[[str], Any], second: Callable[[str], Any]) -> Callable[[str], tuple[Any, Any]]:
    def parse(reply: str) -> tuple[Any, Any]:
        parts = _text(reply).split("&")
        if len(parts) != 2:
            raise ProtocolError(f"expected two '&'-separated values: {reply!r}")
        return first(parts[0]), second(parts[1])

    return parse


def _int_text(text: str) -> int:
    if not re.fullmatch(r"[+-]?\d{1,6}", text):
        raise ProtocolError(f"not an integer: {text!r}")
    return int(text)


def _float_text(text: str) -> float:
    if not re.fullmatch(r"[+-]?\d{1,5}(?:\.\d+)?", text):
        raise ProtocolError(f"not a number: {text!r}")
    return float(text)


def _flag01(text: str) -> bool:
    if text not in ("0", "1"):
        raise ProtocolError(f"expected 0 or 1: {text!r}")
    return text == "1"


def _gat(text: str) -> TrackingState:
    if text in ("0", "1"):
        return TrackingState(text == "1")
    match = re.fullmatch(r"e(\d{1,2})", text)
    if match:
        return TrackingState(False, int(match.group(1)))
    raise ProtocolError(f"not a :GAT# reply: {text!r}")


def _sync_ack(text: str) -> bool:
    """``:CM#``/``:SMMC#``: ``N/A`` or (V1.1's ``:SMMC#``) the synced coordinates mean the sync was taken."""
    if text != SYNC_ACK:
        parse_hms(text.split("&")[0])  # raises ProtocolError when it is neither
    return True


def _gmti(text: str) -> tuple[date, time, float]:
    parts = text.split("&")
    if len(parts) != 3:
        raise ProtocolError(f"not a :GMTI# reply: {text!r}")
    return parse_date(parts[0]), parse_time(parts[1]), parse_utc_offset(parts[2])


def format_tracking_state(on: bool, error: int | None = None) -> str:
    """``:GAT#``'s answer: ``1#`` tracking, ``0#`` not, or the ``eN#`` that says why it stopped."""
    if on:
        return "1#"
    return error_reply(error) if error is not None else "0#"


def _gps(text: str) -> int | None:
    if text == "":
        return None  # firmware that answers an empty '#'
    if text in ("0", "1", "2", "3"):
        return int(text)
    raise ProtocolError(f"not a :Gps# reply: {text!r}")


def _bad(text: str, what: str) -> Any:
    raise ProtocolError(f"not a {what} reply: {text!r}")


# -- both sides of a value: the request's argument and the reply's text ------------------------


@dataclass(frozen=True)
class Codec:
    """One text form, both ways: ``format`` writes a value (the driver's request argument, the mount's
    reply), ``parse`` reads it back (the mount reading the argument, the driver reading the reply);
    ``parse`` raises ``ProtocolError`` (or ``ValueError``) on text that is not such a value."""

    format: Callable[[Any], str]
    parse: Callable[[str], Any]


def _split(text: str, count: int) -> list[str]:
    parts = text.split("&")
    if len(parts) != count:
        raise ProtocolError(f"expected {count} '&'-separated values: {text!r}")
    return parts


def _parse_target(text: str) -> tuple[float, float]:
    ra_text, dec_text = _split(text, 2)
    ra, dec = parse_hms(ra_text), parse_dms(dec_text)
    if not -90.0 <= dec <= 90.0:
        raise ProtocolError(f"declination out of range: {text!r}")
    return ra, dec


def _parse_date_time_zone(text: str) -> tuple[date, time, float]:
    day, clock, zone = _split(text, 3)
    return parse_date(day), parse_time(clock), parse_utc_offset(zone)


def _format_date_time_zone(value: tuple[date, time, float]) -> str:
    day, clock, zone = value
    return f"{format_date(day)}&{format_time(clock)}&{format_utc_offset(zone)}"


def _parse_site(text: str) -> tuple[float, float]:
    latitude, longitude = _split(text, 2)
    return parse_dms(latitude), parse_longitude(longitude)


def _format_site(value: tuple[float, float]) -> str:
    return f"{format_latitude(value[0])}&{format_longitude(value[1])}"


def _format_target(value: tuple[float, float]) -> str:
    return f"{format_hms(value[0])}&{format_dms(value[1])}"


def _parse_two_digits(text: str) -> int:
    """``:SLH``/``:SLL`` take exactly two unsigned digits: the mount refuses a sign."""
    if len(text) != 2 or not text.isdigit():
        raise ProtocolError(f"not two unsigned digits: {text!r}")
    return int(text)


def _parse_pulse(text: str) -> tuple[Direction, int]:
    return Direction(text[0]), int(text[1:])


def _parse_guide_rate(text: str) -> float:
    """``:Rg0.nn#`` (real clients) or the V1.1 document's x15 form ``:Rg1.5#``..``:Rg13.5#``: a fraction of sidereal."""
    value = float(text)
    return value / 15.0 if value >= 1.5 - 1e-9 else value


def _speed_text(multiple: float) -> str:
    return f"{multiple:.2f}"


ANGLE = Codec(format_dms, parse_dms)
HOURS = Codec(format_hms, parse_hms)
LATITUDE = Codec(format_latitude, parse_dms)
LONGITUDE = Codec(format_longitude, parse_longitude)
DATE = Codec(format_date, parse_date)
TIME = Codec(format_time, parse_time)
ZONE = Codec(format_utc_offset, parse_utc_offset)
FLAG = Codec(lambda on: "1" if on else "0", _flag01)
DIGIT = Codec(str, int)
NUMBER = Codec(str, int)
NAME = Codec(str, str)
SPEED = Codec(_speed_text, lambda text: float(text.strip()))
TARGET = Codec(_format_target, _parse_target)
SITE = Codec(_format_site, _parse_site)
DATE_TIME_ZONE = Codec(_format_date_time_zone, _parse_date_time_zone)
LIMIT = Codec(lambda degrees: f"{degrees:02d}", _parse_two_digits)
PULSE = Codec(lambda value: f"{value[0].value}{value[1]:04d}", _parse_pulse)
GUIDE_RATE = Codec(lambda fraction: f"{fraction:.2f}", _parse_guide_rate)
CUSTOM_RATE = Codec(lambda multiple: f"{round(multiple * 10):02d}", lambda text: int(text) / 10.0)
MERIDIAN = Codec(format_meridian, parse_meridian)

# -- reply formatters: the value a mount answers, as the text it sends -------------------------


def _query(form: Callable[[Any], str]) -> Callable[[Any], str]:
    """A query's answer: the value's text form and the ``#``."""
    return lambda value: form(value) + "#"


def _silent(_value: Any) -> None:
    return None


def _ok_or_e2(ok: bool) -> str:
    """``:Sr``/``:Sd``/``:SS``: a bare ``1``, or ``e2#`` for a value the mount will not take (PYAM5)."""
    return "1" if ok else error_reply(2)


def _park_reply(accepted: bool | None) -> str | None:
    """``:hP#``: nothing on current firmware (None), ``1#``/``0#`` on 1.8.8 (PYAM5)."""
    return None if accepted is None else char_reply(accepted) + "#"


def _park_status(status: int | None) -> str:
    return "#" if status is None else f"{status}#"


def _synced(value: int | tuple[float, float]) -> str:
    """``:SMMC#``: the synced RA&Dec (V1.1), or the ``eN#`` of a refused sync."""
    if isinstance(value, int):
        return error_reply(value)
    return _format_target(value) + "#"


def _horizontal(value: tuple[float, float]) -> str:
    """``:GMZA#``: azimuth&altitude."""
    return f"{format_azimuth(value[0])}&{format_dms(value[1])}#"


def _pairing(ok: bool) -> str:
    return "OK#" if ok else "NO#"


def _reply_flag(on: bool) -> str:
    return char_reply(on) + "#"


class Effect(Flag):
    """What a command does besides answering: the driver, the shared port and the poller act on these."""

    NONE = 0
    #: Changes what a poll reads (position, ``:GU#``, ``:GAT#``, ``:Gm#``): a poll that overlapped it is stale.
    STATUS = auto()
    #: A reading means something else afterwards (alignment, clock, site, sidereal time, daylight saving).
    READINGS = auto()
    #: Changes a setting stored in the mount (what ``Mount.read_settings`` reads, and the mode).
    SETTING = auto()
    #: Changes the mount for every program (mode, alignment, stored settings, Bluetooth, clock): refused
    #: on the shared ZWO port unless ``zwo_port.allow_dangerous`` lists it.
    GUARDED = auto()
    #: Changes a setting the server owns and restores (``telescope.StoredSettings``: meridian, altitude
    #: limits, heavy duty, buzzer): every door, the shared port included, writes it through that owner.
    STORED = auto()


@dataclass(frozen=True)
class Command:
    """One ZWO command, both sides of it, as a pymodbus PDU knows its request and its response.

    ``args`` is a regex the text after the code must match in full (``None``: no arguments), and
    ``argument`` the codec of that text: the driver's request builder formats a value with it, the
    mount side (the emulator, the shared port) parses the value back. ``parse`` turns the reply body
    (``#`` stripped) into a value; it raises ``ProtocolError`` on text that is not a valid reply and
    ``MountReplyError`` when the mount refused the command. ``reply`` is its inverse, the mount side's
    reply formatter (None: the mount answers nothing); ``refused`` is the value whose reply a refusal
    or a malformed request gets (a setter's bare ``0``, ``e2#`` …). ``effects`` say what the
    command changes besides answering (:class:`Effect`). ``asks`` is what the command asks of the
    mount side, ``asks(backend, argument)`` with the argument parsed (None without one): a call on
    :class:`Backend` (below), whose value ``reply`` frames. Every row has one; ``dispatch`` refuses to
    import otherwise.
    """

    code: str
    kind: ReplyKind
    summary: str
    args: str | None = None
    parse: Callable[[str], Any] | None = None
    source: str = "doc"  # "doc": ZWO V1.1; "field": real mounts/drivers (field notes §2)
    error_is_value: bool = False  # :GAT#'s eN# reports why tracking stopped; it is not a refusal
    #: CHAR replies other than ``1`` that name a failure (``:Sp01#``'s 2..9), instead of a plain ``0``.
    failure_codes: Mapping[str, str] | None = None
    argument: Codec | None = None
    reply: Callable[[Any], str | None] | None = None
    refused: Any = False
    effects: Effect = Effect.NONE
    asks: Callable[[Backend, Any], Any] | None = None

    @property
    def args_re(self) -> re.Pattern[str] | None:
        return _ARGS_RE.get(self.code)

    def reply_text(self, value: Any) -> str | None:
        """The mount's reply carrying ``value`` (None: no reply at all)."""
        if self.reply is not None:
            return self.reply(value)
        return _KIND_REPLY[self.kind](value)

    def request(self, value: Any = None) -> Request:
        """The request carrying ``value`` as its argument (checked against ``args``)."""
        if self.argument is None:
            return request(self.code)
        return request(self.code, self.argument.format(value))

    def has(self, effect: Effect) -> bool:
        return bool(self.effects & effect)


#: A reply formatter by kind, for rows that need no other: silence, a setter's bare 1/0, a GOTO's 0/eN#.
_KIND_REPLY: dict[ReplyKind, Callable[[Any], str | None]] = {
    ReplyKind.NONE: _silent,
    ReplyKind.CHAR: lambda ok: char_reply(bool(ok)),
    ReplyKind.GOTO: lambda code: goto_reply(int(code)),
}

_T, _C, _G, _N = ReplyKind.TEXT, ReplyKind.CHAR, ReplyKind.GOTO, ReplyKind.NONE
_STATUS, _READINGS, _SETTING, _GUARDED = Effect.STATUS, Effect.READINGS, Effect.SETTING, Effect.GUARDED
#: A stored setting the server owns: it changes the mount for every program, so it is guarded too.
_STORED = Effect.SETTING | Effect.GUARDED | Effect.STORED
_HMS_ARG = r" ?\d{1,2}:\d{1,2}(?::\d{1,2}(?:\.\d)?|\.\d)"
_DMS_ARG = r"[+-]?\d{1,3}[" + re.escape(DEGREE_MARKS) + r"]\d{1,2}(?:[:']\d{1,2})?"
_SPEED_ARG = r"\d{1,4}(?:\.\d{1,2})?"
_CLOCK = _STATUS | _READINGS  # the clock, zone and site: the readings' meaning and what a poll reads


# --------------------------------------------------------------------------------------------
# What a command asks of the mount side (``dispatch`` answers with it)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Verbatim:
    """A backend's own reply text for a request, past the table: firmware that does not know a command
    (``None``: silence, as for any unknown code), or the shared port relaying a command to the mount."""

    reply: str | None


class Backend(Protocol):
    """What the mount knows and does, one method per thing a command asks (in the table's order).

    Commands that ask the same thing share a method (:R#, :RG#, :RM# … all ``select_speed``); a command
    that asks something new adds its method here and to both backends (mypy holds them to it).

    Values are in the units of ``wire_values`` (hours, degrees east-positive, the true UTC offset);
    setters answer whether the mount took the value. A backend may raise ``dispatch.NoReply`` or
    ``dispatch.Refusal`` from any method.
    """

    def intercept(self, match: CommandMatch) -> Verbatim | None:
        """Answer ``match`` before the table (None: let the table answer)."""
        ...

    # Date, time, site
    def clock(self) -> datetime:
        """The mount's wall clock (naive, local)."""
        ...

    def utc_offset(self) -> float:
        """The UTC offset in hours the mount keeps (its zone, shown negated)."""
        ...

    def set_clock(self, day: date | None, clock: time | None, utc_offset: float | None) -> bool:
        """Set what is given: the date (:SC), the time (:SL), the zone (:SG), or all three (:SMTI)."""
        ...

    def sidereal_time(self) -> float: ...
    def set_sidereal_time(self, hours: float) -> bool: ...
    def daylight_saving(self) -> bool: ...
    def set_daylight_saving(self, on: bool) -> bool: ...

    def site(self) -> tuple[float, float]:
        """(latitude, east longitude)."""
        ...

    def set_site(self, latitude: float | None, longitude: float | None) -> bool:
        """Set what is given: :St, :Sg, or both (:SMGE, which takes both or neither)."""
        ...

    # Position and target
    def pier_letter(self) -> str: ...
    def target(self) -> tuple[float, float]: ...

    def set_target(self, ra: float | None, dec: float | None) -> bool:
        """Set what is given: the target RA (:Sr), Dec (:Sd), or both (:SMeq, :SMMC)."""
        ...

    def position(self) -> tuple[float, float]: ...

    def horizontal(self, paired: bool) -> tuple[float, float]:
        """(altitude, azimuth from north); ``paired``: for :GMZA#, whose azimuth some firmware counts from south."""
        ...

    # Motion
    def goto(self) -> int:
        """Start a GOTO to the target: 0, or the mount's error code."""
        ...

    def compound_goto_sync(self) -> bool:
        """Does this mount take :SMeq#/:SMMC# (real firmware answers them e2#)?"""
        ...

    def stop(self) -> None: ...
    def move(self, direction: Direction) -> None: ...
    def stop_axis(self, direction: Direction) -> None: ...
    def select_speed(self, index: int) -> None: ...

    def set_variable_speed(self, multiple: float, axis: int | None) -> None:
        """:Rv# (both axes, ``axis`` None), :Rvr# (0) or :Rvd# (1), in multiples of sidereal."""
        ...

    # Tracking
    def set_tracking_rate(self, rate: TrackRate) -> None: ...

    def tracking_rate_digit(self) -> str:
        """:GT#'s digit, in this firmware's order."""
        ...

    def set_custom_rate(self, multiple: float) -> bool: ...
    def set_tracking(self, on: bool) -> bool: ...
    def tracking_state(self) -> TrackingState: ...

    # Guiding
    def pulse(self, direction: Direction, milliseconds: int) -> None: ...

    def set_guide_rate(self, fraction: float) -> None:
        """A fraction of sidereal; one outside 0.1-0.9 is ignored, as the mount does."""
        ...

    def guide_rate(self) -> float: ...

    # Sync and alignment
    def sync(self) -> int:
        """Sync on the target: 0, or the mount's error code."""
        ...

    def clear_alignment(self) -> bool: ...

    # Home, park
    def home(self) -> None: ...

    def home_flag(self) -> str:
        """:Gh#'s text: ``1``/``0``, or what this firmware answers instead (``0`` always, or nothing)."""
        ...

    def set_current_as_home(self) -> bool: ...

    def park(self) -> bool | None:
        """Whether the park was accepted; None on firmware that answers :hP# with nothing."""
        ...

    def set_park_position(self) -> str:
        """:Sp01#'s one-character result code (``protocol.PARK_SET_CODES``)."""
        ...

    def unpark(self) -> bool: ...

    def park_status(self) -> int | None:
        """0 not parked, 1 parking, 2 parked; None on firmware that answers an empty ``#``."""
        ...

    # Meridian and limits
    def meridian(self) -> MeridianSettings: ...
    def set_meridian(self, settings: MeridianSettings) -> bool: ...
    def limits_enabled(self) -> bool: ...
    def set_limits_enabled(self, on: bool) -> bool: ...
    def upper_limit(self) -> int: ...
    def set_upper_limit(self, degrees: int) -> bool: ...
    def lower_limit(self) -> int: ...
    def set_lower_limit(self, degrees: int) -> bool: ...
    def max_speed(self) -> int: ...
    def set_max_speed(self, multiple: int) -> bool: ...

    # Mode, buzzer, identity
    def set_mode(self, mode: MountMode) -> None: ...
    def buzzer(self) -> int: ...
    def set_buzzer(self, level: int) -> None: ...
    def status(self) -> MountStatus: ...
    def firmware_version(self) -> str: ...
    def model_name(self) -> str: ...
    def compile_time(self) -> str: ...
    def ble_name(self) -> str: ...
    def set_ble_suffix(self, suffix: str) -> bool: ...
    def ble_pair(self, pairing_id: str) -> bool: ...


def _goto_to(backend: Backend, target: tuple[float, float]) -> int:
    """:SMeq#: :Sr + :Sd + :MS# in one, on firmware that has it; e2# (code 2) where it does not."""
    if not backend.compound_goto_sync():
        return 2
    backend.set_target(*target)
    return backend.goto()


def _sync_to(backend: Backend, target: tuple[float, float]) -> int | tuple[float, float]:
    """:SMMC#: :Sr + :Sd + :CM# in one, answering the synced position (V1.1); e2# where it does not exist."""
    if not backend.compound_goto_sync():
        return 2
    backend.set_target(*target)
    code = backend.sync()
    return code if code else backend.position()


def _clock_and_zone(backend: Backend, _: None) -> tuple[date, time, float]:
    """:GMTI#: the date and time of one reading of the clock, and the zone."""
    local = backend.clock()
    return local.date(), local.time(), backend.utc_offset()


COMMANDS: tuple[Command, ...] = (
    # Date, time, site
    Command("SC", _C, "set local date MM/DD/YY", r"\d{2}/\d{2}/\d{2}", argument=DATE, effects=_CLOCK,
            asks=lambda b, day: b.set_clock(day, None, None)),
    Command("GC", _T, "get local date", parse=parse_date, reply=_query(format_date),
            asks=lambda b, _: b.clock().date()),
    Command("SL", _C, "set local time HH:MM:SS", r"\d{2}:\d{2}:\d{2}", argument=TIME, effects=_CLOCK,
            asks=lambda b, clock: b.set_clock(None, clock, None)),
    Command("GL", _T, "get local time", parse=parse_time, reply=_query(format_time),
            asks=lambda b, _: b.clock().time()),
    Command("SS", _C, "set sidereal time HH:MM:SS (1 or e2#)", r"\d{2}:\d{2}:\d{2}", argument=HOURS, reply=_ok_or_e2,
            effects=_READINGS | _GUARDED, asks=lambda b, hours: b.set_sidereal_time(hours)),
    Command("GS", _T, "get local sidereal time", parse=parse_hms, reply=_query(format_hms),
            asks=lambda b, _: b.sidereal_time()),
    Command("GH", _T, "get daylight-saving flag", parse=_flag01, reply=_reply_flag,
            asks=lambda b, _: b.daylight_saving()),
    Command("SH", _C, "set daylight-saving flag", r"[01]", argument=FLAG, effects=_READINGS | _SETTING | _GUARDED,
            asks=lambda b, on: b.set_daylight_saving(on)),
    Command("SG", _C, "set time zone (negated UTC offset) sHH or sHH:MM", r"[+-]\d{1,2}(?::\d{2})?", argument=ZONE,
            effects=_CLOCK, asks=lambda b, offset: b.set_clock(None, None, offset)),
    Command("GG", _T, "get time zone (negated UTC offset)", parse=parse_utc_offset, reply=_query(format_utc_offset),
            asks=lambda b, _: b.utc_offset()),
    Command("St", _C, "set latitude sDD*MM:SS", _DMS_ARG, argument=LATITUDE, effects=_CLOCK,
            asks=lambda b, latitude: b.set_site(latitude, None)),
    Command("Gt", _T, "get latitude", parse=parse_dms, reply=_query(format_latitude), asks=lambda b, _: b.site()[0]),
    Command("Sg", _C, "set longitude sDDD*MM:SS, east negative", _DMS_ARG, argument=LONGITUDE, effects=_CLOCK,
            asks=lambda b, longitude: b.set_site(None, longitude)),
    Command("Gg", _T, "get longitude, east negative", parse=parse_longitude, reply=_query(format_longitude),
            asks=lambda b, _: b.site()[1]),
    Command("SMTI", _C, "set date, time and zone MM/DD/YY&HH:MM:SS&sHH:MM",
            r"\d{2}/\d{2}/\d{2}&\d{2}:\d{2}:\d{2}&[+-]\d{2}:\d{2}", argument=DATE_TIME_ZONE,
            asks=lambda b, value: b.set_clock(*value)),
    Command("GMTI", _T, "get date, time and zone", parse=_gmti, reply=_query(_format_date_time_zone),
            asks=_clock_and_zone),
    Command("SMGE", _C, "set latitude and longitude", _DMS_ARG + "&" + _DMS_ARG, argument=SITE,
            asks=lambda b, site: b.set_site(*site)),
    Command("GMGE", _T, "get latitude and longitude", parse=_pair(parse_dms, parse_longitude),
            reply=_query(_format_site), asks=lambda b, _: b.site()),
    # Position and target
    Command("Gm", _T, "get pier side E/W/N", parse=lambda t: t if t in ("E", "W", "N") else _bad(t, ":Gm#"),
            reply=_query(str), asks=lambda b, _: b.pier_letter()),
    Command("Sr", _C, "set target RA HH:MM:SS", _HMS_ARG, argument=HOURS, reply=_ok_or_e2,
            asks=lambda b, ra: b.set_target(ra, None)),
    Command("Gr", _T, "get target RA", parse=parse_hms, reply=_query(format_hms), asks=lambda b, _: b.target()[0]),
    Command("Sd", _C, "set target Dec sDD*MM:SS", _DMS_ARG, argument=ANGLE, reply=_ok_or_e2,
            asks=lambda b, dec: b.set_target(None, dec)),
    Command("Gd", _T, "get target Dec", parse=parse_dms, reply=_query(format_dms), asks=lambda b, _: b.target()[1]),
    Command("GR", _T, "get current RA", parse=parse_hms, reply=_query(format_hms), asks=lambda b, _: b.position()[0]),
    Command("GD", _T, "get current Dec", parse=parse_dms, reply=_query(format_dms), asks=lambda b, _: b.position()[1]),
    Command("GZ", _T, "get azimuth", parse=parse_dms, reply=_query(format_azimuth),
            asks=lambda b, _: b.horizontal(False)[1]),
    Command("GA", _T, "get altitude", parse=parse_dms, reply=_query(format_dms),
            asks=lambda b, _: b.horizontal(False)[0]),
    Command("GMeq", _T, "get target RA and Dec", parse=_pair(parse_hms, parse_dms), reply=_query(_format_target),
            asks=lambda b, _: b.target()),
    Command("GMEQ", _T, "get current RA and Dec", parse=_pair(parse_hms, parse_dms), reply=_query(_format_target),
            asks=lambda b, _: b.position()),
    Command("GMZA", _T, "get azimuth and altitude", parse=_pair(parse_dms, parse_dms), reply=_horizontal,
            asks=lambda b, _: b.horizontal(True)[::-1]),
    # Motion
    Command("MS", _G, "GOTO the target (bare 0 or eN#)", refused=2, effects=_STATUS, asks=lambda b, _: b.goto()),
    Command("SMeq", _G, "set target and GOTO (e2# on some firmware)", _HMS_ARG + "&" + _DMS_ARG, argument=TARGET,
            refused=2, effects=_STATUS, asks=_goto_to),
    Command("Q", _N, "stop all motion", effects=_STATUS, asks=lambda b, _: b.stop()),
    Command("Me", _N, "move east", effects=_STATUS, asks=lambda b, _: b.move(Direction.EAST)),
    Command("Mw", _N, "move west", effects=_STATUS, asks=lambda b, _: b.move(Direction.WEST)),
    Command("Mn", _N, "move north", effects=_STATUS, asks=lambda b, _: b.move(Direction.NORTH)),
    Command("Ms", _N, "move south", effects=_STATUS, asks=lambda b, _: b.move(Direction.SOUTH)),
    Command("Qe", _N, "stop moving east", effects=_STATUS, asks=lambda b, _: b.stop_axis(Direction.EAST)),
    Command("Qw", _N, "stop moving west", effects=_STATUS, asks=lambda b, _: b.stop_axis(Direction.WEST)),
    Command("Qn", _N, "stop moving north", effects=_STATUS, asks=lambda b, _: b.stop_axis(Direction.NORTH)),
    Command("Qs", _N, "stop moving south", effects=_STATUS, asks=lambda b, _: b.stop_axis(Direction.SOUTH)),
    Command("R", _N, "select move speed 0-9", r"\d", argument=DIGIT, asks=lambda b, index: b.select_speed(index)),
    Command("RG", _N, "move speed 0.5x (R1)", asks=lambda b, _: b.select_speed(1)),
    Command("RC", _N, "move speed 1x (R2)", asks=lambda b, _: b.select_speed(2)),
    Command("RM", _N, "move speed 720x (R8)", asks=lambda b, _: b.select_speed(8)),
    Command("RS", _N, "move speed 1440x (R9)", asks=lambda b, _: b.select_speed(9)),
    Command("Rv", _N, "variable move speed 0-1440x", _SPEED_ARG, argument=SPEED, source="field",
            asks=lambda b, multiple: b.set_variable_speed(multiple, None)),
    Command("Rvr", _N, "variable RA move speed (fw 1.8.8)", _SPEED_ARG, argument=SPEED, source="field",
            asks=lambda b, multiple: b.set_variable_speed(multiple, 0)),
    Command("Rvd", _N, "variable Dec move speed (fw 1.8.8)", _SPEED_ARG, argument=SPEED, source="field",
            asks=lambda b, multiple: b.set_variable_speed(multiple, 1)),
    # Tracking
    Command("TQ", _N, "sidereal tracking rate", effects=_STATUS,
            asks=lambda b, _: b.set_tracking_rate(TrackRate.SIDEREAL)),
    Command("TS", _N, "solar tracking rate", effects=_STATUS, asks=lambda b, _: b.set_tracking_rate(TrackRate.SOLAR)),
    Command("TL", _N, "lunar tracking rate", effects=_STATUS, asks=lambda b, _: b.set_tracking_rate(TrackRate.LUNAR)),
    Command("GT", _T, "get tracking rate digit", parse=lambda t: t if t in "0123" and t else _bad(t, ":GT#"),
            reply=_query(str), asks=lambda b, _: b.tracking_rate_digit()),
    Command("STR", _C, "custom tracking rate n.n (absent on real firmware)", r"\d{2}", argument=CUSTOM_RATE,
            asks=lambda b, multiple: b.set_custom_rate(multiple)),
    Command("Te", _C, "tracking on", effects=_STATUS, asks=lambda b, _: b.set_tracking(True)),
    Command("Td", _C, "tracking off", effects=_STATUS, asks=lambda b, _: b.set_tracking(False)),
    Command("GAT", _T, "get tracking state (0, 1 or eN)", parse=_gat, source="field", error_is_value=True,
            reply=lambda state: format_tracking_state(state.on, state.error), asks=lambda b, _: b.tracking_state()),
    # Guiding
    Command("Mg", _N, "pulse guide d nnnn ms", r"[nsew]\d{1,5}", argument=PULSE, asks=lambda b, pulse: b.pulse(*pulse)),
    Command("Rg", _N, "set guide rate (fraction of sidereal)", r"\d{1,2}(?:\.\d{1,2})?", argument=GUIDE_RATE,
            effects=_SETTING, asks=lambda b, fraction: b.set_guide_rate(fraction)),
    Command("Ggr", _T, "get guide rate", parse=_float_text, source="field", reply=_query(_speed_text),
            asks=lambda b, _: b.guide_rate()),
    # Sync and alignment
    Command("CM", _T, "sync to the target (N/A#)", parse=_sync_ack, reply=lambda code: sync_reply(code), refused=2,
            effects=_CLOCK, asks=lambda b, _: b.sync()),
    Command("SMMC", _T, "set target and sync", _HMS_ARG + "&" + _DMS_ARG, parse=_sync_ack, argument=TARGET,
            reply=_synced, refused=2, effects=_CLOCK, asks=_sync_to),
    Command("NSC", _C, "clear alignment points", source="field", effects=_CLOCK | _GUARDED,
            asks=lambda b, _: b.clear_alignment()),
    # Home, park
    Command("hC", _N, "go to mechanical home", effects=_STATUS, asks=lambda b, _: b.home()),
    Command("Gh", _T, "homed? (unreliable)", parse=_text, source="field", reply=_query(str),
            asks=lambda b, _: b.home_flag()),
    Command("SOa", _C, "set current position as home", source="field", effects=_GUARDED,
            asks=lambda b, _: b.set_current_as_home()),
    Command("hP", _N, "go to factory park (latches a stored parked state)", source="field", reply=_park_reply,
            effects=_STATUS, asks=lambda b, _: b.park()),
    Command("Sp01", _C, "store current position as park position 1", source="field", failure_codes=PARK_SET_CODES,
            reply=str, refused="0", effects=_GUARDED, asks=lambda b, _: b.set_park_position()),
    Command("Spu", _C, "unpark (clear the parked latch)", source="field", effects=_STATUS,
            asks=lambda b, _: b.unpark()),
    Command("Gps", _T, "park status 0-3 (empty on some firmware)", parse=_gps, source="field", reply=_park_status,
            asks=lambda b, _: b.park_status()),
    # Meridian and limits
    Command("STa", _C, "meridian settings f t s nn", r"[01][01][+-]\d{2}", source="field", argument=MERIDIAN,
            effects=_STORED, asks=lambda b, settings: b.set_meridian(settings)),
    Command("GTa", _T, "get meridian settings", parse=parse_meridian, source="field", reply=_query(format_meridian),
            asks=lambda b, _: b.meridian()),
    Command("SLE", _C, "altitude limits on", source="field", effects=_STORED,
            asks=lambda b, _: b.set_limits_enabled(True)),
    Command("SLD", _C, "altitude limits off", source="field", effects=_STORED,
            asks=lambda b, _: b.set_limits_enabled(False)),
    Command("GLC", _T, "altitude limits on?", parse=_flag01, source="field", reply=_reply_flag,
            asks=lambda b, _: b.limits_enabled()),
    Command("SLH", _C, "upper altitude limit 60-90", r"[+-]?\d{1,2}", source="field", argument=LIMIT,
            effects=_STORED, asks=lambda b, degrees: b.set_upper_limit(degrees)),
    Command("GLH", _T, "get upper altitude limit", parse=_int_text, source="field", reply=_query(str),
            asks=lambda b, _: b.upper_limit()),
    Command("SLL", _C, "lower altitude limit 0-30, unsigned two digits", r"[+-]?\d{1,2}", source="field",
            argument=LIMIT, effects=_STORED, asks=lambda b, degrees: b.set_lower_limit(degrees)),
    Command("GLL", _T, "get lower altitude limit", parse=_int_text, source="field", reply=_query(str),
            asks=lambda b, _: b.lower_limit()),
    Command("SRl", _C, "heavy-duty mode: top speed 720 or 1440", r"\d{3,4}", source="field", argument=NUMBER,
            effects=_STORED, asks=lambda b, multiple: b.set_max_speed(multiple)),
    Command("GRl", _T, "get heavy-duty top speed", parse=_int_text, source="field", reply=_query(str),
            asks=lambda b, _: b.max_speed()),
    # Mode, buzzer, identity
    Command("AP", _N, "switch to equatorial mode (after restart)", source="field",
            effects=_STATUS | _SETTING | _GUARDED, asks=lambda b, _: b.set_mode(MountMode.EQUATORIAL)),
    Command("AA", _N, "switch to alt-az mode (after restart)", source="field", effects=_STATUS | _SETTING | _GUARDED,
            asks=lambda b, _: b.set_mode(MountMode.ALTAZ)),
    Command("SBu", _N, "buzzer 0 mute, 1 low, 2 loud", r"[012]", argument=DIGIT, effects=_STORED,
            asks=lambda b, level: b.set_buzzer(level)),
    Command("GBu", _T, "get buzzer", parse=_int_text, reply=_query(str), asks=lambda b, _: b.buzzer()),
    Command("GU", _T, "get status flags", parse=parse_status, reply=_query(format_status),
            asks=lambda b, _: b.status()),
    Command("GV", _T, "get firmware version", parse=_text, reply=_query(str), asks=lambda b, _: b.firmware_version()),
    Command("GVP", _T, "get model", parse=_model_name, reply=_query(str), asks=lambda b, _: b.model_name()),
    Command("GVT", _T, "get firmware compile time", parse=_text, reply=_query(str), asks=lambda b, _: b.compile_time()),
    Command("GBl", _T, "get Bluetooth name", parse=_text, source="field", reply=_query(str),
            asks=lambda b, _: b.ble_name()),
    Command("SBl", _C, "set Bluetooth name suffix", r"[A-Za-z0-9]{1,12}", source="field", argument=NAME,
            effects=_GUARDED, asks=lambda b, suffix: b.set_ble_suffix(suffix)),
    Command("BS", _T, "Bluetooth pairing id (OK#/NO#)", r"[A-Za-z0-9]{1,12}", parse=_text, source="field",
            argument=NAME, reply=_pairing, effects=_GUARDED, asks=lambda b, pairing_id: b.ble_pair(pairing_id)),
)


BY_CODE: dict[str, Command] = {command.code: command for command in COMMANDS}
_ARGS_RE: dict[str, re.Pattern[str]] = {c.code: re.compile(c.args) for c in COMMANDS if c.args is not None}
# Longest code first so 'GVP' wins over 'GV', 'SLH' over 'SL', 'Rvr' over 'Rv' over 'R'.
_CODES_LONGEST_FIRST = sorted(BY_CODE, key=len, reverse=True)


def codes_with(effect: Effect) -> tuple[str, ...]:
    """The codes of the commands with ``effect``, in table order (the code sets the driver, the poller
    and the shared port act on are read off the table, never kept beside it)."""
    return tuple(command.code for command in COMMANDS if command.has(effect))


@dataclass(frozen=True)
class CommandMatch:
    """What a request body (text between ``:`` and ``#``) turned out to be."""

    command: Command
    argument: str  # the text after the code
    well_formed: bool  # False: a known code with arguments the mount would reject


def match_command(body: str) -> CommandMatch | None:
    """Identify a request body; ``None`` means the mount does not know it and stays silent.

    Codes are case-sensitive (``:STA…#`` is not ``:STa…#``). A known code with malformed
    arguments is still that command, so the emulator can answer it the way the mount does.
    """
    exact = BY_CODE.get(body)
    if exact is not None and exact.args is None:
        return CommandMatch(exact, "", True)
    for code in _CODES_LONGEST_FIRST:
        if body.startswith(code):
            command = BY_CODE[code]
            argument = body[len(code):]
            if command.args is None:
                continue  # an argument-less code followed by text is some other command
            pattern = _ARGS_RE[code]
            if pattern.fullmatch(argument):
                return CommandMatch(command, argument, True)
            return CommandMatch(command, argument, False)
    return None


# --------------------------------------------------------------------------------------------
# Requests (driver side)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Request:
    """A command ready for the wire, with how to read and parse its reply."""

    command: Command
    text: str

    @property
    def kind(self) -> ReplyKind:
        return self.command.kind

    @property
    def wire(self) -> bytes:
        return self.text.encode("latin-1")

    def parse(self, reply: str) -> Any:
        """Interpret the raw reply; raise MountReplyError when the mount refused the command."""
        kind = self.command.kind
        if kind is ReplyKind.NONE:
            return None
        if not self.command.error_is_value:
            _raise_if_error(self.text, reply)
        if kind is ReplyKind.CHAR:
            return self._char(reply)
        if kind is ReplyKind.GOTO:
            if reply == "0":
                return True
            raise MountReplyError(self.text, reply)
        body = _text(reply)
        parser = self.command.parse
        return parser(body) if parser is not None else body

    def _char(self, reply: str) -> bool:
        if reply == "1":
            return True
        codes = self.command.failure_codes
        if codes is not None:
            raise MountReplyError(self.text, reply, None, codes.get(reply, "unknown"))
        if reply == "0":
            raise MountReplyError(self.text, reply)
        raise ProtocolError(f"unexpected reply {reply!r} to {self.text}")


def request(code: str, argument: str = "") -> Request:
    """A request for ``code`` with ``argument`` (checked against the table, so typos fail early)."""
    command = BY_CODE[code]
    if command.args is None:
        if argument:
            raise ProtocolError(f":{code}# takes no argument")
    elif not _ARGS_RE[code].fullmatch(argument):
        raise ProtocolError(f"bad argument {argument!r} for :{code}#")
    return Request(command, f":{code}{argument}#")


def query(code: str) -> Request:
    return request(code)


# Typed builders: each command row formats its own argument (``Command.request``); these add the
# ranges the driver may send, so a bad value fails here instead of on the mount.


def _build(code: str, value: Any) -> Request:
    return BY_CODE[code].request(value)


def set_date(day: date) -> Request:
    return _build("SC", day)


def set_time(clock: time) -> Request:
    return _build("SL", clock)


def set_utc_offset(utc_offset_hours: float) -> Request:
    return _build("SG", utc_offset_hours)


def set_date_time_zone(day: date, clock: time, utc_offset_hours: float) -> Request:
    return _build("SMTI", (day, clock, utc_offset_hours))


def set_latitude(latitude: float) -> Request:
    return _build("St", latitude)


def set_longitude(east_longitude: float) -> Request:
    return _build("Sg", east_longitude)


def set_target_ra(hours: float) -> Request:
    return _build("Sr", hours)


def set_target_dec(degrees: float) -> Request:
    if not -90.0 <= degrees <= 90.0:
        raise ProtocolError(f"declination out of range: {degrees}")
    return _build("Sd", degrees)


def move(direction: Direction) -> Request:
    return request("M" + direction.value)


def stop_direction(direction: Direction) -> Request:
    return request("Q" + direction.value)


def set_move_speed_index(index: int) -> Request:
    if not 0 <= index <= 9:
        raise ProtocolError(f"move speed index out of range: {index}")
    return _build("R", index)


def set_variable_speed(multiple_of_sidereal: float) -> Request:
    if not 0.0 <= multiple_of_sidereal <= 1440.0:
        raise ProtocolError(f"variable speed out of range: {multiple_of_sidereal}")
    return _build("Rv", multiple_of_sidereal)


def pulse_guide(direction: Direction, milliseconds: int) -> Request:
    if not 0 <= milliseconds <= 9999:
        raise ProtocolError(f"pulse length out of range: {milliseconds}")
    return _build("Mg", (direction, milliseconds))


def set_guide_rate(fraction_of_sidereal: float) -> Request:
    if not 0.1 <= round(fraction_of_sidereal, 2) <= 0.9:
        raise ProtocolError(f"guide rate out of range 0.1-0.9: {fraction_of_sidereal}")
    return _build("Rg", fraction_of_sidereal)


#: ``:TQ#``/``:TS#``/``:TL#`` by the rate they select.
TRACKING_RATE_CODES = {TrackRate.SIDEREAL: "TQ", TrackRate.SOLAR: "TS", TrackRate.LUNAR: "TL"}


def set_tracking_rate(rate: TrackRate) -> Request:
    return request(TRACKING_RATE_CODES[rate])


def set_meridian(settings: MeridianSettings) -> Request:
    if not -15 <= settings.limit_degrees <= 15:
        raise ProtocolError(f"meridian limit out of range: {settings.limit_degrees}")
    return _build("STa", settings)


def set_upper_limit(degrees: int) -> Request:
    if not 60 <= degrees <= 90:
        raise ProtocolError(f"upper altitude limit out of range 60-90: {degrees}")
    return _build("SLH", degrees)


def set_lower_limit(degrees: int) -> Request:
    if not 0 <= degrees <= 30:
        raise ProtocolError(f"lower altitude limit out of range 0-30: {degrees}")
    return _build("SLL", degrees)


def set_heavy_duty(on: bool) -> Request:
    return _build("SRl", 720 if on else 1440)


def set_buzzer(level: int) -> Request:
    if level not in (0, 1, 2):
        raise ProtocolError(f"buzzer level must be 0, 1 or 2: {level}")
    return _build("SBu", level)
