"""The narrow face the web page sees: exactly the read-outs and operations the setup page needs.

The page (``alpaca_zwo/web``) lives beside the Alpaca API, not above the mount: it must never
reach into ``mount.link`` or the settings store on its own, or every refactoring of the lower
layers would break it silently. Everything it may read or do is a method here, so this module is
the one place that knows how the server, the telescopes, their mounts and links hang together.

Reads are snapshots only (the mount poller's state, the link's counters, the client registry):
nothing here waits for the serial line except the explicit mount-settings read and the controls.
The controls go through the same :class:`~alpaca_zwo.telescope.device.Telescope` methods the Alpaca API
uses, so the safety rules hold for both.

Besides its own classes it names only the types its methods take and return (the settings, the
mount's state and settings, the clock view, a client's key) and the settings file's dict form the page
edits: ``__all__``. The page takes errors from ``_exceptions`` (everyone may) and sky arithmetic from
the pure ``sky`` module, not through here; ``tests/test_layers.py`` holds the page to that.
"""

from __future__ import annotations

import dataclasses
import logging
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from . import __version__
from ._exceptions import (
    AlpacaError,
    AlpacaZwoError,
    InvalidOperation,
    InvalidValue,
    LinkError,
    MountReplyError,
    ProtocolError,
)
from .clients import ClientActivity, ClientKey, current_client
from .config.settings import ParkSettings, Settings, horizon_altitude_at, settings_from_dict, settings_to_dict
from .motion import Motion, MotionKind
from .mount.state import MountSettings, MountState
from .mount.timekeeping import ClockView
from .sky import SIDEREAL_DEG_S, PierSide
from .telescope.passes import Pass
from .telescope.satellites import side_name
from .telescope.stored_settings import CHECKS as STORED_CHECKS
from .zwo.link import LinkCounters, LinkStatus, Priority, TraceEntry
from .zwo.survey import SurveyContext, SurveyReport, run_survey
from .zwo.wire_values import MeridianSettings

if TYPE_CHECKING:
    from .alpaca.hosts import HostGuard
    from .clients import ClientRegistry
    from .config.store import SettingsStore
    from .telescope.device import Telescope

log = logging.getLogger(__name__)


class ServerParts(Protocol):
    """What the facade reads of the server (``server.AlpacaZwoServer`` is one). Declared here, so the
    server builds its facade without the facade importing the server: the two import no circle."""

    store: SettingsStore
    registry: ClientRegistry
    telescopes: list[Telescope]
    host_guard: HostGuard
    discovery: Any  # a DiscoveryResponder with a ``port``, or None when discovery is off
    http: Any  # the Alpaca HttpServer: the ``host`` it listens on and its bound ``port``
    advertiser: Any  # the mDNS advertiser, or None when mDNS is off
    gpsd: Any  # bridges.gpsd.GpsdSite (a ``status()`` dict) when site.gpsd is set, else None

    @property
    def settings(self) -> Settings: ...

    @property
    def safety_watch(self) -> SafetyStatusSource | None: ...  # the observatory interlock (observatory/watch.py)

    @property
    def port(self) -> int: ...

    @property
    def emulators(self) -> Sequence[object | None]: ...

    def bridges(self) -> Mapping[str, StatusSource]: ...


class SafetyStatusSource(Protocol):
    """The observatory interlock's watch as the page sees it: the verdict, the devices' last answers and
    their ages, the recent events (``observatory.SafetyWatch.status``)."""

    def status(self) -> dict[str, Any]: ...

    def ask_once(self, role: str, url: str, timeout: float = 5.0) -> tuple[bool, str]: ...


class FacadeProvider(Protocol):
    """What ``setup_routes`` is given: anything that can hand out the server's facade."""

    @property
    def facade(self) -> ServerFacade: ...


class StatusSource(Protocol):
    """A bridge (Stellarium server, shared ZWO port) as the page sees it: one ``status()`` dict.

    The page shows the keys ``enabled``, ``port``, ``clients`` (a list or a count),
    ``last_command`` and ``last_error`` (a string or a dict with ``time``/``message``/``command``)
    when present; any others are ignored.
    """

    def status(self) -> dict[str, Any]: ...


@dataclass(frozen=True)
class LinkView:
    """The serial link as the page shows it: its state and its traffic counters."""

    status: LinkStatus
    counters: LinkCounters
    poll_error: str


@dataclass(frozen=True)
class MotionView:
    """The Telescope's own answers for the page; ``None``/``False`` where it refuses (not connected)."""

    slewing: bool = False
    at_park: bool = False
    at_home: bool = False
    guiding: bool = False
    tracking_rate: int | None = None
    side_of_pier: int | None = None


@dataclass(frozen=True)
class MotionReport:
    """The server's slew, park or home now, or the last one and how it ended (the page's progress line).

    ``ra``/``dec``: its sky target (mount frame); ``ha``: set instead of ``ra`` for a point fixed to the
    ground (a custom park, a slew to Alt/Az); neither for a home (or a park at home): the pole.
    """

    kind: str
    active: bool
    error: str  # why it ended short ('' while running or when it arrived)
    ra: float | None
    ha: float | None
    dec: float | None


@dataclass(frozen=True)
class TimeSetReport:
    """A time set from the page: the server's reference now and, when the mount took it, its read-back."""

    utc: datetime
    mount_set: bool  # False: the mount is not connected; it gets the time when it is
    mount_utc: datetime | None = None  # the mount's clock as read back (whole seconds)
    mount_difference_s: float | None = None  # that reading minus the server's time at the same instant


def check_stored_setting(name: str, value: object) -> Any:
    """A value of a setting stored in the mount (``telescope/stored_settings.py``'s CHECKS names: ``buzzer``,
    ``meridian.limit_degrees`` ...) by the one check its owner applies: the value, or ValueError with why."""
    return STORED_CHECKS[name](value)


def _quiet(getter: Callable[[], Any], default: Any) -> Any:
    """A Telescope property for display: its ASCOM refusal (not connected, no position yet) shows as blank."""
    try:
        return getter()
    except AlpacaError:
        return default


class DeviceFacade:
    """One telescope as the page sees it: its snapshots, its mount's own settings and its controls."""

    def __init__(self, index: int, telescope: Telescope, server: ServerParts) -> None:
        self.index = index
        self._telescope = telescope
        self._server = server
        self._last_motion: Motion | None = None  # kept so the page can say how the last slew ended
        self._survey_lock = threading.Lock()
        self.last_survey: SurveyReport | None = None  # the page's download

    # -- identity and snapshots ------------------------------------------------------------------

    @property
    def name(self) -> str:
        return self._telescope.device_name

    @property
    def unique_id(self) -> str:
        return self._telescope.unique_id

    @property
    def emulated(self) -> bool:
        """This device drives the built-in emulator (no URL given by --device or the config)."""
        emulators = self._server.emulators
        return self.index < len(emulators) and emulators[self.index] is not None

    @property
    def url(self) -> str:
        """The mount this device really drives ('' for the built-in emulator): --device wins over the
        config's URL, as at start, so the page never calls a real mount "the built-in emulator"."""
        return "" if self.emulated else self._telescope.connection.link_status().url

    @property
    def running(self) -> bool:
        """The mount is connected (some client holds the device connected)."""
        return self._telescope.mount.running

    @property
    def state(self) -> MountState:
        return self._telescope.mount.state

    def mount_now(self) -> float:
        """Now on the mount's monotonic clock, the one its snapshot times are on (the emulator's, when fast)."""
        return self._telescope.mount.monotonic()

    def utc_now(self) -> datetime:
        return self._telescope.clock.utc_now()

    def connected_clients(self) -> frozenset[ClientKey]:
        return self._telescope.connection.clients()

    def motion(self) -> MotionView:
        """What Alpaca clients would read now; all blank while the mount is not connected."""
        if not self.running:
            return MotionView()
        t = self._telescope
        return MotionView(
            slewing=_quiet(t.slewing, False), at_park=_quiet(t.at_park, False), at_home=_quiet(t.at_home, False),
            guiding=_quiet(t.is_pulse_guiding, False), tracking_rate=_quiet(t.capabilities.tracking_rate, None),
            side_of_pier=_quiet(t.side_of_pier, None))

    def target(self) -> tuple[float, float] | None:
        """The slew target (RA hours, Dec degrees), or None when none is set."""
        try:
            return self._telescope.targets.target()
        except AlpacaError:
            return None

    def motion_report(self) -> MotionReport | None:
        """The running slew/park/home, else the last one with its outcome (manual moves and stops are not
        kept: a STOP ends the slew it interrupts with error "stopped", which is what the page reports)."""
        current = self._telescope.motion.running()
        if current is not None and current.kind not in (MotionKind.MOVE, MotionKind.STOP):
            self._last_motion = current
        motion = self._last_motion
        if motion is None:
            return None
        landing = motion.landing
        ra = ha = dec = None
        if landing is not None:
            dec = landing.dec
            if landing.ground:
                ha = landing.ha
            else:
                ra = landing.ra
        return MotionReport(motion.kind.value, not motion.done.is_set(), motion.error, ra, ha, dec)

    def link(self) -> LinkView:
        connection = self._telescope.connection
        state = self._telescope.mount.state
        return LinkView(state.link or connection.link_status(), connection.link_counters(), state.poll_error)

    def trace(self) -> list[TraceEntry]:
        """The recent serial exchanges, oldest first."""
        return self._telescope.connection.link_trace()

    @property
    def park_settings(self) -> ParkSettings:
        return self._telescope.settings.park

    # -- the mount's own settings ------------------------------------------------------------------

    @property
    def cached_mount_settings(self) -> MountSettings | None:
        """The settings stored in the mount as last read (kept while it is away; None if never read).

        No serial exchange: the mount keeps this copy fresh on every change that goes through the
        server, after each (re)connect and by a slow periodic re-read (``mount/settings_cache.py``), so the
        settings view and the status feed cost the line nothing however many pages are open.
        """
        return self._telescope.stored_settings.cached()

    def read_mount_settings(self) -> MountSettings | None:
        """The settings stored in the mount, read now (eight short queries): only after the page has
        written one, so its reply shows what the mount really took. Without a link, the cached ones."""
        if not self.running or not self._telescope.connection.link_status().connected:
            return self.cached_mount_settings
        return self._telescope.stored_settings.read()

    def apply_mount_settings(self, changes: Mapping[str, Any]) -> None:
        """Write settings stored in the mount (meridian, upper_limit, lower_limit, limits_enabled, heavy_duty,
        buzzer) through their one owner, which also mirrors the meridian setting in the configuration."""
        if changes:
            self._telescope.stored_settings.apply(changes)
            log.info("setup page: mount %s set", ", ".join(f"{name.replace('_', ' ')} to {value}"
                                                           for name, value in changes.items()))

    def request_mode(self, name: str) -> None:
        """EQ or alt-az ("equatorial"/"altaz"): sent now, in effect after the mount is restarted (``mount_mode``)."""
        from .telescope.actions import request_mode

        request_mode(self._telescope, name)
        log.info("setup page: mount mode set to %s", name)

    def meridian_setting(self) -> tuple[bool, float]:
        """The mount's "track past" flag and its limit in degrees (negative: before the meridian): by the
        mount's own setting when it has been read, else the configured one."""
        cached = self.cached_mount_settings
        if cached is not None and cached.meridian is not None:
            return cached.meridian.track_after, float(cached.meridian.limit_degrees)
        limits = self._server.settings.limits
        return limits.meridian_track_past, limits.meridian_limit_deg

    def mount_mode(self) -> dict[str, Any] | None:
        """The mode now in effect, the one requested and, while they differ, the warning that the mount
        must be restarted (the zwo:MountMode reply); None without a link. From the poller's last ``:GU#``
        (at most a poll interval old), not a fresh one: the settings view costs the line nothing."""
        mount = self._telescope.mount
        status = mount.state.status
        if not mount.running or not self._telescope.connection.link_status().connected or status is None:
            return None
        from .telescope.actions import mode_report

        return mode_report(self._telescope, status)

    def set_site(self, values: Mapping[str, float]) -> None:
        """Through the Telescope, so the mount gets the new site at once and clients read the same values."""
        self._telescope.capabilities.set_site(values)

    # -- controls (run with the caller's client key set in ``current_client``) --------------------

    def set_connected(self, on: bool) -> None:
        self._telescope.connection.set_connected(on)

    def abort(self) -> None:
        """Stop means stop: also when parked (AbortSlew refuses then), send the mount's stop-all."""
        try:
            self._telescope.abort_slew()
        except AlpacaError:
            if not self.running:
                raise
            self._telescope.mount.stop()

    def move_axis(self, axis: int, rate_deg_s: float) -> None:
        self._telescope.move_axis(axis, rate_deg_s)

    def park(self) -> None:
        self._telescope.park()

    def unpark(self) -> None:
        self._telescope.unpark()

    def find_home(self) -> None:
        self._telescope.find_home()

    def set_park(self) -> ParkSettings:
        self._telescope.set_park()
        return self._telescope.settings.park

    def set_tracking(self, on: bool) -> None:
        self._telescope.set_tracking(on)

    def set_tracking_rate(self, rate: int) -> None:
        self._telescope.capabilities.set_tracking_rate(rate)

    def set_guide_rate(self, fraction: float) -> None:
        """The guide rate as a fraction of sidereal (both axes share it on a ZWO mount)."""
        self._telescope.capabilities.set_guide_rate_right_ascension(fraction * SIDEREAL_DEG_S)

    def clock(self) -> ClockView:
        """The time reference: its source (host, mount or client), why, and the host clock's standing."""
        return self._telescope.mount.time.view()

    def set_time(self, value: datetime, who: str) -> TimeSetReport:
        """Set the server's and (when connected) the mount's time, then read the mount's clock back."""
        telescope = self._telescope
        if not telescope.clock.set_time(value, who):
            return TimeSetReport(telescope.clock.utc_now(), False)
        mount = telescope.mount
        try:
            mount_utc, at = mount.read_clock()
        except (LinkError, ProtocolError, MountReplyError) as exc:
            log.warning("the mount's clock could not be read back: %s", exc)
            return TimeSetReport(telescope.clock.utc_now(), True)
        reference = telescope.clock.utc_now() - timedelta(seconds=mount.monotonic() - at)
        return TimeSetReport(telescope.clock.utc_now(), True, mount_utc, (mount_utc - reference).total_seconds())

    # -- pointing at an object (web/goto.py): the same Telescope calls, limits and refusals as Alpaca --

    def site(self) -> tuple[float, float, float]:
        """Latitude (°N), longitude (°E), elevation (m) the server computes with."""
        site = self._telescope.settings.site
        return site.latitude, site.longitude, site.elevation

    def horizon_floor(self, azimuth: float) -> float:
        """The lowest altitude a GoTo may end at in this azimuth (horizon profile and minimum altitude)."""
        return horizon_altitude_at(self._telescope.settings.limits, azimuth)

    def goto_verdict(self, ra_hours: float, dec_deg: float) -> dict[str, Any]:
        """Whether a GoTo to this mount's-frame RA/Dec would be refused now, and by what, before it is tried:
        the Telescope's own limit check (``Telescope.goto_limit``, the one every GoTo passes first, so the
        page never says fine where the GoTo then refuses), then the state a GoTo needs (connected, unparked).
        ``limit`` names the limit that blocks (``telescope/pointing.py``), ``says`` is the card's words and
        ``detail`` the refusal's; ``state`` is "not connected" or "parked" when that is what blocks; ``down``:
        the limit is a floor (the target is under the allowed sky now or when the slew would land), so a GoTo
        must wait for it to rise."""
        telescope = self._telescope
        blocked = telescope.goto_limit(ra_hours, dec_deg)
        if blocked is not None:
            return {"reachable": False, "limit": blocked.limit, "state": None, "says": blocked.says,
                    "detail": f"target is {blocked.detail}", "altitude": blocked.altitude,
                    "azimuth": blocked.azimuth, "after_s": blocked.after_s, "down": blocked.floor}
        verdict: dict[str, Any] = {"reachable": True, "limit": None, "state": None, "down": False,
                                   "says": "reachable: above the horizon and limits", "detail": None}
        try:
            telescope.connection.require_connected()
        except AlpacaError as exc:
            return {**verdict, "reachable": False, "state": "not connected",
                    "says": "within the limits, but the mount is not connected", "detail": exc.message}
        if telescope.motion.parked:
            return {**verdict, "reachable": False, "state": "parked",
                    "says": "within the limits, but the mount is parked: Unpark first",
                    "detail": "the mount is parked; unpark it first"}
        return verdict

    def down_at(self, ra_hours: float, dec_deg: float, when: datetime) -> bool:
        """Whether a target at this mount's-frame RA/Dec is under the allowed sky at ``when``: under one of
        the floors GoTo's own check knows (the server's horizon and minimum altitude, the mount's horizon and
        lower altitude limit), not above the mount's upper limit. The page's "Not up: rises 00:28"."""
        blocked = self._telescope.goto_limit(ra_hours, dec_deg, travel_deg=0.0, at=when)
        return blocked is not None and blocked.floor

    def destination_side_of_pier(self, ra_hours: float, dec_deg: float) -> int | None:
        """DestinationSideOfPier for the mount's-frame RA/Dec; None while not connected."""
        side = _quiet(lambda: self._telescope.destination_side_of_pier(ra_hours, dec_deg), None)
        return None if side is None else int(side)

    def goto(self, ra_hours: float, dec_deg: float, tracking_rate: int) -> None:
        """SlewToCoordinatesAsync, then the drive rate the object needs (lunar, solar, sidereal): set only
        once the slew has been accepted, so a refused GoTo changes nothing."""
        self._telescope.slew_to_coordinates_async(ra_hours, dec_deg)
        if _quiet(self._telescope.capabilities.tracking_rate, None) != tracking_rate:
            self._telescope.capabilities.set_tracking_rate(tracking_rate)

    def sync(self, ra_hours: float, dec_deg: float) -> None:
        """SyncToCoordinates (the mount's frame), with its refusals."""
        self._telescope.sync_to_coordinates(ra_hours, dec_deg)

    # -- satellites (issue 41: telescope/satellites.py) --------------------------------------------

    def satellites(self, hours: float) -> list[dict[str, Any]]:
        """The kept TLE sets, each with its age, its old-set warning and its passes over the next ``hours``
        that clear the limits (times as UTC datetimes; the page puts them in the site's zone)."""
        part = self._telescope.satellites
        now = self.utc_now()
        found = []
        for tle in part.sets():
            warning = tle.stale(now)
            try:
                planned = [_pass_view(p) for p in part.passes(tle, hours, now)]
            except InvalidValue as exc:  # elements SGP4 cannot carry this far (decayed, years old)
                planned, warning = [], exc.message
            found.append({"number": tle.number, "name": tle.name, "epoch": tle.epoch,
                          "age_days": round(tle.age_days(now), 2), "warning": warning, "passes": planned})
        return found

    def add_satellites(self, text: str) -> list[str]:
        """Keep the sets in ``text`` (a paste or an uploaded file); their names."""
        return [tle.name for tle in self._telescope.satellites.add(text)]

    def remove_satellite(self, number: int) -> None:
        self._telescope.satellites.remove(number)

    def follow_satellite(self, number: int) -> None:
        """Follow the next pass of a kept satellite (the device must be connected, as for a GoTo)."""
        self._telescope.connection.require_connected()
        part = self._telescope.satellites
        part.follow(part.find(number))

    def stop_following(self) -> None:
        self._telescope.satellites.stop()

    def satellite_progress(self) -> dict[str, Any] | None:
        """The follow running or last run (``Satellites.progress``), as a dict; None before the first."""
        progress = self._telescope.satellites.progress()
        return None if progress is None else dataclasses.asdict(progress)

    # -- the owner's survey (zwo/survey.py, docs/survey.md) --------------------------------------------

    def _survey_refusal(self) -> str:
        """Why the survey may not run now ('' when it may): it reads a mount at rest, so its readings agree."""
        if not self.running or not self._telescope.connection.link_status().connected:
            return "connect the mount first: the survey asks the connected mount"
        view, state = self.motion(), self.state
        current = self._telescope.motion.running()
        if view.slewing or state.goto_running or (current is not None and not current.done.is_set()):
            return "the mount is moving: stop it or let it arrive, then run the survey"
        if state.moving_axes or view.guiding:
            return "the mount is being moved (a manual move or a guide pulse): wait until it stops"
        return ""

    def survey(self) -> SurveyReport:
        """Ask the mount the survey's read-only list through the server's own link, each question queued
        behind client commands like a poll (so a STOP never waits for it); keep the report for download."""
        refusal = self._survey_refusal()
        if refusal:
            raise InvalidOperation(f"survey not run: {refusal}")
        if not self._survey_lock.acquire(blocking=False):
            raise InvalidOperation("survey not run: a survey of this mount is already running")
        try:
            link = self._telescope.mount.link
            emulator = self._server.emulators[self.index] if self.emulated else None
            preset_name = str(getattr(getattr(getattr(emulator, "model", None), "firmware", None), "name", ""))
            context = SurveyContext.here(__version__, self.url, preset_name)
            report = run_survey(lambda request: link.exchange(request, Priority.POLL), context)
            self.last_survey = report
            log.info("setup page: survey of %s done (%d exchanges)", report.identity(), len(report.exchanges))
            return report
        finally:
            self._survey_lock.release()

    def pointing_model(self) -> dict[str, Any]:
        """The pointing model built from syncs (mount/pointing_frame.py): points, terms ± σ, RMS, switch."""
        return self._telescope.mount.pointing.report()

    def change_pointing_model(self, clear: bool, enabled: bool | None) -> dict[str, Any]:
        """Clear it and/or switch it on or off, as zwo:PointingModel does; the model as it is then."""
        pointing = self._telescope.mount.pointing
        if clear:
            pointing.clear()
            log.info("pointing model cleared (setup page)")
        if enabled is not None:
            pointing.set_enabled(enabled)
        self._telescope.mount.refresh()
        return pointing.report()


def _pass_view(planned: Pass) -> dict[str, Any]:
    """A pass as the page lists it: its instants, how high, the part followed and its side plan (both
    legs of a planned flip)."""
    flip = planned.side.flip
    return {"rise": planned.rise, "culmination": planned.culmination, "set": planned.set,
            "max_altitude": round(planned.max_altitude, 1), "enters": planned.enters, "leaves": planned.leaves,
            "side": side_name(planned.side.side) if planned.side.side in (PierSide.EAST, PierSide.WEST) else None,
            "side_until": planned.side.until, "side_note": planned.side.why, "keyhole": planned.keyhole,
            "flip": None if flip is None else {
                "side": side_name(flip.side), "flip_at": flip.flip_at, "resumes": flip.resumes,
                "gap_s": round(flip.gap_s), "until": flip.until, "note": flip.why}}


class ServerFacade:
    """The whole server as the page sees it: settings, devices, clients, bridges."""

    def __init__(self, server: ServerParts) -> None:
        self._server = server
        self._devices: dict[int, DeviceFacade] = {}
        self._lock = threading.Lock()

    @property
    def settings(self) -> Settings:
        return self._server.settings

    @property
    def device_count(self) -> int:
        return len(self._server.telescopes)

    def device(self, index: int) -> DeviceFacade:
        with self._lock:
            found = self._devices.get(index)
            if found is None:
                found = self._devices[index] = DeviceFacade(index, self._server.telescopes[index], self._server)
            return found

    def devices(self) -> list[DeviceFacade]:
        return [self.device(i) for i in range(self.device_count)]

    def update_settings(self, change: Callable[[Settings], Settings]) -> None:
        """Change the settings file atomically (validated by ``settings_from_dict`` inside ``change``)."""
        self._server.store.update(change)

    @property
    def config_file(self) -> Path | None:
        return self._server.store.path

    def host_names(self) -> list[str]:
        """The names the DNS-rebinding guard allows without server.allowed_hosts (for the page)."""
        return self._server.host_guard.policy.always_allowed()

    def local_networks(self) -> list[str]:
        """What "local" in a bridge's allowed_networks admits now: loopback and this machine's networks."""
        from .alpaca.local_addresses import local_networks

        return [str(network) for network in local_networks()]

    @property
    def port(self) -> int:
        return self._server.port

    def connect_info(self) -> dict[str, Any]:
        """How a program on another computer reaches this server now: the address it listens on, this
        machine's LAN addresses when that is every address, and the mDNS name when it is advertised."""
        from .alpaca.local_addresses import lan_addresses, mdns_name

        host = str(self._server.http.host)
        everywhere = host in ("", "0.0.0.0", "::")
        return {"listening_on": host, "only_this_machine": host in ("127.0.0.1", "::1", "localhost"),
                "addresses": lan_addresses(ipv6=False) if everywhere else [host],
                "mdns_name": mdns_name() if self._server.advertiser is not None else None}

    def listen_problem(self, host: str, port: int) -> str | None:
        """Why a restart could not listen on ``host:port`` (None: it could; the port held now counts as free)."""
        from .alpaca.listen_check import listen_problem

        return listen_problem(host, port, self.port)

    @property
    def discovery_port(self) -> int | None:
        discovery = self._server.discovery
        return discovery.port if discovery is not None else None

    @property
    def version(self) -> str:
        return __version__

    def touch_client(self, key: ClientKey, user_agent: str) -> None:
        """Record a client's activity (the MoveAxis watchdog stops a jog once its client goes quiet)."""
        self._server.registry.touch(key, user_agent)

    def client_activity(self, window_s: float, now: float | None = None) -> list[ClientActivity]:
        return self._server.registry.snapshot(active_within=window_s, now=time.monotonic() if now is None else now)

    def gps(self) -> dict[str, Any] | None:
        """The GPS receiver's status (bridges/gpsd.py) when site.gpsd is set, else None."""
        gpsd = self._server.gpsd
        return dict(gpsd.status()) if gpsd is not None else None

    def safety(self) -> dict[str, Any]:
        """The observatory interlock: ``{"safe", "source", "since", "state", "reason", "message", "on_unsafe",
        "monitor", "roof", "events", …}`` (safe and off when no monitor is configured)."""
        watch = self._server.safety_watch
        if watch is None:
            return {"safe": True, "state": "off", "source": "", "since": None, "reason": "", "monitor": None,
                    "roof": None, "events": []}
        return watch.status()

    def test_safety_device(self, role: str, url: str) -> dict[str, Any]:
        """Ask a SafetyMonitor (role "monitor") or a Dome ("roof") once, as the interlock would: ``{"ok": True,
        "safe", "answer"}`` or ``{"ok": False, "error"}``. Sends traffic only when the user asks (Test)."""
        watch = self._server.safety_watch
        if watch is None:
            return {"ok": False, "error": "the observatory interlock is not running"}
        try:
            safe, answer = watch.ask_once(role, url)
        except AlpacaZwoError as exc:
            return {"ok": False, "error": str(exc)}
        return {"ok": True, "safe": safe, "answer": answer}

    def find_safety_devices(self, host: str = "") -> list[dict[str, Any]]:
        """Alpaca discovery (a broadcast on this machine's IPv4 networks, or a query to ``host`` only), then
        each server's SafetyMonitor and Dome devices. Sends traffic: only when the user asks (the page's button)."""
        import dataclasses

        from .alpaca.finder import find_devices

        return [dataclasses.asdict(server) for server in find_devices(host)]

    def bridges(self) -> list[dict[str, Any]]:
        """One status dict per running bridge, each with its ``name``; a failing status() shows its error."""
        rows = []
        for name, bridge in self._server.bridges().items():
            try:
                status = dict(bridge.status())
            except Exception as exc:  # a bridge's bug must not take the status feed down with it
                log.exception("bridge %s: status() failed", name)
                status = {"enabled": True, "last_error": f"status unavailable: {exc}"}
            rows.append({"name": name, **status})
        return rows


__all__ = [
    "ClientKey",
    "ClockView",
    "DeviceFacade",
    "FacadeProvider",
    "LinkView",
    "MeridianSettings",
    "MotionReport",
    "MotionView",
    "MountSettings",
    "MountState",
    "ParkSettings",
    "SafetyStatusSource",
    "ServerFacade",
    "ServerParts",
    "Settings",
    "StatusSource",
    "SurveyReport",
    "TimeSetReport",
    "check_stored_setting",
    "current_client",
    "horizon_altitude_at",
    "settings_from_dict",
    "settings_to_dict",
]
