"""A satellite's passes over the site, as far as the mount may follow them (issue 41).

A pass is the time the satellite stands above the geometric horizon (rise, highest point, set); the part
the mount may follow is where the one limit check of a GoTo (``pointing.goto_blocked``: the horizon
profile, the minimum altitude, the mount's horizon and its stored altitude limits) lets it be. An
equatorial mount follows on the pier side its GOTO to the entry point lands on; where that side cannot
reach the whole part (a pass that crosses the meridian beyond what the side may track past it, or the
lower meridian under the pole), the plan ends the first leg there and, when enough of the pass is left,
plans a meridian flip: a GOTO to where the satellite will be once the flip is done (its time predicted
conservatively from the mount's top speed and acceleration, plus a margin), and a second leg on the
other side from there (:class:`FlipLeg`). When no flip is worth it, the plan says where the follow ends
and why. An alt-az mount has no sides; near the zenith its azimuth axis must turn faster than the mount
can (the keyhole): the plan names how fast it would have to turn.

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
from ..motion.kinds import DECELERATION_DEG_S2
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
#: Time added to the predicted flip: braking out of the follow (under half a second), the mount's status
#: flags showing the GOTO over (``kinds.STATUS_LAG_S``), and slack for a slew slower than predicted.
FLIP_MARGIN_S = 5.0
#: A second leg shorter than this is not worth a flip: the mount would arrive, re-acquire and stop.
MIN_SECOND_LEG_S = 20.0


@dataclass(frozen=True)
class FlipLeg:
    """A planned meridian flip mid-pass and the leg after it: at ``flip_at`` the first leg ends and a GOTO
    flips the mount to ``side``, aimed at where the satellite will be at ``resumes`` (the predicted flip,
    ``FLIP_MARGIN_S`` included); the mount waits there and follows again until ``until`` (None: to the end
    of the allowed part; else ``why`` it stops)."""

    side: sky.PierSide
    flip_at: datetime
    resumes: datetime
    until: datetime | None
    why: str | None

    @property
    def gap_s(self) -> float:
        """Seconds of the pass not followed: the flip and the wait after it."""
        return (self.resumes - self.flip_at).total_seconds()


@dataclass(frozen=True)
class SidePlan:
    """The pier side an equatorial mount follows the pass on, and where it must stop if the side cannot
    reach the whole allowed part (``until`` None: it can; ``why`` says why it cannot). ``flip``: the
    second leg after a meridian flip at ``until``, None when there is none (``why`` then also says why
    no flip is planned)."""

    side: sky.PierSide
    until: datetime | None
    why: str | None
    flip: FlipLeg | None = None

    @property
    def follow_until(self) -> datetime | None:
        """Where the whole follow ends (None: at the end of the allowed part)."""
        return self.until if self.flip is None else self.flip.until


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
    top_speed_deg_s: float = TOP_SPEED_DEG_S  # the mount's GOTO speed (half in heavy-duty mode)

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


def _inside(side: sky.PierSide, spot: SatellitePlace, flip_line_deg: float) -> bool:
    """Whether ``side`` can point at ``spot``: pierWest (looking east) reaches hour angles from -12 h up
    to the flip line, pierEast from ``sky.FLIP_ZONE_DEG`` before the meridian to +12 h."""
    ha_deg = sky.wrap_hours_12(spot.ha_hours) * 15.0
    return ha_deg < flip_line_deg if side is sky.PierSide.WEST else ha_deg >= -sky.FLIP_ZONE_DEG


def _reach(side: sky.PierSide, spots: list[SatellitePlace], start: int, flip_line_deg: float) -> int:
    """The index of the first spot from ``start`` that ``side`` cannot point at (``len(spots)``: none)."""
    return next((i for i in range(start, len(spots)) if not _inside(side, spots[i], flip_line_deg)), len(spots))


def _why_ends(spot: SatellitePlace) -> str:
    return ("it passes under the pole (the lower meridian), where neither side follows on"
            if abs(sky.wrap_hours_12(spot.ha_hours)) > 6.0 else
            "it crosses the meridian farther than one side may follow past it")


def _axis_seconds(distance_deg: float, top: float) -> float:
    """A slew's time on one axis from rest to rest: accelerate, cruise at ``top``, brake."""
    accel = DECELERATION_DEG_S2
    if distance_deg <= top * top / accel:
        return 2.0 * math.sqrt(distance_deg / accel)
    return distance_deg / top + top / accel


def flip_seconds(before: SatellitePlace, after: SatellitePlace, latitude: float, top: float) -> float:
    """A conservative time for a GOTO from ``before`` on one side to ``after`` on the other: the RA axis
    turns half a turn plus the hour angles between (the counterweight never goes over the top), the Dec
    axis through the pole side (180° less the two Decs, in the site's hemisphere); both turn at once at
    the mount's top speed and the emulator's 3°/s² (the AM5 measured 4.5°/s²)."""
    primary = 180.0 + abs(sky.wrap_hours_12(after.ha_hours - before.ha_hours)) * 15.0
    hemisphere = 1.0 if latitude >= 0.0 else -1.0
    secondary = abs(180.0 - hemisphere * (before.dec_deg + after.dec_deg))
    return max(_axis_seconds(primary, top), _axis_seconds(secondary, top))


def _flip_leg(spots: list[SatellitePlace], ends: int, first: sky.PierSide, where: AllowedSky) -> FlipLeg | str:
    """The second leg after a flip where ``first`` stops holding (at ``spots[ends]``), or why there is none.

    The flip starts at the last spot the first side can follow; the mount waits at the first later spot
    the satellite reaches after the predicted flip and ``FLIP_MARGIN_S``, where the mount's own GOTO rule
    puts it on the other side."""
    other = sky.PierSide.EAST if first is sky.PierSide.WEST else sky.PierSide.WEST
    flip_from = spots[max(0, ends - 1)]
    goto_limit = max(-15.0, min(15.0, where.flip_line_deg))
    latitude = where.settings.site.latitude
    for j in range(ends, len(spots)):
        spot = spots[j]
        ready = flip_from.when + timedelta(
            seconds=flip_seconds(flip_from, spot, latitude, where.top_speed_deg_s) + FLIP_MARGIN_S)
        if spot.when < ready or sky.goto_pier_side(spot.ha_hours, first, goto_limit) is not other:
            continue
        stops = _reach(other, spots, j, where.flip_line_deg)
        until = None if stops == len(spots) else spots[stops].when
        left = ((until or spots[-1].when) - spot.when).total_seconds()
        if left < MIN_SECOND_LEG_S:
            return f"after a flip only {max(0.0, left):.0f} s would be left to follow"
        return FlipLeg(other, flip_from.when, spot.when, until, None if until is None else _why_ends(spots[stops]))
    return "it leaves the allowed sky before a flip could be done"


def _side_plan(spots: list[SatellitePlace], where: AllowedSky) -> SidePlan:
    """The side the mount follows the allowed part on from its start (module docstring): the side the
    mount's own GOTO rule gives at the entry point, so the slew there lands on it, unless only the other
    side reaches further (the part before a flip). Where the side stops holding, a flip to the other side
    and a second leg when worth it (:func:`_flip_leg`), else the reason none is planned."""
    flip_line_deg = where.flip_line_deg
    entry = sky.goto_pier_side(spots[0].ha_hours, sky.PierSide.UNKNOWN, max(-15.0, min(15.0, flip_line_deg)))
    other = sky.PierSide.EAST if entry is sky.PierSide.WEST else sky.PierSide.WEST
    best = max((entry, other), key=lambda side: _reach(side, spots, 0, flip_line_deg))  # ties: the entry's side
    reached = _reach(best, spots, 0, flip_line_deg)
    if reached == len(spots):
        return SidePlan(best, None, None)
    why = _why_ends(spots[reached])
    if best is not entry:  # the GOTO to the entry lands on the other side: no leg to flip from is known
        return SidePlan(best, spots[reached].when, why)
    flip = _flip_leg(spots, reached, best, where)
    if isinstance(flip, str):
        return SidePlan(best, spots[reached].when, f"{why}; no flip is planned: {flip}")
    return SidePlan(best, flip.flip_at, why, flip)


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
                _side_plan(spots, where), tuple(windows), _azimuth_rate(spots))


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
