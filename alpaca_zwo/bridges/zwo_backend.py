"""What the shared ZWO port answers: the mount's protocol served on top of a Telescope.

``zwo/dispatch.py`` answers every command from one table, the same the emulator answers with; this
is the port's backend behind it, so that a ZWO or LX200 driver (INDI's ``indi_lx200am5``) shares the
mount with Alpaca clients:

* Queries are answered from the state snapshot (``telescope.mount.state`` and the Telescope's
  getters), never with a serial exchange per program; the few settings the poller does not read
  (meridian, limits, heavy duty, buzzer, daylight saving) come from one cached read
  (``StoredSettings.current``).
* Motion and settings go through the Telescope's public methods, so horizon and altitude limits,
  the parked state, the MoveAxis watchdog and abort-from-anyone apply exactly as for Alpaca.
* Commands that change the mount for every program (``Effect.GUARDED`` in the command table) are
  refused, with the refusal the mount itself gives, unless ``zwo_port.allow_dangerous`` lists them.
  Allowed, the stored settings (meridian, altitude limits, heavy duty, buzzer) go through their one
  owner, ``StoredSettings.apply``, as the ``zwo:*`` Actions and the page do (one range check, the
  meridian mirrored in the configuration, in force for DestinationSideOfPier); the rest (mode, home and
  park positions, alignment, sidereal time, Bluetooth) are relayed to the mount as they are
  (``RawCommands.relay``).

Telescope refusals become the mount's own error codes (field notes §4.1): a target under the
configured horizon profile or below altitude 0 is ``e5#``, under ``min_altitude_deg`` ``e6#``; a
GOTO while a GOTO, home or park runs ``e3#`` (as the mount; INDI sends ``:Q#`` first), but a GOTO
while the axes still brake from a stop is accepted and queued behind the braking (the mount would
answer ``e3#``; the server does better, see the README's ZWO-port section); parked
``e4#`` (the emulator's guess, no published code), and so is a GOTO the observatory interlock refuses
(the safety monitor says unsafe; ``:Spu#`` and ``:Te#`` then answer ``0``); a sync while moving ``e4#``, and a sync the
server refuses otherwise (not tracking) ``e11#``; a lost mount link gets no reply, as from a mount
that is not there.

Each program has its own :class:`Session` (target, move speeds) and so its own backend; the time zone
programs set (:class:`SharedZone`) is one for the whole port, as the mount's own is.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import date, datetime, time, timedelta, timezone
from typing import TYPE_CHECKING, Any, NoReturn

from .._exceptions import (
    AlpacaError,
    AlpacaZwoError,
    DriverError,
    InvalidOperation,
    InvalidValue,
    MountReplyError,
    Parked,
    SafetyRefusal,
)
from ..clients import ClientKey
from ..sky import SIDEREAL_DEG_S, PierSide
from ..telescope import pointing
from ..zwo.dispatch import NoReply, Refusal, Verbatim
from ..zwo.protocol import BY_CODE, CommandMatch, Effect, TrackingState
from ..zwo.wire_values import (
    SLEW_SPEEDS,
    Direction,
    MeridianSettings,
    MountMode,
    MountStatus,
    TrackRate,
    format_tracking_rate,
)

if TYPE_CHECKING:
    from ..mount.state import MountSettings, MountState
    from ..telescope.device import Telescope

__all__ = ["Session", "SharedZone", "TelescopeBackend"]

log = logging.getLogger(__name__)

#: Alpaca TrackingRate codes (DriveRates) by the rate :TQ#/:TL#/:TS# select.
DRIVE_RATE = {TrackRate.SIDEREAL: 0, TrackRate.LUNAR: 1, TrackRate.SOLAR: 2}
GUIDE_DIRECTION = {Direction.NORTH: 0, Direction.SOUTH: 1, Direction.EAST: 2, Direction.WEST: 3}
#: :M?# -> (axis, sign): axis 0 is RA (+ east), axis 1 is Dec (+ north), as Telescope.move_axis takes them.
MOVES = {Direction.EAST: (0, 1.0), Direction.WEST: (0, -1.0), Direction.NORTH: (1, 1.0), Direction.SOUTH: (1, -1.0)}
#: The limits (``pointing.Blocked.limit``) the mount refuses a GOTO under with ``e5#``: its horizon, and
#: the horizon profile the server adds to it; every other limit is an altitude limit, ``e6#``.
HORIZON_LIMITS = frozenset({pointing.HORIZON, pointing.MOUNT_HORIZON})
#: A clock or site setter within the wire's resolution of what the server has changes nothing, so a
#: program pushing the same clock (whole seconds) never truncates the server's.
TIME_TOLERANCE_S = 1.5
SITE_TOLERANCE_DEG = 1.5 / 3600.0
#: Commands real firmware does not have (:STR#): no reply, as for any unknown command.
_UNKNOWN = Verbatim(None)
#: ``:SRl#``'s two top speeds, by the heavy-duty switch they mean.
HEAVY_DUTY_BY_SPEED = {720: True, 1440: False}


@dataclass
class Session:
    """One connected program's view of the mount: its own target and move speeds.

    On the mount these are global, but programs sharing the port must not retarget each other's
    GOTO between ``:Sr``/``:Sd`` and ``:MS#``, so each gets its own.
    """

    key: ClientKey
    target: tuple[float, float] | None = None
    speed: float = SLEW_SPEEDS[9]  # multiple of sidereal; the mount powers up at :R9#
    axis_speed: list[float | None] = field(default_factory=lambda: [None, None])  # :Rvr/:Rvd
    moved_axes: set[int] = field(default_factory=set)  # axes this program set moving


class SharedZone:
    """The time zone the port's programs see and set (``:SG#``, ``:SMTI#``, ``:GG#``): it only changes how
    the port reads and shows local times; the mount keeps the zone the server pushed. ``hours`` is None
    until a program sets one: the port then shows the zone the server sets the mount's clock in (the
    site's, ``Mount.clock_zone``), so ``:GG#`` and ``:GL#`` start out as the mount's own."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.hours: float | None = None

    def set(self, hours: float) -> None:
        with self.lock:
            self.hours = hours


class TelescopeBackend:
    """One program's ``zwo.protocol.Backend``: the Telescope, as that program sees the mount.

    Thread-safe as the port uses it: one thread per program uses its backend; what programs share
    (the Telescope, the zone) locks itself.
    """

    def __init__(self, telescope: Telescope, session: Session, zone: SharedZone) -> None:
        self.telescope = telescope
        self.session = session
        self.zone = zone

    @property
    def _state(self) -> MountState:
        return self.telescope.mount.state

    def intercept(self, match: CommandMatch) -> Verbatim | None:
        """Guarded commands: refused unless allowed, then relayed to the mount as they are (the meridian
        setting goes through the table, to the Telescope). :STR#: silence, as real firmware."""
        command = match.command
        if command.code == "STR":
            return _UNKNOWN
        if command.has(Effect.GUARDED):
            allowed = self.telescope.settings.zwo_port.allow_dangerous
            if command.code not in allowed and "all" not in allowed:
                self._refuse_guarded(command.code)
            if not command.has(Effect.STORED):  # a stored setting goes to its owner, via the setters below
                return Verbatim(self.telescope.raw_commands.relay(f":{command.code}{match.argument}#") or None)
        return None

    @staticmethod
    def _refuse_guarded(code: str) -> NoReturn:
        raise Refusal(BY_CODE[code].refused, f":{code}# changes the mount for every program; "
                                             "allow it in [zwo_port] allow_dangerous")

    # -- date, time, site ------------------------------------------------------------------------

    def clock(self) -> datetime:
        return self.telescope.clock.utc_now() + timedelta(hours=self.utc_offset())

    def utc_offset(self) -> float:
        hours = self.zone.hours
        if hours is None:
            return self.telescope.mount.clock_zone(self.telescope.clock.utc_now()).total_seconds() / 3600.0
        return hours

    def set_clock(self, day: date | None, clock: time | None, utc_offset: float | None) -> bool:
        """:SC/:SL set the server's clock (the Telescope's UTCDate, pushed to the mount); :SG only the
        zone programs see; :SMTI both."""
        if utc_offset is not None:
            self.zone.set(utc_offset)
            if day is None or clock is None:
                return True
        local = self.clock()
        return self._set_local(datetime.combine(local.date() if day is None else day,
                                                local.time() if clock is None else clock))

    def _set_local(self, local: datetime) -> bool:
        utc = (local - timedelta(hours=self.utc_offset())).replace(tzinfo=timezone.utc)
        if abs((utc - self.telescope.clock.utc_now()).total_seconds()) < TIME_TOLERANCE_S:
            return True
        try:
            self.telescope.clock.set_utc_date(utc)
        except InvalidValue:
            return False
        return True

    def sidereal_time(self) -> float:
        return self.telescope.clock.sidereal_time()

    def set_sidereal_time(self, hours: float) -> bool:
        self._refuse_guarded("SS")

    def daylight_saving(self) -> bool:
        return bool(self._stored("daylight_saving"))

    def set_daylight_saving(self, on: bool) -> bool:
        self._refuse_guarded("SH")

    def site(self) -> tuple[float, float]:
        return self.telescope.capabilities.site_latitude(), self.telescope.capabilities.site_longitude()

    def set_site(self, latitude: float | None, longitude: float | None) -> bool:
        """The Telescope's site, with Alpaca's validation, so every client shares one site."""
        t = self.telescope
        try:
            if latitude is not None and abs(latitude - t.capabilities.site_latitude()) >= SITE_TOLERANCE_DEG:
                t.capabilities.set_site_latitude(latitude)
            if longitude is not None and abs(longitude - t.capabilities.site_longitude()) >= SITE_TOLERANCE_DEG:
                t.capabilities.set_site_longitude(longitude)
        except AlpacaError:  # out of range, or not saved (full disk: SettingsNotSaved): refused, as the mount would
            return False
        return True

    # -- position, target, status ------------------------------------------------------------------

    def pier_letter(self) -> str:
        """``:Gm#``: the side of pier the server knows (its pointing state, right in either hemisphere),
        as the mount's letter, whatever that mount's firmware names (mount/pier.py)."""
        state = self._state
        if state.pier is None:
            raise NoReply
        if state.side is PierSide.UNKNOWN or state.altaz:
            return state.pier
        return "W" if state.side is PierSide.WEST else "E"

    def target(self) -> tuple[float, float]:
        if self.session.target is not None:
            return self.session.target
        try:
            return self.telescope.targets.target()
        except AlpacaError:
            return self.telescope.right_ascension(), self.telescope.declination()

    def set_target(self, ra: float | None, dec: float | None) -> bool:
        """This program's own target (see :class:`Session`); a Dec beyond ±90 is refused (e2#)."""
        if dec is not None and not -90.0 <= dec <= 90.0:
            return False
        current = self.target()
        self.session.target = (current[0] if ra is None else ra, current[1] if dec is None else dec)
        return True

    def position(self) -> tuple[float, float]:
        return self.telescope.right_ascension(), self.telescope.declination()

    def horizontal(self, paired: bool) -> tuple[float, float]:
        return self.telescope.altitude(), self.telescope.azimuth()

    def _goto_running(self) -> bool:
        """A GOTO, home or park under way (from anyone); manual moves do not count, as on the mount."""
        state = self._state
        return state.goto_running or (self.telescope.slewing() and not state.moving_axes)

    def status(self) -> MountStatus:
        """``:GU#``: the last polled flags, with tracking and slewing as the server knows them now.

        A motion the server started shows as slewing from the moment it was accepted until the
        supervisor has seen it end, so a driver that waits for ``N`` never sees it too early.
        """
        state = self._state
        status = state.status or MountStatus()
        slewing = self._goto_running()
        tracking = state.tracking.on if state.tracking is not None else status.tracking
        return dataclasses.replace(status, tracking=tracking, slewing=slewing,
                                   at_home=status.at_home and not slewing)

    # -- GOTO, sync ------------------------------------------------------------------------------

    def goto(self) -> int:
        ra, dec = self.target()
        if self._goto_running() and not self.telescope.motion.stopping():
            # A stop the server is finishing (INDI re-targets 100 ms after its :Q#) is no reason:
            # the supervisor holds the GOTO until the axes have braked, then sends it.
            raise Refusal(3, "a GOTO, home or park is already running")
        try:
            self.telescope.slew_to_coordinates_async(ra, dec)
        except (Parked, SafetyRefusal, InvalidValue, InvalidOperation) as exc:
            raise self._goto_refusal(exc, ra, dec) from exc
        except DriverError as exc:
            self._mount_refusal(exc)
        return 0

    def _goto_refusal(self, exc: AlpacaError, ra: float, dec: float) -> Refusal:
        """The code a GOTO's refusal goes back as: the mount's own ``eN#`` when the mount refused (its
        words, _exceptions.MOUNT_REFUSALS, made it an ASCOM error too), else the server's own reason."""
        code = _mount_code(exc)
        if code is not None:
            return Refusal(code, exc.message)
        if isinstance(exc, (Parked, SafetyRefusal)):  # the mount's "not now" (parked, or the safety monitor says no)
            return Refusal(4, exc.message)
        if isinstance(exc, InvalidValue):
            return Refusal(self._limit_code(ra, dec), exc.message)
        return Refusal(3, exc.message)

    def compound_goto_sync(self) -> bool:
        return False  # real firmware answers :SMeq#/:SMMC# with e2# (field notes §6 row 14)

    def _limit_code(self, ra: float, dec: float) -> int:
        """The mount's code for the limit the Telescope's one GoTo check names (``Telescope.goto_limit``):
        5 under a horizon (the configured profile, or altitude 0), 6 under or over an altitude limit."""
        blocked = self.telescope.goto_limit(ra, dec)
        if blocked is not None and (blocked.limit in HORIZON_LIMITS or blocked.altitude < 0.0):
            return 5
        return 6

    @staticmethod
    def _mount_refusal(exc: DriverError) -> NoReturn:
        """The mount's own ``eN#`` when it refused; silence when it could not be reached."""
        cause = exc.__cause__
        if isinstance(cause, MountReplyError) and cause.code is not None:
            raise Refusal(cause.code, exc.message) from exc
        log.info("ZWO port: %s", exc.message)
        raise NoReply from exc

    def sync(self) -> int:
        ra, dec = self.target()
        try:
            self.telescope.sync_to_coordinates(ra, dec)
        except (Parked, InvalidValue, InvalidOperation) as exc:
            raise Refusal(self._sync_code(exc), exc.message) from exc
        except DriverError as exc:
            self._mount_refusal(exc)
        return 0

    def _sync_code(self, exc: AlpacaError) -> int:
        """The code a sync's refusal goes back as: the mount's own, else the server's reason's."""
        code = _mount_code(exc)
        if code is not None:
            return code
        if isinstance(exc, Parked):
            return 4
        if isinstance(exc, InvalidValue):
            return 1
        return 4 if self.telescope.slewing() else 11

    def clear_alignment(self) -> bool:
        self._refuse_guarded("NSC")

    # -- manual motion, guiding, tracking ----------------------------------------------------------

    def stop(self) -> None:
        """``:Q#`` from any program stops every motion, whoever started it."""
        self.session.moved_axes.clear()
        with contextlib.suppress(Parked):  # nothing moves while parked
            self.telescope.abort_slew()

    def move(self, direction: Direction) -> None:
        """``:Me#`` etc.: MoveAxis at this program's ``:Rn``/``:Rv`` speed (latched when sent, as on the mount)."""
        axis, sign = MOVES[direction]
        multiple = self.session.axis_speed[axis] or self.session.speed
        rate = sign * max(multiple, SLEW_SPEEDS[0]) * SIDEREAL_DEG_S
        self._quietly(self.telescope.move_axis, axis, rate)
        self.session.moved_axes.add(axis)

    def stop_axis(self, direction: Direction) -> None:
        """``:Qn#`` etc.: stop that axis whoever moves it (the server does not track move directions)."""
        axis = MOVES[direction][0]
        self.session.moved_axes.discard(axis)
        if axis in self._state.moving_axes:
            self._quietly(self.telescope.move_axis, axis, 0.0)

    def select_speed(self, index: int) -> None:
        self.session.speed = SLEW_SPEEDS[index]
        self.session.axis_speed = [None, None]

    def set_variable_speed(self, multiple: float, axis: int | None) -> None:
        multiple = min(multiple, SLEW_SPEEDS[-1])
        if axis is None:
            self.session.speed = multiple
            self.session.axis_speed = [None, None]
        else:
            self.session.axis_speed[axis] = multiple

    def set_tracking_rate(self, rate: TrackRate) -> None:
        self._quietly(self.telescope.capabilities.set_tracking_rate, DRIVE_RATE[rate])

    def tracking_rate_digit(self) -> str:
        return format_tracking_rate(self._state.tracking_rate)  # INDI's digits

    def set_custom_rate(self, multiple: float) -> bool:
        raise NoReply  # not a command on real firmware (``intercept`` answers it first)

    def set_tracking(self, on: bool) -> bool:
        try:
            self.telescope.set_tracking(on)
        except AlpacaError as exc:
            raise Refusal(False, exc.message) from exc
        return True

    def tracking_state(self) -> TrackingState:
        tracking = self._state.tracking
        if tracking is None:
            raise NoReply
        return tracking

    def pulse(self, direction: Direction, milliseconds: int) -> None:
        self._quietly(self.telescope.pulse_guide, GUIDE_DIRECTION[direction], milliseconds)

    def set_guide_rate(self, fraction: float) -> None:
        self._quietly(self.telescope.capabilities.set_guide_rate_right_ascension, fraction * SIDEREAL_DEG_S)

    def guide_rate(self) -> float:
        return self._state.guide_rate

    # -- home, park --------------------------------------------------------------------------------

    def home(self) -> None:
        self._quietly(self.telescope.find_home)

    def home_flag(self) -> str:
        return ""  # the common firmware answer, an empty '#' (field notes §6 row 11)

    def set_current_as_home(self) -> bool:
        self._refuse_guarded("SOa")

    def park(self) -> bool | None:
        self._quietly(self.telescope.park)
        return None  # :hP# answers nothing on current firmware

    def set_park_position(self) -> str:
        self._refuse_guarded("Sp01")

    def unpark(self) -> bool:
        was_parked = self.telescope.at_park()
        try:
            self.telescope.unpark()
        except SafetyRefusal as exc:  # the safety monitor says unsafe: the mount's refusal, 0
            raise Refusal(False, exc.message) from exc
        return was_parked

    def park_status(self) -> int:
        return 2 if self.telescope.at_park() else 0

    # -- the settings stored in the mount: read from the shared cache, written only when allowed ---

    def _stored(self, name: str) -> Any:
        """One of the mount's stored settings, as last read (``StoredSettings.current``); no reply
        while the mount has not answered it."""
        settings: MountSettings = self.telescope.stored_settings.current()
        value = getattr(settings, name)
        if value is None:
            raise NoReply
        return value

    def meridian(self) -> MeridianSettings:
        meridian: MeridianSettings = self._stored("meridian")
        return meridian

    def _store(self, name: str, value: object) -> bool:
        """An allowed setter (``intercept`` refused it otherwise) through the stored settings' one owner:
        checked by its one rule, written, and for the meridian saved in the configuration and in force for
        DestinationSideOfPier. Refused by that rule or the mount, not saved, or the link failing: False,
        the mount's ``0``."""
        try:
            self.telescope.stored_settings.apply({name: value})
        except AlpacaZwoError as exc:
            log.info("ZWO port: %s not stored: %s", name, exc)
            return False
        return True

    def set_meridian(self, settings: MeridianSettings) -> bool:
        return self._store("meridian", settings)

    def limits_enabled(self) -> bool:
        return bool(self._stored("limits_enabled"))

    def set_limits_enabled(self, on: bool) -> bool:
        return self._store("limits_enabled", on)

    def upper_limit(self) -> int:
        return int(self._stored("upper_limit"))

    def set_upper_limit(self, degrees: int) -> bool:
        return self._store("upper_limit", degrees)

    def lower_limit(self) -> int:
        return int(self._stored("lower_limit"))

    def set_lower_limit(self, degrees: int) -> bool:
        return self._store("lower_limit", degrees)

    def max_speed(self) -> int:
        return 720 if self._stored("heavy_duty") else 1440

    def set_max_speed(self, multiple: int) -> bool:
        """``:SRl#`` takes only the two top speeds, as the mount: 720 is heavy duty, 1440 not."""
        heavy = HEAVY_DUTY_BY_SPEED.get(multiple)
        return heavy is not None and self._store("heavy_duty", heavy)

    def set_mode(self, mode: MountMode) -> None:
        self._refuse_guarded("AP" if mode is MountMode.EQUATORIAL else "AA")

    def buzzer(self) -> int:
        return int(self._stored("buzzer"))

    def set_buzzer(self, level: int) -> None:
        self._store("buzzer", level)  # :SBu# answers nothing either way

    # -- identity -----------------------------------------------------------------------------------

    def firmware_version(self) -> str:
        info = self._state.info
        if info is None:
            raise NoReply
        return info.firmware

    def model_name(self) -> str:
        info = self._state.info
        if info is None:
            raise NoReply
        return info.model

    def compile_time(self) -> str:
        raise NoReply  # never polled, unconfirmed on hardware: not worth a serial exchange

    def ble_name(self) -> str:
        raise NoReply  # likewise

    def set_ble_suffix(self, suffix: str) -> bool:
        self._refuse_guarded("SBl")

    def ble_pair(self, pairing_id: str) -> bool:
        self._refuse_guarded("BS")

    @staticmethod
    def _quietly(action: Callable[..., object], *args: object) -> None:
        """A command the mount answers with silence: a refusal can only be logged."""
        try:
            action(*args)
        except AlpacaError as exc:
            log.info("ZWO port: %s refused: %s", getattr(action, "__name__", "command"), exc.message)


def _mount_code(exc: AlpacaError) -> int | None:
    """The mount's own ``eN#`` behind an error (relayed to the program as it came), None for the server's own."""
    cause = exc.__cause__
    return cause.code if isinstance(cause, MountReplyError) else None
