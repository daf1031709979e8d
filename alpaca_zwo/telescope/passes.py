"""A satellite's passes over the site, as far as the mount may follow them (issue 41).

A pass is the time the satellite stands above the geometric horizon (rise, highest point, set); the part
the mount may follow is where the one limit check of a GoTo (``pointing.goto_blocked``: the horizon
profile, the minimum altitude, the mount's horizon and its stored altitude limits) lets it be. An
equatorial mount must keep one pier side through that part (a flip takes a minute and loses the
satellite): the plan names the side, and where no side reaches the whole part (a pass that crosses the
meridian beyond what the side may track past it, or the lower meridian under the pole), the moment the
mount must give up. An alt-az mount has no sides; near the zenith its azimuth axis must turn faster than
the mount can (the keyhole): the plan names how fast it would have to turn.

Times are UTC (aware datetimes); the page shows them in the site's zone.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime, timedelta

from .. import sky
from ..config.settings import Settings
from .orbits import SatellitePlace, Tle, place
from .pointing import MountAltitudeLimits, goto_blocked

#: The coarse step of the search for rises (a pass of the ISS lasts minutes; a grazing one a minute).
SCAN_STEP_S = 20.0
#: The step inside a pass, where the allowed part and the sides are judged (horizon profiles have corners).
PASS_STEP_S = 2.0
#: How finely the crossings are found.
PRECISION_S = 0.1
#: Longer than any pass of a low satellite (the ISS: 11 minutes horizon to horizon).
MAX_PASS_S = 1800.0
#: The AM5's top speed, 1440× sidereal (6°/s; 720× in heavy-duty mode): field notes §2.3.
TOP_SPEED_DEG_S = 1440.0 * sky.SIDEREAL_DEG_S


@dataclass(frozen=True)
class SidePlan:
    """The pier side an equatorial mount follows the pass on, and where it must stop if the side cannot
    reach the whole allowed part (``until`` None: it can)."""

    side: sky.PierSide
    until: datetime | None
    why: str | None


@dataclass(frozen=True)
class Pass:
    """One pass and the part of it the mount may follow (``enters``..``leaves``, its first allowed part)."""

    name: str
    rise: datetime
    culmination: datetime
    set: datetime
    max_altitude: float
    enters: datetime
    leaves: datetime
    enter_place: SatellitePlace
    side: SidePlan
    windows: tuple[tuple[datetime, datetime], ...]  # every allowed part, in order
    max_azimuth_rate: float  # deg/s over the followed part: an alt-az mount's azimuth axis must turn this fast

    @property
    def keyhole(self) -> bool:
        """True when an alt-az mount cannot turn its azimuth as fast as the pass needs near the zenith."""
        return self.max_azimuth_rate > TOP_SPEED_DEG_S


@dataclass(frozen=True)
class AllowedSky:
    """What the planning reads: the site and limits (``settings``), the mount's stored altitude limits,
    and the meridian rule in force (``flip_line_deg``, ``sky.flip_line_deg``)."""

    settings: Settings
    mount_limits: MountAltitudeLimits | None
    flip_line_deg: float = 0.0

    def place(self, tle: Tle, when: datetime) -> SatellitePlace:
        site = self.settings.site
        return place(tle, site.latitude, site.longitude, site.elevation, when)

    def allowed(self, spot: SatellitePlace) -> bool:
        """The one GoTo limit check at the satellite's place (``pointing.goto_blocked``)."""
        lst = spot.ra_hours + spot.ha_hours
        return goto_blocked(self.settings, self.mount_limits, lst, spot.ra_hours, spot.dec_deg) is None


def _crossing(test: Callable[[datetime], bool], before: datetime, after: datetime) -> datetime:
    """The first instant in (before, after] where ``test`` turns to what it is at ``after`` (bisection)."""
    while (after - before).total_seconds() > PRECISION_S:
        middle = before + (after - before) / 2
        if test(middle) == test(after):
            after = middle
        else:
            before = middle
    return after


Span = tuple[datetime, datetime]


def _runs(test: Callable[[datetime], bool], start: datetime, end: datetime, step_s: float) -> list[Span]:
    """The intervals of [start, end] where ``test`` holds, their edges found to :data:`PRECISION_S`."""
    runs: list[Span] = []
    step = timedelta(seconds=step_s)
    opened: datetime | None = start if test(start) else None
    previous, t = start, start + step
    while previous < end:
        t = min(t, end)
        now = test(t)
        if now and opened is None:
            opened = _crossing(test, previous, t)
        elif not now and opened is not None:
            runs.append((opened, _crossing(lambda x: not test(x), previous, t)))
            opened = None
        previous, t = t, t + step
    if opened is not None:
        runs.append((opened, end))
    return runs


def _highest(altitude: Callable[[datetime], float], start: datetime, end: datetime) -> datetime:
    """The instant of the highest altitude in [start, end] (a pass has one maximum): golden-section search."""
    ratio = (math.sqrt(5.0) - 1.0) / 2.0
    a, b = start, end
    while (b - a).total_seconds() > PRECISION_S:
        span = b - a
        c, d = b - span * ratio, a + span * ratio
        if altitude(c) < altitude(d):
            a = c
        else:
            b = d
    return a + (b - a) / 2


def _side_plan(spots: list[SatellitePlace], flip_line_deg: float) -> SidePlan:
    """The side that follows the most of the allowed part from its start (module docstring).

    pierWest (looking east) reaches hour angles from -12 h up to the flip line; pierEast from
    ``sky.FLIP_ZONE_DEG`` before the meridian to +12 h. Both reach the whole part: the side the mount's
    own GOTO rule gives at the entry point, so the slew there lands on it.
    """
    def reach(side: sky.PierSide) -> int:
        for i, spot in enumerate(spots):
            ha_deg = sky.wrap_hours_12(spot.ha_hours) * 15.0
            inside = ha_deg < flip_line_deg if side is sky.PierSide.WEST else ha_deg >= -sky.FLIP_ZONE_DEG
            if not inside:
                return i
        return len(spots)

    entry = sky.goto_pier_side(spots[0].ha_hours, sky.PierSide.UNKNOWN, max(-15.0, min(15.0, flip_line_deg)))
    other = sky.PierSide.EAST if entry is sky.PierSide.WEST else sky.PierSide.WEST
    best = max((entry, other), key=reach)  # max keeps the first of equals: the entry's side
    reached = reach(best)
    if reached == len(spots):
        return SidePlan(best, None, None)
    why = ("it passes under the pole (the lower meridian), where neither side follows on"
           if abs(sky.wrap_hours_12(spots[reached].ha_hours)) > 6.0 else
           "it crosses the meridian farther than one side may follow past it")
    return SidePlan(best, spots[reached].when, why)


def _azimuth_rate(spots: list[SatellitePlace]) -> float:
    rates = [abs(sky.wrap_hours_12((b.azimuth - a.azimuth) / 15.0) * 15.0) / (b.when - a.when).total_seconds()
             for a, b in itertools.pairwise(spots) if b.when > a.when]
    return max(rates, default=0.0)


def _plan(tle: Tle, where: AllowedSky, rise: datetime, set_: datetime) -> Pass | None:
    """The pass between ``rise`` and ``set_``, or None when no part of it is allowed."""
    windows = _runs(lambda t: where.allowed(where.place(tle, t)), rise, set_, PASS_STEP_S)
    if not windows:
        return None
    enters, leaves = windows[0]
    steps = max(1, math.ceil((leaves - enters).total_seconds() / PASS_STEP_S))
    spots = [where.place(tle, enters + (leaves - enters) * (i / steps)) for i in range(steps + 1)]
    top = _highest(lambda t: where.place(tle, t).altitude, rise, set_)
    return Pass(tle.name, rise, top, set_, where.place(tle, top).altitude, enters, leaves, spots[0],
                _side_plan(spots, where.flip_line_deg), tuple(windows), _azimuth_rate(spots))


def passes(tle: Tle, where: AllowedSky, start: datetime, hours: float = 24.0, limit: int = 10) -> list[Pass]:
    """The passes of ``tle``'s satellite from ``start`` over the next ``hours`` that have an allowed part,
    at most ``limit``. A pass under way at ``start`` counts from ``start``."""
    end = start + timedelta(hours=hours)
    found: list[Pass] = []
    scan_end = end + timedelta(seconds=MAX_PASS_S)  # a pass rising before ``end`` is planned to its set
    for rise, set_ in _runs(lambda t: where.place(tle, t).altitude > 0.0, start, scan_end, SCAN_STEP_S):
        if rise >= end:
            break
        planned = _plan(tle, where, rise, set_)
        if planned is not None:
            found.append(planned)
            if len(found) >= limit:
                break
    return found
