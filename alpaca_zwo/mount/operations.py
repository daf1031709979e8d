"""Typed mount operations and the state snapshot kept fresh by one poller.

Reads never touch the port: the server answers every property from :attr:`Mount.state`, an
immutable :class:`~alpaca_zwo.mount.state.MountState` that one poller thread replaces atomically. The poller spends the
fewest bytes it can (``:GMEQ#`` for both coordinates, ``:GU#``, ``:GAT#``, ``:Gm#``), polls fast
while anything moves and slowly at rest, so serial traffic is independent of how many HTTP
clients are reading.

The mount reports RA to one second of time (15″ at the equator) and Dec to one arcsecond. Clients
check much finer than that (ConformU's 1″ pulse-guide test, NINA's 1″ sync check), so a
:class:`PositionEstimator` carries a full-precision position forward from what the server itself
commanded (sync and GOTO coordinates, pulses, tracking rate) for as long as the mount's coarse
readings agree with it, and falls back to the readings the moment they do not.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import replace
from datetime import datetime, timedelta, timezone
from typing import Any

from .. import sky
from .._exceptions import AlpacaZwoError, LinkError, LinkTimeout, MountReplyError, ProtocolError
from ..sky import SIDEREAL_DAY_S, SIDEREAL_DEG_S, SIDEREAL_HOURS_PER_S, PierSide
from ..zwo import protocol, wire_values
from ..zwo.link import Link, Priority
from ..zwo.protocol import Effect, TrackingState
from ..zwo.wire_values import Direction, MeridianSettings, MountMode, MountStatus, TrackRate
from .estimator import PositionEstimator, SyncRemainder, wire_position
from .pier import DecSense, PierSides
from .pointing_frame import PointingFrame, Sky, side_sign
from .settings_cache import DEFAULT_REFRESH_S, SettingsCache
from .state import PARKED, MountInfo, MountSettings, MountState
from .timekeeping import TimeKeeper

log = logging.getLogger(__name__)

#: Tracking rates as multiples of sidereal; the King rate is not offered by ZWO mounts.
TRACK_RATE_FACTORS = {
    TrackRate.SIDEREAL: 1.0,
    TrackRate.SOLAR: SIDEREAL_DAY_S / 86400.0,
    TrackRate.LUNAR: 1.0 - 1.0 / 27.321661 * (SIDEREAL_DAY_S / 86400.0),
}
PULSE_CHUNK_MS = 3000
CLOCK_POLL_S = 0.01  # mount seconds between readings of :GL# while waiting for its second to turn


def utc_now() -> datetime:
    return datetime.now(timezone.utc)


SiteProvider = Callable[[], tuple[float, float]]
#: Checked by the link right before a motion command is written; False withdraws it (a stop came first).
Guard = Callable[[], bool]


class Mount:
    """Typed operations on one ZWO mount, plus its state snapshot.

    ``site`` supplies the (latitude, east longitude) to push on connect and after a mount
    reboot; ``clock`` is the host's UTC clock (an emulator running fast supplies its own);
    ``time_keeper`` the time reference built on it (``timekeeping.py``: whose clock is right, and
    whether the mount's clock is set at connect), a default one when not given; ``pointing`` the
    pointing model between the mount's frame and the client's (pointing_frame.py), an empty one
    kept in memory when not given.
    """

    def __init__(
        self,
        link: Link,
        site: SiteProvider,
        *,
        clock: Callable[[], datetime] = utc_now,
        poll_fast_s: float = 0.25,
        poll_slow_s: float = 0.75,
        utc_offset: Callable[[], timedelta] | None = None,
        monotonic: Callable[[], float] = time.monotonic,
        clock_rate: float = 1.0,
        settings_refresh_s: float = DEFAULT_REFRESH_S,
        time_keeper: TimeKeeper | None = None,
        pointing: PointingFrame | None = None,
    ) -> None:
        self.link = link
        #: Mount time in seconds: pulse windows, motion and reading ages are measured on it. It is
        #: the host's monotonic clock for a real mount and the emulator's clock for a fast emulator.
        self.monotonic = monotonic
        self._clock_rate = clock_rate  # mount seconds per real second (a fast emulator: its speed)
        self._site = site
        self.clock = clock
        self._utc_offset = utc_offset  # a fixed zone (tests); None: the site's (clock_zone)
        self.poll_fast_s = poll_fast_s
        self.poll_slow_s = poll_slow_s
        self._state = MountState(time=monotonic(), link=link.status)
        self._state_cond = threading.Condition()
        self._estimator = PositionEstimator()
        self._estimator_lock = threading.Lock()
        self._init_lock = threading.Lock()
        self._init_generation = -1
        self._poll_wake = threading.Event()
        self._stop = threading.Event()
        self._poller: threading.Thread | None = None
        self._move_directions: dict[int, Direction] = {}  # axis -> the letter of the move running
        self._move_rates: dict[int, float] = {}  # axis -> its :Rv multiple
        self._turn_round = False  # a reading showed the Dec move going the wrong way (mount/pier.py)
        self._side_known = False  # the last published side is known, not merely read (PierSides.trusted)
        #: Sky rates (deg/s) of the slow moves that carry a tracking rate offset (see drift()).
        self._drift = [0.0, 0.0]
        #: The one time reference: what UTCDate, the page and the bridges read, what a push sends.
        self.time = time_keeper or TimeKeeper(clock, monotonic)
        self._goto_target: tuple[float, float] | None = None  # in the mount's frame
        #: The last sync's sub-second rest (estimator.SyncRemainder); the estimator and the goto
        #: target are in the mount's frame, everything published and returned is in the client's.
        self._remainder = SyncRemainder()
        self._pushed_site: tuple[float, float] | None = None  # (lat, east lon) as the mount took them
        #: Bumped (under _publish_lock) after every command that changes what a poll reads, so a
        #: poll that overlapped one publishes nothing: a reading from before a sync must never
        #: land after it.
        self._epoch = 0
        self._publish_lock = threading.Lock()
        #: The mount-stored settings as last read: what the setup page shows (mount/settings_cache.py).
        self.settings_cache = SettingsCache(settings_refresh_s)
        #: The mount's own alignment offset (RA hours, Dec degrees) as far as the server made it: the
        #: sum of its syncs since the mount last forgot them. The axes point at the mount's reading
        #: minus it, so the mount chooses GOTO sides and stops at its meridian limit by that hour angle.
        #: The pointing model (pointing_frame.py) keeps it across a server restart while the mount keeps it.
        self.pointing = pointing or PointingFrame()
        self._alignment = self.pointing.saved_alignment
        #: The meridian setting in force on the mount, as last written or read, a pier flip's temporary
        #: limit included: the side a GOTO lands on depends on it (sky.goto_pier_side). Not the user's
        #: setting, which a flip restores: that one's owner is telescope/stored_settings.py.
        self._meridian: MeridianSettings | None = None
        #: What the mount's pier letters and N/S commands mean (mount/pier.py); guarded by _pier_lock.
        self._pier_lock = threading.Lock()
        self._pier = PierSides()
        self._dec_sense = DecSense()
        #: The link generation on which ``:Gps#`` answered an empty ``#`` (not asked again on it).
        self._park_unreadable = -1

    # -- state -------------------------------------------------------------------------------

    @property
    def state(self) -> MountState:
        return self._state

    def _publish(self, **changes: Any) -> MountState:
        with self._state_cond:
            self._state = replace(self._state, time=self.monotonic(), link=self.link.status, **changes)
            self._state_cond.notify_all()
            return self._state

    def wait_for(self, predicate: Callable[[MountState], bool], timeout: float) -> MountState | None:
        """Block until a published state satisfies ``predicate``; None on timeout."""
        deadline = time.monotonic() + timeout
        with self._state_cond:
            while not predicate(self._state):
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return None
                self._state_cond.wait(remaining)
            return self._state

    def position(self) -> tuple[float, float] | None:
        """RA/Dec now: the estimate carried forward from the last reading by what the server knows
        moved the mount (pulses, tracking drift), so a read between polls is not a poll interval old.

        Only while that reading is recent and the link is up; otherwise the last reading as it was
        (clients then see its true age in DeviceState's TimeStamp), never a guess presented as fresh.
        """
        state = self._state
        if state.ra is None or state.dec is None:
            return None
        now = self.monotonic()
        window = 3 * self.poll_slow_s * max(1.0, self._clock_rate)
        recent = state.position_time is not None and now - state.position_time <= window
        if recent and self.link.status.connected and not state.moving_axes:
            with self._estimator_lock:
                predicted = self._estimator.predict(now)
            if predicted is not None:
                return self._to_client(predicted, state.side)
        return state.ra, state.dec

    def _where(self, side: PierSide) -> Sky:
        return Sky(self.lst(), side_sign(side, self.site()[0]), self._alignment)

    def _to_client(self, mount: tuple[float, float], side: PierSide) -> tuple[float, float]:
        """A mount-frame position in the client's frame: the pointing model's correction, then the
        sync remainder."""
        if self.pointing.applies:
            mount = self.pointing.to_client(mount[0], mount[1], self._where(side))
        return self._remainder.to_sky(*mount)

    def _to_mount(self, client: tuple[float, float], side: PierSide) -> tuple[float, float]:
        """A client's position as the mount must be given it (the inverse of _to_client)."""
        mount = self._remainder.to_mount(*client)
        return self.pointing.to_mount(*mount, self._where(side)) if self.pointing.applies else mount

    def client_offset(self, ra: float, dec: float, side: PierSide) -> tuple[float, float]:
        """(RA hours, Dec degrees) the client's frame adds to the mount's near a client position: the
        sync remainder plus the model's correction there (a ground landing aims whole mount seconds)."""
        mount = self._to_mount((ra, dec), side)
        return sky.wrap_hours_12(ra - mount[0]), dec - mount[1]

    @property
    def sync_remainder(self) -> SyncRemainder:
        """What the last sync's wire could not carry, added to every reading (see SyncRemainder)."""
        return self._remainder

    @property
    def settings(self) -> MountSettings | None:
        """The mount-stored settings as last read, without a serial exchange (None: never read)."""
        return self.settings_cache.value

    @property
    def clock_rate(self) -> float:
        """Mount seconds per real second: 1 for a real mount, the speed of a fast emulator."""
        return self._clock_rate

    def refresh(self) -> None:
        """Ask the poller for a new reading as soon as the line is free."""
        self._poll_wake.set()

    # -- the site's hemisphere and the mount's own frame ----------------------------------------

    def site(self) -> tuple[float, float]:
        """(latitude, east longitude) the mount holds: as pushed, else as configured."""
        return self._pushed_site if self._pushed_site is not None else self._site()

    def lst(self) -> float:
        """Local sidereal time now, by the clock the mount was given and the site it holds."""
        return sky.local_sidereal_time(self.time.now(), self.site()[1])

    def mechanical_hour_angle(self, ra: float, dec: float | None = None) -> float:
        """The hour angle the mount's axes point at (or will) for a client-frame RA: the sync
        remainder, the pointing model's correction (when the Dec is given) and the mount's own
        alignment offset taken off. The mount chooses a GOTO's side and stops at its meridian limit
        by this hour angle, not by the one a client sees."""
        if dec is None:
            mount_ra = self._remainder.to_mount(ra, 0.0)[0]
        else:
            side = sky.pointing_state(self.mechanical_hour_angle(ra))
            mount_ra = self._to_mount((ra, dec), side)[0]
        return sky.hour_angle(self.lst(), mount_ra - self._alignment[0])

    @property
    def pier_conventions(self) -> dict[str, bool | None]:
        """What the server has learned of the mount's pier letters and N/S moves (mount/pier.py)."""
        with self._pier_lock:
            return {"mechanical_names": self._pier.mechanical_names,
                    "follows_hour_angle": self._pier.follows_hour_angle,
                    "mechanical_ns": self._dec_sense.mechanical}

    # -- lifecycle ---------------------------------------------------------------------------

    def connect(self) -> None:
        """Open the link, identify the mount, push time and site, and start the poller."""
        self._stop.clear()
        self.link.open()
        try:
            self.ensure_initialised()
            self.poll_once()
        except AlpacaZwoError:
            self.link.close()
            raise
        self._poller = threading.Thread(target=self._poll_loop, name="mount-poller", daemon=True)
        self._poller.start()

    def disconnect(self) -> None:
        self._stop.set()
        self._poll_wake.set()
        if self._poller is not None and self._poller is not threading.current_thread():
            self._poller.join(timeout=5)
        self._poller = None
        self.link.close()
        self._publish(initialised=False)

    @property
    def running(self) -> bool:
        return self._poller is not None and not self._stop.is_set()

    # -- initialisation (connect, and again after a mount reboot) ----------------------------

    def ensure_initialised(self) -> None:
        """Identify the mount and push time and site unless done since the link last connected.

        A mount that rebooted has lost both (its date reads 01/01/00 and a GOTO would answer
        ``e7#``), so every new link generation is initialised before any GOTO or sync.
        """
        if self._init_generation == self.link.generation and self._state.initialised:
            return
        with self._init_lock:
            generation = self.link.generation
            if self._init_generation == generation and self._state.initialised:
                return
            info = MountInfo(self._exec(protocol.query("GVP")), self._exec(protocol.query("GV")))
            self.link.expect_probe_reply(info.model)
            if self._state.info is not None and info != self._state.info:
                with self._pier_lock:  # another mount, or other firmware: learn its conventions afresh
                    self._pier, self._dec_sense = PierSides(), DecSense()
            status = self._exec(protocol.query("GU"))
            mount_date = self._exec(protocol.query("GC"))
            self._check_restart(status, mount_date.year <= 2000)
            if mount_date.year <= 2000:
                log.info("mount %s reports date %s: time and site not set since power-up", info.model, mount_date)
            self._settle_clock(clock_lost=mount_date.year <= 2000)
            latitude, longitude = self._site()
            self.push_site(latitude, longitude)
            self.pointing.set_site(*self.site(), status.mode is MountMode.ALTAZ)
            guide_rate = self._exec(protocol.query("Ggr"))
            self._init_generation = generation
            self.settings_cache.mark_stale()  # a new link: possibly another mount, or one reset meanwhile
            self._publish(info=info, status=status, status_time=self.monotonic(), guide_rate=guide_rate,
                          initialised=True)
            log.info("mount %s firmware %s initialised (link generation %d)", info.model, info.firmware, generation)

    def _check_restart(self, status: MountStatus, clock_lost: bool) -> None:
        """A mount that restarted (its clock reads 2000, or its mode changed, which happens only at a
        restart) has forgotten its sync: so does the server, and its estimate with it. A reconnect
        to a mount that kept its clock keeps both, as the mount keeps its alignment."""
        previous = self._state.status
        if clock_lost or (previous is not None and previous.mode is not status.mode):
            with self._estimator_lock:
                self._remainder = SyncRemainder()
                self._estimator.invalidate()
                self._goto_target = None
            self._pushed_site = None
            self._alignment = (0.0, 0.0)
            self.pointing.mount_forgot()
            with self._pier_lock:
                self._pier.forget()
                self._dec_sense.cancel()

    def push_time(self) -> None:
        """Set the mount's clock: the site's local date and time, and its zone with the sign the mount
        expects (negated), so the mount, its hand controller and ZWO's apps show the site's time while
        the mount's UTC (local minus zone) is exact, whatever zone the host is on (``clock_zone``).

        The mount keeps whole seconds and sets its clock when the ``:SL`` command has arrived, so
        that command is timed to *arrive* on a second boundary (its bytes take 12.5 ms at 9600
        baud), carrying that second: otherwise its sidereal time, and every Alt/Az landing with it,
        would be off by the fraction of a second the command was late.
        """
        # A mount whose daylight-saving flag is on counts UTC = local - (zone + 1 h): its zone is then sent
        # an hour less, so the total stays the site's offset (the flag is the user's; it is left alone).
        dst = timedelta(hours=1) if self._try(protocol.query("GH")) is True else timedelta(0)
        offset = self.clock_zone(self.time.now(), say=True)
        self._exec(protocol.set_utc_offset((offset - dst).total_seconds() / 3600.0))
        transit_real = len(protocol.set_time(datetime.min.time()).wire) * 10.0 / self.link.baud \
            if self.link.baud else 0.0
        now = self.time.now()
        boundary = now.replace(microsecond=0) + timedelta(seconds=1)
        if self.clock_zone(boundary) != offset:  # daylight saving began or ended in this very second
            offset = self.clock_zone(boundary)
            self._exec(protocol.set_utc_offset((offset - dst).total_seconds() / 3600.0))
            now = self.time.now()
        wait_real = (boundary - now).total_seconds() / self._clock_rate - transit_real
        while wait_real < 0.0:  # too close: a fast emulator's second can be shorter than the transit
            boundary += timedelta(seconds=1)
            wait_real += 1.0 / self._clock_rate
        time.sleep(wait_real)
        local = boundary + offset
        self.link.execute(protocol.set_time(local.time()), Priority.COMMAND)
        self._exec(protocol.set_date(local.date()))
        self._reread_position()  # a new clock moves every RA reading by an amount only the mount knows

    def clock_zone(self, when: datetime, say: bool = False) -> timedelta:
        """The UTC offset the mount's clock is set in at ``when``: the site's zone's, daylight saving
        included (``sky.zone_at`` on the site the server holds now, so a new site's zone applies at the
        next setting); the host's where the site's zone is not known (tzfpy not installed), which ``say``
        logs, with the zone used either way."""
        if self._utc_offset is not None:
            return self._utc_offset()
        latitude, longitude = self._site()
        zone = sky.zone_at(latitude, longitude)
        if zone is not None:
            offset = when.astimezone(zone).utcoffset() or timedelta(0)
            if say:
                log.info("the mount's clock is set in the site's zone, %s (%s)", zone.key, _offset_text(offset))
            return offset
        offset = when.astimezone().utcoffset() or timedelta(0)
        if say:
            log.warning("the site's time zone is not known at %.4f, %.4f (tzfpy is not installed or knows no "
                        "zone there): the mount's clock is set in the host's zone, %s", latitude, longitude,
                        _offset_text(offset))
        return offset

    def _settle_clock(self, clock_lost: bool) -> None:
        """Set the mount's clock, or keep it and adopt its time (``timekeeping.py`` decides why)."""
        if clock_lost:
            self.time.mount_without_time()
            self.push_time()
            return
        mount_utc, at = self.read_clock(precise=True) if self.time.wants_mount_clock() else (None, 0.0)
        if not self.time.at_connect(mount_utc, at):
            self.push_time()

    def read_clock(self, precise: bool = False, priority: Priority = Priority.COMMAND) -> tuple[datetime, float]:
        """The mount's UTC (date, local time, zone, daylight saving) and the mount-monotonic instant it
        refers to.

        The mount keeps whole seconds. ``precise`` reads ``:GL#`` until its second changes (at most
        a little over one second of short exchanges), so the instant is the start of that second
        to within one exchange; otherwise one reading, taken as the middle of its second.
        """
        zone = self._exec(protocol.query("GG"), priority)
        dst = self._try(protocol.query("GH"), priority) is True
        day_before = self._exec(protocol.query("GC"), priority)
        reply_s = 9 * 10.0 / self.link.baud if self.link.baud else 0.0  # "HH:MM:SS#" on its way back
        first = self._exec(protocol.query("GL"), priority)
        before = self.monotonic() - reply_s * self._clock_rate
        reading, at = first, before - 0.5  # on average, its second began half a second ago
        deadline = before + 1.5  # mount seconds: one tick of its clock and a margin
        while precise and self.monotonic() < deadline:
            # Paced: the instant is wanted to a few milliseconds, and a fast link (WiFi, a socket) would
            # otherwise carry thousands of readings of the same second, crowding out everyone else's.
            time.sleep(CLOCK_POLL_S / self._clock_rate)
            reading = self._exec(protocol.query("GL"), priority)
            after = self.monotonic() - reply_s * self._clock_rate
            if reading != first:
                at = (before + after) / 2.0  # the second began between the two readings
                break
            before = after
        day = self._exec(protocol.query("GC"), priority)
        if day != day_before and reading.hour != 0:
            day = day_before  # midnight passed after the reading: it belongs to the earlier day
        local = datetime.combine(day, reading)
        utc = local - timedelta(hours=zone + (1.0 if dst else 0.0))
        return utc.replace(tzinfo=timezone.utc), at

    def push_site(self, latitude: float, east_longitude: float) -> None:
        """Set the mount's site; the position is read again before this returns (see _reread_position)."""
        self._exec(protocol.set_latitude(latitude))
        self._exec(protocol.set_longitude(east_longitude))
        site = (round(latitude * 3600.0) / 3600.0, round(east_longitude * 3600.0) / 3600.0)
        previous, self._pushed_site = self._pushed_site, site
        if self._init_generation == self.link.generation:  # at initialisation: once the mode is known
            self.pointing.set_site(site[0], site[1], self._state.altaz)
        if previous is None or (previous[0] < 0.0) != (site[0] < 0.0):
            with self._pier_lock:  # across the equator the same axes are the other pointing state
                self._pier.forget()
                self._dec_sense.cancel()
        shift: float | None = None
        if previous is not None and (site[0] == previous[0] or not self._state.altaz):
            # Equatorial readings move with the sidereal time only: exactly by the change of longitude.
            shift = (site[1] - previous[1]) / 15.0
        self._reread_position(shift)

    def _reread_position(self, ra_shift_h: float | None = None) -> None:
        """A command changed what the mount's readings mean (site, clock, zone, alignment): read the
        position now and publish it, so the next read anywhere (Alpaca, the bridges, the page)
        reflects the change instead of an estimate carried over from the old meaning for up to a
        poll. ``ra_shift_h``, when the change is known exactly (a new longitude), moves the estimate
        with the readings so it keeps its precision while the new reading agrees; otherwise the
        estimate is dropped, as after a GOTO, and restarts from the reading."""
        with self._estimator_lock:
            if ra_shift_h is None:
                self._estimator.invalidate()
            else:
                self._estimator.shift_ra(ra_shift_h)
        if self._init_generation != self.link.generation:
            return  # initialising: the poll that follows it publishes, with the state it completes
        asked = self.monotonic()
        ra, dec = self._exec(protocol.query("GMEQ"))
        now = self.monotonic()
        with self._publish_lock:
            self._epoch += 1  # a poll that read before the change publishes nothing
            state = self._state
            with self._estimator_lock:
                if state.moving_axes or state.goto_running:
                    self._estimator.invalidate()
                    best = (ra, dec)
                else:
                    best = self._estimator.observe(ra, dec, now, asked)
            sky_ra, sky_dec = self._to_client(best, state.side)
            self._publish(ra=sky_ra, dec=sky_dec, raw_ra=ra, raw_dec=dec, position_time=now)

    # -- motion ------------------------------------------------------------------------------

    def goto(self, ra: float, dec: float, guard: Guard | None = None) -> tuple[float, float]:
        """Start a GOTO; return the target as the mount received it (whole seconds of RA, whole
        arcseconds in the mount's frame) in the client's frame. MountReplyError carries the
        mount's refusal (e3, e5, e6, e7 …); ``guard`` withdraws the :MS# unsent (MotionCancelled)
        if a stop came first."""
        self.ensure_initialised()
        try:
            wire, side = self._send_goto(ra, dec, guard)
        except MountReplyError as exc:
            if exc.code != 7:
                raise
            # The mount forgot time and site behind our back (a reboot the link did not see).
            self._init_generation = -1
            self._publish(initialised=False)
            self.ensure_initialised()  # also forgets the sync the mount lost (_check_restart)
            wire, side = self._send_goto(ra, dec, guard)
        with self._estimator_lock:
            self._estimator.invalidate()
            self._goto_target = wire
        predicted, certain = self._goto_side(wire[0])
        with self._pier_lock:
            self._pier.goto_sent(predicted, certain, self.monotonic())
            self._dec_sense.cancel()
        self.refresh()
        return self._to_client(wire, side)

    def _goto_side(self, mount_ra: float) -> tuple[PierSide, bool]:
        """The side a GOTO to ``mount_ra`` (the mount's frame) lands on by the meridian setting in
        force, and whether both readings of the GOTO side rule agree on it (docs/meridian.md: they
        differ only for a target past the meridian within a positive "track past" limit)."""
        ha = sky.hour_angle(self.lst(), mount_ra - self._alignment[0])
        meridian = self._meridian or MeridianSettings()
        limit = float(meridian.limit_degrees)
        past_limit = sky.flip_line_deg(limit, meridian.track_after)  # A1: flips past the limit
        at_meridian = min(limit, 0.0)  # A2: flips at the meridian
        side = sky.goto_pier_side(ha, PierSide.UNKNOWN, past_limit)
        return side, side is sky.goto_pier_side(ha, PierSide.UNKNOWN, at_meridian)

    def _send_goto(self, ra: float, dec: float, guard: Guard | None) -> tuple[tuple[float, float], PierSide]:
        """``:Sr :Sd :MS#`` for a client's target: the mount gets it in its own frame (the sync remainder
        and the pointing model's correction on the side it will land taken off). Returns the wire
        target and that side."""
        side = self._goto_side(self._remainder.to_mount(ra, dec)[0])[0]
        mount_ra, mount_dec = self._to_mount((ra, dec), side)
        side = self._goto_side(mount_ra)[0]  # the model moved the target: the side by where it now is
        mount_ra, mount_dec = self._to_mount((ra, dec), side)
        wire = wire_position(mount_ra, mount_dec)
        self._exec(protocol.set_target_ra(mount_ra))
        self._exec(protocol.set_target_dec(mount_dec))
        self._exec(protocol.query("MS"), guard=guard)
        return wire, side

    def sync(self, ra: float, dec: float) -> None:
        """Sync the mount to a client's position. The mount takes it in whole seconds and arcseconds
        and reads exactly those afterwards; the rest becomes the sync remainder (SyncRemainder)."""
        self.ensure_initialised()
        before = self._mount_frame_position()
        where = self._where(self._state.side)
        self._exec(protocol.set_target_ra(ra))
        self._exec(protocol.set_target_dec(dec))
        self._exec(protocol.query("CM"))
        self._aligned(before, wire_position(ra, dec))
        self._learn(before, (ra, dec), where)
        now = self.monotonic()
        with self._estimator_lock:
            self._remainder = SyncRemainder.of_sync(ra, dec)
            self._estimator.set_exact(*wire_position(ra, dec), now)
            self._estimator.set_ra_rate(self._ra_drift(), now)
        self._changed(ra=ra % 24.0, dec=dec, position_time=now)
        self.refresh()

    def _learn(self, before: tuple[float, float] | None, synced: tuple[float, float], where: Sky) -> None:
        """A sync's point for the pointing model (refused there if it contradicts the model grossly:
        the sync itself holds, as a single-point sync), and the alignment offset kept with it."""
        self.pointing.add_sync(before, synced, where, self.time.now().isoformat(timespec="seconds"))
        self.pointing.note_alignment(self._alignment)

    def _mount_frame_position(self) -> tuple[float, float] | None:
        """The position now as the mount reads it (the model's correction and the sync remainder taken off)."""
        here = self.position()
        return None if here is None else self._to_mount(here, self._state.side)

    def _aligned(self, before: tuple[float, float] | None, after: tuple[float, float]) -> None:
        """A sync moved the mount's readings from ``before`` to ``after``: its alignment offset grows by
        that (the mount adds the difference to every reading, as ``:CM#`` does on the emulator)."""
        with self._pier_lock:
            self._dec_sense.cancel()
        if before is None:
            return
        d_ra = (after[0] - before[0] + 12.0) % 24.0 - 12.0
        self._alignment = (self._alignment[0] + d_ra, self._alignment[1] + after[1] - before[1])

    def sync_estimate(self, ra: float, dec: float) -> None:
        """Adopt exact coordinates the mount already agrees with, without a sync command. Still a point
        for the pointing model (it confirms it there), which does not move the model's anchor: the
        mount's own sync offset is still the last sync's."""
        before = self._mount_frame_position()
        self.pointing.add_sync(before, (ra, dec), self._where(self._state.side),
                               self.time.now().isoformat(timespec="seconds"), anchors=False)
        now = self.monotonic()
        with self._estimator_lock:
            self._estimator.set_exact(*self._to_mount((ra, dec), self._state.side), now)
            self._estimator.set_ra_rate(self._ra_drift(), now)
        self._publish(ra=ra % 24.0, dec=dec, position_time=now)

    def stop(self) -> None:
        """Stop every motion (GOTO, home, manual moves, pulses) on the link's urgent lane, without
        waiting for the exchange in flight; tracking keeps its setting."""
        self.link.send_urgent(protocol.query("Q"))
        self._move_directions.clear()
        self._move_rates.clear()
        with self._pier_lock:
            self._dec_sense.cancel()
        self._drift = [0.0, 0.0]
        self._rate_changed()
        with self._estimator_lock:
            self._estimator.invalidate()
        self._changed(moving_axes=frozenset())
        self.refresh()

    def move_axis(self, axis: int, rate_deg_s: float, guard: Guard | None = None) -> None:
        """Move axis 0 (RA: + is east) or 1 (Dec: + is north) at a sky rate; 0 stops that axis
        (on the urgent lane). ``guard`` withdraws a start unsent if a stop came first."""
        if axis not in (0, 1):
            raise ValueError(f"axis {axis} cannot move")
        moving = set(self._state.moving_axes)
        if rate_deg_s == 0.0:
            previous = self._move_directions.pop(axis, None)
            self._move_rates.pop(axis, None)
            directions = [previous] if previous else (
                [Direction.EAST, Direction.WEST] if axis == 0 else [Direction.NORTH, Direction.SOUTH])
            for direction in directions:
                self.link.send_urgent(protocol.stop_direction(direction))
            if axis == 1:
                with self._pier_lock:
                    self._dec_sense.ended(self.monotonic())
            moving.discard(axis)
        else:
            multiple = round(min(abs(rate_deg_s) / SIDEREAL_DEG_S, wire_values.SLEW_SPEEDS[-1]), 2)
            direction = self._wire_direction(self._axis_directions(axis)[0 if rate_deg_s > 0 else 1])
            opposite = {Direction.EAST: Direction.WEST, Direction.WEST: Direction.EAST,
                        Direction.NORTH: Direction.SOUTH, Direction.SOUTH: Direction.NORTH}[direction]
            if self._move_directions.get(axis) is opposite:
                self._exec(protocol.stop_direction(opposite))
            self._exec(protocol.set_variable_speed(multiple))
            self._exec(protocol.move(direction), guard=guard)
            self._move_directions[axis] = direction
            self._move_rates[axis] = multiple
            self._motion_started(direction, None)
            moving.add(axis)
        with self._estimator_lock:
            self._estimator.invalidate()
        self._changed(moving_axes=frozenset(moving))
        self.refresh()

    @property
    def drift_rates(self) -> tuple[float, float]:
        """The sky rates (deg/s) of the offset moves now running on axis 0 and 1."""
        return self._drift[0], self._drift[1]

    def drift(self, axis: int, rate_deg_s: float, guard: Guard | None = None, exact_start: bool = True) -> float:
        """Run (or stop, with 0) a slow move that carries a tracking rate offset too large for guide
        pulses, or (alt-az mode) a guide pulse. Unlike move_axis it is part of tracking, not a slew:
        moving_axes is left alone and the position estimator carries the motion. The rate is rounded
        to the mount's 0.01x steps; one that rounds to 0 stops the move.

        Returns when (mount time) the command that starts or stops the move was written. Both go
        out on an idle line (the move after a ``:GVP#`` whose reply proves its ``:Rv…#`` has
        arrived; the stop after whatever else is leaving, at most one request's bytes), so each
        reaches the mount its own four bytes later whether the line is paced at the baud or not
        (USB CDC may ignore it), and however late the transport delivers: a host-timed pulse
        measured from write to write is the pulse the mount makes. A wait for the line is in the
        returned instant, not hidden after it, so it can be booked. ``exact_start`` False skips the
        proof (a speed change of a running move, where a few ms matter at the change in speed only)."""
        multiple = round(min(abs(rate_deg_s) / SIDEREAL_DEG_S, wire_values.SLEW_SPEEDS[-1]), 2)
        written = self.monotonic()
        if multiple == 0.0:
            rate_deg_s = 0.0
            if self._drift[axis] != 0.0:
                direction = self._move_directions.pop(axis, None)
                self._move_rates.pop(axis, None)
                for d in [direction] if direction else self._axis_directions(axis):
                    written = self._mount_time(self.link.send_urgent(protocol.stop_direction(d), idle=True))
        else:
            direction = self._wire_direction(self._axis_directions(axis)[0 if rate_deg_s > 0 else 1])
            previous = self._move_directions.get(axis)
            if previous is not None and previous is not direction:
                self.link.send_urgent(protocol.stop_direction(previous))  # :Me# does not end a running :Mw#
                del self._move_directions[axis]
                self._drift[axis] = 0.0
            # :Rv is latched by the move that follows it (field notes §2.3): always sent, since a
            # mount that rebooted unseen would otherwise move at its power-up speed, the fastest.
            self._exec(protocol.set_variable_speed(multiple))
            if exact_start:  # the reply proves :Rv has arrived: the move goes out on an idle line
                self._exec(self.link.PROBE)
            written = self._send_on_idle_line(protocol.move(direction), guard)
            self._move_directions[axis] = direction
            self._move_rates[axis] = multiple
            rate_deg_s = (multiple if rate_deg_s > 0 else -multiple) * SIDEREAL_DEG_S
        self._drift[axis] = rate_deg_s
        self._rate_changed()
        return written

    def _mount_time(self, monotonic_instant: float) -> float:
        """A ``time.monotonic()`` instant (the link's clock) on the mount's clock."""
        return self.monotonic() + (monotonic_instant - time.monotonic()) * self._clock_rate

    def _wire_direction(self, wanted: Direction) -> Direction:
        """The letter that moves the sky toward ``wanted`` on the side the mount is on: N/S swapped on
        pierWest once the mount has shown its N/S are mechanical (mount/pier.py); E/W as they are.
        An alt-az mount's moves are sky motions."""
        state = self._state
        if state.altaz:
            return wanted
        with self._pier_lock:
            return self._dec_sense.letter(wanted, state.side)

    def _motion_started(self, sent: Direction, until: float | None) -> None:
        """A move or pulse went out: an RA one may leave the counterweight anywhere, a Dec one can
        teach which way N/S go (``until``: when it ends, mount time; None while a move runs)."""
        state = self._state
        if state.altaz:
            return
        with self._pier_lock:
            if sent not in (Direction.EAST, Direction.WEST):
                if self._side_known:  # a side merely read could teach the wrong N/S
                    self._dec_sense.started(sent, state.side, state.raw_dec, until)
                else:
                    self._dec_sense.cancel()
            elif until is None:  # a pulse moves arcseconds; a move may take the counterweight anywhere
                self._pier.ra_moved()

    @staticmethod
    def _axis_directions(axis: int) -> tuple[Direction, Direction]:
        """(positive, negative) directions of an axis: east/west for RA, north/south for Dec."""
        return (Direction.EAST, Direction.WEST) if axis == 0 else (Direction.NORTH, Direction.SOUTH)

    def pulse_guide(self, direction: Direction, milliseconds: int, guard: Guard | None = None) -> float:
        """Send one pulse (≤ 3000 ms, the mount's documented range); return its end in mount time.

        The pulse's displacement goes to the position estimator; the pulse itself (IsPulseGuiding,
        continuation of long pulses) belongs to the motion supervisor.
        """
        if not 0 <= milliseconds <= PULSE_CHUNK_MS:
            raise ValueError(f"pulse of {milliseconds} ms is outside 0..{PULSE_CHUNK_MS}")
        state = self._state
        sent = self._wire_direction(direction)
        self._exec(protocol.pulse_guide(sent, milliseconds), guard=guard)
        start = self.monotonic()  # the mount times the pulse from its arrival, not from before it was sent
        end = start + milliseconds / 1000.0
        self._motion_started(sent, end)
        speed_deg = state.guide_rate * SIDEREAL_DEG_S
        dra = ddec = 0.0
        if direction is Direction.EAST:
            dra = speed_deg / 15.0
        elif direction is Direction.WEST:
            dra = -speed_deg / 15.0
        elif direction is Direction.NORTH:
            ddec = speed_deg
        else:
            ddec = -speed_deg
        with self._estimator_lock:
            self._estimator.add_motion(start, end, dra, ddec)
        return end

    def set_tracking(self, on: bool, guard: Guard | None = None, not_before: float | None = None) -> None:
        """Switch tracking; ``not_before`` (a time.monotonic() instant) times the command exactly."""
        req = protocol.query("Te" if on else "Td")
        try:
            self.link.execute(req, Priority.COMMAND, guard=guard, not_before=not_before)
        except LinkTimeout as exc:
            self._confirm_tracking(req, on, exc)
        self._changed(tracking=TrackingState(on))
        self._rate_changed()

    def _confirm_tracking(self, req: protocol.Request, on: bool, exc: LinkTimeout) -> None:
        """A busy mount answers ``:Te#``/``:Td#`` late or never (a real 1.8.8 mount left ``:Te#``
        unanswered for 1.5 s during a GOTO: real-transcripts-1.8.8.md §2 item 8): what it reports
        decides, read back at once. The link keeps the late byte from being read as a later reply."""
        tracking = self._exec(protocol.query("GAT"))
        if tracking.on != on:
            state = "on" if tracking.on else "off"
            why = (f"no acknowledgement in time ({exc}), and the mount still reports tracking {state}; it may be "
                   "busy with a slew: try again once it ends")
            raise MountReplyError(req.text, "", None, why) from exc
        log.info("%s: no acknowledgement in time, but the mount reports tracking %s: done", req.text,
                 "on" if on else "off")

    def set_tracking_rate(self, rate: TrackRate) -> None:
        self._exec(protocol.set_tracking_rate(rate))
        self._changed(tracking_rate=rate)
        self._rate_changed()

    def set_guide_rate(self, fraction: float) -> float:
        self._exec(protocol.set_guide_rate(fraction))
        actual = float(self._exec(protocol.query("Ggr")))
        self._publish(guide_rate=actual)
        return actual

    def home(self, guard: Guard | None = None) -> None:
        self._exec(protocol.query("hC"), guard=guard)
        with self._pier_lock:
            self._dec_sense.cancel()
        with self._estimator_lock:
            self._estimator.invalidate()
            self._goto_target = None
        self.refresh()

    # -- settings stored in the mount ---------------------------------------------------------

    def read_settings(self, priority: Priority = Priority.COMMAND) -> MountSettings:
        """Read the stored settings now (eight short queries) and keep them as :attr:`settings`."""
        generation = self.settings_cache.generation
        info = self._state.info

        def get(code: str) -> Any:
            return self._try(protocol.query(code), priority)

        meridian = get("GTa") if info is None or info.has_meridian_settings else None
        heavy = get("GRl")
        settings = MountSettings(
            meridian=meridian, limits_enabled=get("GLC"), upper_limit=get("GLH"), lower_limit=get("GLL"),
            heavy_duty=None if heavy is None else heavy == 720, buzzer=get("GBu"), guide_rate=get("Ggr"),
            daylight_saving=get("GH"))
        self.settings_cache.store(settings, generation)
        if meridian is not None:
            self._meridian = meridian
        return settings

    def set_meridian(self, settings: MeridianSettings) -> None:
        self._exec(protocol.set_meridian(settings))
        self._meridian = settings

    def set_limits_enabled(self, enabled: bool) -> None:
        self._exec(protocol.query("SLE" if enabled else "SLD"))

    def set_upper_limit(self, degrees: int) -> None:
        self._exec(protocol.set_upper_limit(degrees))

    def set_lower_limit(self, degrees: int) -> None:
        self._exec(protocol.set_lower_limit(degrees))

    def set_heavy_duty(self, on: bool) -> None:
        self._exec(protocol.set_heavy_duty(on))

    def set_buzzer(self, level: int) -> None:
        self._exec(protocol.set_buzzer(level))

    def set_mode(self, equatorial: bool) -> None:
        """Switch EQ/alt-az; the mount applies it only after a restart."""
        self._exec(protocol.query("AP" if equatorial else "AA"))

    def clear_alignment(self) -> None:
        """``:NSC#``: the mount forgets its syncs, so the sync remainder goes too and the position
        means something else at once."""
        self._exec(protocol.query("NSC"))
        with self._estimator_lock:
            self._remainder = SyncRemainder()
        self._alignment = (0.0, 0.0)
        self.pointing.mount_forgot()
        self._reread_position()

    def raw(self, text: str) -> str:
        """Send a raw command (``:XX#`` with or without the framing) and return its raw reply."""
        body = text.strip()
        body = body[1:] if body.startswith(":") else body
        body = body[:-1] if body.endswith("#") else body
        match = protocol.match_command(body)
        command = match.command if match else protocol.Command(body, protocol.ReplyKind.NONE, "unknown")
        before = self._mount_frame_position() if command.code in ("CM", "SMMC") else None
        try:
            reply = self.link.exchange(protocol.Request(command, f":{body}#"), Priority.COMMAND)
        finally:
            if command.has(Effect.SETTING):
                self.settings_cache.mark_stale()
        if command.has(Effect.READINGS):
            self._raw_changed_readings(command.code, before)
        return reply

    def _raw_changed_readings(self, code: str, before: tuple[float, float] | None) -> None:
        """A raw command changed what the readings mean: the effect the typed method would have. A raw
        sync point is on the wire already, so it, like ``:NSC#``, leaves no sync remainder; the
        alignment offset grows by what the readings moved (from ``before``, the position just before)."""
        with self._estimator_lock:
            if code in ("CM", "SMMC", "NSC"):
                self._remainder = SyncRemainder()
        if code == "NSC":
            self._alignment = (0.0, 0.0)
            self.pointing.mount_forgot()
        where = self._where(self._state.side)
        if code in ("St", "Sg"):
            self._pushed_site = None  # no longer what the server pushed: the next push cannot shift
        self._reread_position()
        state = self._state
        if code in ("CM", "SMMC") and state.raw_ra is not None and state.raw_dec is not None:
            self._aligned(before, (state.raw_ra, state.raw_dec))
            self._learn(before, (state.raw_ra, state.raw_dec), where)
            self._reread_position()  # read through the new anchor: the reading is the sync point again

    # -- polling -----------------------------------------------------------------------------

    def poll_once(self) -> MountState:
        """Read position, status, tracking and pier side with four short queries (≈55 bytes).

        A client command that ran while this poll was under way (a sync, a stop, tracking) may have
        changed what the poll read before it: such a poll publishes nothing and asks for a new
        one, so a stale reading never lands after a fresh command's effect.
        """
        epoch = self._epoch
        asked = self.monotonic()  # the mount takes the reading between this and ``now`` (estimator.observe)
        ra, dec = self._exec(protocol.query("GMEQ"), Priority.POLL)
        now = self.monotonic()
        status = self._exec(protocol.query("GU"), Priority.POLL)
        tracking = self._exec(protocol.query("GAT"), Priority.POLL)
        pier = self._exec(protocol.query("Gm"), Priority.POLL)
        park = self._read_park(status)
        with self._publish_lock:
            if self._epoch != epoch:
                self.refresh()
                return self._state
            published = self._publish_poll(ra, dec, (asked, now), status, tracking, pier, park)
        if self._turn_round:
            self._turn_dec_move_round()
        return published

    def _read_park(self, status: MountStatus) -> int | None:
        """``:Gps#`` when the mount may hold its own park: the status word shows it, or the mount is not
        tracking (a parked mount never tracks, so a tracking one costs no extra byte). Another program
        may park it at any time (the ZWO app, ASIAIR, the hand controller): the default firmware shows
        that only here. Firmware older than the park, or that answers an empty ``#`` or nothing, is not
        asked again on this link."""
        info = self._state.info
        if (self._park_unreadable == self.link.generation or (info is not None and not info.has_park)
                or (status.tracking and not status.parked)):
            return None
        park: int | None = None
        try:
            park = self._exec(protocol.query("Gps"), Priority.POLL)
        except LinkTimeout:
            log.info(":Gps# unanswered: the mount's own park is read from its status word only")
        if park is None:
            self._park_unreadable = self.link.generation
        return park

    def release_park(self) -> None:
        """Release the mount's own park with ``:Spu#`` and confirm it by reading the park state back.

        ``:Spu#`` answers a bare ``1`` when it released a park and ``0`` when there was none (S1's
        ASIMount trace, real-transcripts-1.8.8.md §1): a ``0`` is no failure by itself, the read-back
        decides. Raises MountReplyError when the mount still says it is parked."""
        try:
            self._exec(protocol.query("Spu"))
        except MountReplyError as exc:
            if exc.code is not None:
                raise  # an eN# refusal, not the "was not parked" byte
        park = self._try(protocol.query("Gps"))
        status = self._exec(protocol.query("GU"))
        state = self._changed(park=park, status=status, status_time=self.monotonic())
        if state.parked_by_mount:
            raise MountReplyError(":Spu#", "", None, "the mount still reports itself parked after :Spu#")

    def _publish_poll(self, ra: float, dec: float, window: tuple[float, float], status: MountStatus,
                      tracking: TrackingState, pier: str, park: int | None) -> MountState:
        asked, now = window
        state = self._state
        moving = bool(state.moving_axes) or (status.slewing and park != PARKED)
        with self._estimator_lock:
            if moving:
                self._estimator.invalidate()
                best = (ra, dec)
            else:
                if self._estimator.anchor_ra is None:
                    target = self._goto_target
                    if target is not None and _close(target, (ra, dec)):
                        self._estimator.set_exact(target[0], target[1], now)
                    self._goto_target = None
                drift = self._ra_drift(tracking)
                if drift != self._estimator.ra_rate:
                    self._estimator.set_ra_rate(drift, now)
                best = self._estimator.observe(ra, dec, now, asked)
        side = self._read_side(ra, dec, now, pier, moving, status)
        best = self._to_client(best, side)
        return self._publish(ra=best[0], dec=best[1], raw_ra=ra, raw_dec=dec, position_time=now, status=status,
                             status_time=now, tracking=tracking, pier=pier, side=side, poll_error="", park=park)

    def _read_side(self, ra: float, dec: float, now: float, letter: str, moving: bool,
                   status: MountStatus) -> PierSide:
        """The pointing state the letter means (mount/pier.py); a Dec move found going the wrong way
        (the mount's N/S are mechanical) is turned round here, as soon as a reading shows it."""
        if status.mode is MountMode.ALTAZ:
            return PierSide.UNKNOWN  # an alt-az mount has no pier side
        ha = sky.hour_angle(self.lst(), ra - self._alignment[0])
        south = self.site()[0] < 0.0
        with self._pier_lock:
            side = self._pier.observe(letter, ha, south, moving, now)
            self._side_known = self._pier.trusted(ha, south)
            reversed_now = self._dec_sense.observe(dec, side, now)
        if reversed_now and 1 in self._move_directions:
            self._turn_round = True  # done by the poller once the publish lock is released
        return side

    def _turn_dec_move_round(self) -> None:
        """The Dec move running was sent with a letter that moves the sky the other way on this side:
        send the other letter at the same speed (the mount keeps the latched :Rv for it)."""
        self._turn_round = False
        sent, multiple = self._move_directions.get(1), self._move_rates.get(1)
        if sent is None or multiple is None:
            return
        other = Direction.SOUTH if sent is Direction.NORTH else Direction.NORTH
        try:
            self.link.send_urgent(protocol.stop_direction(sent))
            self._exec(protocol.set_variable_speed(multiple))
            self._exec(protocol.move(other))
            self._move_directions[1] = other
            log.warning("Dec move turned round: %s moved the sky the other way on this side", sent.name)
        except AlpacaZwoError as exc:
            log.error("could not turn the Dec move round (%s): stopping it", exc)
            self.link.send_urgent(protocol.stop_direction(sent))

    def _poll_loop(self) -> None:
        while not self._stop.is_set():
            self._poll_wake.wait(self.poll_fast_s if self._busy() else self.poll_slow_s)
            self._poll_wake.clear()
            if self._stop.is_set():
                return
            if not self.link.status.connected:
                self._publish(poll_error=self.link.status.last_error)
                self.link.wait_connected(1.0)
                continue
            try:
                if self._init_generation != self.link.generation:
                    self.ensure_initialised()
                self.poll_once()
                self._refresh_settings()
                self._follow_host_clock()
            except AlpacaZwoError as exc:
                log.debug("poll failed: %s", exc)
                self._publish(poll_error=str(exc))

    def _refresh_settings(self) -> None:
        """Re-read the stored settings when due (see mount/settings_cache.py), only at rest and at poll priority:
        every command (a pulse, a GOTO) goes ahead of each of the eight queries, and a stop overtakes
        any of them on the urgent lane, so a refresh never holds up motion by more than one short query."""
        if not self._busy() and self.settings_cache.due():
            self.read_settings(Priority.POLL)

    def _follow_host_clock(self) -> None:
        """At rest: a host clock that became synchronised takes over from a kept mount clock, and sets it."""
        if not self._busy() and self.time.host_regained():
            self.push_time()

    def _busy(self) -> bool:
        """Something moves (an axis, a GOTO, a pulse): the poller polls fast and refreshes no settings."""
        state = self._state
        return bool(state.moving_axes) or state.goto_running or self._estimator.in_motion(self.monotonic())

    # -- helpers -----------------------------------------------------------------------------

    def _exec(self, req: protocol.Request, priority: Priority = Priority.COMMAND, guard: Guard | None = None) -> Any:
        try:
            return self.link.execute(req, priority, guard=guard)
        finally:
            if req.command.has(Effect.STATUS):
                with self._publish_lock:
                    self._epoch += 1
            if req.command.has(Effect.SETTING):
                self.settings_cache.mark_stale()

    def _send_on_idle_line(self, req: protocol.Request, guard: Guard | None = None) -> float:
        """A reply-less command written on an idle line (:meth:`Link.send_on_idle_line`); returns when
        it was written, in mount time."""
        try:
            return self._mount_time(self.link.send_on_idle_line(req, guard=guard))
        finally:
            if req.command.has(Effect.STATUS):
                with self._publish_lock:
                    self._epoch += 1

    def _changed(self, **changes: Any) -> MountState:
        """Publish the effect of a command, ending any poll that overlapped it (see poll_once)."""
        with self._publish_lock:
            self._epoch += 1
            return self._publish(**changes)

    def _try(self, req: protocol.Request, priority: Priority = Priority.COMMAND) -> Any:
        try:
            return self._exec(req, priority)
        except (MountReplyError, ProtocolError, LinkError) as exc:
            log.debug("%s failed: %s", req.text, exc)
            return None

    def _ra_drift(self, tracking: TrackingState | None = None) -> float:
        """RA change in hours per second while nothing else moves the mount (offset moves included)."""
        tracking = tracking if tracking is not None else self._state.tracking
        offset = self._drift[0] / 15.0  # a move is relative to the sky, tracking or not
        if tracking is None or not tracking.on:
            return SIDEREAL_HOURS_PER_S + offset
        factor = TRACK_RATE_FACTORS[self._state.tracking_rate]
        return SIDEREAL_HOURS_PER_S * (1.0 - factor) + offset

    def _rate_changed(self) -> None:
        now = self.monotonic()
        with self._estimator_lock:
            self._estimator.set_ra_rate(self._ra_drift(), now)
            self._estimator.set_dec_rate(self._drift[1], now)


def _close(a: tuple[float, float], b: tuple[float, float]) -> bool:
    """Within the mount's reading resolution (1 s of RA, 1″ of Dec) plus a margin."""
    dra_hours = abs((a[0] - b[0] + 12.0) % 24.0 - 12.0)
    return dra_hours <= 1.5 / 3600.0 and abs(a[1] - b[1]) <= 1.5 / 3600.0


def _offset_text(offset: timedelta) -> str:
    """"UTC+11:00", "UTC-03:30": the offset as the log names it."""
    minutes = round(offset.total_seconds() / 60.0)
    sign = "+" if minutes >= 0 else "-"
    return f"UTC{sign}{abs(minutes) // 60:02d}:{abs(minutes) % 60:02d}"
