"""What the shared ZWO port answers: one request body in, the reply a real mount would send out.

The mount's protocol, served on top of a :class:`~alpaca_zwo.telescope.device.Telescope` so that a ZWO
or LX200 driver (INDI's ``indi_lx200am5``) shares the mount with Alpaca clients:

* Queries are answered from the state snapshot (``telescope.mount.state`` and the Telescope's
  getters), never with a serial exchange per program; the few settings the poller does not read
  (meridian, limits, heavy duty, buzzer, daylight saving) come from one cached read.
* Motion and settings go through the Telescope's public methods, so horizon and altitude limits,
  the parked state, the MoveAxis watchdog and abort-from-anyone apply exactly as for Alpaca.
* Replies use ``zwo/protocol.py``'s formatters and the mount's framing: bare ``1``/``0`` from setters,
  bare ``0`` or ``eN#`` from a GOTO, ``#``-terminated queries, nothing for motion or unknown codes.

Telescope refusals become the mount's own error codes (field notes §4.1): a target under the
configured horizon profile or below altitude 0 is ``e5#``, under ``min_altitude_deg`` ``e6#``; a
GOTO while a GOTO, home or park runs ``e3#`` (as the mount; INDI sends ``:Q#`` first), but a GOTO
while the axes still brake from a stop is accepted and queued behind the braking (the mount would
answer ``e3#``; the server does better, see the README's ZWO-port section); parked
``e4#`` (the emulator's guess, no published code), and so is a GOTO the observatory interlock refuses
(the safety monitor says unsafe; ``:Spu#`` and ``:Te#`` then answer ``0``); a sync while moving ``e4#``, and a sync the
server refuses otherwise (not tracking) ``e11#``; a lost mount link gets no reply, as from a mount
that is not there.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING

from .. import sky
from .._exceptions import (
    AlpacaError,
    AlpacaZwoError,
    DriverError,
    InvalidOperation,
    InvalidValue,
    MountReplyError,
    Parked,
    ProtocolError,
    SafetyRefusal,
)
from ..config.settings import ZWO_PORT_DANGEROUS, horizon_altitude_at
from ..mount.state import MountSettings
from ..sky import SIDEREAL_DEG_S, PierSide
from ..zwo import protocol, wire_values
from ..zwo.protocol import ReplyKind, char_reply
from ..zwo.wire_values import (
    SLEW_SPEEDS,
    MeridianSettings,
    MountStatus,
    format_azimuth,
    format_date,
    format_dms,
    format_hms,
    format_latitude,
    format_longitude,
    format_meridian,
    format_status,
    format_time,
    format_tracking_rate,
    format_utc_offset,
)
from .zwo_clock_site import ClockAndSite
from .zwo_session import Handler, Refusal, Session

if TYPE_CHECKING:
    from ..mount.operations import Mount
    from ..telescope.device import Telescope

__all__ = ["ZwoResponder"]

log = logging.getLogger(__name__)

#: ``:GT#`` digits in INDI's (and the V1.1 document's English) order, the emulator's default.
#: Alpaca TrackingRate codes (DriveRates) for ``:TQ#``/``:TL#``/``:TS#``.
DRIVE_RATE = {"TQ": 0, "TL": 1, "TS": 2}
GUIDE_DIRECTION = {"n": 0, "s": 1, "e": 2, "w": 3}  # Telescope.pulse_guide's Direction numbers
#: :M?# -> (axis, sign): axis 0 is RA (+ east), axis 1 is Dec (+ north), as Telescope.move_axis takes them.
MOVES = {"e": (0, 1.0), "w": (0, -1.0), "n": (1, 1.0), "s": (1, -1.0)}


class ZwoResponder:
    """Answers request bodies for every program on the port; thread-safe (state is per Session or locked)."""

    def __init__(self, telescope: Telescope) -> None:
        self.telescope = telescope
        self._lock = threading.Lock()
        self.clock = ClockAndSite(telescope)
        self._handlers = self._build_table()
        missing = {c.code for c in protocol.COMMANDS} - set(self._handlers)
        if missing:  # the shared command table grew: fail loudly rather than go silent
            raise RuntimeError(f"ZWO port has no handler for {sorted(missing)}")

    @property
    def mount(self) -> Mount:
        return self.telescope.mount

    def handle(self, session: Session, body: str) -> str | None:
        """The reply to ``body``; raises :class:`Refusal` when the bridge refuses it (the caller counts it)."""
        match = protocol.match_command(body)
        if match is None:
            return None  # unknown or miscased: a real mount stays silent
        code = match.command.code
        if code in ZWO_PORT_DANGEROUS:
            return self._guarded(match)
        try:
            return self._handlers[code](session, match.argument, match.well_formed)
        except Refusal:
            raise
        except AlpacaZwoError as exc:  # the mount link failed under a command: a missing mount says nothing
            log.info("ZWO port :%s# failed: %s", body, exc)
            return None

    # -- commands that touch every program -----------------------------------------------------

    def _guarded(self, match: protocol.CommandMatch) -> str | None:
        allowed = self.telescope.settings.zwo_port.allow_dangerous
        code = match.command.code
        if code not in allowed and "all" not in allowed:
            refusal = {ReplyKind.NONE: None, ReplyKind.CHAR: "0", ReplyKind.TEXT: "NO#"}.get(match.command.kind)
            if code == "SS":
                refusal = "e2#"
            raise Refusal(refusal, f":{code}# changes the mount for every program; "
                                   "allow it in [zwo_port] allow_dangerous")
        if code == "STa":
            return self._set_meridian(match.argument, match.well_formed)
        reply = self.mount.raw(f":{code}{match.argument}#")
        return reply or None

    def _set_meridian(self, argument: str, well_formed: bool) -> str:
        try:
            self.telescope.stored_settings.apply({"meridian": wire_values.parse_meridian(argument)})
        except AlpacaZwoError:  # refused, out of range, not saved, or the link: the mount's 0
            return "0"
        return "1" if well_formed else "0"

    # -- the table -----------------------------------------------------------------------------

    def _build_table(self) -> dict[str, Handler]:
        t, c = self.telescope, self.clock
        table: dict[str, Handler] = {
            # Date, time, site
            "SC": c.set_date, "GC": lambda s, a, w: format_date(c.local().date()) + "#",
            "SL": c.set_time, "GL": lambda s, a, w: format_time(c.local().time()) + "#",
            "GS": lambda s, a, w: format_hms(t.clock.sidereal_time()) + "#",
            "GH": lambda s, a, w: self._setting_reply(lambda m: f"{int(bool(m.daylight_saving))}#", "daylight_saving"),
            "SG": c.set_zone, "GG": lambda s, a, w: format_utc_offset(c.utc_offset_hours) + "#",
            "St": c.set_latitude, "Gt": lambda s, a, w: format_latitude(t.capabilities.site_latitude()) + "#",
            "Sg": c.set_longitude, "Gg": lambda s, a, w: format_longitude(t.capabilities.site_longitude()) + "#",
            "SMTI": c.set_date_time_zone, "GMTI": c.get_date_time_zone,
            "SMGE": c.set_site,
            "GMGE": lambda s, a, w: (f"{format_latitude(t.capabilities.site_latitude())}&"
                                     f"{format_longitude(t.capabilities.site_longitude())}#"),
            # Position and target
            "Gm": lambda s, a, w: self._pier_letter(),
            "Sr": self._set_target_ra, "Sd": self._set_target_dec,
            "Gr": lambda s, a, w: format_hms(self._target(s)[0]) + "#",
            "Gd": lambda s, a, w: format_dms(self._target(s)[1]) + "#",
            "GMeq": lambda s, a, w: f"{format_hms(self._target(s)[0])}&{format_dms(self._target(s)[1])}#",
            "GR": lambda s, a, w: format_hms(t.right_ascension()) + "#",
            "GD": lambda s, a, w: format_dms(t.declination()) + "#",
            "GMEQ": lambda s, a, w: f"{format_hms(t.right_ascension())}&{format_dms(t.declination())}#",
            "GZ": lambda s, a, w: format_azimuth(t.azimuth()) + "#",
            "GA": lambda s, a, w: format_dms(t.altitude()) + "#",
            "GMZA": lambda s, a, w: f"{format_azimuth(t.azimuth())}&{format_dms(t.altitude())}#",
            # Motion
            "MS": self._goto,
            "SMeq": lambda s, a, w: "e2#",  # what real firmware answers (field notes §6 row 14)
            "Q": self._stop_all,
            **{f"M{d}": self._move(d) for d in MOVES}, **{f"Q{d}": self._stop_axis(d) for d in MOVES},
            "R": self._select_speed,
            "RG": self._fixed_speed(1), "RC": self._fixed_speed(2),
            "RM": self._fixed_speed(8), "RS": self._fixed_speed(9),
            "Rv": self._variable_speed(None), "Rvr": self._variable_speed(0), "Rvd": self._variable_speed(1),
            # Tracking
            **{code: self._tracking_rate(code) for code in DRIVE_RATE},
            "GT": lambda s, a, w: format_tracking_rate(self.mount.state.tracking_rate) + "#",  # INDI's digits
            "STR": lambda s, a, w: None,  # not a command on real firmware: silence
            "Te": lambda s, a, w: self._set_tracking(True), "Td": lambda s, a, w: self._set_tracking(False),
            "GAT": self._tracking_state,
            # Guiding
            "Mg": self._pulse, "Rg": self._guide_rate,
            "Ggr": lambda s, a, w: f"{self.mount.state.guide_rate:.2f}#",
            # Sync and alignment
            "CM": self._sync, "SMMC": lambda s, a, w: "e2#",
            # Home, park
            "hC": self._silently(t.find_home), "hP": self._silently(t.park),
            "Gh": lambda s, a, w: "#",  # the common firmware answer (field notes §6 row 11)
            "Spu": self._unpark, "Gps": lambda s, a, w: "2#" if t.at_park() else "0#",
            # Meridian and limits (read from the cached settings; their setters are guarded)
            "GTa": lambda s, a, w: self._setting_reply(
                lambda m: format_meridian(m.meridian or MeridianSettings()) + "#", "meridian"),
            "GLC": lambda s, a, w: self._setting_reply(
                lambda m: char_reply(bool(m.limits_enabled)) + "#", "limits_enabled"),
            "GLH": lambda s, a, w: self._setting_reply(lambda m: f"{m.upper_limit}#", "upper_limit"),
            "GLL": lambda s, a, w: self._setting_reply(lambda m: f"{m.lower_limit}#", "lower_limit"),
            "GRl": lambda s, a, w: self._setting_reply(lambda m: "720#" if m.heavy_duty else "1440#", "heavy_duty"),
            # Identity
            "GBu": lambda s, a, w: self._setting_reply(lambda m: f"{m.buzzer}#", "buzzer"),
            "GU": lambda s, a, w: self._status(),
            "GV": lambda s, a, w: f"{self.mount.state.info.firmware}#" if self.mount.state.info else None,
            "GVP": lambda s, a, w: f"{self.mount.state.info.model}#" if self.mount.state.info else None,
            "GVT": lambda s, a, w: None,  # never polled, unconfirmed on hardware: not worth a serial exchange
            "GBl": lambda s, a, w: None,
        }
        table.update({code: self._unreachable for code in ZWO_PORT_DANGEROUS})
        return table

    @staticmethod
    def _unreachable(_session: Session, _argument: str, _well_formed: bool) -> None:
        raise AssertionError("guarded commands are answered by _guarded")

    # -- the few settings the poller does not read ---------------------------------------------

    def _mount_settings(self) -> MountSettings:
        """The mount-stored settings from the Mount's one shared cache (the page and the Actions use it
        too): read here only when never read, changed by a command since (every sender marks it), or a
        minute old; the read refills the cache for everyone."""
        with self._lock:
            cache = self.mount.settings_cache
            cached = cache.value
            if cached is None or cache.due():
                return self.mount.read_settings()
            return cached

    def _setting_reply(self, render: Callable[[MountSettings], str], name: str) -> str | None:
        settings = self._mount_settings()
        return None if getattr(settings, name) is None else render(settings)

    # -- position, target, status ----------------------------------------------------------------

    def _target(self, session: Session) -> tuple[float, float]:
        if session.target is not None:
            return session.target
        try:
            return self.telescope.targets.target()
        except AlpacaError:
            return self.telescope.right_ascension(), self.telescope.declination()

    def _set_target_ra(self, session: Session, argument: str, well_formed: bool) -> str:
        try:
            ra = wire_values.parse_hms(argument)
        except ProtocolError:
            return "e2#"  # seconds or minutes of 60, or a bad format (PYAM5)
        if not well_formed:
            return "e2#"
        session.target = (ra, self._target(session)[1])
        return "1"

    def _set_target_dec(self, session: Session, argument: str, well_formed: bool) -> str:
        try:
            dec = wire_values.parse_dms(argument)
        except ProtocolError:
            return "e2#"
        if not well_formed or not -90.0 <= dec <= 90.0:
            return "e2#"
        session.target = (self._target(session)[0], dec)
        return "1"

    def _goto_running(self) -> bool:
        """A GOTO, home or park under way (from anyone); manual moves do not count, as on the mount."""
        state = self.mount.state
        return state.goto_running or (self.telescope.slewing() and not state.moving_axes)

    def _status(self) -> str:
        """``:GU#``: the last polled flags, with tracking and slewing as the server knows them now.

        A motion the server started shows as slewing from the moment it was accepted until the
        supervisor has seen it end, so a driver that waits for ``N`` never sees it too early.
        """
        state = self.mount.state
        status = state.status or MountStatus()
        slewing = self._goto_running()
        tracking = state.tracking.on if state.tracking is not None else status.tracking
        return format_status(dataclasses.replace(
            status, tracking=tracking, slewing=slewing, at_home=status.at_home and not slewing)) + "#"

    def _pier_letter(self) -> str | None:
        """``:Gm#`` as INDI reads it (W pierWest, E pierEast, N at home): the pointing state the server
        reads from the mount's letter, whatever that mount's firmware names (mount/pier.py)."""
        state = self.mount.state
        if state.pier is None:
            return None
        if state.side is PierSide.UNKNOWN or state.altaz:
            return f"{state.pier}#"
        return "W#" if state.side is PierSide.WEST else "E#"

    def _tracking_state(self, _session: Session, _argument: str, _well_formed: bool) -> str | None:
        tracking = self.mount.state.tracking
        if tracking is None:
            return None
        if tracking.on:
            return "1#"
        return f"e{tracking.error}#" if tracking.error is not None else "0#"

    # -- GOTO, sync ------------------------------------------------------------------------------

    def _goto(self, session: Session, _argument: str, _well_formed: bool) -> str | None:
        ra, dec = self._target(session)
        if self._goto_running() and not self.telescope.motion.stopping():
            # A stop the server is finishing (INDI re-targets 100 ms after its :Q#) is no reason:
            # the supervisor holds the GOTO until the axes have braked, then sends it.
            raise Refusal("e3#", "a GOTO, home or park is already running")
        try:
            self.telescope.slew_to_coordinates_async(ra, dec)
        except (Parked, SafetyRefusal) as exc:  # the mount's "not now" (parked, or the safety monitor says no)
            raise Refusal("e4#", exc.message) from exc
        except InvalidValue as exc:
            raise Refusal(f"e{self._limit_code(ra, dec)}#", exc.message) from exc
        except InvalidOperation as exc:
            raise Refusal("e3#", exc.message) from exc
        except DriverError as exc:
            return self._mount_refusal(exc)
        return "0"

    def _limit_code(self, ra: float, dec: float) -> int:
        """5 under the horizon (altitude 0 or the configured profile), 6 under the altitude limit."""
        t = self.telescope
        ha = sky.hour_angle(t.clock.sidereal_time(), ra)
        altitude, azimuth = sky.equatorial_to_horizontal(ha, dec, t.capabilities.site_latitude())
        profile_only = dataclasses.replace(t.settings.limits, min_altitude_deg=-90.0)
        if altitude < 0.0 or altitude < horizon_altitude_at(profile_only, azimuth):
            return 5
        return 6

    @staticmethod
    def _mount_refusal(exc: DriverError) -> str | None:
        """The mount's own ``eN#`` when it refused; silence when it could not be reached."""
        cause = exc.__cause__
        if isinstance(cause, MountReplyError) and cause.code is not None:
            raise Refusal(f"e{cause.code}#", exc.message) from exc
        log.info("ZWO port: %s", exc.message)
        return None

    def _sync(self, session: Session, _argument: str, _well_formed: bool) -> str | None:
        ra, dec = self._target(session)
        try:
            self.telescope.sync_to_coordinates(ra, dec)
        except (Parked, InvalidValue) as exc:
            raise Refusal("e4#" if isinstance(exc, Parked) else "e1#", exc.message) from exc
        except InvalidOperation as exc:
            raise Refusal("e4#" if self.telescope.slewing() else "e11#", exc.message) from exc
        except DriverError as exc:
            return self._mount_refusal(exc)
        return "N/A#"

    # -- manual motion, guiding, tracking ----------------------------------------------------------

    def _stop_all(self, session: Session, _argument: str, _well_formed: bool) -> None:
        """``:Q#`` from any program stops every motion, whoever started it."""
        session.moved_axes.clear()
        with contextlib.suppress(Parked):  # nothing moves while parked
            self.telescope.abort_slew()
        return None

    def _move(self, direction: str) -> Handler:
        """``:Me#`` etc.: MoveAxis at this program's ``:Rn``/``:Rv`` speed (latched when sent, as on the mount)."""
        axis, sign = MOVES[direction]

        def handler(session: Session, _argument: str, _well_formed: bool) -> None:
            multiple = session.axis_speed[axis] or session.speed
            rate = sign * max(multiple, SLEW_SPEEDS[0]) * SIDEREAL_DEG_S
            self._quietly(self.telescope.move_axis, axis, rate)
            session.moved_axes.add(axis)
            return None

        return handler

    def _stop_axis(self, direction: str) -> Handler:
        """``:Qn#`` etc.: stop that axis whoever moves it (the server does not track move directions)."""
        axis = MOVES[direction][0]

        def handler(session: Session, _argument: str, _well_formed: bool) -> None:
            session.moved_axes.discard(axis)
            if axis in self.mount.state.moving_axes:
                self._quietly(self.telescope.move_axis, axis, 0.0)
            return None

        return handler

    def _select_speed(self, session: Session, argument: str, well_formed: bool) -> None:
        if well_formed:
            session.speed = SLEW_SPEEDS[int(argument)]
            session.axis_speed = [None, None]
        return None

    def _fixed_speed(self, index: int) -> Handler:
        def handler(session: Session, _argument: str, _well_formed: bool) -> None:
            session.speed = SLEW_SPEEDS[index]
            session.axis_speed = [None, None]
            return None

        return handler

    def _variable_speed(self, axis: int | None) -> Handler:
        def handler(session: Session, argument: str, well_formed: bool) -> None:
            if not well_formed:
                return None
            multiple = min(float(argument.strip()), SLEW_SPEEDS[-1])
            if axis is None:
                session.speed = multiple
                session.axis_speed = [None, None]
            else:
                session.axis_speed[axis] = multiple
            return None

        return handler

    def _tracking_rate(self, code: str) -> Handler:
        def handler(_session: Session, _argument: str, _well_formed: bool) -> None:
            self._quietly(self.telescope.capabilities.set_tracking_rate, DRIVE_RATE[code])
            return None

        return handler

    def _set_tracking(self, on: bool) -> str:
        try:
            self.telescope.set_tracking(on)
        except AlpacaError as exc:
            raise Refusal("0", exc.message) from exc
        return "1"

    def _pulse(self, _session: Session, argument: str, well_formed: bool) -> None:
        if well_formed:
            self._quietly(self.telescope.pulse_guide, GUIDE_DIRECTION[argument[0]], int(argument[1:]))
        return None

    def _guide_rate(self, _session: Session, argument: str, well_formed: bool) -> None:
        """``:Rg0.nn#`` (real clients) or the V1.1 document's x15 form ``:Rg1.5#``..``:Rg13.5#``."""
        if not well_formed:
            return None
        value = float(argument)
        fraction = value / 15.0 if value >= 1.5 - 1e-9 else value
        self._quietly(self.telescope.capabilities.set_guide_rate_right_ascension, fraction * SIDEREAL_DEG_S)
        return None

    def _unpark(self, _session: Session, _argument: str, _well_formed: bool) -> str:
        was_parked = self.telescope.at_park()
        try:
            self.telescope.unpark()
        except SafetyRefusal as exc:  # the safety monitor says unsafe: the mount's refusal, 0
            raise Refusal("0", exc.message) from exc
        return char_reply(was_parked)

    def _silently(self, action: Callable[[], object]) -> Handler:
        def handler(_session: Session, _argument: str, _well_formed: bool) -> None:
            self._quietly(action)
            return None

        return handler

    @staticmethod
    def _quietly(action: Callable[..., object], *args: object) -> None:
        """A command the mount answers with silence: a refusal can only be logged."""
        try:
            action(*args)
        except AlpacaError as exc:
            log.info("ZWO port: %s refused: %s", getattr(action, "__name__", "command"), exc.message)
