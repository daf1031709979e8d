"""The pieces of an emulated mount's state: constants, what it keeps in flash, slews, pulses, axis kinematics.

Shared by :class:`~alpaca_zwo.emulator.model.MountModel` and its parts (``flash.FlashSettings``,
``clocksite.ClockAndSite``, ``physics.Mechanics``, ``altaz.AltAzRules``); each part owns its own
state, so this module holds only values and pure functions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import datetime

from .. import sky
from ..zwo.wire_values import MeridianSettings, MountMode

# --------------------------------------------------------------------------------------------
# Constants
# --------------------------------------------------------------------------------------------


#: The site stored in every mount at the factory (Suzhou): +31°15'41", 120°43'11" E.
FACTORY_LATITUDE = 31.0 + 15.0 / 60.0 + 41.0 / 3600.0
FACTORY_LONGITUDE = 120.0 + 43.0 / 60.0 + 11.0 / 3600.0

#: The mechanical home: counterweight down, the OTA along the polar axis. North of the equator that is
#: HA -6 h at Dec +90, the convention real mounts report at home (RA = LST + 6 h); south of it the
#: same axes read HA +6 h at Dec -90 (``Hemisphere``).
HOME_P = -90.0
HOME_S = 90.0
#: Factory park: counterweight down (p = home), OTA horizontal: due east in the north (Dec 0 at
#: HA -6 h), due west in the south (Dec 0 at HA +6 h). A mechanical position, like home.
PARK_P = -90.0
PARK_S = 0.0

ACCEL_DEG_S2 = 3.0
SLEW_STEP_S = 0.02  # sampled-controller period during GOTO/home/park slews
STEADY_STEP_S = 1.0  # exact integration allows long steps otherwise; bounds horizon-check lag
SNAP_DEG = 0.3 / 3600.0  # a slewing axis this close to its target locks onto it
AT_HOME_DEG = 1e-6
HORIZON_TOLERANCE_DEG = 1e-6  # rounding of an altitude computed as exactly 0 (the pole, on the equator)
#: Tracking stops (and ``:Te#`` is refused, e5) only this far under the horizon: on the equator home is the
#: pole on the horizon, and a Dec move from there follows an hour circle that skims it, dipping by the
#: move times the RA axis' turn from HA ±6 h (docs/southern.md, assumption 13: the firmware's slack is
#: not documented). The server's manual-move margin along a limit is the same (motion/limits.py).
TRACKING_HORIZON_SLACK_DEG = 0.5
PULSE_MAX_MS = 3000
SYNC_MAX_DEG = 20.0
SYNC_POLE_DEG = 85.0
EPOCH_LOCAL = datetime(2000, 1, 1)  # the mount's clock at power-on: 01/01/00 00:00:00

TRACK_RATES = ("sidereal", "solar", "lunar", "custom")
RA, DEC = 0, 1


# --------------------------------------------------------------------------------------------
# Internal state pieces
# --------------------------------------------------------------------------------------------


@dataclass
class Persistent:
    """What the mount keeps in flash across power cycles (field notes §5.3)."""

    limits_enabled: bool = False
    upper_limit: int = 90
    lower_limit: int = 0
    max_speed: int = 1440  # heavy duty: 720
    mode: MountMode = MountMode.EQUATORIAL  # takes effect at the next power-up
    parked: bool = False  # the :hP# latch, cleared only by :Spu#
    custom_park: tuple[float, float] | None = None  # (p, s) stored by :Sp01#
    buzzer: int = 1
    meridian: MeridianSettings = field(default_factory=MeridianSettings)
    guide_rate: float = 0.5
    ble_suffix: str = "123456"  # takes effect at the next power-up
    ble_paired: str | None = None
    latitude: float = FACTORY_LATITUDE
    longitude: float = FACTORY_LONGITUDE  # east positive; the mount shows it east-negative


@dataclass
class Slew:
    """A GOTO, home or park slew: per-axis targets, the primary one possibly moving."""

    kind: str  # goto | home | park
    t0: float  # emulated seconds at the start
    p0: float  # primary target at t0
    p_rate: float  # primary target velocity (sidereal for a GOTO: the target's HA grows)
    s: float
    outer: bool = False  # the Dec axis through the pole at arrival (ambiguous at the pole itself)
    done: list[bool] = field(default_factory=lambda: [False, False])

    def target(self, axis: int, t: float) -> float:
        return self.p0 + self.p_rate * (t - self.t0) if axis == RA else self.s

    def velocity(self, axis: int, t: float = 0.0) -> float:
        """The target's speed on ``axis`` at ``t`` (constant here; an alt-az target's is not)."""
        return self.p_rate if axis == RA else 0.0


@dataclass
class AxisPulse:
    velocity: float  # mechanical deg/s added to the axis
    end: float  # emulated seconds


def ramp(pos: float, vel: float, target: float, accel: float, dt: float) -> tuple[float, float]:
    """Exact position and velocity after ``dt`` when accelerating at ``accel`` toward ``target``."""
    dv = target - vel
    t1 = abs(dv) / accel
    if t1 >= dt:
        new_vel = vel + math.copysign(accel * dt, dv)
        return pos + (vel + new_vel) * 0.5 * dt, new_vel
    return pos + (vel + target) * 0.5 * t1 + target * (dt - t1), target


def axes_to_ha_dec(p: float, s: float) -> tuple[float, float]:
    """(HA hours, Dec degrees) the mechanical axes of a northern mount point at, before any alignment
    offset (``Hemisphere.ha_dec`` for either hemisphere)."""
    if -90.0 <= s <= 90.0:
        return sky.wrap_hours_12(p / 15.0), s
    dec = 180.0 - s if s > 90.0 else -180.0 - s
    return sky.wrap_hours_12(p / 15.0 + 12.0), dec


def wrap_primary(p: float) -> float:
    """A primary-axis angle brought into [-270, 90): within half a turn of counterweight down (-90),
    the range the RA axis turns in (it never turns the counterweight over the top)."""
    return (p + 270.0) % 360.0 - 270.0


@dataclass(frozen=True)
class Hemisphere:
    """How the mount's axes point at the sky: the one place the site's hemisphere enters the mechanics.

    South of the equator the mount is the same machine turned to face the south celestial pole: the
    polar axis points at it and the whole mount is rotated half a turn about the vertical. The axes
    keep their mechanical meaning (home is still counterweight down with the OTA along the polar
    axis, now at Dec -90; the factory park still points the OTA at the horizon, now due west), and
    the sky they point at is the north's mirrored through the celestial equator's plane: HA and Dec
    change sign. So the RA axis turns the other way to track (OnStepX reverses its RA motor south of
    the equator, docs/southern.md), and the mechanical side with the Dec axis inside ±90° (pierWest,
    looking east, in the north) looks west in the south: pierEast, ASCOM's pointing state.
    Everything the emulator derives from the axes goes through here; the equator counts as north.
    """

    sign: float  # +1 north of the equator (and on it), -1 south of it

    @staticmethod
    def of(latitude_deg: float) -> Hemisphere:
        return NORTH if latitude_deg >= 0.0 else SOUTH

    def ha_dec(self, p: float, s: float) -> tuple[float, float]:
        """(HA hours, Dec degrees) the axes point at, before any alignment offset."""
        return axes_to_ha_dec(self.sign * p, self.sign * s)

    def axes(self, ha_hours: float, dec: float, side: sky.PierSide) -> tuple[float, float]:
        """The axes (p, s) that point at (HA, Dec) in the pointing state ``side`` (WEST or EAST)."""
        if self.outer(side):
            p, s = self.sign * (ha_hours - 12.0) * 15.0, 180.0 - self.sign * dec
        else:
            p, s = self.sign * ha_hours * 15.0, self.sign * dec
        return wrap_primary(p), s

    def outer(self, side: sky.PierSide) -> bool:
        """Whether ``side`` has the Dec axis through the pole (mechanical Dec beyond ±90°): pierEast in
        the north, pierWest in the south."""
        return (side is sky.PierSide.EAST) == (self.sign > 0.0)

    def side(self, outer: bool) -> sky.PierSide:
        """The ASCOM pointing state of the axes with the Dec axis inside (False) or through the pole."""
        return sky.PierSide.EAST if outer == (self.sign > 0.0) else sky.PierSide.WEST

    def past_meridian(self, p: float) -> float:
        """Degrees the counterweight has turned past horizontal the way tracking turns it (the
        meridian, or the lower meridian on the other side): negative while it is still below."""
        return self.sign * (p + 90.0) - 90.0

    def primary_rate(self, ha_rate: float) -> float:
        """The primary axis' speed (deg/s) that moves the pointing's hour angle at ``ha_rate``."""
        return self.sign * ha_rate

    def dec_rate_sign(self, outer: bool) -> float:
        """+1 when turning the secondary angle up raises Dec on that side, else -1."""
        return -self.sign if outer else self.sign


NORTH = Hemisphere(1.0)
SOUTH = Hemisphere(-1.0)
