"""The page's object search and apparent places (alpaca_zwo/web/objects.py, issue 25 item 1).

Search: what a person types finds the object they mean, best first. Apparent places: checked against
Skyfield with JPL's DE421 (from skyfield-data, offline), a different library and ephemeris from the
PyEphem the product uses: stars and deep-sky objects to well under 30″, planets to a few arcsec, the
Moon topocentric (its parallax is about 1°, so a geocentric place would fail by far).
"""

from __future__ import annotations

import math
import warnings
from datetime import datetime, timedelta, timezone
from typing import Any

import pytest
from skyfield.api import Loader, Star, wgs84

from alpaca_zwo.web import objects
from alpaca_zwo.web.objects import LUNAR, SIDEREAL, SOLAR, ObjectError, Site, apparent, lookup, search

with warnings.catch_warnings():  # its Earth-orientation table's age: unused here (builtin timescale)
    warnings.simplefilter("ignore", RuntimeWarning)
    from skyfield_data import get_skyfield_data_path

    DATA = str(get_skyfield_data_path())

SITE = Site(51.4769, -0.0005, 46.0)
WHEN = datetime(2026, 11, 26, 1, 30, tzinfo=timezone.utc)

_load = Loader(DATA, expire=False, verbose=False)  # never downloads
TS = _load.timescale(builtin=True)
EPH = _load("de421.bsp")
SKYFIELD_BODIES = {"Sun": "sun", "Moon": "moon", "Mercury": "mercury", "Venus": "venus", "Mars": "mars barycenter",
                   "Jupiter": "jupiter barycenter", "Saturn": "saturn barycenter", "Uranus": "uranus barycenter",
                   "Neptune": "neptune barycenter"}


def skyfield_place(obj: objects.SkyObject, site: Site, when: datetime) -> tuple[float, float]:
    """Topocentric apparent RA (h) / Dec (°) of date by Skyfield: the check on the product's PyEphem."""
    observer = EPH["earth"] + wgs84.latlon(site.latitude, site.longitude, elevation_m=site.elevation)
    target: Any
    if obj.body is not None:
        target = EPH[SKYFIELD_BODIES[obj.body]]
    elif obj.id.startswith("star:"):  # the catalogue's J2000 place and proper motion, reduced by Skyfield
        target = Star(ra_hours=obj.ra_hours, dec_degrees=obj.dec_deg, ra_mas_per_year=obj.pm_ra_mas,
                      dec_mas_per_year=obj.pm_dec_mas)
    else:
        assert obj.ra_hours is not None and obj.dec_deg is not None
        target = Star(ra_hours=obj.ra_hours, dec_degrees=obj.dec_deg)
    ra_t, dec_t, _ = observer.at(TS.from_datetime(when)).observe(target).apparent().radec(epoch="date")
    return ra_t.hours, dec_t.degrees


def separation_arcsec(a: tuple[float, float], b: tuple[float, float]) -> float:
    ra1, dec1, ra2, dec2 = math.radians(a[0] * 15), math.radians(a[1]), math.radians(b[0] * 15), math.radians(b[1])
    c = math.sin(dec1) * math.sin(dec2) + math.cos(dec1) * math.cos(dec2) * math.cos(ra1 - ra2)
    return math.degrees(math.acos(min(1.0, c))) * 3600.0


# --- search ----------------------------------------------------------------------------------------


@pytest.mark.parametrize(("query", "name", "kind"), [
    ("Vega", "Vega", "star"), ("vega ", "Vega", "star"), ("alpha Lyr", "Vega", "star"), ("α Lyr", "Vega", "star"),
    ("Alp Lyr", "Vega", "star"), ("3 Lyr", "Vega", "star"), ("beta Ori", "Rigel", "star"),
    ("alpha1 Cru", "Acrux", "star"), ("M31", "M31", "galaxy"), ("m 31", "M31", "galaxy"),
    ("Messier 42", "M42", "cluster with nebula"), ("NGC 224", "M31", "galaxy"),
    ("NGC 7000", "NGC 7000", "emission nebula"),
    ("ngc7000", "NGC 7000", "emission nebula"), ("IC 434", "IC 434", "emission nebula"),
    ("Orion Nebula", "M42", "cluster with nebula"), ("Andromeda Galaxy", "M31", "galaxy"),
    ("M45", "M45", "open cluster"),
    ("Mars", "Mars", "planet"), ("moon", "Moon", "moon"), ("Sun", "Sun", "star (the Sun)"),
])
def test_search_puts_the_meant_object_first(query: str, name: str, kind: str) -> None:
    best = search(query)[0]
    assert (best.name, best.kind) == (name, kind)
    assert lookup(best.id) == best  # the id round-trips, as the GoTo route needs


def test_a_prefix_lists_bright_things_first() -> None:
    names = [m.name for m in search("Al")]
    assert names[:3] == ["Altair", "Aldebaran", "Alnilam"]  # by magnitude: 0.76, 0.87, 1.69
    assert [m.name for m in search("Ve")][:2] == ["Venus", "Vega"]


@pytest.mark.parametrize("text", ["5h35m17s -5°23'28\"", "05 35 17 -05 23 28", "05:35:17 -05:23:28",
                                  "5h35m17.0s, -5d23m28s", "83.82083 -5.39111", "5.5880556h -5.3911111"])
def test_typed_coordinates_in_each_form(text: str) -> None:
    (match,) = search(text)
    assert match.kind == "coordinates (J2000)"
    assert match.ra_hours == pytest.approx(5 + 35 / 60 + 17 / 3600, abs=1e-5)
    assert match.dec_deg == pytest.approx(-(5 + 23 / 60 + 28 / 3600), abs=1e-5)
    assert lookup(match.id).ra_hours == pytest.approx(match.ra_hours, abs=1e-6)


@pytest.mark.parametrize("text", ["", "   ", "x" * 81, "Vega\x00", "25h00m00s +10 00 00", "361 0", "10 95"])
def test_junk_is_refused_with_a_message(text: str) -> None:
    with pytest.raises(ObjectError):
        search(text)


def test_a_name_nobody_knows_finds_nothing() -> None:
    assert search("Xyzzy nebula") == []


def test_tracking_rates_follow_the_object() -> None:
    assert lookup("Moon").tracking_rate == LUNAR
    assert lookup("Sun").tracking_rate == SOLAR
    assert {lookup(n).tracking_rate for n in ("Mars", "Vega", "M31", "10 20")} == {SIDEREAL}


def test_the_iau_names_of_the_bright_stars() -> None:
    """Every IAU-named star to magnitude 2.5 (85 of them in IAU-CSN), found by name and Bayer form."""
    stars = {o.id: o for o in objects._stars().values()}.values()
    bright = [o for o in stars if o.magnitude is not None and o.magnitude <= 2.5]
    assert len(bright) == 85
    for star in bright:
        assert search(star.name)[0] == star
        assert any(search(a)[0] == star for a in star.aliases), star  # α Cen is Rigil Kentaurus; α2 Cen Toliman
    assert search("Sargas")[0].aliases[0] == "θ Sco"
    assert search("theta Sco")[0].name == "Sargas"
    assert search("Toliman")[0].magnitude == pytest.approx(1.35)
    assert search("Agena")[0].name == "Hadar"  # PyEphem's traditional name of β Cen


def test_every_bright_named_star_of_the_list_has_its_bayer_form() -> None:
    """The Bayer forms come from the IAU-keyed table; each of the first-magnitude stars must have one."""
    for name in ("Sirius", "Canopus", "Arcturus", "Capella", "Rigel", "Procyon", "Betelgeuse", "Achernar", "Altair",
                 "Aldebaran", "Antares", "Spica", "Pollux", "Fomalhaut", "Deneb", "Regulus", "Polaris"):
        star = lookup(f"star:{name}")
        assert any(a[0] in "αβγδεζηθικλμνξοπρστυφχψω" for a in star.aliases), name


# --- apparent places against Skyfield ----------------------------------------------------------------


@pytest.mark.parametrize("name", ["Vega", "Sirius", "Polaris", "Canopus", "Arcturus", "Rigil Kentaurus", "Acrux",
                                  "Barnard's Star", "Sargas",
                                  "M31", "M42", "NGC 7000", "IC 434", "05 35 17 -05 23 28"])
@pytest.mark.parametrize("when", [WHEN, WHEN + timedelta(days=3650)])
def test_star_and_deep_sky_places_agree_with_skyfield(name: str, when: datetime) -> None:
    obj = lookup(name)
    place = apparent(obj, SITE, when)
    assert separation_arcsec((place.ra_hours, place.dec_deg), skyfield_place(obj, SITE, when)) < 5.0
    # and it is not the catalogue place: 26+ years of precession move it by far more than 30″
    assert separation_arcsec((place.ra_hours, place.dec_deg), (obj.ra_hours or 0.0, obj.dec_deg or 0.0)) > 300


@pytest.mark.parametrize("name", ["Mercury", "Venus", "Mars", "Jupiter", "Saturn", "Uranus", "Neptune", "Sun"])
def test_planet_places_agree_with_skyfield(name: str) -> None:
    obj = lookup(name)
    place = apparent(obj, SITE, WHEN)
    assert separation_arcsec((place.ra_hours, place.dec_deg), skyfield_place(obj, SITE, WHEN)) < 3.0


@pytest.mark.parametrize("hours", [0, 6, 12, 18])
def test_the_moon_is_topocentric(hours: int) -> None:
    """The Moon's parallax (up to ~1°) is in the place: from Greenwich and from Sydney it differs."""
    when = WHEN + timedelta(hours=hours)
    moon = lookup("Moon")
    here = apparent(moon, SITE, when)
    assert separation_arcsec((here.ra_hours, here.dec_deg), skyfield_place(moon, SITE, when)) < 10.0
    sydney = Site(-33.87, 151.21, 0.0)
    there = apparent(moon, sydney, when)
    assert separation_arcsec((there.ra_hours, there.dec_deg), skyfield_place(moon, sydney, when)) < 10.0
    assert separation_arcsec((here.ra_hours, here.dec_deg), (there.ra_hours, there.dec_deg)) > 1200


def test_altaz_and_rise_transit_set() -> None:
    vega = apparent(lookup("Vega"), SITE, WHEN)
    assert vega.always_up and vega.rise is None and vega.set is None and vega.transit is not None
    canopus = apparent(lookup("Canopus"), SITE, WHEN)
    assert canopus.never_up and canopus.altitude < 0
    mars = apparent(lookup("Mars"), SITE, WHEN)
    assert mars.rise is not None and mars.set is not None and mars.transit is not None
    assert WHEN < mars.transit < WHEN + timedelta(days=1.01)
    observer = EPH["earth"] + wgs84.latlon(SITE.latitude, SITE.longitude, elevation_m=SITE.elevation)
    alt, az, _ = observer.at(TS.from_datetime(WHEN)).observe(EPH["mars barycenter"]).apparent().altaz()
    assert mars.altitude == pytest.approx(alt.degrees, abs=0.01)
    assert mars.azimuth == pytest.approx(az.degrees, abs=0.01)
