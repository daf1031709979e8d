"""A target that is down gets "Not up: rises 00:28" instead of a GoTo that must be refused (issue 43 point 8).

Over the page's HTTP API against the built-in emulator, north and at Sydney: Arcturus is put 5° up and
rising (the site's longitude chosen for now) under a floor of 10° (the minimum altitude) or 20° (a horizon
profile). The object's ``not_up`` names the minute it is up by in the site's clock, and that instant is
judged by Skyfield (DE421, another library than the product's PyEphem): under the floor just before, over
it just after. A star that never rises, one whose highest is under the limit, one that is up and a parked
mount (a state, not the sky) are each said as what they are.
"""

from __future__ import annotations

import math
from datetime import datetime, timedelta

import pytest
from skyfield.api import Star, wgs84

from alpaca_zwo.catalogue import objects
from alpaca_zwo.config.settings import EmulatorSettings, LimitSettings, SiteSettings
from tests.catalogue.test_objects import EPH, TS
from tests.conftest import ServerFactory, make_settings
from tests.support import wait_until
from tests.support.sites import NORTH, SYDNEY, Site
from tests.web.test_setup_api import Client
from tests.web.test_setup_goto import _longitude_putting

STAR = "Arcturus"


def hour_angle_rising_at(altitude: float, dec: float, latitude: float) -> float:
    """The (negative: east, rising) hour angle in hours at which a star at ``dec`` stands at ``altitude``."""
    phi, delta = math.radians(latitude), math.radians(dec)
    cos_h = (math.sin(math.radians(altitude)) - math.sin(phi) * math.sin(delta)) / (math.cos(phi) * math.cos(delta))
    return -math.degrees(math.acos(cos_h)) / 15.0


def skyfield_altitude(obj: objects.SkyObject, site: tuple[float, float, float], when: datetime) -> float:
    """The star's geometric altitude (no refraction, as the mount's frame) by Skyfield, in degrees."""
    assert obj.ra_hours is not None and obj.dec_deg is not None
    star = Star(ra_hours=obj.ra_hours, dec_degrees=obj.dec_deg, ra_mas_per_year=obj.pm_ra_mas,
                dec_mas_per_year=obj.pm_dec_mas)
    observer = EPH["earth"] + wgs84.latlon(site[0], site[1], elevation_m=site[2])
    altitude, _, _ = observer.at(TS.from_datetime(when)).observe(star).apparent().altaz()
    return float(altitude.degrees)


def _server(server_factory: ServerFactory, site: Site, limits: LimitSettings, rising_at: float = 5.0) -> Client:
    star = objects.lookup(STAR)
    assert star.dec_deg is not None
    lon = _longitude_putting(star, ha_hours=hour_angle_rising_at(rising_at, star.dec_deg, site.latitude),
                             latitude=site.latitude)
    server = server_factory(make_settings(site=SiteSettings(latitude=site.latitude, longitude=lon, elevation=46.0),
                                          limits=limits, emulator=EmulatorSettings(speed=1.0, baud=0)))
    return Client(f"http://127.0.0.1:{server.port}")


def _describe(client: Client, name: str) -> dict[str, object]:
    r = client.session.get(f"{client.api}/object", params={"id": name}, timeout=10)
    assert r.status_code == 200, r.text
    body: dict[str, object] = r.json()
    return body


FLOORS = {"min-altitude-10": (LimitSettings(min_altitude_deg=10.0), 10.0),
          "horizon-20": (LimitSettings(horizon=((0.0, 20.0), (180.0, 20.0))), 20.0)}


@pytest.mark.parametrize("site", [NORTH, SYDNEY], ids=lambda s: s.name)
@pytest.mark.parametrize("floor", list(FLOORS))
def test_a_star_under_the_floor_says_when_it_rises_over_it(server_factory: ServerFactory, site: Site,
                                                           floor: str) -> None:
    limits, floor_deg = FLOORS[floor]
    client = _server(server_factory, site, limits)
    body = _describe(client, STAR)
    assert body["verdict"]["reachable"] is False and body["verdict"]["down"] is True  # type: ignore[index]
    not_up = body["not_up"]
    assert isinstance(not_up, dict), body
    rises = datetime.fromisoformat(str(not_up["rises"]))
    up_by = (rises + timedelta(seconds=59)).replace(second=0, microsecond=0)
    assert not_up["words"] == f"Not up: rises {up_by:%H:%M}", not_up
    # In the site's clock, as the card's other times: the same offset as Tonight's.
    tonight = body["tonight"]
    assert isinstance(tonight, dict)
    assert str(not_up["rises"])[-6:] == str(tonight["start"])[-6:]
    star = objects.lookup(STAR)
    where = (site.latitude, float(client.value("sitelongitude")), 46.0)
    assert skyfield_altitude(star, where, rises - timedelta(seconds=30)) < floor_deg
    assert skyfield_altitude(star, where, rises + timedelta(seconds=30)) > floor_deg
    assert timedelta(minutes=10) < rises - datetime.now(rises.tzinfo) < timedelta(hours=3)


def test_never_up_never_clears_up_and_parked(server_factory: ServerFactory) -> None:
    client = _server(server_factory, NORTH, LimitSettings(min_altitude_deg=15.0), rising_at=40.0)
    # Canopus never rises at 51.5° N; Fomalhaut's highest there (about 9°) is under the 15° limit.
    assert _describe(client, "Canopus")["not_up"] == {"rises": None, "words": "Not up: never rises here"}
    assert _describe(client, "Fomalhaut")["not_up"] == {"rises": None, "words": "Not up: never clears the limits here"}
    assert _describe(client, STAR)["not_up"] is None  # up: the GoTo is a GoTo
    client.command("connected", Connected="true")
    client.action("park")
    wait_until(lambda: client.status()["at_park"], 60, "the mount to park")
    parked = _describe(client, STAR)
    assert parked["verdict"]["state"] == "parked" and parked["not_up"] is None  # type: ignore[index]
