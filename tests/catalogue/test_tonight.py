"""Tonight's plan for an object (issue 43 point 3): the dark window, the object's events inside it in time
order, its best time, and the site's own time zone with daylight saving. The Sun's altitude at the window's
edges is checked with PyEphem's own Sun, the zone against the IANA database through zoneinfo."""

from __future__ import annotations

import math
import sys
from datetime import datetime, timedelta, timezone
from zoneinfo import ZoneInfo

import ephem
import pytest

from alpaca_zwo.catalogue import objects, tonight
from alpaca_zwo.catalogue.objects import Site, site_zone, zone_at

SYDNEY = Site(-33.8688, 151.2093, 40.0)
GREENWICH = Site(51.4769, -0.0005, 46.0)
#: 20:00 in Sydney (AEDT, UTC+11) on 2 December: the Sun has just set, the sky not yet dark.
EVENING = datetime(2026, 12, 2, 9, 0, tzinfo=timezone.utc)


def _sun_altitude(site: Site, when: datetime) -> float:
    obs = objects.observer(site, when)
    sun = ephem.Sun()
    sun.compute(obs)
    return math.degrees(float(sun.alt))


def _altitude(obj: objects.SkyObject, site: Site, when: datetime) -> float:
    return objects.apparent(obj, site, when).altitude


@pytest.mark.parametrize(("name", "site", "when"), [
    ("Acrux", SYDNEY, EVENING), ("Canopus", SYDNEY, EVENING), ("Vega", SYDNEY, EVENING),
    ("Vega", GREENWICH, datetime(2026, 12, 2, 12, 0, tzinfo=timezone.utc)),
    ("Sirius", GREENWICH, datetime(2026, 12, 2, 23, 0, tzinfo=timezone.utc)),  # dark now: the window starts now
    ("Moon", SYDNEY, EVENING), ("Jupiter", SYDNEY, EVENING),
])
def test_the_plan_is_in_time_order_inside_the_dark_window(name: str, site: Site, when: datetime) -> None:
    obj = objects.lookup(name)
    night = tonight.tonight(obj, site, when)
    assert night.dark and when <= night.start < night.end <= when + timedelta(hours=24)
    if night.start > when:  # dusk: the Sun 18° down (to a minute of its motion)
        assert _sun_altitude(site, night.start) == pytest.approx(-18.0, abs=0.3)
    else:
        assert _sun_altitude(site, when) < -18.0
    assert _sun_altitude(site, night.end) == pytest.approx(-18.0, abs=0.3)  # dawn
    times = [at for _, at in night.events]
    assert times == sorted(times) and all(night.start <= at <= night.end for at in times), night.events
    for what, at in night.events:  # each event is what it says: on the horizon, or the highest
        if what in ("rise", "set"):
            assert _altitude(obj, site, at) == pytest.approx(0.0, abs=0.5), (what, at)
    if night.best is None:
        assert _altitude(obj, site, night.start) <= 0 and _altitude(obj, site, night.end) <= 0
        return
    assert night.start <= night.best <= night.end and night.best_altitude is not None
    assert _altitude(obj, site, night.best) == pytest.approx(night.best_altitude, abs=0.1)
    samples = [night.start + (night.end - night.start) * i / 40 for i in range(41)]
    assert max(_altitude(obj, site, t) for t in samples) <= night.best_altitude + 0.1


def test_a_daylight_transit_is_not_tonights_best() -> None:
    """Fomalhaut at Sydney in December transits at 19:05, in daylight: tonight it is best at dusk and sets at
    02:37; Omega Centauri rises at 00:28 and is best at dawn."""
    zone = ZoneInfo("Australia/Sydney")
    fomalhaut = objects.lookup("Fomalhaut")
    assert objects.apparent(fomalhaut, SYDNEY, EVENING).transit.astimezone(zone).hour == 19  # type: ignore[union-attr]
    night = tonight.tonight(fomalhaut, SYDNEY, EVENING)
    assert [(what, at.astimezone(zone).strftime("%H:%M")) for what, at in night.events] == [("set", "02:37")]
    assert night.best == night.start and night.best_altitude is not None and night.best_altitude > 55
    night = tonight.tonight(objects.lookup("Omega Centauri"), SYDNEY, EVENING)
    assert [(what, at.astimezone(zone).strftime("%H:%M")) for what, at in night.events] == [("rise", "00:28")]
    assert night.best == night.end


def test_no_full_darkness_in_a_greenwich_june() -> None:
    night = tonight.tonight(objects.lookup("Vega"), GREENWICH, datetime(2026, 6, 21, 12, 0, tzinfo=timezone.utc))
    assert not night.dark and night.end - night.start == timedelta(hours=1)
    assert -18.0 < _sun_altitude(GREENWICH, night.start + timedelta(minutes=30)) < 0.0


@pytest.mark.parametrize(("site", "server", "when", "label"), [
    (SYDNEY, timezone.utc, EVENING, "AEDT, UTC+11"),  # a UTC container: daylight saving all the same
    (SYDNEY, timezone.utc, datetime(2026, 6, 1, tzinfo=timezone.utc), "AEST, UTC+10"),
    (Site(52.52, 13.405), ZoneInfo("Europe/London"), EVENING, "CET, UTC+1"),  # a Pi left on London, in Berlin
    (Site(52.52, 13.405), ZoneInfo("Europe/London"), datetime(2026, 7, 1, tzinfo=timezone.utc), "CEST, UTC+2"),
    (Site(35.6895, 139.6917), ZoneInfo("America/New_York"), EVENING, "JST, UTC+9"),
    (Site(-33.45, -70.66), timezone.utc, EVENING, "UTC\u22123"),  # Santiago in summer time (the name is "-03")
])
def test_the_site_zone_is_the_sites_own(site: Site, server: timezone | ZoneInfo, when: datetime, label: str) -> None:
    zone = site_zone(site.longitude, when, server, latitude=site.latitude)
    assert (zone.label(when), zone.source) == (label, "site")
    assert zone.name is not None and zone.name == zone_at(site.latitude, site.longitude).key  # type: ignore[union-attr]


def test_without_the_lookup_package_the_server_zone_or_the_longitude_stands_in(
        monkeypatch: pytest.MonkeyPatch) -> None:
    zone_at.cache_clear()
    monkeypatch.setitem(sys.modules, "tzfpy", None)  # as on 32-bit ARM, where it has no wheel
    try:
        zone = site_zone(SYDNEY.longitude, EVENING, timezone.utc, latitude=SYDNEY.latitude)
        assert (zone.label(EVENING), zone.source) == ("UTC+10", "longitude")
        zone = site_zone(SYDNEY.longitude, EVENING, ZoneInfo("Australia/Sydney"), latitude=SYDNEY.latitude)
        assert (zone.label(EVENING), zone.source) == ("AEDT, UTC+11", "server")
    finally:
        zone_at.cache_clear()
