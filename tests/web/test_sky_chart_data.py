"""The sky chart's star list and lines (alpaca_zwo/catalogue/sky_data.json), its deep-sky objects (OpenNGC) and its
route (issue 25 item 2, issue 33 item 6).

The star positions are checked against the IAU WGSN's own J2000 places (star_names.csv, another source
than the Hipparcos copy the file is built from); the route's alt/az against Skyfield with DE421.
"""

from __future__ import annotations

import math
from datetime import datetime, timezone

import pytest
from skyfield.api import Star, wgs84

from alpaca_zwo.catalogue import objects
from alpaca_zwo.web.skyview import BODIES, catalogue, deep_sky, sky_now
from tests.catalogue.test_objects import EPH, SKYFIELD_BODIES, TS, separation_arcsec

SITE = (51.4769, -0.0005, 46.0)
WHEN = datetime(2026, 11, 26, 1, 30, tzinfo=timezone.utc)


def test_the_star_list_reaches_magnitude_4_5() -> None:
    stars = catalogue()["stars"]
    line_stars = {i for pair in catalogue()["lines"] for i in pair}
    bright = [s for s in stars if s[3] <= 4.5]
    assert len(bright) >= 900  # the Hipparcos stars to V 4.5: 921
    assert all(s[3] <= 4.5 or i in line_stars for i, s in enumerate(stars))  # fainter only for the figures
    assert [s[3] for s in stars] == sorted(s[3] for s in stars)  # brightest first: the page names the first few
    assert len({s[0] for s in stars}) == len(stars)
    assert all(0 <= s[1] < 360 and -90 <= s[2] <= 90 for s in stars)


def test_named_stars_sit_where_the_iau_catalogue_puts_them() -> None:
    checked = agree = 0
    for hip, ra, dec, mag, name, _designations, _pm_ra, _pm_dec in catalogue()["stars"]:
        if name is None:
            continue
        iau = objects.lookup("star:" + name)
        assert iau.ra_hours is not None and iau.dec_deg is not None
        # Binaries whose two sources place different components/photocentres: alpha Cen B (1.2″),
        # xi UMa (7″), 36 Oph (14″); a chart pixel is ~2000″
        loose = name in ("Toliman", "Alula Australis", "Guniibuu")
        assert separation_arcsec((ra / 15, dec), (iau.ra_hours, iau.dec_deg)) < (20.0 if loose else 1.0), (hip, name)
        assert iau.magnitude is not None and mag < iau.magnitude + 0.3, (name, mag, iau.magnitude)
        agree += abs(mag - iau.magnitude) < 0.1
        checked += 1
    assert checked >= 250
    assert agree >= 0.9 * checked  # the rest brighter here: doubles' combined light (Acrux 0.77, alpha1 Cru 1.33)
    assert "Vega" in {s[4] for s in catalogue()["stars"][:10]}


def test_constellation_lines_join_listed_stars() -> None:
    stars, lines = catalogue()["stars"], catalogue()["lines"]
    assert len(lines) >= 600  # the 88 western figures: 672 segments
    assert all(0 <= i < len(stars) and 0 <= j < len(stars) and i != j for i, j in lines)
    hips = {(stars[i][0], stars[j][0]) for i, j in lines}
    assert (91262, 91971) in hips or (91971, 91262) in hips  # Lyra: Vega - zeta1 Lyr
    for i, j in lines:  # a figure's segment is short: no stray pairing across the sky
        assert separation_arcsec((stars[i][1] / 15, stars[i][2]), (stars[j][1] / 15, stars[j][2])) < 40 * 3600


def _skyfield_altaz(target: object) -> tuple[float, float]:
    observer = EPH["earth"] + wgs84.latlon(SITE[0], SITE[1], elevation_m=SITE[2])
    alt, az, _ = observer.at(TS.from_datetime(WHEN)).observe(target).apparent().altaz()
    return alt.degrees, az.degrees


def _off_deg(a: tuple[float, float], b: tuple[float, float]) -> float:
    (alt1, az1), (alt2, az2) = (map(math.radians, a)), (map(math.radians, b))
    c = math.sin(alt1) * math.sin(alt2) + math.cos(alt1) * math.cos(alt2) * math.cos(az1 - az2)
    return math.degrees(math.acos(min(1.0, c)))


@pytest.mark.parametrize("name", ["Vega", "Sirius", "Polaris", "Capella"])
def test_star_places_agree_with_skyfield(name: str) -> None:
    now = sky_now(*SITE, WHEN)
    stars = catalogue()["stars"]
    i = next(i for i, s in enumerate(stars) if s[4] == name)
    assert len(now["stars"]) == len(stars)
    truth = _skyfield_altaz(Star(ra_hours=stars[i][1] / 15, dec_degrees=stars[i][2]))
    assert _off_deg(tuple(now["stars"][i]), truth) < 0.02  # the 0.01° rounding; a chart pixel is ~0.5°


def test_body_places_agree_with_skyfield() -> None:
    now = sky_now(*SITE, WHEN)
    assert [b["name"] for b in now["bodies"]] == list(BODIES)
    for body in now["bodies"]:
        truth = _skyfield_altaz(EPH[SKYFIELD_BODIES[body["name"]]])
        assert _off_deg((body["alt"], body["az"]), truth) < 0.01, body  # the Moon topocentric (parallax ~1°)
        assert body["id"] == "body:" + body["name"] and objects.lookup(body["id"]).name == body["name"]


def test_the_unnamed_stars_carry_designations_and_proper_motions() -> None:
    stars = catalogue()["stars"]
    assert catalogue()["fields"] == ["hip", "ra_deg", "dec_deg", "vmag", "name", "designations", "pmra_mas",
                                     "pmdec_mas"]
    gamma_cas = next(s for s in stars if s[0] == 4427)
    assert gamma_cas[4] is None and gamma_cas[5].split(";")[0] == "γ Cas"
    assert sum(1 for s in stars if s[5]) >= 0.95 * len(stars)  # Stellarium's name.fab: all but a few faint ones
    barnard_like = max(stars, key=lambda s: math.hypot(s[6], s[7]))
    assert math.hypot(barnard_like[6], barnard_like[7]) > 3000  # alpha Cen's 3.7″/yr: the motions are there
    for star in stars:  # each is found by its HIP number, named or not
        assert objects.lookup(f"HIP {star[0]}").ra_hours == pytest.approx(star[1] / 15, abs=2e-3)


def test_the_deep_sky_objects_are_the_showpiece_lists_and_the_bright_ones() -> None:
    dsos = deep_sky()
    ids = [d[0] for d in dsos]
    assert len(ids) == len(set(ids)) and 200 <= len(ids) <= 300
    messier = {objects.lookup(f"M{n}").id for n in range(1, 111) if n != 102}  # M102: OpenNGC has no object
    caldwell = {objects.lookup(f"C{n}").id for n in range(1, 110)}
    assert messier <= set(ids) and caldwell <= set(ids)
    for southern in ("LMC", "SMC", "Omega Centauri", "47 Tucanae", "Carina Nebula", "Jewel Box", "Coalsack"):
        assert objects.lookup(southern).id in ids, southern
    assert "dso:NGC0869" not in ids and "dso:NGC0884" not in ids  # the Double Cluster is drawn once, as C14
    lmc = dsos[ids.index("dso:ESO056-115")]
    assert lmc[1:5] == ["Large Magellanic Cloud", "LMC", "galaxy", "galaxy"] and lmc[8] > 10  # 10.8° across
    shapes = {d[4] for d in dsos}
    assert shapes == {"galaxy", "open", "globular", "nebula", "planetary", "dark"}
    mags = [d[7] for d in dsos if d[7] is not None]
    assert mags == sorted(mags)


@pytest.mark.parametrize("name", ["M31", "LMC", "Omega Centauri", "M42"])
def test_deep_sky_places_agree_with_skyfield(name: str) -> None:
    now = sky_now(*SITE, WHEN)
    obj = objects.lookup(name)
    i = [d[0] for d in deep_sky()].index(obj.id)
    assert len(now["dsos"]) == len(deep_sky())
    truth = _skyfield_altaz(Star(ra_hours=obj.ra_hours, dec_degrees=obj.dec_deg))
    assert _off_deg(tuple(now["dsos"][i]), truth) < 0.02
