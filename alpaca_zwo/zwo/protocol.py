"""The ZWO AM mount command language: one table of commands, request builders, reply parsers.

Pure functions and small value types, no I/O, shared by the driver (link, mount) and by the
emulator (responder). Where ZWO's V1.1 document and real mounts disagree, this module follows
the real mounts (``shared/zwo/field-notes.md``): setters answer one bare character, a GOTO
answers a bare ``0`` or ``eN#``, the time-zone sign is negated, longitude is east-negative, and
unknown commands get no reply at all.

Text on the wire is ASCII except the degree mark, which some firmware sends as ``°`` or the
LX200 ``0xDF``; callers decode bytes as latin-1 so every byte maps to one character.

The values themselves (angles, dates, status flags) and their text forms live in
``wire_values``; cutting a byte stream into command bodies, mount-side, in ``request_framer``.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from datetime import date, time
from enum import Enum
from typing import Any

from .._exceptions import MountReplyError, ProtocolError
from .wire_values import (
    DEGREE_MARKS,
    Direction,
    MeridianSettings,
    TrackRate,
    format_date,
    format_dms,
    format_hms,
    format_latitude,
    format_longitude,
    format_meridian,
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
    11: "sync is not allowed near the pole",
    12: "sync point is too far from the current position",
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


@dataclass(frozen=True)
class Command:
    """One ZWO command: its code, how its arguments look, how its reply is framed and parsed.

    ``args`` is a regex the text after the code must match in full (``None``: no arguments).
    ``parse`` turns the reply body (``#`` stripped) into a value; it raises ``ProtocolError`` on
    text that is not a valid reply and ``MountReplyError`` when the mount refused the command.
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

    @property
    def args_re(self) -> re.Pattern[str] | None:
        return _ARGS_RE.get(self.code)


_T, _C, _G, _N = ReplyKind.TEXT, ReplyKind.CHAR, ReplyKind.GOTO, ReplyKind.NONE
_HMS_ARG = r" ?\d{1,2}:\d{1,2}(?::\d{1,2}(?:\.\d)?|\.\d)"
_DMS_ARG = r"[+-]?\d{1,3}[" + re.escape(DEGREE_MARKS) + r"]\d{1,2}(?:[:']\d{1,2})?"

COMMANDS: tuple[Command, ...] = (
    # Date, time, site
    Command("SC", _C, "set local date MM/DD/YY", r"\d{2}/\d{2}/\d{2}"),
    Command("GC", _T, "get local date", parse=parse_date),
    Command("SL", _C, "set local time HH:MM:SS", r"\d{2}:\d{2}:\d{2}"),
    Command("GL", _T, "get local time", parse=parse_time),
    Command("SS", _C, "set sidereal time HH:MM:SS (1 or e2#)", r"\d{2}:\d{2}:\d{2}"),
    Command("GS", _T, "get local sidereal time", parse=parse_hms),
    Command("GH", _T, "get daylight-saving flag", parse=_flag01),
    Command("SH", _C, "set daylight-saving flag", r"[01]"),
    Command("SG", _C, "set time zone (negated UTC offset) sHH or sHH:MM", r"[+-]\d{1,2}(?::\d{2})?"),
    Command("GG", _T, "get time zone (negated UTC offset)", parse=parse_utc_offset),
    Command("St", _C, "set latitude sDD*MM:SS", _DMS_ARG),
    Command("Gt", _T, "get latitude", parse=parse_dms),
    Command("Sg", _C, "set longitude sDDD*MM:SS, east negative", _DMS_ARG),
    Command("Gg", _T, "get longitude, east negative", parse=parse_longitude),
    Command("SMTI", _C, "set date, time and zone MM/DD/YY&HH:MM:SS&sHH:MM",
            r"\d{2}/\d{2}/\d{2}&\d{2}:\d{2}:\d{2}&[+-]\d{2}:\d{2}"),
    Command("GMTI", _T, "get date, time and zone", parse=_gmti),
    Command("SMGE", _C, "set latitude and longitude", _DMS_ARG + "&" + _DMS_ARG),
    Command("GMGE", _T, "get latitude and longitude", parse=_pair(parse_dms, parse_longitude)),
    # Position and target
    Command("Gm", _T, "get pier side E/W/N", parse=lambda t: t if t in ("E", "W", "N") else _bad(t, ":Gm#")),
    Command("Sr", _C, "set target RA HH:MM:SS", _HMS_ARG),
    Command("Gr", _T, "get target RA", parse=parse_hms),
    Command("Sd", _C, "set target Dec sDD*MM:SS", _DMS_ARG),
    Command("Gd", _T, "get target Dec", parse=parse_dms),
    Command("GR", _T, "get current RA", parse=parse_hms),
    Command("GD", _T, "get current Dec", parse=parse_dms),
    Command("GZ", _T, "get azimuth", parse=parse_dms),
    Command("GA", _T, "get altitude", parse=parse_dms),
    Command("GMeq", _T, "get target RA and Dec", parse=_pair(parse_hms, parse_dms)),
    Command("GMEQ", _T, "get current RA and Dec", parse=_pair(parse_hms, parse_dms)),
    Command("GMZA", _T, "get azimuth and altitude", parse=_pair(parse_dms, parse_dms)),
    # Motion
    Command("MS", _G, "GOTO the target (bare 0 or eN#)"),
    Command("SMeq", _G, "set target and GOTO (e2# on some firmware)", _HMS_ARG + "&" + _DMS_ARG),
    Command("Q", _N, "stop all motion"),
    Command("Me", _N, "move east"), Command("Mw", _N, "move west"),
    Command("Mn", _N, "move north"), Command("Ms", _N, "move south"),
    Command("Qe", _N, "stop moving east"), Command("Qw", _N, "stop moving west"),
    Command("Qn", _N, "stop moving north"), Command("Qs", _N, "stop moving south"),
    Command("R", _N, "select move speed 0-9", r"\d"),
    Command("RG", _N, "move speed 0.5x (R1)"), Command("RC", _N, "move speed 1x (R2)"),
    Command("RM", _N, "move speed 720x (R8)"), Command("RS", _N, "move speed 1440x (R9)"),
    Command("Rv", _N, "variable move speed 0-1440x", r"\d{1,4}(?:\.\d{1,2})?", source="field"),
    Command("Rvr", _N, "variable RA move speed (fw 1.8.8)", r"\d{1,4}(?:\.\d{1,2})?", source="field"),
    Command("Rvd", _N, "variable Dec move speed (fw 1.8.8)", r"\d{1,4}(?:\.\d{1,2})?", source="field"),
    # Tracking
    Command("TQ", _N, "sidereal tracking rate"),
    Command("TS", _N, "solar tracking rate"),
    Command("TL", _N, "lunar tracking rate"),
    Command("GT", _T, "get tracking rate digit", parse=lambda t: t if t in "0123" and t else _bad(t, ":GT#")),
    Command("STR", _C, "custom tracking rate n.n (absent on real firmware)", r"\d{2}"),
    Command("Te", _C, "tracking on"),
    Command("Td", _C, "tracking off"),
    Command("GAT", _T, "get tracking state (0, 1 or eN)", parse=_gat, source="field", error_is_value=True),
    # Guiding
    Command("Mg", _N, "pulse guide d nnnn ms", r"[nsew]\d{1,5}"),
    Command("Rg", _N, "set guide rate (fraction of sidereal)", r"\d{1,2}(?:\.\d{1,2})?"),
    Command("Ggr", _T, "get guide rate", parse=_float_text, source="field"),
    # Sync and alignment
    Command("CM", _T, "sync to the target (N/A#)", parse=_sync_ack),
    Command("SMMC", _T, "set target and sync", _HMS_ARG + "&" + _DMS_ARG, parse=_sync_ack),
    Command("NSC", _C, "clear alignment points", source="field"),
    # Home, park
    Command("hC", _N, "go to mechanical home"),
    Command("Gh", _T, "homed? (unreliable)", parse=_text, source="field"),
    Command("SOa", _C, "set current position as home", source="field"),
    Command("hP", _N, "go to factory park (latches a stored parked state)", source="field"),
    Command("Sp01", _C, "store current position as park position 1", source="field",
            failure_codes=PARK_SET_CODES),
    Command("Spu", _C, "unpark (clear the parked latch)", source="field"),
    Command("Gps", _T, "park status 0-3 (empty on some firmware)", parse=_gps, source="field"),
    # Meridian and limits
    Command("STa", _C, "meridian settings f t s nn", r"[01][01][+-]\d{2}", source="field"),
    Command("GTa", _T, "get meridian settings", parse=parse_meridian, source="field"),
    Command("SLE", _C, "altitude limits on", source="field"),
    Command("SLD", _C, "altitude limits off", source="field"),
    Command("GLC", _T, "altitude limits on?", parse=_flag01, source="field"),
    Command("SLH", _C, "upper altitude limit 60-90", r"[+-]?\d{1,2}", source="field"),
    Command("GLH", _T, "get upper altitude limit", parse=_int_text, source="field"),
    Command("SLL", _C, "lower altitude limit 0-30, unsigned two digits", r"[+-]?\d{1,2}", source="field"),
    Command("GLL", _T, "get lower altitude limit", parse=_int_text, source="field"),
    Command("SRl", _C, "heavy-duty mode: top speed 720 or 1440", r"\d{3,4}", source="field"),
    Command("GRl", _T, "get heavy-duty top speed", parse=_int_text, source="field"),
    # Mode, buzzer, identity
    Command("AP", _N, "switch to equatorial mode (after restart)", source="field"),
    Command("AA", _N, "switch to alt-az mode (after restart)", source="field"),
    Command("SBu", _N, "buzzer 0 mute, 1 low, 2 loud", r"[012]"),
    Command("GBu", _T, "get buzzer", parse=_int_text),
    Command("GU", _T, "get status flags", parse=parse_status),
    Command("GV", _T, "get firmware version", parse=_text),
    Command("GVP", _T, "get model", parse=_model_name),
    Command("GVT", _T, "get firmware compile time", parse=_text),
    Command("GBl", _T, "get Bluetooth name", parse=_text, source="field"),
    Command("SBl", _C, "set Bluetooth name suffix", r"[A-Za-z0-9]{1,12}", source="field"),
    Command("BS", _T, "Bluetooth pairing id (OK#/NO#)", r"[A-Za-z0-9]{1,12}", parse=_text, source="field"),
)


def _bad(text: str, what: str) -> Any:
    raise ProtocolError(f"not a {what} reply: {text!r}")


BY_CODE: dict[str, Command] = {command.code: command for command in COMMANDS}
_ARGS_RE: dict[str, re.Pattern[str]] = {c.code: re.compile(c.args) for c in COMMANDS if c.args is not None}
# Longest code first so 'GVP' wins over 'GV', 'SLH' over 'SL', 'Rvr' over 'Rv' over 'R'.
_CODES_LONGEST_FIRST = sorted(BY_CODE, key=len, reverse=True)


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


def flag_reply(command: Command, value: bool) -> str:
    """A yes/no answer framed as ``command``'s reply kind says: a setter's bare ``1``/``0``, a query's ``1#``/``0#``."""
    if command.kind is ReplyKind.CHAR:
        return char_reply(value)
    if command.kind is ReplyKind.TEXT:
        return char_reply(value) + "#"
    raise ProtocolError(f":{command.code}# has no yes/no reply (its replies are {command.kind.value})")


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


# Builders for commands with arguments: each does the unit and sign conventions once.


def set_date(day: date) -> Request:
    return request("SC", format_date(day))


def set_time(clock: time) -> Request:
    return request("SL", format_time(clock))


def set_utc_offset(utc_offset_hours: float) -> Request:
    return request("SG", format_utc_offset(utc_offset_hours))


def set_date_time_zone(day: date, clock: time, utc_offset_hours: float) -> Request:
    return request("SMTI", f"{format_date(day)}&{format_time(clock)}&{format_utc_offset(utc_offset_hours)}")


def set_latitude(latitude: float) -> Request:
    return request("St", format_latitude(latitude))


def set_longitude(east_longitude: float) -> Request:
    return request("Sg", format_longitude(east_longitude))


def set_target_ra(hours: float) -> Request:
    return request("Sr", format_hms(hours))


def set_target_dec(degrees: float) -> Request:
    if not -90.0 <= degrees <= 90.0:
        raise ProtocolError(f"declination out of range: {degrees}")
    return request("Sd", format_dms(degrees))


def move(direction: Direction) -> Request:
    return request("M" + direction.value)


def stop_direction(direction: Direction) -> Request:
    return request("Q" + direction.value)


def set_move_speed_index(index: int) -> Request:
    if not 0 <= index <= 9:
        raise ProtocolError(f"move speed index out of range: {index}")
    return request("R", str(index))


def set_variable_speed(multiple_of_sidereal: float) -> Request:
    if not 0.0 <= multiple_of_sidereal <= 1440.0:
        raise ProtocolError(f"variable speed out of range: {multiple_of_sidereal}")
    return request("Rv", f"{multiple_of_sidereal:.2f}")


def pulse_guide(direction: Direction, milliseconds: int) -> Request:
    if not 0 <= milliseconds <= 9999:
        raise ProtocolError(f"pulse length out of range: {milliseconds}")
    return request("Mg", f"{direction.value}{milliseconds:04d}")


def set_guide_rate(fraction_of_sidereal: float) -> Request:
    if not 0.1 <= round(fraction_of_sidereal, 2) <= 0.9:
        raise ProtocolError(f"guide rate out of range 0.1-0.9: {fraction_of_sidereal}")
    return request("Rg", f"{fraction_of_sidereal:.2f}")


def set_tracking_rate(rate: TrackRate) -> Request:
    return request({TrackRate.SIDEREAL: "TQ", TrackRate.SOLAR: "TS", TrackRate.LUNAR: "TL"}[rate])


def set_meridian(settings: MeridianSettings) -> Request:
    if not -15 <= settings.limit_degrees <= 15:
        raise ProtocolError(f"meridian limit out of range: {settings.limit_degrees}")
    return request("STa", format_meridian(settings))


def set_upper_limit(degrees: int) -> Request:
    if not 60 <= degrees <= 90:
        raise ProtocolError(f"upper altitude limit out of range 60-90: {degrees}")
    return request("SLH", f"{degrees:02d}")


def set_lower_limit(degrees: int) -> Request:
    if not 0 <= degrees <= 30:
        raise ProtocolError(f"lower altitude limit out of range 0-30: {degrees}")
    return request("SLL", f"{degrees:02d}")


def set_heavy_duty(on: bool) -> Request:
    return request("SRl", "720" if on else "1440")


def set_buzzer(level: int) -> Request:
    if level not in (0, 1, 2):
        raise ProtocolError(f"buzzer level must be 0, 1 or 2: {level}")
    return request("SBu", str(level))
