"""ASCOM ITelescopeV4 semantics on top of one :class:`~alpaca_zwo.mount.Mount`.

Validation and ranges, the Can* flags, Slewing / IsPulseGuiding / AtPark bookkeeping, target and
site caches and the client reference count live here; bytes do not. Every failure is an
:class:`~alpaca_zwo._exceptions.AlpacaError` subclass carrying the ASCOM code a client expects.

Busy flags are set *before* a call returns and cleared only by the supervisor thread when the
mount has really finished: a GOTO counts as finished when a poll taken after the command shows
the mount idle, having either seen it busy or waited out the mount's status lag. Slewing never
flickers false mid-motion, and a pulse never sets it.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone
from enum import Enum

from . import __version__, sky
from ._exceptions import (
    AlpacaError,
    DriverError,
    InvalidOperation,
    InvalidValue,
    LinkError,
    LinkTimeout,
    MemberNotImplemented,
    MountReplyError,
    NotConnected,
    Parked,
    ProtocolError,
    ValueNotSet,
)
from .clients import ClientKey, ClientRegistry, current_client
from .config import DeviceSettings, Settings, horizon_altitude_at
from .mount import PULSE_CHUNK_MS, SIDEREAL_DEG_S, Mount, MountState
from .protocol import SLEW_SPEEDS, Direction, MeridianSettings, MountMode, TrackRate
from .sky import PierSide
from .store import SettingsStore

log = logging.getLogger(__name__)

#: The mount's status flags can lag a command by ~0.5 s (field notes §5.1).
STATUS_LAG_S = 1.0
MAX_MOTION_S = 600.0
#: After the last client disconnects the link stays open this long, so reconnects are instant.
LINGER_S = 60.0
#: During a link outage, Connected stays true (last-known state served with its age) this long.
LINK_GRACE_S = 30.0
MAX_PULSE_MS = 60_000
#: The mount's clock keeps a two-digit year; a day of margin either side for the UTC offset.
MOUNT_EPOCH_FIRST = datetime(2000, 1, 2, tzinfo=timezone.utc)
MOUNT_EPOCH_LAST = datetime(2099, 12, 30, tzinfo=timezone.utc)
#: A GOTO takes about this long per degree plus a fixed part; used to aim HA-fixed targets.
SLEW_S_PER_DEG = 1 / 5.0
SLEW_S_FIXED = 3.0

DRIVE_RATES = {0: TrackRate.SIDEREAL, 1: TrackRate.LUNAR, 2: TrackRate.SOLAR}
RATE_CODES = {rate: code for code, rate in DRIVE_RATES.items()}
GUIDE_DIRECTIONS = {0: Direction.NORTH, 1: Direction.SOUTH, 2: Direction.EAST, 3: Direction.WEST}
AXIS_MIN_DEG_S = SLEW_SPEEDS[0] * SIDEREAL_DEG_S  # 0.25x sidereal

# DriverError numbers, so scripts can tell the cases apart.
ERR_LINK = 0x500
ERR_MOUNT_REFUSED = 0x501
ERR_MOUNT_PROTOCOL = 0x502
ERR_TIMEOUT = 0x503


class MotionKind(Enum):
    GOTO = "goto"
    ALTAZ = "slew to alt/az"
    PARK = "park"
    HOME = "find home"


@dataclass
class _Motion:
    kind: MotionKind
    started: float
    saw_busy: bool = False
    arrived_at: float | None = None


@dataclass
class _Pulse:
    """A guide pulse sent in chunks of at most 3 s: ``remaining_ms`` not yet sent, and the mount time
    by which the whole pulse should be over (a link failure may cost pulse time, nothing else may)."""

    direction: Direction
    remaining_ms: int
    deadline: float
    chunk_end: float


def _utc(t: datetime) -> datetime:
    return t.astimezone(timezone.utc) if t.tzinfo else t.replace(tzinfo=timezone.utc)


class Telescope:
    """One Alpaca telescope device (the handlers named in ``alpaca/device.py``)."""

    interface_version_value = 4

    def __init__(
        self,
        mount: Mount,
        store: SettingsStore,
        device_index: int = 0,
        *,
        registry: ClientRegistry | None = None,
        clock: Callable[[], datetime] | None = None,
        linger_s: float = LINGER_S,
        link_grace_s: float = LINK_GRACE_S,
    ) -> None:
        self.mount = mount
        self.store = store
        self.device_index = device_index
        self.registry = registry or ClientRegistry()
        self.clock = clock or mount.clock
        self.linger_s = linger_s
        self.link_grace_s = link_grace_s
        # Three locks, so a GET never waits on the serial line: _clients_lock guards the client set
        # and is never held across I/O; _lock serialises commands (held across I/O, never taken by
        # a GET); _wake is what the supervisor and synchronous slews wait on.
        self._lock = threading.RLock()
        self._clients_lock = threading.Lock()
        self._clients: set[ClientKey] = set()
        self._connecting = False
        self._linger_timer: threading.Timer | None = None
        self._target_ra: float | None = None
        self._target_dec: float | None = None
        self._motion: _Motion | None = None
        self._restore_tracking: bool | None = None
        self._parked = False
        self._settle_s = 0
        self._utc_offset = timedelta(0)
        self._pulses: dict[int, _Pulse] = {}
        self._move_owner: dict[int, ClientKey | None] = {}
        self._meridian = MeridianSettings()
        self._stop_pending = ""  # why a safety stop is still owed to the mount ('' = none)
        self._wake = threading.Condition()
        self._stop = threading.Event()
        self._supervisor = threading.Thread(target=self._supervise, name=f"telescope-{device_index}", daemon=True)
        self._supervisor.start()

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
            self._stop_manual_motion("the server is shutting down")
            if self._pulses:
                self._pulses.clear()
            if park and not self._parked:
                try:
                    log.info("parking on shutdown")
                    self._park()
                    deadline = time.monotonic() + park_timeout_s
                    with self._wake:
                        while self._motion is not None and time.monotonic() < deadline:
                            self._wake.wait(0.25)
                except AlpacaError as exc:
                    log.error("could not park on shutdown: %s", exc.message)
        self._stop.set()
        self._notify()
        self._cancel_linger()
        if self.mount.running:
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
        from . import actions  # the ZWO actions live in their own module (issue 15)

        return actions.supported_actions()

    def action(self, action: str, parameters: str) -> str:
        from . import actions

        return actions.run_action(self, action, parameters)

    def _raw(self, command: str) -> str:
        if not self.settings.server.allow_raw_commands:
            raise MemberNotImplemented(
                "raw mount commands are disabled (they bypass every safety check); "
                "set server.allow_raw_commands = true to enable them"
            )
        self._require_connected()
        with self._mount_errors("raw command"):
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

    # -- connection (reference-counted across clients) ---------------------------------------

    def _caller(self) -> ClientKey:
        return current_client.get() or ClientKey("internal", 0)

    def connected(self) -> bool:
        key = current_client.get()
        with self._clients_lock:
            has_client = bool(self._clients) if key is None else key in self._clients
        return has_client and self._device_up()

    def _device_up(self) -> bool:
        if not self.mount.running:
            return False
        status = self.mount.link.status
        return status.connected or time.time() - status.since < self.link_grace_s

    def set_connected(self, value: bool) -> None:
        key = self._caller()
        if value:
            self._open_mount()
            with self._clients_lock:
                self._clients.add(key)
                self._cancel_linger()
            log.info("client %s connected (%d connected)", key, len(self._clients))
        else:
            self._release(key)

    def connect(self) -> None:
        key = self._caller()
        with self._clients_lock:
            if self._connecting:
                return
            self._connecting = True

        def run() -> None:
            try:
                self._open_mount()
                with self._clients_lock:
                    self._clients.add(key)
                    self._cancel_linger()
            except AlpacaError as exc:
                log.error("connect failed: %s", exc.message)
            finally:
                with self._clients_lock:
                    self._connecting = False

        threading.Thread(target=run, name="telescope-connect", daemon=True).start()

    def disconnect(self) -> None:
        self._release(self._caller())

    def connecting(self) -> bool:
        return self._connecting

    def _open_mount(self) -> None:
        with self._lock:
            if self.mount.running:
                return
            try:
                self.mount.connect()
            except (LinkError, ProtocolError, MountReplyError) as exc:
                raise DriverError(f"cannot connect to the mount at {self.mount.link.url}: {exc}", ERR_LINK) from exc
            self._load_mount_settings()

    def connected_clients(self) -> frozenset[ClientKey]:
        """Who holds the device connected (the setup page lists them)."""
        with self._clients_lock:
            return frozenset(self._clients)

    def _configured_meridian(self) -> MeridianSettings:
        limits = self.settings.limits
        return MeridianSettings(False, limits.meridian_track_past, round(limits.meridian_limit_deg))

    def set_meridian_settings(self, meridian: MeridianSettings) -> None:
        """Write the mount's meridian behaviour and remember it: DestinationSideOfPier depends on it."""
        with self._mount_errors("setting the meridian behaviour"):
            self.mount.set_meridian(meridian)
        self._meridian = meridian

    def _load_mount_settings(self) -> None:
        """The configuration is the single source of truth: a replaced or reset mount gets it back."""
        settings = self.mount.read_settings()
        wanted = self._configured_meridian()
        if settings.meridian is not None:
            self._meridian = settings.meridian
            if settings.meridian != wanted:
                try:
                    self.set_meridian_settings(wanted)
                    log.info("mount meridian setting %s replaced by the configured %s", settings.meridian, wanted)
                except DriverError as exc:
                    log.warning("could not apply the configured meridian setting: %s", exc.message)
        try:
            self.mount.set_tracking_rate(TrackRate.SIDEREAL)  # "start up with a known tracking rate"
        except (LinkError, ProtocolError) as exc:
            log.warning("could not select the sidereal rate: %s", exc)

    def _release(self, key: ClientKey) -> None:
        with self._clients_lock:
            self._clients.discard(key)
            remaining = len(self._clients)
        if remaining == 0 and self.mount.running:
            with self._lock:
                self._stop_manual_motion("the last client disconnected")
            with self._clients_lock:
                if not self._clients:
                    self._cancel_linger()
                    timer = threading.Timer(self.linger_s, self._linger_expired)
                    timer.daemon = True
                    self._linger_timer = timer
                    timer.start()
        log.info("client %s disconnected (%d still connected)", key, remaining)

    def _cancel_linger(self) -> None:
        if self._linger_timer is not None:
            self._linger_timer.cancel()
            self._linger_timer = None

    def _linger_expired(self) -> None:
        with self._lock:
            with self._clients_lock:
                if self._clients or self._motion is not None:
                    return
            log.info("no client for %.0f s: closing the mount link", self.linger_s)
            self.mount.disconnect()

    def _notify(self) -> None:
        with self._wake:
            self._wake.notify_all()

    def _require_connected(self) -> None:
        """The device is connected while at least one client holds it (the link may linger longer)."""
        with self._clients_lock:
            held = bool(self._clients)
        if not held or not self.mount.running:
            raise NotConnected("the telescope is not connected: set Connected=true or call Connect first")

    def _require_unparked(self, what: str) -> None:
        if self._parked:
            raise Parked(f"{what} is not allowed while the telescope is parked; unpark it first")

    @contextmanager
    def _mount_errors(self, what: str) -> Iterator[None]:
        """Translate link and mount failures into the DriverErrors a client should see."""
        try:
            yield
        except MountReplyError as exc:
            raise DriverError(f"{what}: the mount refused: {exc.meaning or exc.reply}", ERR_MOUNT_REFUSED) from exc
        except ProtocolError as exc:
            raise DriverError(f"{what}: garbled reply from the mount: {exc}", ERR_MOUNT_PROTOCOL) from exc
        except LinkError as exc:
            raise DriverError(f"{what}: mount link problem: {exc}", ERR_LINK) from exc

    # -- state -------------------------------------------------------------------------------

    def _state(self) -> MountState:
        self._require_connected()
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
        return self.clock() + self._utc_offset

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
        self._require_connected()
        return self._lst()

    def utc_date(self) -> datetime:
        self._require_connected()
        return self.utc_now()

    def set_utc_date(self, value: datetime) -> None:
        self._require_connected()
        value = _utc(value)
        if not MOUNT_EPOCH_FIRST <= value <= MOUNT_EPOCH_LAST:
            raise InvalidValue(
                f"UTCDate {value.isoformat()} is outside 2000-2099, the years the mount's clock can hold")
        self._utc_offset = value - self.clock()
        log.info("UTCDate set: clock offset now %.3f s", self._utc_offset.total_seconds())
        with self._mount_errors("setting the mount clock"):
            self.mount.clock_offset = self._utc_offset
            self.mount.push_time()

    def tracking(self) -> bool:
        state = self._state()
        return bool(state.tracking and state.tracking.on)

    def set_tracking(self, value: bool) -> None:
        self._require_connected()
        if value:
            self._require_unparked("Tracking=true")
        try:
            with self._mount_errors("setting tracking"):
                self.mount.set_tracking(value)
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
        self._require_connected()
        return RATE_CODES[self.mount.state.tracking_rate]

    def set_tracking_rate(self, value: int) -> None:
        if value not in DRIVE_RATES:
            raise InvalidValue(f"TrackingRate {value} is not supported; use 0 (sidereal), 1 (lunar) or 2 (solar)")
        self._require_connected()
        with self._mount_errors("setting the tracking rate"):
            self.mount.set_tracking_rate(DRIVE_RATES[value])

    def at_park(self) -> bool:
        self._require_connected()
        return self._parked

    def at_home(self) -> bool:
        state = self._state()
        if self._motion is not None or state.moving_axes:
            return False
        return state.pier == "N" or bool(state.status and state.status.at_home)

    def slewing(self) -> bool:
        self._require_connected()
        return self._slewing_now(self.mount.state)

    def _slewing_now(self, state: MountState) -> bool:
        """Our own motions, manual moves, and any GOTO the mount reports (a hand-controller GOTO too)."""
        return self._motion is not None or bool(state.moving_axes) or state.goto_running

    def is_pulse_guiding(self) -> bool:
        self._require_connected()
        return bool(self._pulses)

    def side_of_pier(self) -> int:
        state = self._state()
        if state.pier == "W":
            return int(PierSide.WEST)
        if state.pier == "E":
            return int(PierSide.EAST)
        return int(sky.pointing_state(sky.hour_angle(self._lst(), self._position()[0])))

    def set_side_of_pier(self, value: int) -> None:
        raise MemberNotImplemented("the mount chooses its pier side itself; SideOfPier cannot be set")

    def destination_side_of_pier(self, right_ascension: float, declination: float) -> int:
        self._check_equatorial(right_ascension, declination)
        self._require_connected()
        ha = sky.hour_angle(self._lst(), right_ascension)
        return int(sky.goto_pier_side(ha, PierSide.UNKNOWN, self._flip_limit_deg()))

    def _flip_limit_deg(self) -> float:
        meridian = self._meridian
        limit = float(meridian.limit_degrees)
        # A negative limit stops tracking before the meridian whatever the "track past" flag says.
        return limit if limit < 0.0 or meridian.track_after else 0.0

    def alignment_mode(self) -> int:
        state = self._state()
        if state.status is not None and state.status.mode is MountMode.ALTAZ:
            return 0
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
            ("AtPark", self._parked),
            ("Azimuth", azimuth),
            ("Declination", position[1]),
            ("IsPulseGuiding", bool(self._pulses)),
            ("RightAscension", position[0]),
            ("SideOfPier", self.side_of_pier()),
            ("SiderealTime", self._lst()),
            ("Slewing", self._slewing_now(state)),
            ("Tracking", bool(state.tracking and state.tracking.on)),
            ("UTCDate", self.utc_now()),
            ("TimeStamp", stamp),
        ]

    # -- capabilities ------------------------------------------------------------------------

    def can_find_home(self) -> bool:
        return True

    def can_park(self) -> bool:
        return True

    def can_unpark(self) -> bool:
        return True

    def can_set_park(self) -> bool:
        return True

    def can_pulse_guide(self) -> bool:
        return True

    def can_set_guide_rates(self) -> bool:
        return True

    def can_set_tracking(self) -> bool:
        return True

    def can_slew(self) -> bool:
        return True

    def can_slew_async(self) -> bool:
        return True

    def can_slew_alt_az(self) -> bool:
        return True

    def can_slew_alt_az_async(self) -> bool:
        return True

    def can_sync(self) -> bool:
        return True

    def can_sync_alt_az(self) -> bool:
        return True

    def can_set_pier_side(self) -> bool:
        return False

    def can_set_declination_rate(self) -> bool:
        return False

    def can_set_right_ascension_rate(self) -> bool:
        return False

    def can_move_axis(self, axis: int) -> bool:
        if axis not in (0, 1, 2):
            raise InvalidValue(f"axis {axis} does not exist; axes are 0 (RA), 1 (Dec) and 2 (none on this mount)")
        return axis in (0, 1)

    def axis_rates(self, axis: int) -> list[tuple[float, float]]:
        if not self.can_move_axis(axis):
            return []
        return [(AXIS_MIN_DEG_S, self._max_rate())]

    def _max_rate(self) -> float:
        return SLEW_SPEEDS[-1] * SIDEREAL_DEG_S

    # -- properties the mount does not have ----------------------------------------------------

    def aperture_area(self) -> float:
        raise MemberNotImplemented("a mount does not know the telescope's aperture")

    def aperture_diameter(self) -> float:
        raise MemberNotImplemented("a mount does not know the telescope's aperture")

    def focal_length(self) -> float:
        raise MemberNotImplemented("a mount does not know the telescope's focal length")

    def does_refraction(self) -> bool:
        return False

    def set_does_refraction(self, value: bool) -> None:
        if value:
            raise MemberNotImplemented("the mount does not correct for refraction")

    def declination_rate(self) -> float:
        return 0.0

    def set_declination_rate(self, value: float) -> None:
        raise MemberNotImplemented("the mount cannot track with a declination rate offset")

    def right_ascension_rate(self) -> float:
        return 0.0

    def set_right_ascension_rate(self, value: float) -> None:
        raise MemberNotImplemented("the mount cannot track with a right ascension rate offset")

    # -- guide rates (one mount rate shared by both axes) --------------------------------------

    def guide_rate_right_ascension(self) -> float:
        self._require_connected()
        return self.mount.state.guide_rate * SIDEREAL_DEG_S

    def guide_rate_declination(self) -> float:
        return self.guide_rate_right_ascension()

    def set_guide_rate_right_ascension(self, value: float) -> None:
        fraction = value / SIDEREAL_DEG_S
        if not 0.095 <= fraction <= 0.905:
            raise InvalidValue(
                f"guide rate {value:.6f} deg/s is {fraction:.2f}x sidereal; the mount accepts 0.1x to 0.9x "
                f"({0.1 * SIDEREAL_DEG_S:.6f} to {0.9 * SIDEREAL_DEG_S:.6f} deg/s)"
            )
        self._require_connected()
        with self._mount_errors("setting the guide rate"):
            self.mount.set_guide_rate(min(0.9, max(0.1, round(fraction, 2))))

    def set_guide_rate_declination(self, value: float) -> None:
        self.set_guide_rate_right_ascension(value)

    # -- site ----------------------------------------------------------------------------------

    def site_latitude(self) -> float:
        return self.settings.site.latitude

    def site_longitude(self) -> float:
        return self.settings.site.longitude

    def site_elevation(self) -> float:
        return self.settings.site.elevation

    def set_site_latitude(self, value: float) -> None:
        if not -90.0 <= value <= 90.0:
            raise InvalidValue(f"SiteLatitude {value} is outside -90..90 degrees")
        self._update_site(latitude=value)

    def set_site_longitude(self, value: float) -> None:
        if not -180.0 <= value <= 180.0:
            raise InvalidValue(f"SiteLongitude {value} is outside -180..180 degrees")
        self._update_site(longitude=value)

    def set_site_elevation(self, value: float) -> None:
        if not -300.0 <= value <= 10000.0:
            raise InvalidValue(f"SiteElevation {value} is outside -300..10000 m")
        self._update_site(elevation=value)

    def _update_site(self, **changes: float) -> None:
        """Keep the exact values clients wrote (they read back with ==); the mount gets arcseconds."""
        site = dataclasses.replace(self.settings.site, **changes)
        self.store.update(lambda s: dataclasses.replace(s, site=site))
        if self.mount.running and ("latitude" in changes or "longitude" in changes):
            with self._mount_errors("setting the site"):
                self.mount.push_site(site.latitude, site.longitude)

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

    # -- slews ---------------------------------------------------------------------------------

    @staticmethod
    def _check_equatorial(ra: float, dec: float) -> None:
        if not (math.isfinite(ra) and 0.0 <= ra < 24.0):
            raise InvalidValue(f"RightAscension {ra} is outside 0..24 hours")
        if not (math.isfinite(dec) and -90.0 <= dec <= 90.0):
            raise InvalidValue(f"Declination {dec} is outside -90..90 degrees")

    @staticmethod
    def _check_horizontal(azimuth: float, altitude: float) -> None:
        if not (math.isfinite(azimuth) and 0.0 <= azimuth <= 360.0):
            raise InvalidValue(f"Azimuth {azimuth} is outside 0..360 degrees")
        if not (math.isfinite(altitude) and -90.0 <= altitude <= 90.0):
            raise InvalidValue(f"Altitude {altitude} is outside -90..90 degrees")

    def _check_above_limits(self, ra: float, dec: float) -> None:
        """Refuse a target below the configured horizon before anything is sent to the mount."""
        ha = sky.hour_angle(self._lst(), ra)
        altitude, azimuth = sky.equatorial_to_horizontal(ha, dec, self.settings.site.latitude)
        floor = horizon_altitude_at(self.settings.limits, azimuth)
        if altitude < floor:
            raise InvalidValue(
                f"target is below the horizon limit: altitude {altitude:.2f}° at azimuth {azimuth:.1f}° "
                f"is under the {floor:.2f}° allowed there"
            )

    def slew_to_coordinates_async(self, right_ascension: float, declination: float) -> None:
        self._check_equatorial(right_ascension, declination)
        self._require_connected()
        self._require_unparked("SlewToCoordinatesAsync")
        self._target_ra, self._target_dec = right_ascension, declination
        self._start_goto(right_ascension, declination, MotionKind.GOTO)

    def slew_to_coordinates(self, right_ascension: float, declination: float) -> None:
        self.slew_to_coordinates_async(right_ascension, declination)
        self._wait_motion()

    def slew_to_target_async(self) -> None:
        ra, dec = self.target_right_ascension(), self.target_declination()
        self._require_connected()
        self._require_unparked("SlewToTargetAsync")
        self._start_goto(ra, dec, MotionKind.GOTO)

    def slew_to_target(self) -> None:
        self.slew_to_target_async()
        self._wait_motion()

    def _aim_fixed_hour_angle(self, ha: float, dec: float) -> tuple[float, float]:
        """RA/Dec to GOTO so the mount arrives at a point fixed to the ground (HA/Dec, alt/az).

        A GOTO chases a fixed RA while the sky turns; aiming at the RA the point will have when the
        slew ends keeps the arrival within a fraction of the sky's motion during the slew.
        """
        here = self.mount.position()
        lst = self._lst()
        if here is None:
            return sky.ra_from_hour_angle(lst, ha), dec
        distance = sky.angular_separation(sky.ra_from_hour_angle(lst, ha), dec, *here)
        lead_s = SLEW_S_FIXED + distance * SLEW_S_PER_DEG
        return sky.ra_from_hour_angle(lst + lead_s * 24.0 / 86164.0905, ha), dec

    def _radec_from_altaz(self, azimuth: float, altitude: float) -> tuple[float, float]:
        ha, dec = sky.horizontal_to_equatorial(altitude, azimuth, self.settings.site.latitude)
        return sky.ra_from_hour_angle(self._lst(), ha), dec

    def slew_to_alt_az_async(self, azimuth: float, altitude: float) -> None:
        self._check_horizontal(azimuth, altitude)
        self._require_connected()
        self._require_unparked("SlewToAltAzAsync")
        ha, dec = sky.horizontal_to_equatorial(altitude, azimuth, self.settings.site.latitude)
        self._start_goto(*self._aim_fixed_hour_angle(ha, dec), MotionKind.ALTAZ)

    def slew_to_alt_az(self, azimuth: float, altitude: float) -> None:
        self.slew_to_alt_az_async(azimuth, altitude)
        self._wait_motion()

    def _start_goto(self, ra: float, dec: float, kind: MotionKind) -> None:
        self._check_above_limits(ra, dec)
        with self._lock:
            self._stop_for_new_motion()
            was_tracking = bool(self.mount.state.tracking and self.mount.state.tracking.on)
            self._restore_tracking = was_tracking if kind is MotionKind.ALTAZ else None
            self._motion = _Motion(kind, self.mount.monotonic())
        try:
            self.mount.goto(ra, dec)
        except LinkTimeout as exc:
            # The reply was lost, not necessarily the command: the mount may be slewing. Keep the
            # motion under supervision; polls end it as soon as they show the mount idle.
            self._notify()
            raise DriverError(f"{kind.value}: the mount did not confirm the GOTO ({exc}); Slewing shows whether "
                              "it started", ERR_TIMEOUT) from exc
        except (MountReplyError, ProtocolError, LinkError) as exc:
            with self._lock:
                self._motion = None
            with self._mount_errors(kind.value):
                raise exc
        self._notify()

    def _stop_for_new_motion(self) -> None:
        """A new GOTO replaces whatever moves now: stop it and wait for the mount to be idle."""
        state = self.mount.state
        if self._motion is None and not state.moving_axes and not state.goto_running:
            return
        with self._mount_errors("stopping the current motion"):
            self.mount.stop()
        self._motion = None
        self._move_owner.clear()
        self.mount.refresh()
        idle = self.mount.wait_for(
            lambda s: s.status_time is not None and s.status_time > self.mount.monotonic() - 0.5 and not s.goto_running,
            timeout=10.0,
        )
        if idle is None:
            raise DriverError("the mount did not stop the previous motion", ERR_TIMEOUT)

    def _wait_motion(self) -> None:
        deadline = time.monotonic() + MAX_MOTION_S
        with self._wake:
            while self._motion is not None:
                if time.monotonic() > deadline:
                    raise DriverError("the slew did not finish in time", ERR_TIMEOUT)
                self._wake.wait(0.25)

    def abort_slew(self) -> None:
        self._require_connected()
        self._require_unparked("AbortSlew")
        with self._lock:
            self._motion = None
            self._restore_tracking = None
            self._move_owner.clear()
            with self._mount_errors("AbortSlew"):
                self.mount.stop()
        self._notify()

    # -- syncs ---------------------------------------------------------------------------------

    def _require_tracking(self, what: str) -> None:
        tracking = self.mount.state.tracking
        if tracking is None or not tracking.on:
            raise InvalidOperation(f"{what} needs Tracking=true (a sync is made on a tracked position)")

    def sync_to_coordinates(self, right_ascension: float, declination: float) -> None:
        self._check_equatorial(right_ascension, declination)
        self._require_connected()
        self._require_unparked("SyncToCoordinates")
        self._require_tracking("SyncToCoordinates")
        self._sync(right_ascension, declination)
        self._target_ra, self._target_dec = right_ascension, declination

    def sync_to_target(self) -> None:
        ra, dec = self.target_right_ascension(), self.target_declination()
        self._require_connected()
        self._require_unparked("SyncToTarget")
        self._require_tracking("SyncToTarget")
        self._sync(ra, dec)

    def sync_to_alt_az(self, azimuth: float, altitude: float) -> None:
        self._check_horizontal(azimuth, altitude)
        self._require_connected()
        self._require_unparked("SyncToAltAz")
        self._sync(*self._radec_from_altaz(azimuth, altitude))

    def _sync(self, ra: float, dec: float) -> None:
        if self._motion is not None or self.mount.state.moving_axes:
            raise InvalidOperation("cannot sync while the mount is moving")
        here = self.mount.position()
        if here is not None and sky.angular_separation(ra, dec, *here) < 1 / 3600:
            # Already there: a sync would change nothing, and near the pole the mount refuses it (e11).
            self.mount.sync_estimate(ra, dec)
            return
        with self._mount_errors("sync"):
            self.mount.sync(ra, dec)

    # -- home, park ----------------------------------------------------------------------------

    def find_home(self) -> None:
        self._require_connected()
        self._require_unparked("FindHome")
        with self._lock:
            self._stop_for_new_motion()
            self._motion = _Motion(MotionKind.HOME, self.mount.monotonic())
        try:
            with self._mount_errors("FindHome"):
                self.mount.home()
        except AlpacaError:
            self._motion = None
            raise

    def park(self) -> None:
        self._require_connected()
        self._park()

    def _park(self) -> None:
        if self._parked:
            return  # parking twice is harmless
        park = self.settings.park
        with self._lock:
            self._stop_for_new_motion()
            self._motion = _Motion(MotionKind.PARK, self.mount.monotonic())
        try:
            with self._mount_errors("Park"):
                if park.mode == "home":
                    self.mount.home()
                else:
                    self.mount.goto(*self._aim_fixed_hour_angle(park.ha_hours, park.dec_deg))
        except AlpacaError:
            self._motion = None
            raise

    def unpark(self) -> None:
        self._require_connected()
        self._parked = False

    def set_park(self) -> None:
        ra, dec = self._position()
        ha = sky.hour_angle(self._lst(), ra)
        park = dataclasses.replace(self.settings.park, mode="custom", ha_hours=ha, dec_deg=dec)
        self.store.update(lambda s: dataclasses.replace(s, park=park))
        log.info("park position set to HA %.4f h, Dec %.4f°", ha, dec)

    # -- manual motion ---------------------------------------------------------------------------

    def move_axis(self, axis: int, rate: float) -> None:
        if not self.can_move_axis(axis):
            raise MemberNotImplemented(f"axis {axis} cannot be moved on this mount: CanMoveAxis({axis}) is false")
        if not math.isfinite(rate) or (rate != 0.0 and not AXIS_MIN_DEG_S <= abs(rate) <= self._max_rate()):
            raise InvalidValue(
                f"rate {rate} deg/s is outside the axis rates: 0, or ±{AXIS_MIN_DEG_S:.6f} to ±{self._max_rate():.4f}"
            )
        self._require_connected()
        self._require_unparked("MoveAxis")
        with self._lock:
            if rate != 0.0 and self._motion is not None:
                raise InvalidOperation(f"a {self._motion.kind.value} is in progress; abort it first")
            with self._mount_errors("MoveAxis"):
                self.mount.move_axis(axis, rate)
            if rate == 0.0:
                self._move_owner.pop(axis, None)
            else:
                self._move_owner[axis] = current_client.get()

    def _stop_manual_motion(self, why: str) -> None:
        if not self._move_owner and not self.mount.state.moving_axes:
            return
        log.warning("stopping manual motion: %s", why)
        self._move_owner.clear()
        try:
            for axis in (0, 1):
                if axis in self.mount.state.moving_axes:
                    self.mount.move_axis(axis, 0.0)
        except (LinkError, ProtocolError, MountReplyError) as exc:
            self._safety_stop(f"{why} (stopping the axes failed: {exc})")

    def _safety_stop(self, why: str) -> None:
        """Send :Q# now, and keep retrying from the supervisor until the mount has taken it."""
        try:
            self.mount.stop()
            self._stop_pending = ""
            log.warning("mount stopped: %s", why)
        except (LinkError, ProtocolError) as exc:
            if not self._stop_pending:
                log.error("could not stop the mount (%s): %s; retrying until it answers", why, exc)
            self._stop_pending = why

    # -- guiding -------------------------------------------------------------------------------

    def pulse_guide(self, direction: int, duration: int) -> None:
        if direction not in GUIDE_DIRECTIONS:
            raise InvalidValue(f"Direction {direction} is not 0 (N), 1 (S), 2 (E) or 3 (W)")
        if not 0 <= duration <= MAX_PULSE_MS:
            raise InvalidValue(f"Duration {duration} ms is outside 0..{MAX_PULSE_MS} ms")
        self._require_connected()
        self._require_unparked("PulseGuide")
        if self._motion is not None:
            raise InvalidOperation(f"cannot pulse guide during a {self._motion.kind.value}")
        if duration == 0:
            return
        guide = GUIDE_DIRECTIONS[direction]
        axis = 0 if guide in (Direction.EAST, Direction.WEST) else 1
        chunk = min(duration, PULSE_CHUNK_MS)
        with self._lock:
            with self._mount_errors("PulseGuide"):
                end = self.mount.pulse_guide(guide, chunk)
            self._pulses[axis] = _Pulse(guide, duration - chunk, end - chunk / 1000.0 + duration / 1000.0, end)
        self._notify()

    # -- supervisor ------------------------------------------------------------------------------

    def _supervise(self) -> None:
        """One loop that ends motions, continues long pulses and enforces the safety rules."""
        while not self._stop.is_set():
            with self._wake:
                self._wake.wait(self._next_wake())
            if self._stop.is_set():
                return
            try:
                self._tick()
            except Exception:  # the supervisor must survive anything to keep the mount safe
                log.exception("telescope supervisor error")

    def _next_wake(self) -> float:
        """Real seconds to wait: 0.1 s at most, sooner when a pulse chunk ends (in mount time)."""
        now = self.mount.monotonic()
        rate = self.mount.clock_rate
        delays = [0.1]
        delays.extend(max(0.0, pulse.chunk_end - now) / rate for pulse in self._pulses.values())
        return min(delays)

    def _tick(self) -> None:
        if self._stop_pending and self.mount.running:
            self._safety_stop(self._stop_pending)
        now = self.mount.monotonic()
        self._tick_pulses(now)
        self._tick_motion(now)
        self._tick_watchdog()

    def _tick_pulses(self, now: float) -> None:
        """Send the next chunk of long pulses. If the link is down, retry until the pulse's own end:
        the mount carries on with the chunk it has, and the rest goes out once the link is back."""
        with self._lock:
            for axis, pulse in list(self._pulses.items()):
                if now < pulse.chunk_end:
                    continue
                if pulse.remaining_ms < 10 or not self.mount.running:
                    del self._pulses[axis]
                    continue
                chunk = min(pulse.remaining_ms, PULSE_CHUNK_MS)
                try:
                    end = self.mount.pulse_guide(pulse.direction, chunk)
                except (LinkError, ProtocolError) as exc:
                    # What the link outage took is lost; the rest still ends by the pulse's deadline.
                    left = min(pulse.remaining_ms, int((pulse.deadline - now) * 1000.0))
                    log.warning("pulse continuation failed (%s); retrying with %d ms left", exc, left)
                    self._pulses[axis] = _Pulse(pulse.direction, left, pulse.deadline, now + 0.05)
                    continue
                self._pulses[axis] = _Pulse(pulse.direction, pulse.remaining_ms - chunk, pulse.deadline, end)

    def _tick_motion(self, now: float) -> None:
        motion = self._motion
        if motion is None:
            return
        state = self.mount.state
        if now - motion.started > MAX_MOTION_S:
            log.error("%s did not finish within %.0f s: stopping", motion.kind.value, MAX_MOTION_S)
            self._finish_motion(motion, arrived=False)
            return
        if motion.arrived_at is None:
            if state.status_time is None or state.status_time <= motion.started or state.status is None:
                return  # no reading taken after the command yet
            if state.status.slewing:
                motion.saw_busy = True
                return
            if not motion.saw_busy and state.status_time - motion.started < STATUS_LAG_S:
                return  # the flags may still show the state from before the command
            motion.arrived_at = now
            self._on_arrival(motion)
        if now - motion.arrived_at >= self._settle_s:
            self._finish_motion(motion, arrived=True)

    def _on_arrival(self, motion: _Motion) -> None:
        try:
            if motion.kind is MotionKind.PARK or (motion.kind is MotionKind.ALTAZ and self._restore_tracking is False):
                self.mount.set_tracking(False)
        except (LinkError, ProtocolError, MountReplyError) as exc:
            log.error("after %s: could not set tracking: %s", motion.kind.value, exc)

    def _finish_motion(self, motion: _Motion, arrived: bool) -> None:
        with self._lock:
            if self._motion is not motion:
                return
            if motion.kind is MotionKind.PARK and arrived:
                self._parked = True
                log.info("parked")
            self._motion = None
            self._restore_tracking = None
        self._notify()

    def _tick_watchdog(self) -> None:
        """Stop a MoveAxis whose client stopped talking, and any manual move below the horizon."""
        if not self._move_owner:
            return
        limit = self.settings.safety.moveaxis_watchdog_s
        now = time.monotonic()
        for axis, owner in list(self._move_owner.items()):
            if owner is None:
                continue
            seen = self.registry.last_seen(owner)
            if seen is not None and now - seen > limit:
                with self._lock:
                    self._stop_axis(axis, f"client {owner} went silent for {now - seen:.0f} s during MoveAxis")
        state = self.mount.state
        if state.ra is not None and state.dec is not None and self._move_owner:
            altitude, azimuth = self._altaz((state.ra, state.dec))
            floor = horizon_altitude_at(self.settings.limits, azimuth)
            if altitude < floor:
                with self._lock:
                    for axis in list(self._move_owner):
                        self._stop_axis(axis, f"manual move reached the horizon limit ({altitude:.2f}° < {floor:.2f}°)")

    def _stop_axis(self, axis: int, why: str) -> None:
        log.warning("stopping axis %d: %s", axis, why)
        self._move_owner.pop(axis, None)
        try:
            self.mount.move_axis(axis, 0.0)
        except (LinkError, ProtocolError, MountReplyError) as exc:
            self._safety_stop(f"{why} (stopping axis {axis} failed: {exc})")
