"""ASCOM ITelescopeV4 semantics on top of one mount and its motion supervisor.

Validation and ranges, targets, the clock offset, slews, syncs and park live here; the client
reference count and the link live in :class:`~alpaca_zwo.telescope.connection.Connection`, the
Can* flags, rates and site in :class:`~alpaca_zwo.telescope.capabilities.Capabilities`, the pure
target checks in :mod:`~alpaca_zwo.telescope.pointing`. Bytes do not live here, and neither does
motion: every slew, move, pulse, park and stop goes through
:class:`~alpaca_zwo.motion.MotionSupervisor`, which decides Slewing / IsPulseGuiding / AtPark from
what the mount does. Every failure is an :class:`~alpaca_zwo._exceptions.AlpacaError` subclass
carrying the ASCOM code a client expects.

Locks: Telescope creates none. Its parts own theirs (``Connection._clients_lock`` and
``_link_lock``, ``PierFlips._lock``, the supervisor's); its own fields (target, settle time, clock
offset) are single values written by one member and read by others.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Mapping
from datetime import datetime, timedelta, timezone

from .. import __version__, sky
from .._exceptions import (
    ERR_LINK,
    ERR_MOUNT_PROTOCOL,
    ERR_MOUNT_REFUSED,
    AlpacaError,
    DriverError,
    InvalidOperation,
    InvalidValue,
    MemberNotImplemented,
    Parked,
    ValueNotSet,
    mount_errors,
)
from ..clients import ClientKey, ClientRegistry, current_client
from ..config.settings import DeviceSettings, Settings
from ..config.store import SettingsStore
from ..motion import Motion, MotionKind, MotionSupervisor
from ..motion.flip import PierFlips, side_setting
from ..motion.interlock import Interlock
from ..mount.operations import Mount
from ..mount.state import MountState
from ..sky import PierSide
from ..zwo.wire_values import Direction, MeridianSettings, TrackRate
from . import actions, pointing
from .capabilities import AXIS_MIN_DEG_S, Capabilities
from .connection import Connection

log = logging.getLogger(__name__)

#: After the last client disconnects the link stays open this long, so reconnects are instant.
LINGER_S = 60.0
#: During a link outage, Connected stays true (last-known state served with its age) this long.
LINK_GRACE_S = 30.0
#: The mount's clock keeps a two-digit year; a day of margin either side for the UTC offset.
MOUNT_EPOCH_FIRST = datetime(2000, 1, 2, tzinfo=timezone.utc)
MOUNT_EPOCH_LAST = datetime(2099, 12, 30, tzinfo=timezone.utc)
DRIVE_RATES = {0: TrackRate.SIDEREAL, 1: TrackRate.LUNAR, 2: TrackRate.SOLAR}
RATE_CODES = {rate: code for code, rate in DRIVE_RATES.items()}
GUIDE_DIRECTIONS = {0: Direction.NORTH, 1: Direction.SOUTH, 2: Direction.EAST, 3: Direction.WEST}


def _utc(t: datetime) -> datetime:
    return t.astimezone(timezone.utc) if t.tzinfo else t.replace(tzinfo=timezone.utc)


class Telescope:
    """One Alpaca telescope device (the handlers named in ``alpaca/device.py``).

    Built from parts it owns: ``connection`` (clients and the mount link; both locks live there),
    ``caps`` (Can*, rates, site), ``motion`` (the supervisor; its own locks) and ``flips`` (pier
    flips; its own lock). The members a part implements are one-line delegations here, because the
    Alpaca member table binds each handler on this object.
    """

    interface_version_value = 4

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
        self._target_ra: float | None = None
        self._target_dec: float | None = None
        self._settle_s = 0
        self.motion = MotionSupervisor(mount, lambda: self.store.settings, self._lst, self.registry,
                                       name=f"motion-{device_index}", interlock=interlock)
        self.connection = Connection(mount=mount, motion=self.motion, settings=lambda: self.store.settings,
                                     linger_s=linger_s, link_grace_s=link_grace_s)
        self.caps = Capabilities(mount=mount, store=store, motion=self.motion,
                                 require_connected=self.connection.require_connected)
        self.flips = PierFlips(mount=mount, motion=self.motion,  # SideOfPier writes
                               configured=lambda: self.connection.meridian)

    # -- configuration -----------------------------------------------------------------------

    @property
    def settings(self) -> Settings:
        return self.store.settings

    @property
    def device_settings(self) -> DeviceSettings:
        return self.settings.devices[self.device_index]

    @property
    def device_name(self) -> str:
        return self.device_settings.name

    @property
    def unique_id(self) -> str:
        return self.device_settings.unique_id

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

    def interface_version(self) -> int:
        return self.interface_version_value

    def name(self) -> str:
        return self.device_name

    def description(self) -> str:
        info = self.mount.state.info
        model = f"ZWO {info.model} (firmware {info.firmware})" if info else "ZWO AM-series mount"
        return f"{model} via alpaca-zwo"

    def driver_info(self) -> str:
        return "alpaca-zwo: ASCOM Alpaca server for ZWO AM3/AM5/AM7 mounts (ITelescopeV4)"

    def driver_version(self) -> str:
        return __version__

    def supported_actions(self) -> list[str]:
        return actions.supported_actions()

    def action(self, action: str, parameters: str) -> str:
        return actions.run_action(self, action, parameters)

    def _raw(self, command: str) -> str:
        if not self.settings.server.allow_raw_commands:
            raise MemberNotImplemented(
                "raw mount commands are disabled (they bypass every safety check); "
                "set server.allow_raw_commands = true to enable them"
            )
        self.connection.require_connected()
        with mount_errors("raw command"):
            return self.mount.raw(command)

    def command_blind(self, command: str, raw: bool) -> None:
        self._raw(command)

    def command_bool(self, command: str, raw: bool) -> bool:
        reply = self._raw(command).rstrip("#")
        if reply not in ("0", "1"):
            raise DriverError(f"mount replied {reply!r}, not a boolean", ERR_MOUNT_PROTOCOL)
        return reply == "1"

    def command_string(self, command: str, raw: bool) -> str:
        return self._raw(command).rstrip("#")

    # -- connection (reference-counted across clients: Connection) ------------------------------

    def _caller(self) -> ClientKey:
        return current_client.get() or ClientKey("internal", 0)

    def set_connected(self, value: bool) -> None:
        if value:
            self.connection.attach(self._caller())
        else:
            self.connection.release(self._caller())

    def connected(self) -> bool: return self.connection.connected(current_client.get())
    def connect(self) -> None: self.connection.connect_in_background(self._caller())
    def disconnect(self) -> None: self.connection.release(self._caller())
    def connecting(self) -> bool: return self.connection.connecting()
    def connected_clients(self) -> frozenset[ClientKey]: return self.connection.clients()
    def set_meridian_settings(self, meridian: MeridianSettings) -> None: self.connection.set_meridian_settings(meridian)

    def _require_unparked(self, what: str) -> None:
        if self.motion.parked:
            raise Parked(f"{what} is not allowed while the telescope is parked; unpark it first")

    # -- capabilities, rates and site (Capabilities) ---------------------------------------------

    def can_find_home(self) -> bool: return self.caps.can_find_home()
    def can_park(self) -> bool: return self.caps.can_park()
    def can_unpark(self) -> bool: return self.caps.can_unpark()
    def can_set_park(self) -> bool: return self.caps.can_set_park()
    def can_pulse_guide(self) -> bool: return self.caps.can_pulse_guide()
    def can_set_guide_rates(self) -> bool: return self.caps.can_set_guide_rates()
    def can_set_tracking(self) -> bool: return self.caps.can_set_tracking()
    def can_slew(self) -> bool: return self.caps.can_slew()
    def can_slew_async(self) -> bool: return self.caps.can_slew_async()
    def can_slew_alt_az(self) -> bool: return self.caps.can_slew_alt_az()
    def can_slew_alt_az_async(self) -> bool: return self.caps.can_slew_alt_az_async()
    def can_sync(self) -> bool: return self.caps.can_sync()
    def can_sync_alt_az(self) -> bool: return self.caps.can_sync_alt_az()
    def can_set_pier_side(self) -> bool: return self.caps.can_set_pier_side()
    def flips_by_limit(self) -> bool: return self.caps.flips_by_limit()
    def can_set_declination_rate(self) -> bool: return self.caps.can_set_declination_rate()
    def can_set_right_ascension_rate(self) -> bool: return self.caps.can_set_right_ascension_rate()
    def can_move_axis(self, axis: int) -> bool: return self.caps.can_move_axis(axis)
    def axis_rates(self, axis: int) -> list[tuple[float, float]]: return self.caps.axis_rates(axis)
    def aperture_area(self) -> float: return self.caps.aperture_area()
    def aperture_diameter(self) -> float: return self.caps.aperture_diameter()
    def focal_length(self) -> float: return self.caps.focal_length()
    def does_refraction(self) -> bool: return self.caps.does_refraction()
    def set_does_refraction(self, value: bool) -> None: self.caps.set_does_refraction(value)
    def declination_rate(self) -> float: return self.caps.declination_rate()
    def set_declination_rate(self, value: float) -> None: self.caps.set_declination_rate(value)
    def right_ascension_rate(self) -> float: return self.caps.right_ascension_rate()
    def set_right_ascension_rate(self, value: float) -> None: self.caps.set_right_ascension_rate(value)
    def guide_rate_right_ascension(self) -> float: return self.caps.guide_rate_right_ascension()
    def guide_rate_declination(self) -> float: return self.caps.guide_rate_declination()
    def set_guide_rate_right_ascension(self, value: float) -> None: self.caps.set_guide_rate_right_ascension(value)
    def set_guide_rate_declination(self, value: float) -> None: self.caps.set_guide_rate_declination(value)
    def site_latitude(self) -> float: return self.caps.site_latitude()
    def site_longitude(self) -> float: return self.caps.site_longitude()
    def site_elevation(self) -> float: return self.caps.site_elevation()
    def set_site_latitude(self, value: float) -> None: self.caps.set_site_latitude(value)
    def set_site_longitude(self, value: float) -> None: self.caps.set_site_longitude(value)
    def set_site_elevation(self, value: float) -> None: self.caps.set_site_elevation(value)
    def set_site(self, values: Mapping[str, float]) -> None: self.caps.set_site(values)

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

    def utc_now(self) -> datetime:
        """The server's time reference for this mount (mount/timekeeping.py): what every reading uses."""
        return self.mount.time.now()

    def _lst(self, now: datetime | None = None) -> float:
        return sky.local_sidereal_time(now or self.utc_now(), self.settings.site.longitude)

    def _altaz(self, position: tuple[float, float]) -> tuple[float, float]:
        ha = sky.hour_angle(self._lst(), position[0])
        return sky.equatorial_to_horizontal(ha, position[1], self.settings.site.latitude)

    def right_ascension(self) -> float:
        return self._position()[0]

    def declination(self) -> float:
        return self._position()[1]

    def altitude(self) -> float:
        return self._altaz(self._position())[0]

    def azimuth(self) -> float:
        return self._altaz(self._position())[1]

    def sidereal_time(self) -> float:
        self.connection.require_connected()
        return self._lst()

    def utc_date(self) -> datetime:
        self.connection.require_connected()
        return self.utc_now()

    def set_utc_date(self, value: datetime) -> None:
        self.connection.require_connected()
        caller = current_client.get()
        who = f"client {caller.address} #{caller.client_id} (UTCDate)" if caller else "a client (UTCDate)"
        self.set_time(value, who)

    def set_time(self, value: datetime, who: str) -> bool:
        """The strongest time source (a client's UTCDate, a program on the ZWO port, a person on the page):
        the server's reference from now on, and the mount's clock when the link is up (True: it was set)."""
        value = _utc(value)
        if not MOUNT_EPOCH_FIRST <= value <= MOUNT_EPOCH_LAST:
            raise InvalidValue(
                f"UTCDate {value.isoformat()} is outside 2000-2099, the years the mount's clock can hold")
        self.mount.time.set_by_client(value, who)
        if not (self.mount.running and self.mount.link.status.connected):
            return False  # the mount gets it when it is connected (a client's time is pushed at connect)
        with mount_errors("setting the mount clock"):
            self.mount.push_time()
        return True

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

    def tracking_rates(self) -> list[int]:
        return sorted(DRIVE_RATES)

    def tracking_rate(self) -> int:
        self.connection.require_connected()
        return RATE_CODES[self.mount.state.tracking_rate]

    def set_tracking_rate(self, value: int) -> None:
        if value not in DRIVE_RATES:
            raise InvalidValue(f"TrackingRate {value} is not supported; use 0 (sidereal), 1 (lunar) or 2 (solar)")
        self.connection.require_connected()
        with mount_errors("setting the tracking rate"):
            self.mount.set_tracking_rate(DRIVE_RATES[value])
        if DRIVE_RATES[value] is not TrackRate.SIDEREAL:  # offsets exist only on sidereal (Platform 7)
            self.caps.zero_offsets()

    def at_park(self) -> bool:
        self.connection.require_connected()
        return self.motion.parked

    def at_home(self) -> bool:
        state = self._state()
        if self.motion.slewing(state):
            return False
        return state.pier == "N" or bool(state.status and state.status.at_home)

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
        return int(sky.pointing_state(self.mount.mechanical_hour_angle(self._position()[0])))

    def set_side_of_pier(self, value: int) -> None:
        """Flip to the other pointing state on the current position: a GOTO under a meridian limit
        that makes the mount take that side (motion/flip.py, docs/meridian.md). Asynchronous like
        any slew: Slewing until at rest, AbortSlew stops it. Writing the current side does nothing.
        In alt-az mode (CanSetPierSide false) every write is NotImplemented, whatever its value: ConformU
        writes back the -1 it read there and counts an InvalidValue as a finding."""
        if not self.caps.flips_by_limit():
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
        ha = self.mount.mechanical_hour_angle(ra)
        limit = sky.side_limit_deg(ha, PierSide(value))
        if limit is None:
            side = "pierEast" if value == PierSide.EAST else "pierWest"
            raise InvalidOperation(
                f"the mount cannot take {side} here: its axes point at hour angle {ha:+.2f} h, and a German mount "
                f"reaches {side} there only within 15° of the meridian (its meridian limit's range)")
        pointing.check_above_limits(self.settings, self._lst(), ra, dec)
        self.flips.goto(ra, dec, side_setting(limit))

    def _pier(self) -> PierSide:
        return self.mount.state.side

    def destination_side_of_pier(self, right_ascension: float, declination: float) -> int:
        pointing.check_equatorial(right_ascension, declination)
        self.connection.require_connected()
        if self._altaz_mode():
            return int(PierSide.UNKNOWN)  # no pier side to predict in alt-az mode
        ha = self.mount.mechanical_hour_angle(right_ascension)  # the mount chooses by its axes' hour angle
        side_rule = sky.kept_goto_side if self.caps.flips_by_limit() else sky.goto_pier_side
        return int(side_rule(ha, self._pier(), self._flip_limit_deg()))

    def _flip_limit_deg(self) -> float:
        meridian = self.connection.meridian
        limit = float(meridian.limit_degrees)
        # A negative limit stops tracking before the meridian whatever the "track past" flag says.
        return limit if limit < 0.0 or meridian.track_after else 0.0

    def alignment_mode(self) -> int:
        self._state()
        if self._altaz_mode():
            return 0  # algAltAz, from the Z in :GU#
        return 2  # German polar

    def equatorial_system(self) -> int:
        return 1  # topocentric (JNow), what the mount works in

    def device_state(self) -> list[tuple[str, object]]:
        state = self._state()
        position = self._position()
        altitude, azimuth = self._altaz(position)
        stamp = self.utc_now()
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
            ("SiderealTime", self._lst()),
            ("Slewing", self.motion.slewing(state)),
            ("Tracking", bool(state.tracking and state.tracking.on)),
            ("UTCDate", self.utc_now()),
            ("TimeStamp", stamp),
        ]

    # -- targets -------------------------------------------------------------------------------

    def target_right_ascension(self) -> float:
        if self._target_ra is None:
            raise ValueNotSet("TargetRightAscension has not been set")
        return self._target_ra

    def target_declination(self) -> float:
        if self._target_dec is None:
            raise ValueNotSet("TargetDeclination has not been set")
        return self._target_dec

    def set_target_right_ascension(self, value: float) -> None:
        if not 0.0 <= value < 24.0:
            raise InvalidValue(f"TargetRightAscension {value} is outside 0..24 hours")
        self._target_ra = value

    def set_target_declination(self, value: float) -> None:
        if not -90.0 <= value <= 90.0:
            raise InvalidValue(f"TargetDeclination {value} is outside -90..90 degrees")
        self._target_dec = value

    def slew_settle_time(self) -> int:
        return self._settle_s

    def set_slew_settle_time(self, value: int) -> None:
        if not 0 <= value <= 3600:
            raise InvalidValue(f"SlewSettleTime {value} is outside 0..3600 s")
        self._settle_s = value
        self.motion.settle_s = float(value)

    # -- slews ---------------------------------------------------------------------------------

    def slew_to_coordinates_async(self, right_ascension: float, declination: float) -> None:
        self._slew_to_coordinates(right_ascension, declination)

    def slew_to_coordinates(self, right_ascension: float, declination: float) -> None:
        self.motion.wait(self._slew_to_coordinates(right_ascension, declination))

    def _slew_to_coordinates(self, right_ascension: float, declination: float) -> Motion:
        pointing.check_equatorial(right_ascension, declination)
        self.connection.require_connected()
        self._require_unparked("SlewToCoordinatesAsync")
        self._target_ra, self._target_dec = right_ascension, declination
        return self._goto(right_ascension, declination)

    def slew_to_target_async(self) -> None:
        self._slew_to_target()

    def slew_to_target(self) -> None:
        self.motion.wait(self._slew_to_target())

    def _slew_to_target(self) -> Motion:
        ra, dec = self.target_right_ascension(), self.target_declination()
        self.connection.require_connected()
        self._require_unparked("SlewToTargetAsync")
        return self._goto(ra, dec)

    def _goto(self, ra: float, dec: float) -> Motion:
        pointing.check_above_limits(self.settings, self._lst(), ra, dec)
        return self.flips.goto(ra, dec, self._keep_east_setting(ra))

    def _keep_east_setting(self, ra: float) -> MeridianSettings | None:
        """The temporary limit that keeps a mount on pierEast there past the meridian (sky.kept_goto_side),
        None where the mount's own setting gives the side DestinationSideOfPier promises."""
        if not self.caps.flips_by_limit():
            return None  # alt-az, or firmware without :STa: the mount's own rule
        ha, side, own_limit = self.mount.mechanical_hour_angle(ra), self._pier(), self._flip_limit_deg()
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
        lst = self._lst()
        ha, dec = sky.horizontal_to_equatorial(altitude, azimuth, self.settings.site.latitude)
        pointing.check_above_limits(self.settings, lst, sky.ra_from_hour_angle(lst, ha), dec)
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
        self._target_ra, self._target_dec = right_ascension, declination

    def sync_to_target(self) -> None:
        ra, dec = self.target_right_ascension(), self.target_declination()
        self.connection.require_connected()
        self._require_unparked("SyncToTarget")
        self._require_tracking("SyncToTarget")
        self._sync(ra, dec)

    def sync_to_alt_az(self, azimuth: float, altitude: float) -> None:
        pointing.check_horizontal(azimuth, altitude)
        self.connection.require_connected()
        self._require_unparked("SyncToAltAz")
        self._sync(*pointing.radec_from_altaz(self.settings, self._lst(), azimuth, altitude))

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
        ha = sky.hour_angle(self._lst(), ra)
        park = dataclasses.replace(self.settings.park, mode="custom", ha_hours=ha, dec_deg=dec)
        self.store.update(lambda s: dataclasses.replace(s, park=park))
        log.info("park position set to HA %.4f h, Dec %.4f°", ha, dec)

    # -- manual motion ---------------------------------------------------------------------------

    def move_axis(self, axis: int, rate: float) -> None:
        if not self.caps.can_move_axis(axis):
            raise MemberNotImplemented(f"axis {axis} cannot be moved on this mount: CanMoveAxis({axis}) is false")
        if not math.isfinite(rate) or (rate != 0.0 and not AXIS_MIN_DEG_S <= abs(rate) <= self.caps.max_rate()):
            raise InvalidValue(f"rate {rate} deg/s is outside the axis rates: 0, "
                               f"or ±{AXIS_MIN_DEG_S:.6f} to ±{self.caps.max_rate():.4f}")
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
