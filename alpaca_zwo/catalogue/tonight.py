"""Tonight for one object at one site: the dark window, the object's events inside it in time order, and
its best time (the highest it stands while the sky is dark).

A plan for a night reads in the order it happens: "dark 21:10 · rises 23:28 · highest 02:14 (58°) · dawn
04:31". The next rise, transit and set alone (``objects.apparent``) are not a plan: the next transit can be
tomorrow's at 08:03, in daylight, listed after a set that comes first. Darkness is the Sun 18° under the
horizon (astronomical twilight's end); where it never gets so dark (summer at high latitudes) the window
is the Sun's deepest hour and says so, and in a polar night the window is the next 24 hours.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone
from typing import Any

from .naming import SkyObject
from .objects import Site, ephem_body, observer

#: The Sun this far under the horizon: the sky dark enough for faint objects (astronomical twilight).
DARK_SUN_DEG = -18.0
#: The altitude curve is sampled this often through the window (the best time to its nearest step).
STEP = timedelta(minutes=5)
#: The longest window looked at: a polar night's day.
DAY = timedelta(hours=24)


@dataclass(frozen=True)
class Night:
    """The dark window (``dark`` False: no full darkness tonight, the window is the Sun's deepest hour),
    the object's rise/transit/set inside it in time order, and its best time while dark (None: not up)."""

    start: datetime
    end: datetime
    dark: bool
    events: tuple[tuple[str, datetime], ...]
    best: datetime | None
    best_altitude: float | None


def _sun_window(obs: Any, when: datetime) -> tuple[datetime, datetime, bool]:
    """Tonight's dark window from ``when``: now until dawn if it is dark now, else dusk until dawn."""
    import ephem

    sun = ephem.Sun()
    obs.horizon = str(DARK_SUN_DEG)
    sun.compute(obs)

    def utc(value: Any) -> datetime:
        return ephem.Date(value).datetime().replace(tzinfo=timezone.utc)  # type: ignore[no-any-return]

    try:
        start = when if math.degrees(float(sun.alt)) < DARK_SUN_DEG else utc(obs.next_setting(sun, use_center=True))
        obs.date = ephem.Date(start.replace(tzinfo=None))
        return start, utc(obs.next_rising(sun, use_center=True)), True
    except ephem.NeverUpError:  # a polar night: dark all day
        return when, when + DAY, True
    except ephem.AlwaysUpError:  # never dark: the hour around the Sun's lowest
        lowest = utc(obs.next_antitransit(sun))
        return lowest - timedelta(minutes=30), lowest + timedelta(minutes=30), False
    finally:
        obs.horizon = "0"


def _events(target: Any, obs: Any, start: datetime, end: datetime) -> list[tuple[str, datetime]]:
    """The object's rise, transit and set between ``start`` and ``end`` (each at most once: the window is
    never longer than a day), in time order."""
    import ephem

    found = []
    for name, method in (("rise", "next_rising"), ("transit", "next_transit"), ("set", "next_setting")):
        obs.date = ephem.Date(start.replace(tzinfo=None))
        try:
            at = ephem.Date(getattr(obs, method)(target)).datetime().replace(tzinfo=timezone.utc)
        except (ephem.AlwaysUpError, ephem.NeverUpError):
            continue
        if at <= end:
            found.append((name, at))
    return sorted(found, key=lambda event: event[1])


def _highest(target: Any, obs: Any, start: datetime, end: datetime) -> tuple[datetime, float]:
    """The sampled instant in the window where the object stands highest (both ends included: with no
    transit inside, the best is at one of them), and that altitude."""
    import ephem

    steps = int((end - start) / STEP)
    best = (start, -90.0)
    for at in [start + STEP * i for i in range(steps + 1)] + [end]:
        obs.date = ephem.Date(at.replace(tzinfo=None))
        target.compute(obs)
        altitude = math.degrees(float(target.alt))
        if altitude > best[1]:
            best = (at, altitude)
    return best


def tonight(obj: SkyObject, site: Site, when: datetime) -> Night:
    """Tonight's plan for ``obj`` at ``site`` from ``when`` (an aware instant)."""
    obs = observer(site, when)
    start, end, dark = _sun_window(obs, when.astimezone(timezone.utc))
    target = ephem_body(obj)
    events = _events(target, obs, start, end)
    best_at, altitude = _highest(target, obs, start, end)
    transit = next((at for name, at in events if name == "transit"), None)
    if transit is not None:  # the exact instant, not the nearest sample
        import ephem

        obs.date = ephem.Date(transit.replace(tzinfo=None))
        target.compute(obs)
        best_at, altitude = transit, math.degrees(float(target.alt))
    up = altitude > 0.0
    return Night(start, end, dark, tuple(events), best_at if up else None, round(altitude, 1) if up else None)
