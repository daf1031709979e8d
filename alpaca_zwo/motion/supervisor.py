"""MotionSupervisor: the one owner of every motion of one mount.

GOTOs, alt/az and park slews, home, MoveAxis, guide pulses, aborts, the MoveAxis watchdog, the
horizon and meridian limits and the shutdown stop all live here, so every program that moves the
mount (Alpaca, the bridges, the setup page) gets the same rules, and a stop from any of them stops
motion started by any other. ``Telescope`` maps Alpaca members onto this; bytes live in ``mount``.

The supervisor owns small parts, each with its own state, built in ``__init__`` and handed what
they use by keyword (none reaches back into the supervisor): ``rest`` (RestDetector, the readings),
``limits`` (Limits, the braking-aware rules), ``guiding`` (Guiding: client pulses and alt-az timed
moves), ``payer`` (OffsetPayer: rate offsets, paid from the ledger ``offsets`` the supervisor owns,
``balance.py``), ``lander`` (Lander: landing exactly where asked), and ``stops`` (Generation, the
stop generation every command's guard reads, ``kinds.py``). It is lent ``interlock`` (the
observatory's safety gate, ``interlock.py``, shared by every telescope of the server): every start
but a park asks it, so no door into the server can start motion while the safety monitor says unsafe.

Lock rules (the reason this module exists):

- ``MotionSupervisor._start_lock`` serialises motion *starts* (GOTO, MoveAxis, home, park, pulses).
  It may be held across serial I/O and waits. **Stop paths never take it.**
- ``MotionSupervisor._lock`` guards the supervisor's fields (``motion``, ``moves``, ``parked``) and
  every ``stops.bump()``. It is never held across I/O or a wait.
- ``Guiding._lock`` guards the pulse and timed-move dicts; never held across I/O.
- ``Guiding.timed_lock`` makes starting or ending one alt-az timed pulse (``guiding.py``), and one
  speed change of an alt-az offset move with its booking (``offsets.py``), a single step; it is held
  across that one move command, never by ``abort`` (whose ``:Q#`` ends every move anyway). A
  client's new rate offset takes it too, so it never lands between a speed change and its booking.
- Order: supervisor ``_lock`` -> ``Guiding._lock``, never the reverse; ``Guiding.timed_lock`` ->
  ``Guiding._lock``; ``_start_lock`` -> ``timed_lock`` (a client pulse). Stops take neither
  ``_start_lock`` nor ``timed_lock``. A client pulse registers only if the generation is still the
  one it was started under (checked under ``Guiding._lock``), and an abort bumps the generation
  before it makes Guiding forget its pulses (under ``Guiding._lock``): so a pulse racing an abort
  is either forgotten by it or never registered.
- The link's write lock is held only for one ``write``. A stop bumps the generation under
  ``_lock`` and then writes its reply-less ``:Q#`` through the link's urgent lane; every motion
  command carries a guard ("generation unchanged") that the link checks under its write lock right
  before writing. So a motion racing a stop is either never written or written before the stop:
  an abort can never be overtaken by the GOTO it meant to cancel.

Rest, not flags: the mount drops its "slewing" flag the moment a GOTO ends or ``:Q#`` arrives,
while the axes may still brake for seconds. A motion therefore ends only when the readings taken
after it show the mount at rest (consecutive positions stable in the frame the mount holds still:
RA/Dec while tracking, HA/Dec when not) *and* the braking time predicted from its last speed has
passed. Slewing stays true until then.

Guide pulses (and the alt-az timed moves that stand in for them) live in ``guiding.py``; landing
exactly where asked in ``landing.py``; rate offsets in ``offsets.py`` (their ledger in
``balance.py``); rest detection in ``rest.py``; braking-aware limits in ``limits.py``.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

from .. import sky
from .._exceptions import (
    ERR_INTERRUPTED,
    ERR_LINK,
    ERR_TIMEOUT,
    AlpacaError,
    AmbiguousReply,
    DriverError,
    InvalidOperation,
    LinkError,
    LinkTimeout,
    MotionCancelled,
    MountReplyError,
    ProtocolError,
    driver_error,
    mount_errors,
)
from ..clients import ClientKey, ClientRegistry
from ..config.settings import Settings
from ..mount.operations import Mount
from ..mount.state import MountState
from ..zwo.wire_values import Direction
from .balance import CYCLE_S, RateOffsets
from .follow import Follower
from .guiding import Guiding
from .interlock import Interlock
from .kinds import (
    DECELERATION_DEG_S2,
    INTERRUPTIONS,
    MAX_MOTION_S,
    STATUS_LAG_S,
    TICK_S,
    Follow,
    Generation,
    Landing,
    ManualMove,
    Motion,
    MotionKind,
    Phase,
    _wrap12,
)
from .landing import LANDING_MARGIN_S, SLEW_S_FIXED, SLEW_S_PER_DEG, Lander
from .limits import Limits
from .offsets import OffsetPayer
from .rest import RestDetector

log = logging.getLogger(__name__)

#: Real seconds between supervisor ticks while nothing moves (a Pi at the mount idles cheaply).
IDLE_TICK_S = 1.0
#: A GOTO that replaced a motion and meets ``e3#`` (the mount still braking) is sent again this
#: often, for at most the braking time from full speed plus a margin (real seconds).
BRAKED_RETRY_S = 0.2
BRAKED_WITHIN_S = 4.0


class MotionSupervisor:
    """Starts, watches, lands and stops every motion of one mount (see the module docstring).

    Creates and owns ``_start_lock`` (starts; may be held across I/O, never by stops), ``_lock``
    (``motion``, ``moves``, ``parked`` and every generation bump; never across I/O or a wait) and
    ``_wake`` (the loop's wake-up). Owns the ledger ``offsets`` and the generation ``stops``, and
    lends them to its parts."""

    def __init__(
        self,
        mount: Mount,
        settings: Callable[[], Settings],
        lst: Callable[[], float],
        registry: ClientRegistry,
        *,
        name: str = "motion",
        interlock: Interlock | None = None,
    ) -> None:
        self.mount = mount
        self.interlock = interlock or Interlock()  # asked by every start but a park (interlock.py)
        self._settings = settings
        self._lst = lst
        self.registry = registry
        self._start_lock = threading.Lock()
        self._lock = threading.Lock()
        self._wake = threading.Condition()
        self.stops = Generation()
        self.motion: Motion | None = None
        self.moves: dict[int, ManualMove] = {}
        self.settle_s = 0.0
        self._own_park = False  # a park of ours ended at its position (the mount's own park: Mount.state)
        self.offsets = RateOffsets()
        self.rest = RestDetector(mount=mount)
        self.limits = Limits(mount=mount, settings=settings, lst=lst)
        self.guiding = Guiding(mount=mount, ledger=self.offsets, stops=self.stops, notify=self._notify,
                               safety_stop=self.safety_stop)
        self.payer = OffsetPayer(mount=mount, ledger=self.offsets, guiding=self.guiding, stops=self.stops,
                                 moving=self._moving)
        self.lander = Lander(mount=mount, lst=lst, guiding=self.guiding, rest=self.rest, stops=self.stops)
        self.follower = Follower(mount=mount)
        self._stop_pending = ""  # why a safety stop is still owed to the mount ('' = none)
        self._stopped = threading.Event()
        registry.protect(self.move_owners)  # the watchdog needs every owner's last-seen time
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    # -- read-outs ---------------------------------------------------------------------------

    @property
    def generation(self) -> int:
        """The stop generation now (read-only; ``stops`` bumps it)."""
        return self.stops.value

    def running(self) -> Motion | None:
        """The slew, park, home or stop running now (None at rest or in a manual move only): one
        reference, read without the lock. Its ``done`` and ``error`` say how it ends."""
        return self.motion

    def _moving(self) -> bool:
        """A motion of ours (slew, home, park, stop) or a manual move runs: offsets start afresh after it."""
        return self.motion is not None or bool(self.moves)

    def slewing(self, state: MountState | None = None) -> bool:
        """Our motions until the mount is at rest, manual moves, and any GOTO the mount reports."""
        state = state or self.mount.state
        return self.motion is not None or bool(self.moves) or bool(state.moving_axes) or state.goto_running

    @property
    def parked(self) -> bool:
        """AtPark: a park of ours arrived, or the mount holds its own (firmware) park, whoever set it."""
        return self._own_park or self.mount.state.parked_by_mount

    @property
    def parked_by_mount(self) -> bool:
        """The mount holds its own park (``:hP#`` from the ZWO app, ASIAIR, a hand controller...)."""
        return self.mount.state.parked_by_mount

    def pulse_guiding(self) -> bool:
        return bool(self.guiding.pulses)

    def stopping(self) -> bool:
        """Only a stop the server is finishing (axes braking to rest): a new GOTO is queued behind
        it, never refused because of it."""
        motion = self.motion
        return motion is not None and motion.kind is MotionKind.STOP

    def move_owners(self) -> list[ClientKey]:
        """The clients whose MoveAxis runs (the registry never evicts them); takes no lock."""
        return [move.owner for move in list(self.moves.values()) if move.owner is not None]

    # -- stops (no lock held across I/O; never waits) ------------------------------------------

    def abort(self, why: str = "AbortSlew") -> None:
        """Stop every motion now: bump the generation (withdrawing motions being started), write
        :Q# on the urgent lane, and keep Slewing true until the readings show the mount at rest."""
        state = self.mount.state
        with self._lock:
            self.stops.bump()
            previous = self.motion
            speed = self.rest.speed_estimate([move.rate for move in self.moves.values()])
            moving = previous is not None or self.moves or state.moving_axes or state.goto_running
            self.moves.clear()
            self.guiding.forget()  # :Q# stops pulses and timed moves with everything else
            self.offsets.reset()
            self.motion = self._stopping(speed, previous) if moving else None
        try:
            self.mount.stop()
            self._stop_pending = ""
        except LinkError as exc:
            self._stop_pending = why
            raise driver_error(why, exc) from exc
        finally:
            self._notify()
        log.info("%s: mount stopped (was %s)", why, previous.kind.value if previous else "idle")

    def _stopping(self, speed: float, previous: Motion | None) -> Motion:
        """A STOP motion that lasts until the mount is at rest (callers hold ``_lock``)."""
        now = self.mount.monotonic()
        motion = Motion(MotionKind.STOP, self.stops.value, now, Phase.SETTLING, rest_from=now,
                        brake_s=speed / DECELERATION_DEG_S2)
        if previous is not None:
            previous.error = previous.error or "stopped"
            _end_follow(previous, "stopped")
            previous.done.set()
        return motion

    def stop_axis(self, axis: int, why: str) -> None:
        """MoveAxis(axis, 0) and the watchdog: stop one axis on the urgent lane."""
        with self._lock:
            move = self.moves.pop(axis, None)
            self.stops.bump()
            if not self.moves and (self.motion is None or self.motion.kind is MotionKind.MOVE):
                speed = max(abs(move.rate) if move else 0.0,
                            self.rest.speed_estimate([m.rate for m in self.moves.values()]))
                self.motion = self._stopping(speed, self.motion)
        try:
            self.mount.move_axis(axis, 0.0)
        except (LinkError, ProtocolError, MountReplyError) as exc:
            self.safety_stop(f"{why} (stopping axis {axis} failed: {exc})")
        finally:
            self._notify()
        if why:
            log.info("axis %d stopped: %s", axis, why)

    def stop_manual(self, why: str) -> None:
        """Stop manual moves and pulses (last client gone, server shutting down)."""
        if not self.moves and not self.mount.state.moving_axes and not self.guiding.busy:
            return
        log.warning("stopping manual motion: %s", why)
        self.guiding.forget_pulses()
        self.guiding.end_all()
        for axis in (0, 1):
            if axis in self.moves or axis in self.mount.state.moving_axes:
                self.stop_axis(axis, "")

    def safety_stop(self, why: str) -> None:
        """Send :Q# now, and keep retrying from the supervisor until the mount has taken it."""
        try:
            self.mount.stop()
            self._stop_pending = ""
            self.guiding.forget_timed_moves()
            log.warning("mount stopped: %s", why)
        except (LinkError, ProtocolError) as exc:
            if not self._stop_pending:
                log.error("could not stop the mount (%s): %s; retrying until it answers", why, exc)
            self._stop_pending = why

    # -- starts ------------------------------------------------------------------------------

    def _begin(self, kind: MotionKind) -> Motion:
        """Replace whatever moves now by a new motion (callers hold ``_start_lock``).

        The new motion is installed at once, QUEUED, so Slewing stays true without a gap while the
        one it replaces (a slew, a move, or a stop still braking) is stopped and brakes to rest;
        an abort meanwhile ends it like any motion and this start raises."""
        state = self.mount.state
        with self._lock:
            if kind is not MotionKind.PARK:  # before anything changes: a refusal leaves a running park alone
                self.interlock.require(kind.value)
                self._refuse_during_follow(kind.value)
            generation = self.stops.bump()
            busy = (self.motion is not None or bool(self.moves) or bool(state.moving_axes)
                    or state.goto_running or any(self.mount.drift_rates))
            motion = Motion(kind, generation, self.mount.monotonic(), Phase.QUEUED, queued=busy)
            previous, self.motion = self.motion, motion
        if previous is not None:
            previous.error = previous.error or "replaced"
            _end_follow(previous, "replaced by a park")
            previous.done.set()
        try:
            if busy:
                self._stop_previous(generation)
        except AlpacaError:
            self._withdraw(motion)
            raise
        with self._lock:
            if self.stops.value != generation:
                motion.done.set()
                raise InvalidOperation(f"{kind.value} cancelled: a stop arrived while it was starting")
            motion.started = self.mount.monotonic()
            motion.phase = Phase.MOVING
        return motion

    def _withdraw(self, motion: Motion) -> None:
        with self._lock:
            if self.motion is motion:
                self.motion = None
        motion.done.set()

    def _stop_previous(self, generation: int) -> None:
        """A new slew replaces the running one: :Q#, then wait for the mount to drop its GOTO flag,
        which a ZWO mount holds until its axes have braked (a GOTO before then gets e3#). The wait
        gives up at once if a stop arrives."""
        try:
            self.mount.stop()
        except LinkError as exc:
            raise driver_error("stopping the current motion", exc) from exc
        with self._lock:
            self.moves.clear()  # :Q# ended them: no watchdog or limit stop may cancel the queued start
        since = self.mount.monotonic()
        self.mount.refresh()
        idle = self.mount.wait_for(
            lambda s: self.stops.value != generation
            or (s.status_time is not None and s.status_time > since and not s.goto_running),
            timeout=10.0,
        )
        if idle is None:
            raise DriverError("the mount did not stop the previous motion", ERR_TIMEOUT)

    def _fail(self, motion: Motion, what: str, exc: Exception) -> AlpacaError:
        self._withdraw(motion)
        if isinstance(exc, MotionCancelled):
            return InvalidOperation(f"{what} cancelled: a stop arrived while it was starting")
        return driver_error(what, exc, moving=self.slewing())  # a "busy" refusal says moving only if so

    def goto(self, ra: float, dec: float, kind: MotionKind = MotionKind.GOTO,
             restore_tracking: bool | None = None) -> Motion:
        """Slew to a sky position (RA/Dec), landing on it exactly."""
        with self._start_lock:
            motion = self._begin(kind)
            motion.landing = Landing(False, ra % 24.0, 0.0, dec, False)
            motion.restore_tracking = restore_tracking
            self._send_goto(motion, ra, dec)
        return motion

    def goto_fixed(self, ha: float, dec: float, kind: MotionKind, freeze: bool) -> Motion:
        """Slew to a point fixed to the ground (HA/Dec), landing on it at a known instant."""
        with self._start_lock:
            motion = self._begin(kind)
            landing = Landing(True, 0.0, _wrap12(ha), dec, freeze)
            motion.landing = landing
            here = self.mount.position()
            lst = self._lst()
            distance = 0.0 if here is None else sky.angular_separation(
                sky.ra_from_hour_angle(lst, ha), dec, *here)
            lead = SLEW_S_FIXED + distance * SLEW_S_PER_DEG + LANDING_MARGIN_S + self.lander.see_arrival(landing)
            ra = self.lander.aim(landing, lead)
            self._send_goto(motion, ra, dec)
        return motion

    def _send_goto(self, motion: Motion, ra: float, dec: float) -> None:
        guard = self.stops.guard(motion.generation)
        try:
            wire = self._goto_when_braked(motion, ra, dec, guard)
        except (LinkTimeout, AmbiguousReply) as exc:
            # The reply was lost or garbled, not necessarily the command: the mount may be slewing.
            # Keep the motion under supervision; the readings end it when they show the mount idle.
            self._notify()
            raise DriverError(f"{motion.kind.value}: the mount did not confirm the GOTO ({exc}); Slewing "
                              "shows whether it started", ERR_TIMEOUT) from exc
        except (MountReplyError, ProtocolError, LinkError, MotionCancelled) as exc:
            raise self._fail(motion, motion.kind.value, exc) from exc
        assert motion.landing is not None
        motion.landing.wire = wire
        motion.landing.attempts += 1
        self._notify()

    def _goto_when_braked(self, motion: Motion, ra: float, dec: float,
                          guard: Callable[[], bool]) -> tuple[float, float]:
        """Send the GOTO; if it replaced a motion and the mount answers e3# (still braking from the
        stop), send it again until the braking is over. A stop meanwhile withdraws it (the guard)."""
        deadline = time.monotonic() + BRAKED_WITHIN_S
        while True:
            try:
                return self.mount.goto(ra, dec, guard=guard)
            except MountReplyError as exc:
                if exc.code != 3 or not motion.queued or time.monotonic() > deadline:
                    raise
            log.debug("%s: the mount is still braking (e3); sending the GOTO again", motion.kind.value)
            time.sleep(BRAKED_RETRY_S)

    def follow(self, follow: Follow) -> Motion:
        """Follow a moving target (a satellite's pass, follow.py): slew to where it enters the allowed sky,
        wait for it, then drive the axes' speeds until it leaves. One motion throughout: Slewing is true,
        any stop ends it, and other motions, pulses and rate offsets are refused while it runs."""
        with self._start_lock:
            motion = self._begin(MotionKind.FOLLOW)
            with self._lock:
                self.offsets.reset()  # the speeds carry the whole motion: no offset may drift beside them
            motion.follow = follow
            here = self.mount.position()
            try:
                ground = self.follower.held(follow)(self.mount.time.now())
                distance = 0.0 if here is None else sky.angular_separation(*ground, *here)
                ra, dec = self.follower.aim_point(follow, SLEW_S_FIXED + distance * SLEW_S_PER_DEG)
            except ValueError as exc:
                self._withdraw(motion)
                raise InvalidOperation(f"{follow.name}: {exc}") from exc
            motion.landing = Landing(False, ra % 24.0, 0.0, dec, False)
            follow.goto_sent = self.mount.monotonic()
            self._send_goto(motion, ra, dec)
        return motion

    def _refuse_during_follow(self, what: str) -> None:
        """Refuse ``what`` while a follow runs, saying why and how to end it."""
        motion = self.motion
        if motion is not None and motion.kind is MotionKind.FOLLOW and motion.follow is not None:
            raise InvalidOperation(f"{what} refused: the mount is following {motion.follow.name}'s pass; "
                                   "stop it first (AbortSlew, STOP, or zwo:TrackSatellite stop)")

    def home(self, kind: MotionKind = MotionKind.HOME) -> Motion:
        with self._start_lock:
            motion = self._begin(kind)
            try:
                self.mount.home(guard=self.stops.guard(motion.generation))
            except (MountReplyError, ProtocolError, LinkError, MotionCancelled) as exc:
                raise self._fail(motion, kind.value, exc) from exc
        self._notify()
        return motion

    def move_axis(self, axis: int, rate: float, owner: ClientKey | None) -> None:
        """Start (rate != 0) or stop (0) a manual move of one axis."""
        if rate == 0.0:
            self.stop_axis(axis, "")
            return
        with self._start_lock:
            motion = self.motion
            self._refuse_during_follow("MoveAxis")
            if motion is not None and motion.kind not in (MotionKind.MOVE, MotionKind.STOP):
                raise InvalidOperation(f"a {motion.kind.value} is in progress; abort it first")
            self.limits.check_move(axis, rate)
            with self._lock:
                self.interlock.require("MoveAxis")
                generation = self.stops.value
                if motion is None or motion.kind is MotionKind.STOP:
                    self.motion = Motion(MotionKind.MOVE, generation, self.mount.monotonic())
            try:
                self.mount.move_axis(axis, rate, guard=self.stops.guard(generation))
            except (MountReplyError, ProtocolError, LinkError, MotionCancelled) as exc:
                with self._lock:
                    if not self.moves and self.motion is not None and self.motion.kind is MotionKind.MOVE:
                        self.motion = None
                if isinstance(exc, MotionCancelled):
                    raise InvalidOperation("MoveAxis cancelled: a stop arrived while it was starting") from exc
                raise driver_error("MoveAxis", exc) from exc
            with self._lock:
                self.moves[axis] = ManualMove(rate, owner)
        self._notify()

    def wait(self, motion: Motion, timeout: float = MAX_MOTION_S) -> None:
        """Block until ``motion`` has ended (synchronous Alpaca slews)."""
        if not motion.done.wait(timeout):
            raise DriverError(f"the {motion.kind.value} did not finish in time", ERR_TIMEOUT)
        if motion.error in INTERRUPTIONS:  # never success: the mount is not where this caller asked
            raise DriverError(f"the {motion.kind.value} did not arrive: {INTERRUPTIONS[motion.error]}",
                              ERR_INTERRUPTED)
        if motion.error:
            raise DriverError(f"the {motion.kind.value} failed: {motion.error}", ERR_LINK)

    # -- guide pulses and rate offsets (guiding.py, offsets.py) --------------------------------

    def pulse(self, direction: Direction, duration_ms: int) -> None:
        """Start a guide pulse of any length (sent in chunks the mount accepts)."""
        self.interlock.require("PulseGuide")  # even a zero-length one: the rule is simply "no PulseGuide"
        self._refuse_during_follow("PulseGuide")
        if self.motion is not None and self.motion.kind is not MotionKind.STOP:
            raise InvalidOperation(f"cannot pulse guide during a {self.motion.kind.value}")
        if duration_ms == 0:
            return
        chunk = self.guiding.first_chunk_ms(duration_ms)
        with self._start_lock:
            with self._lock:  # the gate and the generation in one step (interlock.py's race rule)
                self.interlock.require("PulseGuide")
                generation = self.stops.value
            self.guiding.start(direction, duration_ms, chunk, generation)
        self._notify()

    def set_rate_offset(self, axis: int, arcsec_per_s: float) -> None:
        """RightAscensionRate / DeclinationRate (arcsec/s of sky; axis 0 + is east); zero always goes."""
        if arcsec_per_s != 0.0:
            self.interlock.require("A rate offset")
            self._refuse_during_follow("A rate offset")
        self.payer.set_rate(axis, arcsec_per_s)
        self._notify()

    # -- tracking and unpark: starts too (the mount turns with the sky, or may move again) -----------

    def set_tracking(self, on: bool) -> None:
        """Tracking on or off. On asks the gate, and its ``:Te#`` is withdrawn unsent if the interlock
        closes before it is written (the observatory's ``:Td#`` then follows it); off always goes."""
        if not on:
            self.mount.set_tracking(False)
            return
        self.interlock.require("Tracking=true")
        try:
            self.mount.set_tracking(True, guard=self.interlock.guard())
        except MotionCancelled as exc:
            raise self.interlock.refusal("Tracking=true") from exc

    def unpark(self) -> None:
        """Unpark: the mount may move again, so the gate must allow it. A park the mount holds itself (or is
        still making) is released with ``:Spu#`` and answered only once the mount confirms it (Mount.release_park)."""
        self.interlock.require("Unpark")
        if self.mount.state.park_latched:
            with mount_errors("Unpark"):
                self.mount.release_park()
        with self._lock:
            self.interlock.require("Unpark")
            self._own_park = False

    # -- the supervisor thread -----------------------------------------------------------------

    def close(self) -> None:
        self.registry.unprotect(self.move_owners)
        self._stopped.set()
        self._notify()
        self._thread.join(timeout=2)

    def _notify(self) -> None:
        with self._wake:
            self._wake.notify_all()

    def _run(self) -> None:
        while not self._stopped.is_set():
            try:
                wait_s = self._next_wake()
            except Exception:  # as below: a bug here must not end the watchdog and the limits
                log.exception("motion supervisor error (next wake-up)")
                wait_s = TICK_S
            with self._wake:
                self._wake.wait(wait_s)
            if self._stopped.is_set():
                return
            try:
                self._tick()
            except Exception:  # the supervisor must survive anything to keep the mount safe
                log.exception("motion supervisor error")

    def _next_wake(self) -> float:
        """Real seconds to wait: TICK_S at most while anything is under way (sooner when a pulse chunk,
        a landing or an offset pulse is due), IDLE_TICK_S when nothing is: every start notifies."""
        now = self.mount.monotonic()
        rate = self.mount.clock_rate
        busy = (self.motion is not None or self.moves or self.guiding.busy or self.offsets.active
                or self._stop_pending)
        delays = [TICK_S if busy else IDLE_TICK_S]
        delays.extend(self.guiding.wake_delays(now, rate))
        motion = self.motion
        landing = motion.landing if motion is not None and motion.phase is Phase.LANDING else None
        if landing is not None and landing.t_star is not None:
            delays.append(max(0.0, (landing.t_star - now) / rate - 0.05))
        if self.offsets.active and self.offsets.accrued_at is not None:
            delays.append(max(0.0, (self.offsets.accrued_at + CYCLE_S - now) / rate))
        return min(delays)

    def _tick(self) -> None:
        if not self.mount.running:
            return
        if self._stop_pending:
            self.safety_stop(self._stop_pending)
        state = self.mount.state
        self.rest.record(state)
        now = self.mount.monotonic()
        self.guiding.tick(now)
        self.payer.tick(now, state)
        self._tick_motion(now, state)
        self._tick_watchdog()
        self._tick_limits(state)

    # -- motion phases -------------------------------------------------------------------------

    def _tick_motion(self, now: float, state: MountState) -> None:
        motion = self.motion
        if motion is None:
            return
        if now - motion.started > MAX_MOTION_S and motion.kind not in (MotionKind.MOVE, MotionKind.FOLLOW):
            log.error("%s did not finish within %.0f s: stopping", motion.kind.value, MAX_MOTION_S)
            motion.error = "did not finish in time"
            self.safety_stop(f"{motion.kind.value} overran")
            self._finish(motion)
            return
        if motion.phase is Phase.QUEUED:
            return  # its start is waiting for the motion it replaces to brake (``_begin``)
        if motion.phase is Phase.MOVING:
            self._tick_moving(motion, now, state)
        elif motion.phase is Phase.LANDING:
            self._tick_landing(motion, now)
        elif motion.phase is Phase.SETTLING:
            if motion.kind is MotionKind.MOVE:
                return  # manual moves settle through their STOP motion
            if self.rest.at_rest(motion, now):
                motion.at_rest = now
                motion.phase = Phase.SETTLE_TIME
        settle_s = 0.0 if motion.kind is MotionKind.STOP else self.settle_s
        settled = motion.at_rest is not None and now - motion.at_rest >= settle_s
        if motion.phase is Phase.SETTLE_TIME and settled:
            self._finish(motion)

    def _tick_landing(self, motion: Motion, now: float) -> None:
        at_rest = self.lander.tick(motion, now)
        if at_rest is not None:  # a tracked slew ended at t* already at rest: its settle time runs from there
            self._tick_motion(at_rest, self.mount.state)

    def _tick_moving(self, motion: Motion, now: float, state: MountState) -> None:
        if motion.kind is MotionKind.MOVE:
            return
        if motion.follow is not None:
            self._tick_follow(motion, motion.follow, now, state)
            return
        if state.status_time is None or state.status_time <= motion.started or state.status is None:
            return  # no reading taken after the command yet
        if state.goto_running:
            motion.saw_busy = True
            return
        if not motion.saw_busy and state.status_time - motion.started < STATUS_LAG_S:
            return  # the flags may still show the state from before the command
        self.lander.arrived(motion, now)

    def _tick_follow(self, motion: Motion, follow: Follow, now: float, state: MountState) -> None:
        """A follow's phases (follow.py): a GOTO (to the entry point, or the flip's) ends as any GOTO's does
        (the flags), then the follower steers until the pass, the limits or a failure end it, or the
        planned flip begins (where the first leg ends, or sooner if the meridian limit would stop it)."""
        if follow.phase in ("aiming", "flipping"):
            why = self._tick_follow_goto(motion, follow, now, state)
            if why:
                self._end_following(motion, follow, why, now)
            return
        flip_due = (follow.phase == "following" and follow.leg == 1 and follow.flip_at is not None
                    and self.mount.time.now() >= follow.flip_at)
        why = "" if flip_due else self.follower.tick(follow, state, self.stops.guard(motion.generation))
        if not why and follow.phase == "following":
            reason = self.limits.reached(dict(enumerate(follow.speeds)), state)
            if follow.leg == 1 and follow.flip_at is not None and (flip_due or reason.startswith("meridian")):
                self._begin_flip(motion, follow, now)
                return
            why = f"it would cross the {reason}" if reason else ""
        if why:
            self._end_following(motion, follow, why, now)

    def _tick_follow_goto(self, motion: Motion, follow: Follow, now: float, state: MountState) -> str:
        """The GOTO of a leg: sent (the flip's, once the axes have braked), then watched until the flags
        show it over, when the mount waits for the target. '' while it goes on, else why the follow ends."""
        if self.mount.time.now() >= follow.leaves:
            return "the pass ended before the slew to it did"
        if follow.goto_sent is None:
            return self._send_flip(motion, follow, now)
        if state.status_time is None or state.status_time <= follow.goto_sent or state.status is None:
            return ""
        if state.status.slewing:
            follow.goto_busy = True
        elif follow.goto_busy or state.status_time - follow.goto_sent >= STATUS_LAG_S:
            follow.phase = "waiting"
        return ""

    def _begin_flip(self, motion: Motion, follow: Follow, now: float) -> None:
        """End the first leg: stop the axes' moves (:Q#, the generation unchanged so the flip's GOTO may
        follow) and let them brake; ``_send_flip`` sends the GOTO once they have."""
        speed = max(abs(v) for v in follow.speeds)
        try:
            self.mount.stop()
        except (LinkError, ProtocolError) as exc:
            self._end_following(motion, follow, f"the axes did not take the stop before the flip: {exc}", now)
            return
        with self._lock:
            if self.motion is not motion or follow.phase != "following":
                return  # a stop or a park ended it meanwhile
            follow.phase = "flipping"
            follow.leg = 2
            follow.speeds = [0.0, 0.0]
            follow.goto_sent = None
            follow.goto_busy = False
            follow.aim = follow.resumes or follow.aim
            follow.flip_deadline = now + (speed / DECELERATION_DEG_S2 + BRAKED_WITHIN_S) * self.mount.clock_rate
        log.info("%s: first leg ended; flipping to %s to wait at %s", follow.name, follow.flip_side, follow.aim)

    def _send_flip(self, motion: Motion, follow: Follow, now: float) -> str:
        """The flip's GOTO, through the one limit check of any GoTo, to where the target will be when the
        mount waits for it (held fixed to the ground, as at the start). Sent again on the next tick while
        the mount still brakes from the first leg (``e3#``). '' while it goes on, else why it ended."""
        landing_s = max(0.0, (follow.aim - self.mount.time.now()).total_seconds())
        try:
            self.interlock.require("the flip's GOTO")
        except AlpacaError as exc:
            return exc.message
        try:
            ra, dec = self.follower.aim_point(follow, landing_s)
        except ValueError as exc:
            return f"the target cannot be placed: {exc}"
        blocked = follow.blocked(ra, dec, landing_s)
        if blocked:
            return f"the flip's GOTO was refused: target is {blocked}"
        try:
            current, safe = self.stops.guard(motion.generation), self.interlock.guard()
            self.mount.goto(ra, dec, guard=lambda: current() and safe())
        except MotionCancelled:
            return ""  # a stop came first: it ends the motion
        except MountReplyError as exc:
            if exc.code == 3 and now < follow.flip_deadline:
                return ""  # still braking from the first leg
            return f"the mount refused the flip's GOTO: {exc}"
        except (LinkError, ProtocolError) as exc:
            return f"the flip's GOTO failed: {exc}"
        with self._lock:
            if self.motion is motion:
                motion.landing = Landing(False, ra % 24.0, 0.0, dec, False)
                follow.goto_sent = self.mount.monotonic()
        self._notify()
        return ""

    def _end_following(self, motion: Motion, follow: Follow, why: str, now: float) -> None:
        """Stop the axes and let the motion settle like a stop (Slewing true until at rest)."""
        speed = max(abs(v) for v in follow.speeds)
        _end_follow(motion, why)
        log.info("%s: following ended: %s", follow.name, why)
        self.safety_stop(f"{follow.name}: {why}")
        with self._lock:
            motion.phase = Phase.SETTLING
            motion.rest_from = now
            motion.brake_s = speed / DECELERATION_DEG_S2

    def _finish(self, motion: Motion) -> None:
        with self._lock:
            if self.motion is not motion:
                motion.done.set()
                return
            if motion.kind is MotionKind.PARK and not motion.error:
                self._own_park = True
                log.info("parked")
            self.motion = None
        motion.done.set()
        self._notify()

    # -- watchdog and limits -------------------------------------------------------------------

    def _tick_watchdog(self) -> None:
        """Stop a MoveAxis whose client stopped talking, or that the server cannot find (counts as silent)."""
        limit = self._settings().safety.moveaxis_watchdog_s
        now = time.monotonic()
        for axis, move in list(self.moves.items()):
            if move.owner is None:
                continue
            seen = self.registry.last_seen(move.owner)
            if seen is None:
                self.stop_axis(axis, f"client {move.owner} went silent (no longer known to the server) during MoveAxis")
            elif now - seen > limit:
                self.stop_axis(axis, f"client {move.owner} went silent for {now - seen:.0f} s during MoveAxis")

    def _tick_limits(self, state: MountState) -> None:
        """Stop a manual move before it reaches the horizon, minimum altitude or meridian limit:
        where it would come to rest if stopped now (braking distance plus reaction time)."""
        if not self.moves:
            return
        moves = {axis: move.rate for axis, move in list(self.moves.items())}  # a client may start one now
        reason = self.limits.reached(moves, state)
        if reason:
            for axis in list(self.moves):
                self.stop_axis(axis, f"manual move stopped before the {reason}")


def _end_follow(motion: Motion, why: str) -> None:
    """Mark a FOLLOW motion's follow ended (its first reason stands)."""
    follow = motion.follow
    if follow is not None and follow.phase != "ended":
        follow.phase = "ended"
        follow.ended = why
