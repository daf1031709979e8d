"""Values on the ZWO wire and their text forms: angles, dates, times, time zones, status, meridian.

Pure functions and small value types, no I/O. ``protocol`` builds its command table on them; the
driver parses replies and the emulator formats them with the same functions, so a sign or rounding
convention lives in exactly one place. Conventions follow real mounts (``shared/zwo/field-notes.md``):
the time-zone sign is negated and longitude is east-negative.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from datetime import date, time
from enum import Enum

from .._exceptions import ProtocolError

# --------------------------------------------------------------------------------------------
# Sexagesimal formats
# --------------------------------------------------------------------------------------------

#: Marks firmware puts between degrees and minutes (``*``, ``°``, the LX200 ``0xDF``, ``:``).
DEGREE_MARKS = "*°ß\xdf:"


def _split_seconds(total: int) -> tuple[int, int, int]:
    whole, seconds = divmod(total, 60)
    degrees, minutes = divmod(whole, 60)
    return degrees, minutes, seconds


def format_hms(hours: float) -> str:
    """``HH:MM:SS`` for an hour angle or RA; rounding carries and 23:59:59.7 wraps to 00:00:00."""
    _check_finite(hours)
    total = round(hours * 3600.0) % 86400
    h, m, s = _split_seconds(total)
    return f"{h:02d}:{m:02d}:{s:02d}"


def format_dms(degrees: float, width: int = 2, signed: bool = True, mark: str = "*") -> str:
    """``sDD*MM:SS``; rounding carries into minutes and degrees, and a small negative keeps its sign."""
    _check_finite(degrees)
    total = round(abs(degrees) * 3600.0)
    d, m, s = _split_seconds(total)
    body = f"{d:0{width}d}{mark}{m:02d}:{s:02d}"
    if not signed:
        return body
    return ("-" if degrees < 0 and total > 0 else "+") + body


def format_azimuth(degrees: float) -> str:
    """``DDD*MM:SS`` in [0, 360) for ``:GZ#``/``:GMZA#``: rounding 359.99999 must give 000, not 360."""
    _check_finite(degrees)
    total = round(degrees * 3600.0) % (360 * 3600)
    d, m, s = _split_seconds(total)
    return f"{d:03d}*{m:02d}:{s:02d}"


def format_latitude(latitude: float) -> str:
    """Latitude as the mount takes it: ``sDD*MM:SS``."""
    return format_dms(latitude, 2)


def format_longitude(east_longitude: float) -> str:
    """Longitude as the mount takes it: ``sDDD*MM:SS``, **east negative** (Meade convention)."""
    west = -east_longitude
    if west <= -180.0:  # keep within the mount's -180..+180
        west += 360.0
    if west > 180.0:
        west -= 360.0
    return format_dms(west + 0.0, 3)


def format_date(day: date) -> str:
    """``MM/DD/YY``: the mount assumes the 21st century."""
    return f"{day.month:02d}/{day.day:02d}/{day.year % 100:02d}"


def format_time(clock: time) -> str:
    """``HH:MM:SS``; fractions of a second are dropped (the mount keeps whole seconds)."""
    return f"{clock.hour:02d}:{clock.minute:02d}:{clock.second:02d}"


def format_utc_offset(utc_offset_hours: float) -> str:
    """The mount's time-zone field ``sHH:MM``: the **negated** UTC offset (UTC+8 is ``-08:00``)."""
    _check_finite(utc_offset_hours)
    minutes = round(-utc_offset_hours * 60.0)
    sign = "-" if minutes < 0 else "+"
    h, m = divmod(abs(minutes), 60)
    return f"{sign}{h:02d}:{m:02d}"


def _check_finite(value: float) -> None:
    if not math.isfinite(value):
        raise ProtocolError(f"cannot format non-finite value {value!r}")


_HMS_RE = re.compile(r"\s*(\d{1,2}):(\d{1,2})(?::(\d{1,2}(?:\.\d+)?)|\.(\d))\s*")
_DMS_RE = re.compile(
    r"\s*([+-]?)\s*(\d{1,3})[" + re.escape(DEGREE_MARKS) + r"](\d{1,2})(?:[:'](\d{1,2}(?:\.\d+)?))?\"?\s*"
)


def parse_hms(text: str) -> float:
    """Hours from ``HH:MM:SS`` (or the short ``HH:MM.T``)."""
    match = _HMS_RE.fullmatch(text)
    if not match:
        raise ProtocolError(f"not a HH:MM:SS value: {text!r}")
    h, m = int(match.group(1)), int(match.group(2))
    s = float(match.group(3)) if match.group(3) is not None else int(match.group(4)) * 6.0
    if h > 23 or m > 59 or s >= 60.0:
        raise ProtocolError(f"HH:MM:SS value out of range: {text!r}")
    return h + m / 60.0 + s / 3600.0


def parse_dms(text: str) -> float:
    """Degrees from ``sDD*MM:SS``, ``sDDD*MM:SS`` or without seconds; ``*``, ``°`` or ``ß`` as mark."""
    match = _DMS_RE.fullmatch(text)
    if not match:
        raise ProtocolError(f"not a sDD*MM:SS value: {text!r}")
    d, m = int(match.group(2)), int(match.group(3))
    s = float(match.group(4)) if match.group(4) is not None else 0.0
    if m > 59 or s >= 60.0 or d > 360:
        raise ProtocolError(f"sDD*MM:SS value out of range: {text!r}")
    value = d + m / 60.0 + s / 3600.0
    return -value if match.group(1) == "-" else value


def parse_longitude(text: str) -> float:
    """East-positive longitude from the mount's east-negative ``sDDD*MM:SS``."""
    return -parse_dms(text) + 0.0


def parse_date(text: str) -> date:
    match = re.fullmatch(r"(\d{2})/(\d{2})/(\d{2})", text)
    if not match:
        raise ProtocolError(f"not a MM/DD/YY date: {text!r}")
    try:
        return date(2000 + int(match.group(3)), int(match.group(1)), int(match.group(2)))
    except ValueError as exc:
        raise ProtocolError(f"impossible date {text!r}") from exc


def parse_time(text: str) -> time:
    match = re.fullmatch(r"(\d{2}):(\d{2}):(\d{2})", text)
    if not match:
        raise ProtocolError(f"not a HH:MM:SS time: {text!r}")
    try:
        return time(int(match.group(1)), int(match.group(2)), int(match.group(3)))
    except ValueError as exc:
        raise ProtocolError(f"impossible time {text!r}") from exc


def parse_utc_offset(text: str) -> float:
    """UTC offset in hours from the mount's negated ``sHH:MM`` (or ``sHH``)."""
    match = re.fullmatch(r"([+-]?)(\d{1,2})(?::(\d{2}))?", text)
    if not match:
        raise ProtocolError(f"not a time-zone value: {text!r}")
    minutes = int(match.group(2)) * 60 + int(match.group(3) or 0)
    if minutes > 14 * 60:
        raise ProtocolError(f"time-zone value out of range: {text!r}")
    return (minutes if match.group(1) == "-" else -minutes) / 60.0


# --------------------------------------------------------------------------------------------
# Typed values
# --------------------------------------------------------------------------------------------


class Direction(Enum):
    """Motion and guide directions as the mount names them."""

    NORTH = "n"
    SOUTH = "s"
    EAST = "e"
    WEST = "w"


class MountMode(Enum):
    EQUATORIAL = "G"
    ALTAZ = "Z"
    UNKNOWN = "?"


class TrackRate(Enum):
    """Tracking rates the mount offers (custom ``:STR`` rates are not on real firmware)."""

    SIDEREAL = "sidereal"
    LUNAR = "lunar"
    SOLAR = "solar"


#: Manual move speeds selected by ``:R0#``..``:R9#``, in multiples of the sidereal rate.
SLEW_SPEEDS: tuple[float, ...] = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 20.0, 60.0, 720.0, 1440.0)

#: ``:GT#`` digit -> rate; firmware disagrees on 1 and 2 (field notes §6 row 6).
GT_ENGLISH = {"0": TrackRate.SIDEREAL, "1": TrackRate.SOLAR, "2": TrackRate.LUNAR}
GT_CHINESE = {"0": TrackRate.SIDEREAL, "1": TrackRate.LUNAR, "2": TrackRate.SOLAR}
#: The two orders by the name firmware variants use for them.
GT_MAPPINGS = {"english": GT_ENGLISH, "chinese": GT_CHINESE}
#: ``:GT#``'s digit for a custom (``:STR``) rate, on firmware that has one.
GT_CUSTOM = "3"


def format_tracking_rate(rate: TrackRate | None, mapping: str = "english") -> str:
    """The ``:GT#`` digit of ``rate`` in a firmware's ``mapping`` (None: a custom rate)."""
    if rate is None:
        return GT_CUSTOM
    return next(digit for digit, named in GT_MAPPINGS[mapping].items() if named is rate)


@dataclass(frozen=True)
class MountStatus:
    """The ``:GU#`` flags. Letters appear only when true; the digits are kept but not decoded."""

    tracking: bool = False  # no 'n'
    slewing: bool = False  # no 'N': a GOTO, home or park slew is running
    low_voltage: bool = False  # 'L'
    at_home: bool = False  # 'H' (firmware dependent)
    homing: bool = False  # 'h'
    mode: MountMode = MountMode.EQUATORIAL  # 'G' / 'Z'
    ra_stall: bool = False  # 'S'
    dec_stall: bool = False  # 's'
    st4_ra: bool = False  # 'T'
    st4_dec: bool = False  # 't'
    #: The firmware's own park shown: 'P' (dropped from firmware >= v1.8 documents) or, as real 1.8.8
    #: mounts show it, the digit 5 ending the word (``nGM000000005#`` parked, ``nGM040000895#`` right
    #: after ``:hP#``: real-transcripts-1.8.8.md §1 "Status word", S1/S2). Parked *or parking*: only
    #: ``:Gps#`` tells the two apart.
    parked: bool = False
    other_flags: str = ""  # letters nobody has decoded (e.g. 'M')
    digits: str = "000000000"


_KNOWN_FLAGS = "nNLHhGZSsTtP"


def format_status(status: MountStatus) -> str:
    """The ``:GU#`` body the emulator sends, in the documented letter order."""
    letters = "".join(
        flag
        for flag, on in (
            ("n", not status.tracking),
            ("N", not status.slewing),
            ("L", status.low_voltage),
            ("H", status.at_home),
            ("h", status.homing),
            ("G", status.mode is MountMode.EQUATORIAL),
            ("Z", status.mode is MountMode.ALTAZ),
            ("S", status.ra_stall),
            ("s", status.dec_stall),
            ("T", status.st4_ra),
            ("t", status.st4_dec),
            ("P", status.parked),
        )
        if on
    )
    return letters + status.other_flags + status.digits


def parse_status(text: str) -> MountStatus:
    """Decode ``:GU#``: clients may only test whether a letter is present, so that is all we do."""
    match = re.fullmatch(r"([A-Za-z]*)(\d*)", text)
    if not match or not (match.group(1) or match.group(2)):
        raise ProtocolError(f"not a :GU# status: {text!r}")
    letters = set(match.group(1))
    mode = MountMode.UNKNOWN
    if "Z" in letters:
        mode = MountMode.ALTAZ
    elif "G" in letters:
        mode = MountMode.EQUATORIAL
    return MountStatus(
        tracking="n" not in letters,
        slewing="N" not in letters,
        low_voltage="L" in letters,
        at_home="H" in letters,
        homing="h" in letters,
        mode=mode,
        ra_stall="S" in letters,
        dec_stall="s" in letters,
        st4_ra="T" in letters,
        st4_dec="t" in letters,
        parked="P" in letters or match.group(2).endswith("5"),
        other_flags="".join(ch for ch in match.group(1) if ch not in _KNOWN_FLAGS),
        digits=match.group(2),
    )


@dataclass(frozen=True)
class MeridianSettings:
    """``:STa``/``:GTa#``: flip on GOTO (documented, "temporarily not supported"), track past, limit."""

    flip: bool = False
    track_after: bool = False
    limit_degrees: int = 0


def format_meridian(settings: MeridianSettings) -> str:
    limit = settings.limit_degrees
    return f"{int(settings.flip)}{int(settings.track_after)}{'-' if limit < 0 else '+'}{abs(limit):02d}"


def parse_meridian(text: str) -> MeridianSettings:
    match = re.fullmatch(r"([01])([01])([+-])(\d{1,2})", text)
    if not match:
        raise ProtocolError(f"not a :GTa# meridian setting: {text!r}")
    limit = int(match.group(4))
    signed_limit = -limit if match.group(3) == "-" else limit
    return MeridianSettings(match.group(1) == "1", match.group(2) == "1", signed_limit)
