"""The model's mechanics: lazy, exact integration of the two axes (slews, moves, pulses, tracking).

Every public call of the model first advances the physics to ``clock.seconds()`` in bounded steps,
so the result depends only on the sequence of clock readings; each step integrates a trapezoidal
velocity profile exactly, and GOTOs use a sampled braking-curve controller (see ``model``).
"""

from __future__ import annotations

import math

from .. import sky
from ..sky import LUNAR_DEG_S, SIDEREAL_DEG_S, SOLAR_DEG_S
from ..zwo.wire_values import MountMode
from .altaz import SETTLED_S, axes_to_ha_dec_altaz, follow_sky
from .state import (
    AT_HOME_DEG,
    DEC,
    HOME_P,
    HOME_S,
    RA,
    SLEW_STEP_S,
    SNAP_DEG,
    STEADY_STEP_S,
    ModelBase,
    Slew,
    axes_to_ha_dec,
    ramp,
)


class Mechanics(ModelBase):
    """The axes and their motion; callers hold the lock."""

    def _advance(self) -> None:
        """Integrate the physics up to the clock's present (callers hold the lock)."""
        now = self._clock.seconds()
        while now - self._t > 1e-12:
            if self._at_rest():
                self._t = now  # nothing moves and nothing can start by itself: one jump
                break
            dt = min(now - self._t, SLEW_STEP_S if self._slew is not None else STEADY_STEP_S)
            for pulse in self._pulses:
                if pulse is not None and pulse.end - self._t > 1e-12:
                    dt = min(dt, pulse.end - self._t)
            if self._slew is None:
                dt = self._until_meridian(dt)
            self._step(dt)
            self._t += dt
            for axis, pulse in enumerate(self._pulses):
                if pulse is not None and pulse.end - self._t <= 1e-9:
                    self._pulses[axis] = None

    def _at_rest(self) -> bool:
        return (
            self._slew is None
            and not self._tracking
            and self._vel[RA] == 0.0
            and self._vel[DEC] == 0.0
            and self._moves == [None, None]
            and self._pulses == [None, None]
        )

    def _altaz(self) -> bool:
        return self._mode is MountMode.ALTAZ

    def _until_meridian(self, dt: float) -> float:
        """Shorten a steady tracking step so the meridian stop happens where it should."""
        if not self._tracking or self._altaz():  # an alt-az mount has no meridian limit
            return dt
        v = self._vel[RA]
        p = self._pos[RA]
        stop = self._meridian_stop_deg()
        if v > 0.0 and v == self._commanded(RA) and p <= stop < p + v * dt:
            return max((stop - p) / v + 1e-9, 1e-9)
        return dt

    def _step(self, dt: float) -> None:
        if self._slew is not None:
            self._slew_step(dt)
        elif self._altaz():
            # The sky motion EQ mode gives the axes directly, turned into azimuth/altitude motion;
            # guide pulses move nothing in alt-az (field notes §2.5, PT).
            sky_velocity = (self._commanded(RA, pulses=False), self._commanded(DEC, pulses=False))
            if not self._tracking or self._moves != [None, None]:
                self._disturbed_t = self._t + dt
            limits = (self._accel, self._persist.max_speed * SIDEREAL_DEG_S)
            settled = self._t - self._disturbed_t >= SETTLED_S
            follow_sky(self._pos, self._vel, sky_velocity, self._latitude, limits, dt, may_invert=settled)
        else:
            for axis in (RA, DEC):
                self._pos[axis], self._vel[axis] = ramp(
                    self._pos[axis], self._vel[axis], self._commanded(axis), self._accel, dt
                )
        self._note_side()
        if self._tracking and self._slew is None:
            self._check_tracking_limits()

    def _slew_step(self, dt: float) -> None:
        slew = self._slew
        assert slew is not None
        self._disturbed_t = self._t + dt + 3.0  # a slew ends braking onto the target
        vmax = self._persist.max_speed * SIDEREAL_DEG_S
        t = self._t
        for axis in (RA, DEC):
            vt = slew.velocity(axis, t)
            if slew.done[axis]:
                self._pos[axis] = slew.target(axis, t + dt)
                self._vel[axis] = vt
                continue
            error = slew.target(axis, t) - self._pos[axis]
            if abs(error) <= SNAP_DEG and abs(self._vel[axis] - vt) <= self._accel * dt + 1e-9:
                slew.done[axis] = True
                self._pos[axis] = slew.target(axis, t + dt)
                self._vel[axis] = vt
                continue
            # Braking curve (never faster than it can stop), and never more than the remaining
            # error per step, so the sampled controller settles instead of ringing.
            speed = min(vmax, math.sqrt(2.0 * self._accel * abs(error)), abs(error) / dt)
            desired = max(-vmax, min(vmax, vt + math.copysign(speed, error)))
            self._pos[axis], self._vel[axis] = ramp(self._pos[axis], self._vel[axis], desired, self._accel, dt)
        if all(slew.done):
            self._arrive(slew)

    def _arrive(self, slew: Slew) -> None:
        self._slew = None
        self._last_side = slew.side
        if slew.kind == "goto":
            self._tracking = True  # GOTO arrival switches tracking on, at the selected rate
            self._track_error = None
        else:
            self._tracking = False
            self._vel = [0.0, 0.0]
            if slew.kind == "home":
                self._pos = [HOME_P, HOME_S]
                self._homed = True
                self._home_flag = True

    def _begin_braking(self) -> None:
        """A slew stopped by ``:Q#``: the mount stays in its GOTO state until both axes have braked
        to the speed they keep (tracking or rest) at the normal deceleration, exactly as ``ramp`` does."""
        keep = [0.0, 0.0] if self._altaz() else [self._commanded(RA), self._commanded(DEC)]
        excess = max(abs(self._vel[axis] - keep[axis]) for axis in (RA, DEC))
        self._braking_until = self._t + excess / self._accel

    def _braking(self) -> bool:
        return self._t < self._braking_until - 1e-9

    def _commanded(self, axis: int, pulses: bool = True) -> float:
        """Steady velocity an axis is driven at outside slews (mechanical deg/s; in alt-az mode the
        hour-angle and Dec speeds the pointing is to move at)."""
        move = self._moves[axis]
        pulse = self._pulses[axis] if pulses else None
        extra = (move or 0.0) + (pulse.velocity if pulse is not None else 0.0)
        if axis == DEC:
            return extra
        tracking = self._tracking_velocity() if self._tracking else 0.0
        if (move is not None or pulse is not None) and not self._tracking:
            # Moves and pulses are relative to the sky: the RA reading changes at the commanded
            # rate whether or not tracking is on (PYAM5 observation), so they ride on sidereal.
            return SIDEREAL_DEG_S + extra
        return tracking + extra

    def _tracking_velocity(self) -> float:
        return {
            "sidereal": SIDEREAL_DEG_S,
            "solar": SOLAR_DEG_S,
            "lunar": LUNAR_DEG_S,
            "custom": self._custom_multiple * SIDEREAL_DEG_S,
        }[self._track_rate]

    def _check_tracking_limits(self) -> None:
        if self._altaz():
            if self._pos[DEC] > 90.0 + 1e-9:  # carried over the zenith: "altitude inverted"
                self._tracking = False
                self._track_error = 10
            elif self._raw_altitude() < 0.0:
                self._tracking = False
                self._track_error = 5
            return
        if self._pos[RA] > self._meridian_stop_deg():
            self._tracking = False
            self._track_error = 8
            return
        if self._raw_altitude() < 0.0:
            self._tracking = False
            self._track_error = 5

    def _meridian_stop_deg(self) -> float:
        """Primary-axis angle past which tracking stops (field notes §5.3, ZWO v2.1 p.18)."""
        settings = self._persist.meridian
        limit = float(settings.limit_degrees)
        if limit < 0.0:
            return limit
        return max(limit, 1.0) if settings.track_after else 1.0

    #: Which reading of the evidence the GOTO side follows (docs/meridian.md): False (the default,
    #: the assumption) = a GOTO flips only past the track-past limit; True = at the meridian itself
    #: (ASIAIR users' description), a negative limit still moving the line before the meridian.
    goto_flip_at_meridian = False

    def _goto_limit_deg(self) -> float:
        """The limit handed to ``sky.goto_pier_side``: how far past the meridian the west side may go."""
        settings = self._persist.meridian
        limit = float(settings.limit_degrees)
        if self.goto_flip_at_meridian:
            return min(limit, 0.0)
        return limit if limit < 0.0 or settings.track_after else 0.0

    def _note_side(self) -> None:
        s = self._pos[DEC]
        if s < 90.0 - 1e-9 and s > -90.0 + 1e-9:
            self._last_side = sky.PierSide.WEST
        elif s > 90.0 + 1e-9 or s < -90.0 - 1e-9:
            self._last_side = sky.PierSide.EAST

    # ---------------------------------------------------------------- derived quantities

    def _at_home_position(self) -> bool:
        return abs(self._pos[RA] - HOME_P) < AT_HOME_DEG and abs(self._pos[DEC] - HOME_S) < AT_HOME_DEG

    def _side(self) -> sky.PierSide:
        return self._last_side

    def _moving(self) -> bool:
        """A slew, manual move or pulse is under way (tracking alone does not count)."""
        return (
            self._slew is not None
            or any(m is not None for m in self._moves)
            or any(p is not None for p in self._pulses)
        )

    def _raw_ha_dec(self) -> tuple[float, float]:
        if self._altaz():
            return axes_to_ha_dec_altaz(self._pos[RA], self._pos[DEC], self._latitude)
        return axes_to_ha_dec(self._pos[RA], self._pos[DEC])

    def _raw_altitude(self) -> float:
        ha, dec = self._raw_ha_dec()
        return sky.equatorial_to_horizontal(ha, dec, self._latitude)[0]

    def _reported(self) -> tuple[float, float]:
        ha, dec = self._raw_ha_dec()
        raw_ra = sky.ra_from_hour_angle(self._lst(), ha)
        ra = sky.wrap_hours_24(raw_ra + self._offset_ra)
        return ra, max(-90.0, min(90.0, dec + self._offset_dec))
