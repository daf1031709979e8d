"""ASCOM ITelescopeV4 semantics on top of one mount and its motion supervisor.

The Telescope answers the members about where the mount points and what it does (position, Alt/Az,
pier side, tracking, Slewing, AtPark, DeviceState) and every motion command (slews, syncs, park, home,
MoveAxis, PulseGuide, AbortSlew). Its parts answer the rest themselves, as the member table
(``alpaca/members.py``) says row by row: :class:`~alpaca_zwo.telescope.connection.Connection` (who holds
it connected, the mount link), :class:`~alpaca_zwo.telescope.capabilities.Capabilities` (the flags that
vary, rates, site), :class:`~alpaca_zwo.telescope.clock.SiteClock` (UTCDate, sidereal time),
:class:`~alpaca_zwo.telescope.targets.Targets` and :class:`~alpaca_zwo.telescope.raw_commands.RawCommands`;
the pure target checks are :mod:`~alpaca_zwo.telescope.pointing`. Bytes do not live here, and neither does
motion: every slew, move, pulse, park and stop goes through
:class:`~alpaca_zwo.motion.MotionSupervisor`, which decides Slewing / IsPulseGuiding / AtPark from
what the mount does. Every failure is an :class:`~alpaca_zwo._exceptions.AlpacaError` subclass
carrying the ASCOM code a client expects.

Locks: Telescope creates none. Its parts own theirs (``Connection._clients_lock`` and
``_link_lock``, ``PierFlips._lock``, the supervisor's); the parts' own fields (targets, settle time,
rate offsets) are single values written by one member and read by others.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from datetime import datetime, timedelta

from .. import sky
from .._exceptions import (
    ERR_LINK,
    ERR_MOUNT_REFUSED,
    AlpacaError,
    DriverError,
    InvalidOperation,
    InvalidValue,
    MemberNotImplemented,
    MountReplyError,
    Parked,
    mount_errors,
)
from ..clients import ClientRegistry, current_client
from ..config.settings import Settings
from ..config.store import SettingsStore
from ..motion import Motion, MotionKind, MotionSupervisor
from ..motion.flip import PierFlips, side_setting
from ..motion.interlock import Interlock
from ..motion.landing import SLEW_S_FIXED, SLEW_S_PER_DEG
from ..mount.operations import Mount
from ..mount.state import MountState
from ..sky import PierSide
from ..zwo.wire_values import Direction, MeridianSettings
from . import actions, pointing
from .capabilities import AXIS_MIN_DEG_S, Capabilities
from .clock import SiteClock
from .connection import Connection
from .raw_commands import RawCommands
from .satellites import Satellites
from .stored_settings import StoredSettings
from .targets import Targets

log = logging.getLogger(__name__)

#: After the last client disconnects the link stays open this long, so reconnects are instant.
LINGER_S = 60.0
#: During a link outage, Connected stays true (last-known state served with its age) this long.
LINK_GRACE_S = 30.0
#: How far the axes turn in a pier flip (SideOfPier write), for when it lands.
FLIP_TRAVEL_DEG = 180.0
#: The home pose read from the position (``_home_pose``): Dec this close to the pole (degrees; the mount
#: prints whole arcseconds) and the hour angle this close to ±6 h (hours: a minute of time, 0.25°).
HOME_DEC_TOLERANCE_DEG = 1.0 / 60.0
HOME_HA_TOLERANCE_H = 1.0 / 60.0
GUIDE_DIRECTIONS = {0: Direction.NORTH, 1: Direction.SOUTH, 2: Direction.EAST, 3: Direction.WEST}


class Telescope:
    """One Alpaca telescope device: the members the member table (``alpaca/members.py``) gives no owner.

    Built from parts it owns, each answering its own members (the table names the attribute):
    ``connection`` (clients and the mount link; both locks live there), ``capabilities`` (the flags
    that vary, rates, site), ``clock`` (UTCDate, sidereal time), ``targets`` (targets, settle time),
    ``raw_commands``; and, answering none, ``motion`` (the supervisor; its own locks), ``flips``
    (pier flips; its own lock), ``stored_settings`` (the settings stored in the mount: the one path
    the Actions, the page and the shared ZWO port change them by; the meridian setting in force) and
    ``satellites`` (the kept TLE sets, their passes and the follow of one: issue 41). A
    caller outside ``telescope/`` uses the part that answers, as a client would:
    ``telescope.connection.set_connected(True)``, ``telescope.clock.utc_now()``.
    """

    def __init__(
        self,
        mount: Mount,
        store: SettingsStore,
        device_index: int = 0,
        *,
        registry: ClientRegistry | None = None,
        linger_s: float = LINGER_S,
        link_grace_s: float = LINK_GRACE_S,
        interlock: Interlock | None = None,
    ) -> None:
        self.mount = mount
        self.store = store
        self.device_index = device_index
        self.registry = registry or ClientRegistry()
        self.clock = SiteClock(mount=mount, settings=lambda: self.store.settings,
                               require_connected=self._require_connected)
        self.motion = MotionSupervisor(mount, lambda: self.store.settings, self.clock.lst, self.registry,
                                       name=f"motion-{device_index}", interlock=interlock)
        self.stored_settings = StoredSettings(mount=mount, store=store)
        self.connection = Connection(mount=mount, motion=self.motion, stored=self.stored_settings,
                                     linger_s=linger_s, link_grace_s=link_grace_s)
        self.capabilities = Capabilities(mount=mount, store=store, motion=self.motion,
                                         require_connected=self.connection.require_connected)
        self.targets = Targets(motion=self.motion)
        self.raw_commands = RawCommands(mount=mount, settings=lambda: self.store.settings,
                                        require_connected=self.connection.require_connected)
        self.flips = PierFlips(mount=mount, motion=self.motion,  # SideOfPier writes
                               configured=lambda: self.stored_settings.meridian)
        self.satellites = Satellites(mount=mount, motion=self.motion, settings=lambda: self.store.settings,
                                     mount_limits=self._mount_altitude_limits,
                                     flip_line_deg=self.stored_settings.flip_line_deg,
                                     folder=None if store.path is None else store.path.parent)

    # -- configuration -----------------------------------------------------------------------

    @property
    def settings(self) -> Settings:
        return self.store.settings

    @property
    def device_name(self) -> str:
        return self.settings.devices[self.device_index].name

    @property
    def unique_id(self) -> str:
        return self.settings.devices[self.device_index].unique_id

    def shutdown(self, park: bool = False, park_timeout_s: float = 120.0) -> None:
        """Leave the mount safe when the server stops: no manual motion, parked if configured."""
        if self.mount.running:
            self.motion.stop_manual("the server is shutting down")
            if park and not self.motion.parked:
                try:
                    log.info("parking on shutdown")
                    motion = self._park()
                    if motion is not None:
                        self.motion.wait(motion, park_timeout_s)
                except AlpacaError as exc:
                    log.error("could not park on shutdown: %s", exc.message)
        self.motion.close()
        self.connection.close()
        if self.mount.running:
            self.flips.restore_now()
            self.mount.disconnect()

    # -- common members ----------------------------------------------------------------------

    def name(self) -> str:
        return self.device_name

    def description(self) -> str:
        info = self.mount.state.info
        model = f"ZWO {info.model} (firmware {info.firmware})" if info else "ZWO AM-series mount"
        return f"{model} via alpaca-zwo"

    def supported_actions(self) -> list[str]:
        return actions.supported_actions()

    def action(self, action: str, parameters: str) -> str:
        return actions.run_action(self, action, parameters)

    def _require_connected(self) -> None:
        """The parts' connection check, looked up per call: the clock is built before the connection."""
        self.connection.require_connected()

    def _require_unparked(self, what: str) -> None:
        if self.motion.parked_by_mount:
            raise Parked(f"{what} is not allowed while the mount is parked: it parked itself (its own park, "
                         "set by the ZWO app, ASIAIR, a hand controller or another program, kept across power "
                         "cycles); Unpark releases it")
        if self.motion.parked:
            raise Parked(f"{what} is not allowed while the telescope is parked; unpark it first")

    # -- state -------------------------------------------------------------------------------

    def _state(self) -> MountState:
        self.connection.require_connected()
        state = self.mount.state
        if state.ra is None or state.dec is None:
            raise DriverError("the mount has not reported its position yet", ERR_LINK)
        return state

    def _position(self) -> tuple[float, float]:
        """RA/Dec as of now (see Mount.position): what every coordinate property reports."""
        self._state()
        position = self.mount.position()
        if position is None:
            raise DriverError("the mount has not reported its position yet", ERR_LINK)
        return position

    def _altaz(self, position: tuple[float, float]) -> tuple[float, float]:
        ha = sky.hour_angle(self.clock.lst(), position[0])
        return sky.equatorial_to_horizontal(ha, position[1], self.settings.site.latitude)

    def right_ascension(self) -> float:
        return self._position()[0]

    def declination(self) -> float:
        return self._position()[1]

    def altitude(self) -> float:
        return self._altaz(self._position())[0]

    def azimuth(self) -> float:
        return self._altaz(self._position())[1]

    def tracking(self) -> bool:
        state = self._state()
        return bool(state.tracking and state.tracking.on)

    def set_tracking(self, value: bool) -> None:
        self.connection.require_connected()
        if value:
            self._require_unparked("Tracking=true")
        try:
            with mount_errors("setting tracking"):
                self.motion.set_tracking(value)  # on is a start: the observatory interlock admits it
        except DriverError as exc:
            self.mount.refresh()
            reason = self.mount.state.tracking.reason if self.mount.state.tracking else ""
            if reason:
                raise DriverError(f"the mount refused to {'start' if value else 'stop'} tracking: {reason}",
                                  ERR_MOUNT_REFUSED) from exc
            raise

    def at_park(self) -> bool:
        self.connection.require_connected()
        return self.motion.parked

    def at_home(self) -> bool:
        state = self._state()
        if self.motion.slewing(state):
            return False
        return state.pier == "N" or bool(state.status and state.status.at_home) or self._home_pose(state)

    def _home_pose(self, state: MountState) -> bool:
        """At rest at the pole with the counterweight down (hour angle ±6 h): the home position, whatever
        the firmware calls it. The documents' firmware reads ``N`` and −6 h there (north), real 1.8.8 mounts
        ``E`` and +6 h, with no ``H`` (docs/firmware-evidence.md); both are this one pose."""
        if self._altaz_mode() or state.moving_axes or (state.tracking is not None and state.tracking.on):
            return False
        ra, dec = self._position()
        if 90.0 - abs(dec) > HOME_DEC_TOLERANCE_DEG:
            return False
        ha = self.mount.mechanical_hour_angle(ra)
        return abs(abs(sky.wrap_hours_12(ha)) - 6.0) < HOME_HA_TOLERANCE_H

    def slewing(self) -> bool:
        self.connection.require_connected()
        return self.motion.slewing()

    def is_pulse_guiding(self) -> bool:
        self.connection.require_connected()
        return self.motion.pulse_guiding()

    def _altaz_mode(self) -> bool:
        """Alt-az as the mount's ``:GU#`` last said (``Z``). The mount reads its mode only at power-up,
        and ``:GU#`` is read again on every poll and at every new link generation, so this follows a
        mode switch once the mount has been restarted and the link reconnected."""
        return self.mount.state.altaz

    def side_of_pier(self) -> int:
        state = self._state()
        if self._altaz_mode():
            return int(PierSide.UNKNOWN)  # an alt-az mount has no pier side (ASCOM pierUnknown)
        if state.side is not PierSide.UNKNOWN:  # the letter as the mount's convention means it (mount/pier.py)
            return int(state.side)
        return int(sky.pointing_state(self.mount.mechanical_hour_angle(*self._position())))

    def set_side_of_pier(self, value: int) -> None:
        """Flip to the other pointing state on the current position: a GOTO under a meridian limit
        that makes the mount take that side (motion/flip.py, docs/meridian.md). Asynchronous like
        any slew: Slewing until at rest, AbortSlew stops it. Writing the current side does nothing.
        In alt-az mode (CanSetPierSide false) every write is NotImplemented, whatever its value: ConformU
        writes back the -1 it read there and counts an InvalidValue as a finding."""
        if not self.capabilities.flips_by_limit():
            raise MemberNotImplemented("an alt-az mount has no pier side to set" if self._altaz_mode() else
                                       "flipping needs the mount's meridian settings (firmware 1.2.4 or later)")
        if value not in (PierSide.EAST, PierSide.WEST):
            raise InvalidValue(f"SideOfPier {value} is not 0 (pierEast) or 1 (pierWest)")
        self.connection.require_connected()
        self._require_unparked("SideOfPier")
        if self.side_of_pier() == value:
            return
        ra, dec = self._position()
        # One frame: the mount applies the limit to the hour angle its axes point at, which a sync
        # has moved away from the one a client sees; so the limit and the refusal use that one.
        ha = self.mount.mechanical_hour_angle(ra, dec)
        limit = sky.side_limit_deg(ha, PierSide(value))
        if limit is None:
            side = "pierEast" if value == PierSide.EAST else "pierWest"
            raise InvalidOperation(
                f"the mount cannot take {side} here: its axes point at hour angle {ha:+.2f} h, and a German mount "
                f"reaches {side} there only within 15° of the meridian (its meridian limit's range)")
        self._check_goto(ra, dec, FLIP_TRAVEL_DEG)
        self.flips.goto(ra, dec, side_setting(limit))

    def _pier(self) -> PierSide:
        return self.mount.state.side

    def destination_side_of_pier(self, right_ascension: float, declination: float) -> int:
        pointing.check_equatorial(right_ascension, declination)
        self.connection.require_connected()
        if self._altaz_mode():
            return int(PierSide.UNKNOWN)  # no pier side to predict in alt-az mode
        ha = self.mount.mechanical_hour_angle(right_ascension, declination)  # the mount chooses by its axes' hour angle
        side_rule = sky.kept_goto_side if self.capabilities.flips_by_limit() else sky.goto_pier_side
        return int(side_rule(ha, self._pier(), self.stored_settings.flip_line_deg()))


    def alignment_mode(self) -> int:
        self._state()
        if self._altaz_mode():
            return 0  # algAltAz, from the Z in :GU#
        return 2  # German polar

    def device_state(self) -> list[tuple[str, object]]:
        state = self._state()
        position = self._position()
        altitude, azimuth = self._altaz(position)
        stamp = self.clock.utc_now()
        if state.position_time is not None:
            stamp -= timedelta(seconds=max(0.0, self.mount.monotonic() - state.position_time))
        return [
            ("Altitude", altitude),
            ("AtHome", self.at_home()),
            ("AtPark", self.motion.parked),
            ("Azimuth", azimuth),
            ("Declination", position[1]),
            ("IsPulseGuiding", self.motion.pulse_guiding()),
            ("RightAscension", position[0]),
            ("SideOfPier", self.side_of_pier()),
            ("SiderealTime", self.clock.lst()),
            ("Slewing", self.motion.slewing(state)),
            ("Tracking", bool(state.tracking and state.tracking.on)),
            ("UTCDate", self.clock.utc_now()),
            ("TimeStamp", stamp),
        ]

    # -- slews ---------------------------------------------------------------------------------

    def slew_to_coordinates_async(self, right_ascension: float, declination: float) -> None:
        self._slew_to_coordinates(right_ascension, declination)

    def slew_to_coordinates(self, right_ascension: float, declination: float) -> None:
        self.motion.wait(self._slew_to_coordinates(right_ascension, declination))

    def _slew_to_coordinates(self, right_ascension: float, declination: float) -> Motion:
        pointing.check_equatorial(right_ascension, declination)
        self.connection.require_connected()
        self._require_unparked("SlewToCoordinatesAsync")
        self.targets.remember(right_ascension, declination)
        return self._goto(right_ascension, declination)

    def slew_to_target_async(self) -> None:
        self._slew_to_target()

    def slew_to_target(self) -> None:
        self.motion.wait(self._slew_to_target())

    def _slew_to_target(self) -> Motion:
        ra, dec = self.targets.target()
        self.connection.require_connected()
        self._require_unparked("SlewToTargetAsync")
        return self._goto(ra, dec)

    def _goto(self, ra: float, dec: float) -> Motion:
        self._check_goto(ra, dec)
        try:
            return self.flips.goto(ra, dec, self._keep_east_setting(ra, dec))
        except AlpacaError as exc:
            if isinstance(exc.__cause__, MountReplyError):  # e5#/e6#: its limits may have changed over WiFi
                self.mount.settings_cache.mark_stale()
            raise

    def goto_limit(self, ra: float, dec: float, travel_deg: float | None = None,
                   at: datetime | None = None) -> pointing.Blocked | None:
        """The one limit check every GoTo to a sky position passes first (``pointing.goto_blocked``), and
        what the setup page shows before one: the server's horizon and minimum altitude, the mount's horizon
        and its stored altitude limits, now and through the slew's landing. ``travel_deg`` is how far the
        slew goes (default: from where the mount points); it sets when the landing is. ``at``: the same
        check at another instant (when a target that is down now will be up: the page's "Not up: rises")."""
        if travel_deg is None:
            here = self.mount.position()
            travel_deg = 0.0 if here is None else sky.angular_separation(ra, dec, *here)
        slew_s = SLEW_S_FIXED + travel_deg * SLEW_S_PER_DEG
        return pointing.goto_blocked(self.settings, self._mount_altitude_limits(), self.clock.lst(at), ra, dec,
                                     slew_s)

    def _check_goto(self, ra: float, dec: float, travel_deg: float | None = None) -> None:
        blocked = self.goto_limit(ra, dec, travel_deg)
        if blocked is not None:
            raise InvalidValue(f"target is {blocked.detail}")

    def _mount_altitude_limits(self) -> pointing.MountAltitudeLimits | None:
        """The altitude limits stored in the mount as last read (``mount/settings_cache.py``: no exchange),
        None when they are off or were never read; the mount refuses a GOTO outside them (``e6#``)."""
        stored = self.mount.settings
        if stored is None or stored.limits_enabled is not True:
            return None
        lower = 0.0 if stored.lower_limit is None else float(stored.lower_limit)
        upper = 90.0 if stored.upper_limit is None else float(stored.upper_limit)
        return pointing.MountAltitudeLimits(lower, upper)

    def _keep_east_setting(self, ra: float, dec: float) -> MeridianSettings | None:
        """The temporary limit that keeps a mount on pierEast there past the meridian (sky.kept_goto_side),
        None where the mount's own setting gives the side DestinationSideOfPier promises."""
        if not self.capabilities.flips_by_limit():
            return None  # alt-az, or firmware without :STa: the mount's own rule
        ha, side = self.mount.mechanical_hour_angle(ra, dec), self._pier()
        own_limit = self.stored_settings.flip_line_deg()
        limit = sky.side_limit_deg(ha, PierSide.EAST)
        if limit is None or sky.kept_goto_side(ha, side, own_limit) is sky.goto_pier_side(ha, side, own_limit):
            return None
        return side_setting(limit)

    def slew_to_alt_az_async(self, azimuth: float, altitude: float) -> None:
        self._slew_to_alt_az(azimuth, altitude)

    def slew_to_alt_az(self, azimuth: float, altitude: float) -> None:
        self.motion.wait(self._slew_to_alt_az(azimuth, altitude))

    def _slew_to_alt_az(self, azimuth: float, altitude: float) -> Motion:
        pointing.check_horizontal(azimuth, altitude)
        self.connection.require_connected()
        self._require_unparked("SlewToAltAzAsync")
        lst = self.clock.lst()
        ha, dec = sky.horizontal_to_equatorial(altitude, azimuth, self.settings.site.latitude)
        # A point fixed to the ground: where it is now is where the slew lands.
        pointing.check_goto(self.settings, self._mount_altitude_limits(), lst, sky.ra_from_hour_angle(lst, ha), dec)
        tracking = bool(self.mount.state.tracking and self.mount.state.tracking.on)
        # With tracking off the pointing is frozen on the Alt/Az at the landing instant; with it on,
        # the slew ends at the instant the pointing passes the Alt/Az, and tracking carries on.
        self.flips.restore_now()  # no slew runs under a pier flip's temporary meridian limit
        return self.motion.goto_fixed(ha, dec, MotionKind.ALTAZ, freeze=not tracking)

    def abort_slew(self) -> None:
        self.connection.require_connected()
        self._require_unparked("AbortSlew")
        self.motion.abort()

    # -- syncs ---------------------------------------------------------------------------------

    def _require_tracking(self, what: str) -> None:
        tracking = self.mount.state.tracking
        if tracking is None or not tracking.on:
            raise InvalidOperation(f"{what} needs Tracking=true (a sync is made on a tracked position)")

    def sync_to_coordinates(self, right_ascension: float, declination: float) -> None:
        pointing.check_equatorial(right_ascension, declination)
        self.connection.require_connected()
        self._require_unparked("SyncToCoordinates")
        self._require_tracking("SyncToCoordinates")
        self._sync(right_ascension, declination)
        self.targets.remember(right_ascension, declination)

    def sync_to_target(self) -> None:
        ra, dec = self.targets.target()
        self.connection.require_connected()
        self._require_unparked("SyncToTarget")
        self._require_tracking("SyncToTarget")
        self._sync(ra, dec)

    def sync_to_alt_az(self, azimuth: float, altitude: float) -> None:
        pointing.check_horizontal(azimuth, altitude)
        self.connection.require_connected()
        self._require_unparked("SyncToAltAz")
        self._sync(*pointing.radec_from_altaz(self.settings, self.clock.lst(), azimuth, altitude))

    def _sync(self, ra: float, dec: float) -> None:
        if self.motion.slewing():
            raise InvalidOperation("cannot sync while the mount is moving")
        here = self.mount.position()
        if here is not None and sky.angular_separation(ra, dec, *here) < 1 / 3600:
            # Already there: a sync would change nothing, and near the pole the mount refuses it (e11).
            self.mount.sync_estimate(ra, dec)
            return
        with mount_errors("sync"):
            self.mount.sync(ra, dec)

    # -- home, park ----------------------------------------------------------------------------

    def find_home(self) -> None:
        self.connection.require_connected()
        self._require_unparked("FindHome")
        self.motion.home()

    def park(self) -> None:
        self.connection.require_connected()
        self._park()

    def _park(self) -> Motion | None:
        if self.motion.parked:
            return None  # parking twice is harmless
        park = self.settings.park
        if park.mode == "home":
            return self.motion.home(MotionKind.PARK)
        return self.motion.goto_fixed(park.ha_hours, park.dec_deg, MotionKind.PARK, freeze=True)

    def unpark(self) -> None:
        self.connection.require_connected()
        self.motion.unpark()

    def set_park(self) -> None:
        ra, dec = self._position()
        ha = sky.hour_angle(self.clock.lst(), ra)
        park = dataclasses.replace(self.settings.park, mode="custom", ha_hours=ha, dec_deg=dec)
        self.store.update(lambda s: dataclasses.replace(s, park=park))
        log.info("park position set to HA %.4f h, Dec %.4f°", ha, dec)

    # -- manual motion ---------------------------------------------------------------------------

    def move_axis(self, axis: int, rate: float) -> None:
        if not self.capabilities.can_move_axis(axis):
            raise MemberNotImplemented(f"axis {axis} cannot be moved on this mount: CanMoveAxis({axis}) is false")
        max_rate = self.capabilities.max_rate()
        if not math.isfinite(rate) or (rate != 0.0 and not AXIS_MIN_DEG_S <= abs(rate) <= max_rate):
            raise InvalidValue(f"rate {rate} deg/s is outside the axis rates: 0, "
                               f"or ±{AXIS_MIN_DEG_S:.6f} to ±{max_rate:.4f}")
        self.connection.require_connected()
        self._require_unparked("MoveAxis")
        self.motion.move_axis(axis, rate, current_client.get())

    # -- guiding -------------------------------------------------------------------------------

    def pulse_guide(self, direction: int, duration: int) -> None:
        longest = self.settings.safety.guide_max_ms
        if direction not in GUIDE_DIRECTIONS:
            raise InvalidValue(f"Direction {direction} is not 0 (N), 1 (S), 2 (E) or 3 (W)")
        if not 0 <= duration <= longest:
            raise InvalidValue(f"Duration {duration} ms is outside 0..{longest} ms (safety.guide_max_ms)")
        self.connection.require_connected()
        self._require_unparked("PulseGuide")
        self.motion.pulse(GUIDE_DIRECTIONS[direction], duration)
