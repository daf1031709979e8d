"""Alt-az mode: the same two mechanical axes, stood upright, as azimuth and altitude.

After ``:AA#`` and a restart (field notes §2.8, §5.3) the primary axis is vertical: its angle is the
azimuth (from north through east) and the secondary angle is the altitude. The mechanical zero is
unchanged, so home (secondary 90°) points at the zenith. A secondary angle past 90° is the OTA
carried over the zenith: the altitude is "inverted" (the mount's ``e10``, field notes §4.1), and the
pointing is azimuth + 180°, altitude 180° - s.

How the mount moves in this mode (the field notes say nothing more, so this is the assumption):

- A GOTO chases the target's azimuth and altitude, both moving as the sky turns, with the same
  acceleration, top speed and braking-curve controller as an equatorial GOTO; it always ends with
  the altitude upright and takes the short way round in azimuth.
- Tracking and manual moves keep the equatorial meaning they have in EQ mode (tracking holds RA/Dec;
  ``:Me/:Mw/:Mn/:Ms#`` move relative to the sky): each step the controller turns the wanted
  hour-angle/Dec motion into the axis positions for the end of the step and drives both axes there
  together, within the acceleration. Near the zenith the azimuth cannot keep up (the keyhole): the
  altitude stays upright and the pointing lags, except when the mount has been tracking undisturbed
  (no move, slew or braking for ``SETTLED_S``) and the star needs the azimuth to turn faster than
  its top speed, i.e. it crosses (almost) through the zenith: then the altitude is carried over
  the top, and tracking stops with ``e10``.
- Guide pulses are accepted but move nothing (PT: 200-2000 ms pulses gave no measurable movement in
  alt-az mode, field notes §2.5).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

from .. import sky
from ..sky import SIDEREAL_DEG_S
from ..zwo.wire_values import MountMode
from .clocksite import ClockAndSite
from .flash import FlashSettings
from .state import DEC, RA, Slew, ramp

#: Undisturbed tracking time after which a zenith transit takes the altitude over the top (mount s).
SETTLED_S = 10.0
#: Half-width of the time window used to differentiate a moving alt-az GOTO target.
_DIFF_S = 0.25


def wrap_180(degrees: float) -> float:
    """``degrees`` folded into [-180, 180)."""
    return (degrees + 180.0) % 360.0 - 180.0


def axes_to_alt_az(p: float, s: float) -> tuple[float, float]:
    """(altitude, azimuth) the mechanical axes point at; s > 90 is the altitude carried over the top."""
    if s <= 90.0:
        return s, sky.wrap_degrees_360(p)
    return 180.0 - s, sky.wrap_degrees_360(p + 180.0)


def axes_to_ha_dec_altaz(p: float, s: float, latitude: float) -> tuple[float, float]:
    """(HA hours, Dec degrees) of an alt-az mount's axes at ``latitude``."""
    alt, az = axes_to_alt_az(p, s)
    return sky.horizontal_to_equatorial(alt, az, latitude)


def nearest_axes(alt: float, az: float, p_ref: float, s_ref: float) -> tuple[float, float]:
    """The mechanical (p, s) for (alt, az) closest to the axes at (p_ref, s_ref): upright or over the top."""
    upright = (p_ref + wrap_180(az - p_ref), alt)
    over = (p_ref + wrap_180(az + 180.0 - p_ref), 180.0 - alt)

    def distance(axes: tuple[float, float]) -> float:
        return math.hypot(axes[0] - p_ref, axes[1] - s_ref)

    return upright if distance(upright) <= distance(over) else over


@dataclass
class AltAzSlew(Slew):
    """A GOTO in alt-az mode: ``p0``/``p_rate``/``s`` describe the target's hour angle (degrees) and
    Dec as for an equatorial GOTO; the axis targets are that point's azimuth and altitude."""

    latitude: float = 0.0
    az_ref: float = 0.0  # the unwrapped azimuth-axis angle the target starts at (keeps it continuous)

    def _alt_az(self, t: float) -> tuple[float, float]:
        ha_deg = self.p0 + self.p_rate * (t - self.t0)
        alt, az = sky.equatorial_to_horizontal(ha_deg / 15.0, self.s, self.latitude)
        return alt, self.az_ref + wrap_180(az - self.az_ref)

    def target(self, axis: int, t: float) -> float:
        alt, az = self._alt_az(t)
        return az if axis == RA else alt

    def velocity(self, axis: int, t: float = 0.0) -> float:
        return (self.target(axis, t + _DIFF_S) - self.target(axis, t - _DIFF_S)) / (2.0 * _DIFF_S)


def follow_sky(
    pos: list[float], vel: list[float], sky_velocity: tuple[float, float], latitude: float,
    limits: tuple[float, float], dt: float, may_invert: bool = False,
) -> None:
    """One step of tracking/moves in alt-az: drive both axes (in place) toward where the pointing,
    moved by ``sky_velocity`` (hour angle, Dec; deg/s), will be after ``dt``. ``limits`` are the axes'
    (acceleration, top speed). With ``may_invert`` (settled tracking) an azimuth turn faster than the
    top speed is made by carrying the altitude over the top instead."""
    accel, vmax = limits
    v_ha_deg, v_dec = sky_velocity
    ha, dec = axes_to_ha_dec_altaz(pos[RA], pos[DEC], latitude)
    ha_deg, dec = ha * 15.0 + v_ha_deg * dt, dec + v_dec * dt
    if dec > 90.0:  # a move carried past the pole: same point, HA turned by 12 h
        ha_deg, dec = ha_deg + 180.0, 180.0 - dec
    elif dec < -90.0:
        ha_deg, dec = ha_deg + 180.0, -180.0 - dec
    alt, az = sky.equatorial_to_horizontal(ha_deg / 15.0, dec, latitude)
    goal = (pos[RA] + wrap_180(az - pos[RA]), alt)
    upright = pos[DEC] <= 90.0
    if not upright or (may_invert and abs(goal[RA] - pos[RA]) > vmax * dt):
        goal = nearest_axes(alt, az, pos[RA], pos[DEC])  # stays over the top once there
        upright = False
    wanted = [(goal[axis] - pos[axis]) / dt for axis in (RA, DEC)]
    # Coordinated: when one axis cannot reach its speed within the step, both change speed in the
    # same proportion, so a move starts and stops along its sky path instead of curving off it.
    change = max(abs(wanted[RA] - vel[RA]), abs(wanted[DEC] - vel[DEC]))
    scale = min(1.0, accel * dt / change) if change > 0.0 else 1.0
    for axis in (RA, DEC):
        goal_speed = vel[axis] + (wanted[axis] - vel[axis]) * scale
        pos[axis], vel[axis] = ramp(pos[axis], vel[axis], goal_speed, accel, dt)
    if upright and pos[DEC] > 90.0:  # the upright altitude stops at the zenith (no overshoot over the top)
        pos[DEC], vel[DEC] = 90.0, 0.0


class Axes(Protocol):
    """What the rules read of the mechanics (``physics.Mechanics``, declared here so this module,
    which the mechanics import, does not import them back)."""

    t: float
    pos: list[float]


class AltAzRules:
    """The alt-az parts of the model's commands. Stateless: it reads the axes, the site and the mode
    in effect. Lock: none; callers hold ``MountModel._lock`` (the model's one lock)."""

    def __init__(self, *, mechanics: Axes, site: ClockAndSite, flash: FlashSettings) -> None:
        self._mechanics = mechanics
        self._site = site
        self._flash = flash

    def goto(self, raw_ha: float, raw_dec: float) -> AltAzSlew:
        """An alt-az GOTO: no pier side; the azimuth axis takes the short way round."""
        latitude, p = self._site.latitude_deg, self._mechanics.pos[RA]
        _, az = sky.equatorial_to_horizontal(raw_ha, raw_dec, latitude)
        az_ref = p + ((az - p + 180.0) % 360.0 - 180.0)
        return AltAzSlew("goto", self._mechanics.t, raw_ha * 15.0, SIDEREAL_DEG_S, raw_dec, False,
                         latitude=latitude, az_ref=az_ref)

    def tracking_refusal(self) -> int | None:
        """Why alt-az tracking cannot start: 7 time and site not set (field notes §2.4, §4.1), 10 the
        altitude carried over the zenith; None in EQ mode or when it can."""
        if self._flash.mode_in_effect is not MountMode.ALTAZ:
            return None
        if not self._site.initialized():
            return 7
        if self._mechanics.pos[DEC] > 90.0 + 1e-9:
            return 10
        return None
