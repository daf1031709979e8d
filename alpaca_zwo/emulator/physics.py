"""The model's mechanics: lazy, exact integration of the two axes (slews, moves, pulses, tracking).

Every public call of the model first advances the physics to ``clock.seconds()`` in bounded steps,
so the result depends only on the sequence of clock readings; each step integrates a trapezoidal
velocity profile exactly, and GOTOs use a sampled braking-curve controller (see ``model``).
"""

from __future__ import annotations

import math

from .. import sky
from ..sky import LUNAR_DEG_S, SIDEREAL_DEG_S, SOLAR_DEG_S
from ..zwo.wire_values import SLEW_SPEEDS, MountMode
from .altaz import SETTLED_S, axes_to_ha_dec_altaz, follow_sky
from .clock import Clock
from .clocksite import ClockAndSite
from .flash import FlashSettings
from .imperfection import Imperfection
from .state import (
    AT_HOME_DEG,
    DEC,
    HOME_P,
    HOME_S,
    RA,
    SLEW_STEP_S,
    SNAP_DEG,
    STEADY_STEP_S,
    TRACKING_HORIZON_SLACK_DEG,
    AxisPulse,
    Hemisphere,
    Slew,
    ramp,
)


class Mechanics:
    """The physics of the mount: the two axes and what drives them (slews, braking, moves, pulses,
    tracking), the target and alignment offsets, and the home bookkeeping. All of it is volatile
    (``power_up`` resets it); the attributes are read and written by ``MountModel``'s commands.

    Lock: none of its own. Callers hold ``MountModel._lock`` (the model's one lock) for every call
    and every attribute access. It reads the mode in effect, top speed and meridian setting from
    ``flash``, the latitude and sidereal time from ``site``; it never calls back into the model.
    """

    imperfection: Imperfection  # the mechanical errors between the axes and the sky (not volatile)
    t: float  # emulated seconds the physics has been advanced to
    pos: list[float]  # (primary, secondary) axis angles, degrees
    vel: list[float]  # their velocities, deg/s
    outer: bool  # the Dec axis through the pole (Hemisphere.side names the pointing state)
    slew: Slew | None
    braking_until: float  # emulated time a slew stopped by :Q# ends braking (GOTO state held till then)
    moves: list[float | None]  # manual moves per axis, deg/s of the axis (alt-az: of the sky)
    pulses: list[AxisPulse | None]
    speed: float  # the latched :Rn#/:Rv# speed, multiples of sidereal
    disturbed_t: float  # when a slew, move or untracked motion last ran (alt-az zenith rule)
    axis_speed: list[float | None]  # per-axis :Rvr#/:Rvd# speeds, overriding ``speed``
    tracking: bool
    track_rate: str  # one of state.TRACK_RATES
    custom_multiple: float
    track_error: int | None  # why tracking stopped by itself (the :GAT# code)
    target_ra: float
    target_dec: float
    offset_ra: float  # hours, from syncs
    offset_dec: float  # degrees, from syncs
    alignment_points: int
    homed: bool  # a home slew completed since power-up
    home_flag: bool  # 'H' latch of the after_home variant

    def __init__(self, *, clock: Clock, accel: float, flash: FlashSettings, site: ClockAndSite, t: float,
                 imperfection: Imperfection) -> None:
        """``accel``: each axis's acceleration, deg/s²; ``t``: the emulated seconds it powers up at;
        ``imperfection``: where the tube truly points relative to the axes (kept across power-ups)."""
        self.imperfection = imperfection
        self._clock = clock
        self._accel = accel
        self._flash = flash
        self._site = site
        self.t = t
        self.power_up()

    def power_up(self) -> None:
        """At home, still, not tracking, no target, offsets or alignment (flash settings are not here)."""
        self.pos = [HOME_P, HOME_S]
        self.vel = [0.0, 0.0]
        self.outer = False
        self.slew = None
        self.braking_until = self.t
        self.moves = [None, None]
        self.pulses = [None, None]
        self.speed = SLEW_SPEEDS[9]
        self.disturbed_t = self.t
        self.axis_speed = [None, None]
        self.tracking = False
        self.track_rate = "sidereal"
        self.custom_multiple = 1.0
        self.track_error = None
        self.target_ra = 0.0
        self.target_dec = 0.0
        self.offset_ra = 0.0
        self.offset_dec = 0.0
        self.alignment_points = 0
        self.homed = False
        self.home_flag = False

    def advance(self) -> float:
        """Integrate the physics up to the clock's present; the emulated seconds reached."""
        now = self._clock.seconds()
        while now - self.t > 1e-12:
            if self.at_rest():
                self.t = now  # nothing moves and nothing can start by itself: one jump
                break
            dt = min(now - self.t, SLEW_STEP_S if self.slew is not None else STEADY_STEP_S)
            for pulse in self.pulses:
                if pulse is not None and pulse.end - self.t > 1e-12:
                    dt = min(dt, pulse.end - self.t)
            if self.slew is None:
                dt = self._until_meridian(dt)
            self._step(dt)
            self.t += dt
            for axis, pulse in enumerate(self.pulses):
                if pulse is not None and pulse.end - self.t <= 1e-9:
                    self.pulses[axis] = None
        return self.t

    def at_rest(self) -> bool:
        return (
            self.slew is None
            and not self.tracking
            and self.vel[RA] == 0.0
            and self.vel[DEC] == 0.0
            and self.moves == [None, None]
            and self.pulses == [None, None]
        )

    def altaz(self) -> bool:
        return self._flash.mode_in_effect is MountMode.ALTAZ

    def hemisphere(self) -> Hemisphere:
        """The hemisphere of the site the mount holds now: a latitude set across the equator while
        powered changes what the axes point at from that instant (the axes stay where they are)."""
        return Hemisphere.of(self._site.latitude_deg)

    def _until_meridian(self, dt: float) -> float:
        """Shorten a steady tracking step so the meridian stop happens where it should."""
        if not self.tracking or self.altaz():  # an alt-az mount has no meridian limit
            return dt
        hemisphere = self.hemisphere()
        v = hemisphere.primary_rate(self.vel[RA])  # toward the meridian stop when positive
        past = hemisphere.past_meridian(self.pos[RA])
        stop = self.meridian_stop_deg()
        if v > 0.0 and self.vel[RA] == self.commanded(RA) and past <= stop < past + v * dt:
            return max((stop - past) / v + 1e-9, 1e-9)
        return dt

    def _step(self, dt: float) -> None:
        if self.slew is not None:
            self._slew_step(dt)
        elif self.altaz():
            # The sky motion EQ mode gives the axes directly, turned into azimuth/altitude motion;
            # guide pulses move nothing in alt-az (field notes §2.5, PT).
            sky_velocity = (self.commanded(RA, pulses=False), self.commanded(DEC, pulses=False))
            if not self.tracking or self.moves != [None, None]:
                self.disturbed_t = self.t + dt
            limits = (self._accel, self._flash.persist.max_speed * SIDEREAL_DEG_S)
            settled = self.t - self.disturbed_t >= SETTLED_S
            follow_sky(self.pos, self.vel, sky_velocity, self._site.latitude_deg, limits, dt, may_invert=settled)
        else:
            for axis in (RA, DEC):
                self.pos[axis], self.vel[axis] = ramp(
                    self.pos[axis], self.vel[axis], self.commanded(axis), self._accel, dt
                )
        self._note_side()
        if self.tracking and self.slew is None:
            self._check_tracking_limits()

    def _slew_step(self, dt: float) -> None:
        slew = self.slew
        assert slew is not None
        self.disturbed_t = self.t + dt + 3.0  # a slew ends braking onto the target
        vmax = self._flash.persist.max_speed * SIDEREAL_DEG_S
        t = self.t
        for axis in (RA, DEC):
            vt = slew.velocity(axis, t)
            if slew.done[axis]:
                self.pos[axis] = slew.target(axis, t + dt)
                self.vel[axis] = vt
                continue
            error = slew.target(axis, t) - self.pos[axis]
            if abs(error) <= SNAP_DEG and abs(self.vel[axis] - vt) <= self._accel * dt + 1e-9:
                slew.done[axis] = True
                self.pos[axis] = slew.target(axis, t + dt)
                self.vel[axis] = vt
                continue
            # Braking curve (never faster than it can stop), and never more than the remaining
            # error per step, so the sampled controller settles instead of ringing.
            speed = min(vmax, math.sqrt(2.0 * self._accel * abs(error)), abs(error) / dt)
            desired = max(-vmax, min(vmax, vt + math.copysign(speed, error)))
            self.pos[axis], self.vel[axis] = ramp(self.pos[axis], self.vel[axis], desired, self._accel, dt)
        if all(slew.done):
            self._arrive(slew)

    def _arrive(self, slew: Slew) -> None:
        self.slew = None
        self.outer = slew.outer
        if slew.kind == "goto":
            self.tracking = True  # GOTO arrival switches tracking on, at the selected rate
            self.track_error = None
        else:
            self.tracking = False
            self.vel = [0.0, 0.0]
            if slew.kind == "home":
                self.pos = [HOME_P, HOME_S]
                self.homed = True
                self.home_flag = True

    def start_slew(self, slew: Slew) -> None:
        """A GOTO, home or park slew takes over both axes from whatever drove them."""
        self.slew = slew
        self.braking_until = self.t  # the new slew takes over the braking axes
        self.moves = [None, None]
        self.pulses = [None, None]
        self.track_error = None  # a slew moves away from whatever stopped tracking

    def begin_braking(self) -> None:
        """A slew stopped by ``:Q#``: the mount stays in its GOTO state until both axes have braked
        to the speed they keep (tracking or rest) at the normal deceleration, exactly as ``ramp`` does."""
        keep = [0.0, 0.0] if self.altaz() else [self.commanded(RA), self.commanded(DEC)]
        excess = max(abs(self.vel[axis] - keep[axis]) for axis in (RA, DEC))
        self.braking_until = self.t + excess / self._accel

    def braking(self) -> bool:
        return self.t < self.braking_until - 1e-9

    def commanded(self, axis: int, pulses: bool = True) -> float:
        """Steady velocity an axis is driven at outside slews (mechanical deg/s; in alt-az mode the
        hour-angle and Dec speeds the pointing is to move at)."""
        move = self.moves[axis]
        pulse = self.pulses[axis] if pulses else None
        extra = (move or 0.0) + (pulse.velocity if pulse is not None else 0.0)
        if axis == DEC:
            return extra
        tracking = self._tracking_velocity() if self.tracking else 0.0
        if (move is not None or pulse is not None) and not self.tracking:
            # Moves and pulses are relative to the sky: the RA reading changes at the commanded
            # rate whether or not tracking is on (PYAM5 observation), so they ride on sidereal.
            tracking = SIDEREAL_DEG_S
        return self.ra_sign() * tracking + extra

    def _tracking_velocity(self) -> float:
        return {
            "sidereal": SIDEREAL_DEG_S,
            "solar": SOLAR_DEG_S,
            "lunar": LUNAR_DEG_S,
            "custom": self.custom_multiple * SIDEREAL_DEG_S,
        }[self.track_rate]

    def _check_tracking_limits(self) -> None:
        if self.altaz():
            if self.pos[DEC] > 90.0 + 1e-9:  # carried over the zenith: "altitude inverted"
                self.tracking = False
                self.track_error = 10
            elif self.below_horizon():
                self.tracking = False
                self.track_error = 5
            return
        if self.hemisphere().past_meridian(self.pos[RA]) > self.meridian_stop_deg():
            self.tracking = False
            self.track_error = 8
            return
        if self.below_horizon():
            self.tracking = False
            self.track_error = 5

    def meridian_stop_deg(self) -> float:
        """Degrees past the meridian (``Hemisphere.past_meridian``) at which tracking stops (field
        notes §5.3, ZWO v2.1 p.18)."""
        settings = self._flash.persist.meridian
        limit = float(settings.limit_degrees)
        if limit < 0.0:
            return limit
        return max(limit, 1.0) if settings.track_after else 1.0

    def _note_side(self) -> None:
        """Which side the Dec axis is on; exactly at the pole it stays the side it came from."""
        s = self.pos[DEC]
        if s < 90.0 - 1e-9 and s > -90.0 + 1e-9:
            self.outer = False
        elif s > 90.0 + 1e-9 or s < -90.0 - 1e-9:
            self.outer = True

    # ---------------------------------------------------------------- derived quantities

    def at_home_position(self) -> bool:
        return abs(self.pos[RA] - HOME_P) < AT_HOME_DEG and abs(self.pos[DEC] - HOME_S) < AT_HOME_DEG

    def side(self) -> sky.PierSide:
        """The ASCOM pointing state of the axes at the site's hemisphere."""
        return self.hemisphere().side(self.outer)

    def moving(self) -> bool:
        """A slew, manual move or pulse is under way (tracking alone does not count)."""
        return (
            self.slew is not None
            or any(m is not None for m in self.moves)
            or any(p is not None for p in self.pulses)
        )

    def dec_sign(self) -> float:
        """+1 when raising the secondary angle raises Dec, else -1 (``Hemisphere.dec_rate_sign``); in
        alt-az mode moves are sky motions (the alt-az controller turns them into axis motions), so +1."""
        if self.altaz():
            return 1.0
        return self.hemisphere().dec_rate_sign(self.outer)

    def ra_sign(self) -> float:
        """+1 when raising the primary angle raises the hour angle (north of the equator), -1 south
        of it; in alt-az mode RA speeds are sky motions, so +1."""
        if self.altaz():
            return 1.0
        return self.hemisphere().primary_rate(1.0)

    def raw_ha_dec(self) -> tuple[float, float]:
        if self.altaz():
            return axes_to_ha_dec_altaz(self.pos[RA], self.pos[DEC], self._site.latitude_deg)
        return self.hemisphere().ha_dec(self.pos[RA], self.pos[DEC])

    def true_ha_dec(self) -> tuple[float, float]:
        """(HA hours, Dec) the tube truly points at: ``raw_ha_dec`` moved by the mechanical errors between the
        axes and the sky (``imperfection.py``); a perfect mount's exactly."""
        ha, dec = self.raw_ha_dec()
        p, s = self.pos
        if self.imperfection.perfect:
            return ha, dec
        latitude = self._site.latitude_deg
        if self.altaz():
            alt, az = self.imperfection.altaz_sky(p, s)
            return sky.horizontal_to_equatorial(alt, az, latitude)
        # TPOINT's mechanical Dec is past ±90° exactly where raw_ha_dec folds it (state.axes_to_ha_dec).
        return self.imperfection.equatorial_sky(p, s, ha, dec, latitude, abs(s) > 90.0)

    def raw_altitude(self) -> float:
        ha, dec = self.raw_ha_dec()
        return sky.equatorial_to_horizontal(ha, dec, self._site.latitude_deg)[0]

    def below_horizon(self) -> bool:
        """Under the horizon by more than the firmware's tracking slack: on the equator home points at
        the pole, on it, and moves from there skim it (``TRACKING_HORIZON_SLACK_DEG``)."""
        return self.raw_altitude() < -TRACKING_HORIZON_SLACK_DEG

    def reported(self) -> tuple[float, float]:
        ha, dec = self.raw_ha_dec()
        raw_ra = sky.ra_from_hour_angle(self._site.lst(self.t), ha)
        ra = sky.wrap_hours_24(raw_ra + self.offset_ra)
        return ra, max(-90.0, min(90.0, dec + self.offset_dec))
