"""The mount's side of the ZWO protocol: one request body in, the reply a real mount sends out.

One table (:data:`ANSWERS`) says what each command asks of the mount; the command's row in
``protocol.COMMANDS`` parses its argument and formats its reply; a :class:`Backend` is the mount
that answers. Two backends serve it: the emulator's (``emulator/responder.py``: the modelled mount,
with its firmware's quirks) and the shared ZWO port's (``bridges/zwo_backend.py``: the Telescope,
answering from its snapshots, refusing what changes the mount for every program). Where they answer
differently, the backend says so; the table is the same.

The rules every answer follows (field notes §2-§4): a request the mount does not know (an unknown or
miscased code) gets no reply; a known command whose arguments are malformed, or whose values do not
parse, gets its row's refusal (``Command.refused``: a setter's bare ``0``, ``e2#`` for a target, a
GOTO's ``e2#``) without reaching the backend; otherwise the backend acts and its value is framed
by the row (a setter's bare ``1``/``0``, a GOTO's bare ``0`` or ``eN#``, ``#``-terminated queries,
silence for motion).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from datetime import date, datetime, time
from typing import Any, Protocol

from .._exceptions import AlpacaZwoError, ProtocolError
from .protocol import BY_CODE, TRACKING_RATE_CODES, CommandMatch, TrackingState, match_command
from .wire_values import Direction, MeridianSettings, MountMode, MountStatus, TrackRate

__all__ = ["ANSWERS", "Backend", "NoReply", "Refusal", "Verbatim", "answer"]


@dataclass(frozen=True)
class Verbatim:
    """A backend's own reply text for a request, past the table: firmware that does not know a command
    (``None``: silence, as for any unknown code), or the shared port relaying a command to the mount."""

    reply: str | None


class NoReply(AlpacaZwoError):
    """Raised by a backend that has nothing to say (no reading yet, the mount unreachable): no reply,
    as from a mount that is not there."""


class Refusal(AlpacaZwoError):
    """Raised by a backend that refuses a command: ``value`` is the reply value the mount gives that
    refusal (formatted by the command's row: a bare ``0``, ``e3#`` …), ``reason`` says why. The
    dispatcher fills in ``reply``, the text, and raises it on, so the shared port can count it."""

    def __init__(self, value: Any, reason: str) -> None:
        super().__init__(reason)
        self.value = value
        self.reason = reason
        self.reply: str | None = None


class Backend(Protocol):
    """What the mount knows and does, one method per thing a command asks (in the table's order).

    Values are in the units of ``wire_values`` (hours, degrees east-positive, the true UTC offset);
    setters answer whether the mount took the value. A backend may raise :class:`NoReply` or
    :class:`Refusal` from any method.
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


#: What a command asks of the backend: ``answer(backend, argument)`` with the argument parsed by the
#: command's row (None for a command without one); the value returned is framed by the row.
Answer = Callable[[Backend, Any], Any]


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


def _move(direction: Direction) -> Answer:
    return lambda b, _a: b.move(direction)


def _stop_axis(direction: Direction) -> Answer:
    return lambda b, _a: b.stop_axis(direction)


def _tracking_rate(rate: TrackRate) -> Answer:
    return lambda b, _a: b.set_tracking_rate(rate)


ANSWERS: dict[str, Answer] = {
    # Date, time, site
    "SC": lambda b, day: b.set_clock(day, None, None),
    "GC": lambda b, _a: b.clock().date(),
    "SL": lambda b, clock: b.set_clock(None, clock, None),
    "GL": lambda b, _a: b.clock().time(),
    "SS": lambda b, hours: b.set_sidereal_time(hours),
    "GS": lambda b, _a: b.sidereal_time(),
    "GH": lambda b, _a: b.daylight_saving(),
    "SH": lambda b, on: b.set_daylight_saving(on),
    "SG": lambda b, offset: b.set_clock(None, None, offset),
    "GG": lambda b, _a: b.utc_offset(),
    "St": lambda b, latitude: b.set_site(latitude, None),
    "Gt": lambda b, _a: b.site()[0],
    "Sg": lambda b, longitude: b.set_site(None, longitude),
    "Gg": lambda b, _a: b.site()[1],
    "SMTI": lambda b, value: b.set_clock(*value),
    "GMTI": lambda b, _a: _date_time_zone(b.clock(), b.utc_offset()),
    "SMGE": lambda b, site: b.set_site(*site),
    "GMGE": lambda b, _a: b.site(),
    # Position and target
    "Gm": lambda b, _a: b.pier_letter(),
    "Sr": lambda b, ra: b.set_target(ra, None),
    "Gr": lambda b, _a: b.target()[0],
    "Sd": lambda b, dec: b.set_target(None, dec),
    "Gd": lambda b, _a: b.target()[1],
    "GR": lambda b, _a: b.position()[0],
    "GD": lambda b, _a: b.position()[1],
    "GZ": lambda b, _a: b.horizontal(False)[1],
    "GA": lambda b, _a: b.horizontal(False)[0],
    "GMeq": lambda b, _a: b.target(),
    "GMEQ": lambda b, _a: b.position(),
    "GMZA": lambda b, _a: b.horizontal(True)[::-1],
    # Motion
    "MS": lambda b, _a: b.goto(),
    "SMeq": _goto_to,
    "Q": lambda b, _a: b.stop(),
    **{"M" + d.value: _move(d) for d in Direction},
    **{"Q" + d.value: _stop_axis(d) for d in Direction},
    "R": lambda b, index: b.select_speed(index),
    "RG": lambda b, _a: b.select_speed(1),
    "RC": lambda b, _a: b.select_speed(2),
    "RM": lambda b, _a: b.select_speed(8),
    "RS": lambda b, _a: b.select_speed(9),
    "Rv": lambda b, multiple: b.set_variable_speed(multiple, None),
    "Rvr": lambda b, multiple: b.set_variable_speed(multiple, 0),
    "Rvd": lambda b, multiple: b.set_variable_speed(multiple, 1),
    # Tracking
    **{code: _tracking_rate(rate) for rate, code in TRACKING_RATE_CODES.items()},
    "GT": lambda b, _a: b.tracking_rate_digit(),
    "STR": lambda b, multiple: b.set_custom_rate(multiple),
    "Te": lambda b, _a: b.set_tracking(True),
    "Td": lambda b, _a: b.set_tracking(False),
    "GAT": lambda b, _a: b.tracking_state(),
    # Guiding
    "Mg": lambda b, pulse: b.pulse(*pulse),
    "Rg": lambda b, fraction: b.set_guide_rate(fraction),
    "Ggr": lambda b, _a: b.guide_rate(),
    # Sync and alignment
    "CM": lambda b, _a: b.sync(),
    "SMMC": _sync_to,
    "NSC": lambda b, _a: b.clear_alignment(),
    # Home, park
    "hC": lambda b, _a: b.home(),
    "Gh": lambda b, _a: b.home_flag(),
    "SOa": lambda b, _a: b.set_current_as_home(),
    "hP": lambda b, _a: b.park(),
    "Sp01": lambda b, _a: b.set_park_position(),
    "Spu": lambda b, _a: b.unpark(),
    "Gps": lambda b, _a: b.park_status(),
    # Meridian and limits
    "STa": lambda b, settings: b.set_meridian(settings),
    "GTa": lambda b, _a: b.meridian(),
    "SLE": lambda b, _a: b.set_limits_enabled(True),
    "SLD": lambda b, _a: b.set_limits_enabled(False),
    "GLC": lambda b, _a: b.limits_enabled(),
    "SLH": lambda b, degrees: b.set_upper_limit(degrees),
    "GLH": lambda b, _a: b.upper_limit(),
    "SLL": lambda b, degrees: b.set_lower_limit(degrees),
    "GLL": lambda b, _a: b.lower_limit(),
    "SRl": lambda b, multiple: b.set_max_speed(multiple),
    "GRl": lambda b, _a: b.max_speed(),
    # Mode, buzzer, identity
    "AP": lambda b, _a: b.set_mode(MountMode.EQUATORIAL),
    "AA": lambda b, _a: b.set_mode(MountMode.ALTAZ),
    "SBu": lambda b, level: b.set_buzzer(level),
    "GBu": lambda b, _a: b.buzzer(),
    "GU": lambda b, _a: b.status(),
    "GV": lambda b, _a: b.firmware_version(),
    "GVP": lambda b, _a: b.model_name(),
    "GVT": lambda b, _a: b.compile_time(),
    "GBl": lambda b, _a: b.ble_name(),
    "SBl": lambda b, suffix: b.set_ble_suffix(suffix),
    "BS": lambda b, pairing_id: b.ble_pair(pairing_id),
}

_missing = set(BY_CODE) ^ set(ANSWERS)
if _missing:  # the command table and this one must hold the same codes: fail at import, never go silent
    raise RuntimeError(f"zwo.dispatch and protocol.COMMANDS disagree on {sorted(_missing)}")


def _date_time_zone(local: datetime, utc_offset: float) -> tuple[date, time, float]:
    return local.date(), local.time(), utc_offset


def answer(backend: Backend, body: str) -> str | None:
    """The reply text for request ``body`` (the text between ``:`` and ``#``), None for silence.

    Raises :class:`Refusal` (with ``reply`` filled in) when the backend refused the command.
    """
    match = match_command(body)
    if match is None:
        return None  # unknown or miscased: a real mount stays silent
    command = match.command
    try:
        own = backend.intercept(match)
        if own is not None:
            return own.reply
        argument = None
        if command.argument is not None:
            if not match.well_formed:
                return command.reply_text(command.refused)
            try:
                argument = command.argument.parse(match.argument)
            except (ProtocolError, ValueError):
                return command.reply_text(command.refused)
        return command.reply_text(ANSWERS[command.code](backend, argument))
    except NoReply:
        return None
    except Refusal as refusal:
        refusal.reply = command.reply_text(refusal.value)
        raise
