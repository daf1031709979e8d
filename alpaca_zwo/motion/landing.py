"""Landing exactly where asked.

The mount takes targets in whole seconds of RA and whole arcseconds, and a slew to a point fixed
to the ground (Alt/Az, a custom park) chases a sky that turns during the slew. A sky target is
reached exactly by a short guide pulse for the rounding residual after arrival. A ground target is
aimed at a whole-second RA the point will have at a known instant t* just after arrival; the mount
tracks until t*, and tracking is switched off at t* exactly (the line is held and the ``:Td#``
written at t*), which freezes the pointing on the requested Alt/Az. With tracking wanted on, the
slew simply ends at t*. If the mount arrives too late for t*, a short correcting GOTO aims at a
new t*, each further ahead by the lateness it saw.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable

from .. import sky
from .._exceptions import (
    LinkError,
    MotionCancelled,
    MountReplyError,
    ProtocolError,
)
from ..mount.operations import PULSE_CHUNK_MS, Mount
from ..sky import SIDEREAL_DEG_S, SIDEREAL_HOURS_PER_S
from ..zwo.wire_values import Direction
from .guiding import Guiding
from .kinds import Generation, Landing, Motion, Phase, _wrap12
from .rest import RestDetector

log = logging.getLogger(__name__)


#: A GOTO takes about this long per degree plus a fixed part; aims ground targets at arrival.
SLEW_S_PER_DEG = 1 / 5.0
SLEW_S_FIXED = 3.0
#: How far after the predicted arrival a ground target's freeze instant is placed (mount s).
LANDING_MARGIN_S = 1.0
#: Lead for a short correcting GOTO (mount s): it must arrive before its freeze instant.
CORRECTION_LEAD_S = 2.5
#: Real seconds the server needs to see an arrival (a fast poll and a supervisor tick), added to
#: the leads above in mount time, so a fast emulator is aimed as well as a real mount.
SEE_ARRIVAL_REAL_S = 0.6
#: Real seconds of readings that confirm rest before a tracked landing instant (three fast polls).
CONFIRM_REST_REAL_S = 0.8
MAX_LANDING_ATTEMPTS = 3
#: Residuals smaller than this (ms of guide pulse) are not worth a pulse.
MIN_PULSE_MS = 5


class Lander:
    """The arrival and landing phases of a slew (the module docstring).

    Owns no state and no lock: the landing record is the motion's own (``Motion.landing``), and
    every call comes from the supervisor with the motion it is about (its loop, or a start under
    the supervisor's ``_start_lock``). Uses ``guiding`` for residual pulses, ``rest`` to see the
    mount at rest, ``stops`` (the supervisor's Generation) for the guards of its commands, and
    ``lst`` for local sidereal time."""

    def __init__(self, *, mount: Mount, lst: Callable[[], float], guiding: Guiding, rest: RestDetector,
                 stops: Generation) -> None:
        self.mount = mount
        self._lst = lst
        self._guiding = guiding
        self._rest = rest
        self._stops = stops

    def see_arrival(self, landing: Landing) -> float:
        """Mount seconds the server needs to see an arrival; with tracking on, also to confirm rest."""
        real_s = SEE_ARRIVAL_REAL_S + (0.0 if landing.freeze else CONFIRM_REST_REAL_S)
        return real_s * self.mount.clock_rate

    def aim(self, landing: Landing, lead_s: float) -> float:
        """Pick the whole-second RA the ground point will have ``lead_s`` or a little more from now,
        and record the instant t* at which it has it."""
        now = self.mount.monotonic()
        lst_at = self._lst() + lead_s * SIDEREAL_HOURS_PER_S
        ra_exact = (lst_at - landing.ha) % 24.0
        # Whole seconds in the mount's frame, which is the client's less the sync remainder and the
        # pointing model's correction there (constant to far below a second over the landing).
        offset = self.mount.client_offset(ra_exact, landing.dec, sky.pointing_state(landing.ha))[0]
        ra_wire = math.ceil((ra_exact - offset) * 3600.0 - 1e-9) / 3600.0 + offset
        landing.t_star = now + lead_s + (ra_wire - ra_exact) / SIDEREAL_HOURS_PER_S
        return ra_wire % 24.0

    def arrived(self, motion: Motion, now: float) -> None:
        """The mount says the slew is over: start the landing, or settle."""
        landing = motion.landing
        if landing is not None and self.mount.running:
            try:
                if landing.ground:
                    self._land_ground(motion, landing, now)
                else:
                    self._land_sky(motion, landing, now)
                return
            except (LinkError, ProtocolError, MountReplyError, MotionCancelled) as exc:
                log.warning("%s: fine landing skipped: %s", motion.kind.value, exc)
        self._after_arrival(motion)
        self.settle(motion, now)

    def _land_sky(self, motion: Motion, landing: Landing, now: float) -> None:
        """Pulse away the whole-second/arcsecond rounding of the target the mount was given."""
        guide_deg_s = self.mount.state.guide_rate * SIDEREAL_DEG_S
        d_ra_deg = _wrap12(landing.ra - landing.wire[0]) * 15.0
        d_dec = landing.dec - landing.wire[1]
        end = now
        for delta, positive, negative in ((d_ra_deg, Direction.EAST, Direction.WEST),
                                          (d_dec, Direction.NORTH, Direction.SOUTH)):
            ms = round(abs(delta) / guide_deg_s * 1000.0)
            if ms >= MIN_PULSE_MS:
                direction = positive if delta > 0 else negative
                end = max(end, self._guiding.guide_pulse(direction, min(ms, PULSE_CHUNK_MS),
                                                 guard=self._stops.guard(motion.generation)))
        landing.pulse_end = end
        self._after_arrival(motion)
        motion.phase = Phase.LANDING if end > now else Phase.SETTLING
        motion.rest_from = end

    def _land_ground(self, motion: Motion, landing: Landing, now: float) -> None:
        """Wait for t*, or aim a short correcting GOTO at a new t* if the mount arrived too late."""
        assert landing.t_star is not None
        if landing.t_star - now > 0.05 * self.mount.clock_rate:
            motion.phase = Phase.LANDING
            motion.rest_from = now  # readings while it waits for t* show whether it is at rest
            self._pulse_dec_residual(motion, landing)
            return
        if landing.attempts >= MAX_LANDING_ATTEMPTS:
            log.warning("%s: arrived too late for the landing instant %d times; landing as is",
                        motion.kind.value, landing.attempts)
            self._after_arrival(motion)
            self.settle(motion, now)
            return
        self._correct(motion, landing, now)

    def _pulse_dec_residual(self, motion: Motion, landing: Landing) -> None:
        """The mount took the Dec in whole arcseconds: guide the rest (a Dec pulse leaves RA alone)."""
        d_dec = landing.dec - landing.wire[1]
        ms = round(abs(d_dec) / (self.mount.state.guide_rate * SIDEREAL_DEG_S) * 1000.0)
        if ms >= MIN_PULSE_MS:
            direction = Direction.NORTH if d_dec > 0 else Direction.SOUTH
            try:
                self._guiding.guide_pulse(direction, min(ms, PULSE_CHUNK_MS),
                                          guard=self._stops.guard(motion.generation))
            except (LinkError, ProtocolError, MountReplyError, MotionCancelled) as exc:
                log.debug("Dec residual pulse not sent: %s", exc)

    def _correct(self, motion: Motion, landing: Landing, now: float) -> None:
        """A short GOTO aimed at a new landing instant (the mount was too late for the last one)."""
        assert landing.t_star is not None
        log.debug("%s: %.2f s late for the landing instant; correcting GOTO", motion.kind.value,
                  now - landing.t_star)
        # Each correction aims further ahead by what the last one missed, and by more each time: a busy
        # host (or a slow link) sees arrivals later than the leads assume, and three misses in a row
        # landed a custom park 75" from its place (CI, two cores and five test lanes).
        late = max(0.0, now - landing.t_star)
        ra = self.aim(landing, (CORRECTION_LEAD_S + self.see_arrival(landing) + late) * (1 + landing.attempts))
        motion.saw_busy = False
        motion.started = self.mount.monotonic()
        wire = self.mount.goto(ra, landing.dec, guard=self._stops.guard(motion.generation))
        landing.wire = wire
        landing.attempts += 1
        motion.phase = Phase.MOVING

    def tick(self, motion: Motion, now: float) -> float | None:
        """One supervisor tick of a LANDING motion. Returns the instant it came to rest when a tracked
        slew ends at t* already at rest (SETTLE_TIME): the supervisor then runs that phase at once
        from there; else None."""
        landing = motion.landing
        assert landing is not None
        if not landing.ground:
            if now >= landing.pulse_end:
                self.settle(motion, now)
            return None
        assert landing.t_star is not None
        rate = self.mount.clock_rate
        if (landing.t_star - now) / rate > 0.06:
            if motion.at_rest is None and not landing.freeze and self._rest.at_rest(motion, now):
                motion.at_rest = now  # tracking steadily: the slew can end at t* itself
            return None
        if not landing.freeze and motion.at_rest is None and landing.attempts < MAX_LANDING_ATTEMPTS:
            # Tracking on, and rest not yet confirmed: ending at t* could report a moving mount as
            # arrived, ending later would pass the Alt/Az. Aim again at a later instant instead.
            self._correct(motion, landing, now)
            return None
        if not self._at_landing_instant(motion, landing):
            return None
        if motion.restore_tracking is True:
            motion.restore_tracking = None  # already tracking: nothing to restore
        self._after_arrival(motion, skip_tracking=landing.freeze)
        if motion.at_rest is not None:
            # Already at rest and tracking: the pointing passes the Alt/Az now, so the slew ends now.
            motion.at_rest = self.mount.monotonic()
            motion.phase = Phase.SETTLE_TIME
            return motion.at_rest
        self.settle(motion, self.mount.monotonic())
        return None

    def _at_landing_instant(self, motion: Motion, landing: Landing) -> bool:
        """At t* exactly: freeze the pointing (:Td# written at t*) or just let the moment come.
        False if a stop withdrew the freeze."""
        assert landing.t_star is not None
        at_real = time.monotonic() + (landing.t_star - self.mount.monotonic()) / self.mount.clock_rate
        if landing.freeze:
            try:
                self.mount.set_tracking(False, guard=self._stops.guard(motion.generation), not_before=at_real)
            except MotionCancelled:
                return False
            except (LinkError, ProtocolError, MountReplyError) as exc:
                log.error("%s: could not stop tracking at the landing instant: %s", motion.kind.value, exc)
        else:
            delay = at_real - time.monotonic()
            if delay > 0:
                time.sleep(delay)
        return True

    def _after_arrival(self, motion: Motion, skip_tracking: bool = False) -> None:
        wanted = motion.restore_tracking
        if skip_tracking or wanted is None:
            return
        try:
            self.mount.set_tracking(wanted)
        except (LinkError, ProtocolError, MountReplyError) as exc:
            log.error("after %s: could not set tracking: %s", motion.kind.value, exc)
        motion.restore_tracking = None

    def settle(self, motion: Motion, now: float) -> None:
        """The commanded motion is over: wait for readings taken from ``now`` on to show rest."""
        motion.phase = Phase.SETTLING
        motion.rest_from = max(motion.rest_from, now)
        self.mount.refresh()
