"""Following a moving target (a satellite's pass, issue 41) with continuously adjusted axis speeds.

The supervisor runs a follow as one motion (``MotionKind.FOLLOW``), so Slewing is true from the slew to
the entry point to the end of the pass, and a stop (AbortSlew, the page's STOP, the interlock) ends it
like any motion: its ``:Q#`` ends the axis moves too. Its phases, kept in :class:`Follow`:

1. *aiming*: a GOTO to where the target will be when it enters the allowed sky (``enters``); with
   tracking on, the mount holds that point of the sky while it waits.
2. *waiting*: until the target is one lead time from that point. After a meridian flip (the second leg,
   ``supervisor._begin_flip``) the target arrives fast: each axis ramps to its speed centred on that
   instant (the run-up), so the mount is on it and at speed together.
3. *following*: every supervisor tick, each axis is given the speed the target moves at (its rate
   one lead time ahead) plus a correction of the error between where the target will be and where the
   mount will be by then (``CORRECTION_S``: the error is paid back over that time). The lead is the
   latency measured from the tick to the instant the speed commands were written. A speed changes by
   at most ``MAX_SPEED_STEP_DEG_S2`` per second (an abrupt change can stall a motor; the AM5 itself
   accelerates at about 4.5°/s², field notes §2.3), and is held under the mount's top speed.
   The speeds go out through ``Mount.drift`` (``:Rv…#`` then ``:Me#``/``:Mw#``/``:Mn#``/``:Ms#``, the
   speed latched per axis by the move command: field notes §2.3; ``YugnatD/eq-satrack``), which books
   them in the position estimator, so the mount's readings between polls are carried by what was sent.
4. the follow ends at ``leaves`` (the end of the allowed part), when the braking-aware limits
   (``limits.py``) would be crossed, or when the target cannot be placed: both axes are stopped and the
   motion settles like a stop, Slewing true until the readings show the mount at rest.

Moves are sky motions (relative to the stars) in both modes: the mount turns RA/Dec speeds into its axes'
speeds, alt-az ones included, so the same law serves both (near the zenith an alt-az mount cannot turn its
azimuth fast enough, and the error grows until the target leaves the keyhole; the plan says so before).
The target is a function of UTC giving RA (hours) and Dec (degrees) in the client's frame, the frame of
``Mount.position``; this module knows nothing of orbits (``telescope/orbits.py`` does).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from datetime import datetime, timedelta

from .. import sky
from .._exceptions import LinkError, MountReplyError, ProtocolError
from ..mount.operations import Mount
from ..mount.state import MountState
from .kinds import MAX_AXIS_DEG_S, TICK_S, Follow, Target

log = logging.getLogger(__name__)

#: The error is paid back over this time (seconds): short enough to trim a lag within a second or two,
#: long enough not to chase the 1″ steps of the readings.
CORRECTION_S = 0.8
#: The fastest a commanded speed may change (deg/s per second), under the AM5's ~4.5°/s² and the
#: emulator's braking deceleration, so the axes keep up with every change they are given.
MAX_SPEED_STEP_DEG_S2 = 2.5
#: A speed change smaller than this (deg/s) is not sent: the mount's 0.01× sidereal step.
SPEED_STEP_DEG_S = 0.01 * sky.SIDEREAL_DEG_S
def _rates(target: Target, when: datetime) -> tuple[float, float, float, float]:
    """(RA deg, Dec deg, RA speed deg/s, Dec speed deg/s) of the target at ``when``, by a central
    difference over a tenth of a second."""
    step = timedelta(seconds=0.05)
    ra0, dec0 = target(when - step)
    ra1, dec1 = target(when + step)
    ra, dec = target(when)
    return (ra * 15.0, dec, sky.wrap_hours_12(ra1 - ra0) * 15.0 / 0.1, (dec1 - dec0) / 0.1)


def _limited(wanted: float, previous: float, dt: float, top: float) -> float:
    """``wanted`` moved toward from ``previous`` by at most the speed step a tick allows, under ``top``."""
    step = MAX_SPEED_STEP_DEG_S2 * max(dt, TICK_S)
    return max(-top, min(top, previous + max(-step, min(step, wanted - previous))))


class Follower:
    """Drives the axes of a follow (module docstring). Owns no lock: only the supervisor's thread ticks it,
    and a stop ends its moves through the mount's ``:Q#`` and the stop generation its commands carry."""

    def __init__(self, *, mount: Mount) -> None:
        self.mount = mount
        self._last_tick: float | None = None

    def top_speed(self) -> float:
        """The mount's top speed now (deg/s): 1440× sidereal, 720× in heavy-duty mode (field notes §2.3)."""
        settings = self.mount.settings
        heavy = settings is not None and bool(settings.heavy_duty)
        return MAX_AXIS_DEG_S / 2.0 if heavy else MAX_AXIS_DEG_S

    def held(self, follow: Follow) -> Target:
        """The aim point held fixed to the ground (its hour angle and Dec), where the mount waits: a point
        fixed on the sky would drift a quarter of a degree a minute away from where the target will be."""
        ra_aim, dec_aim = follow.target(follow.aim)
        longitude = self.mount.site()[1]
        lst_aim = sky.local_sidereal_time(follow.aim, longitude)

        def ground(when: datetime) -> tuple[float, float]:
            return sky.wrap_hours_24(ra_aim + sky.local_sidereal_time(when, longitude) - lst_aim), dec_aim

        return ground

    def aim_point(self, follow: Follow, landing_s: float) -> tuple[float, float]:
        """Where the GOTO goes: the held aim point as it will stand on the sky ``landing_s`` from now."""
        return self.held(follow)(self.mount.time.now() + timedelta(seconds=landing_s))

    def tick(self, follow: Follow, state: MountState, guard: Callable[[], bool]) -> str:
        """One step of the follow after its GOTO: hold the aim point, then follow the target. '' while it
        goes on, else why it ended (its moves then still run: the supervisor stops them)."""
        now = self.mount.time.now()
        if follow.phase == "waiting" and now + timedelta(seconds=follow.lead_s) >= follow.aim + self._run_up(follow):
            follow.phase = "following"
        if now >= follow.leaves:
            return "the pass left the allowed sky"
        try:
            following = follow.phase == "following"
            return self._steer(follow, follow.target if following else self.held(follow), now, guard,
                               run_up=follow.leg == 2 and not following)
        except ValueError as exc:
            return f"the target cannot be placed: {exc}"
        except (LinkError, ProtocolError, MountReplyError) as exc:
            return f"the mount did not take a speed change: {exc}"

    @staticmethod
    def _run_up(follow: Follow) -> timedelta:
        """After a flip the target passes the waiting mount fast (near the meridian, often near the zenith):
        each axis ramps up to the target's speed centred on the instant it arrives (``_steer``'s run-up),
        so the error is paid when the mount is at speed; this is half the longest ramp."""
        if follow.leg != 2:
            return timedelta(0)
        _, _, v_ra, v_dec = _rates(follow.target, follow.aim)
        return timedelta(seconds=max(abs(v_ra), abs(v_dec)) / (2.0 * MAX_SPEED_STEP_DEG_S2))

    def _steer(self, follow: Follow, target: Target, now: datetime, guard: Callable[[], bool],
               run_up: bool = False) -> str:
        """Give each axis its speed toward ``target`` (module docstring). ``run_up`` (waiting after a flip):
        an axis whose ramp to the target's speed at the aim instant must begin (half the ramp before it)
        is given that speed alone, so it is at speed and on the target as the target arrives."""
        position = self.mount.position()
        if position is None:
            return ""
        started = self.mount.monotonic()
        dt = TICK_S if self._last_tick is None else min(3 * TICK_S, (started - self._last_tick) / self.mount.clock_rate)
        self._last_tick = started
        ahead = now + timedelta(seconds=follow.lead_s)
        ra_deg, dec, v_ra, v_dec = _rates(target, ahead)
        if follow.phase == "following":
            ra_t, dec_t = target(now)
            follow.note_error(now, sky.angular_separation(ra_t, dec_t, position[0], position[1]))
        # Where the mount will be by then, at the speeds it was given.
        mount_ra = position[0] * 15.0 + follow.speeds[0] * follow.lead_s
        mount_dec = position[1] + follow.speeds[1] * follow.lead_s
        error_ra = sky.wrap_hours_12((ra_deg - mount_ra) / 15.0) * 15.0
        top = self.top_speed()
        wanted = [v_ra + error_ra / CORRECTION_S, v_dec + (dec - mount_dec) / CORRECTION_S]
        if run_up:
            arriving = _rates(follow.target, follow.aim)[2:]
            for axis in (0, 1):
                starts = follow.aim - timedelta(seconds=abs(arriving[axis]) / (2.0 * MAX_SPEED_STEP_DEG_S2))
                if ahead >= starts:
                    wanted[axis] = arriving[axis]
        for axis in (0, 1):
            speed = _limited(wanted[axis], follow.speeds[axis], dt, top)
            if abs(speed - follow.speeds[axis]) >= SPEED_STEP_DEG_S or (speed == 0.0) != (follow.speeds[axis] == 0.0):
                self.mount.drift(axis, speed, guard=guard, exact_start=False)
                follow.speeds[axis] = speed
        written = self.mount.monotonic()
        measured = TICK_S + (written - started) / self.mount.clock_rate
        follow.lead_s += (measured - follow.lead_s) * 0.2  # a running mean: one slow write is not the rule
        return ""

