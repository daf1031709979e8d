"""Find, GoTo and Sync over the page's HTTP API against the built-in emulator (issue 25 items 1 and 3).

Judged by the emulator's truth (its model's snapshot), against places Skyfield computes with DE421:
another library and ephemeris than the product's PyEphem. Each scene puts its object about 1.5 h east
of the meridian by choosing the site's longitude for the moment the test runs, so it is well up.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import pytest

from alpaca_zwo import sky
from alpaca_zwo.catalogue import objects
from alpaca_zwo.config.settings import EmulatorSettings, SiteSettings
from alpaca_zwo.emulator import MountModel
from alpaca_zwo.server import AlpacaZwoServer
from tests.catalogue.test_objects import separation_arcsec, skyfield_place
from tests.conftest import ServerFactory, make_settings
from tests.support import wait_until
from tests.web.test_setup_api import Client

LATITUDE = 51.4769
#: Emulated seconds per real second: landings are judged at the mount's own time, not by timing.
SPEED = 4.0
REPO = Path(__file__).resolve().parents[2]


@pytest.fixture
def client(base_url: str) -> Client:
    return Client(base_url)


def _longitude_putting(obj: objects.SkyObject, ha_hours: float = -1.5, latitude: float = LATITUDE,
                       now: datetime | None = None) -> float:
    """The east longitude where ``obj`` stands ``ha_hours`` from the meridian ``now`` (default: the wall
    clock's now; a mount on a fast emulator clock is ahead of it), at ``latitude``."""
    now = now or datetime.now(timezone.utc)
    place = objects.apparent(obj, objects.Site(latitude, 0.0, 0.0), now)
    gmst = sky.local_sidereal_time(now, 0.0)
    return (((place.ra_hours + ha_hours - gmst) * 15.0 + 180.0) % 360.0) - 180.0


def _scene(server_factory: ServerFactory, name: str) -> tuple[AlpacaZwoServer, Client, MountModel]:
    lon = _longitude_putting(objects.lookup(name))
    server = server_factory(make_settings(site=SiteSettings(latitude=LATITUDE, longitude=lon, elevation=46.0),
                                          emulator=EmulatorSettings(speed=SPEED, baud=0)))
    client = Client(f"http://127.0.0.1:{server.port}")
    client.command("connected", Connected="true")
    wait_until(lambda: client.status()["position"] is not None, what="a first position")
    emulator = server.emulators[0]
    assert emulator is not None
    return server, client, emulator.model


def _truth_place(model: MountModel) -> tuple[tuple[float, float], datetime]:
    truth: dict[str, Any] = model.snapshot()
    return (truth["ra_h"], truth["dec_deg"]), datetime.fromisoformat(truth["mount_utc"])


def _goto(client: Client, model: MountModel, name: str) -> dict[str, Any]:
    selected = client.session.get(f"{client.api}/object", params={"id": name}, timeout=10).json()
    r = client.post("/setup/api/telescope/0/goto", {"id": selected["id"]})
    assert r.status_code == 200, r.text
    wait_until(lambda: model.snapshot()["slew"] is None and not client.value("slewing"), 180.0, f"the GoTo to {name}")
    return selected


@pytest.mark.parametrize("name", ["Vega", "M31", "Jupiter"])
def test_goto_lands_on_the_object(server_factory: ServerFactory, name: str) -> None:
    _, client, model = _scene(server_factory, name)
    before, _ = _truth_place(model)
    selected = _goto(client, model, name)
    assert selected["above_limits"] and selected["altitude"] > 30
    landed, when = _truth_place(model)
    expected = skyfield_place(objects.lookup(selected["id"]), objects.Site(LATITUDE, *client_site(client)), when)
    assert separation_arcsec(before, expected) > 3600  # it really moved there
    assert separation_arcsec(landed, expected) < 30.0, (landed, expected)
    assert model.snapshot()["tracking_rate"] == "sidereal"
    side = {"E": "pierEast", "W": "pierWest"}[model.snapshot()["pier"]]
    assert selected["destination_side_of_pier"] == side


def test_goto_the_moon_tracks_lunar(server_factory: ServerFactory) -> None:
    """The Moon's topocentric place (parallax up to 1°), then the lunar rate keeps it."""
    _, client, model = _scene(server_factory, "Moon")
    selected = _goto(client, model, "Moon")
    assert selected["tracking_rate"] == 1
    landed, when = _truth_place(model)
    site = objects.Site(LATITUDE, *client_site(client))
    expected = skyfield_place(objects.lookup("Moon"), site, when)
    # the Moon moves ~0.5″/s on the stars: the slew's own seconds are in this bound
    assert separation_arcsec(landed, expected) < 60.0, (landed, expected)
    assert model.snapshot()["tracking_rate"] == "lunar"
    assert client.value("trackingrate") == 1


def client_site(client: Client) -> tuple[float, float]:
    return client.value("sitelongitude"), client.value("siteelevation")


def test_the_sun_needs_a_confirmation_naming_the_danger(server_factory: ServerFactory) -> None:
    _, client, model = _scene(server_factory, "Sun")
    before = model.snapshot()
    r = client.post("/setup/api/telescope/0/goto", {"id": "body:Sun"})
    assert r.status_code == 409 and "solar filter" in r.json()["confirm"]
    r = client.post("/setup/api/telescope/0/goto", {"id": "body:Sun", "confirm": False})
    assert r.status_code == 409
    after = model.snapshot()
    assert after["slew"] is None and after["target_ra_h"] == before["target_ra_h"]
    assert separation_arcsec((after["ra_h"], after["dec_deg"]), (before["ra_h"], before["dec_deg"])) < 1.0
    assert not client.value("slewing")

    r = client.post("/setup/api/telescope/0/goto", {"id": "body:Sun", "confirm": True})
    assert r.status_code == 200, r.text
    wait_until(lambda: model.snapshot()["slew"] is None and not client.value("slewing"), 180.0, "the GoTo to the Sun")
    landed, when = _truth_place(model)
    expected = skyfield_place(objects.lookup("Sun"), objects.Site(LATITUDE, *client_site(client)), when)
    assert separation_arcsec(landed, expected) < 30.0
    assert model.snapshot()["tracking_rate"] == "solar"
    assert client.value("trackingrate") == 2


def test_sync_on_a_selected_object(server_factory: ServerFactory) -> None:
    """The user's GoTo landed 0.4° off (a poor polar alignment); they centre Arcturus by eye and sync."""
    _, client, model = _scene(server_factory, "Arcturus")
    arcturus = objects.lookup("Arcturus")
    assert arcturus.ra_hours is not None and arcturus.dec_deg is not None
    _goto(client, model, f"{arcturus.ra_hours:.6f}h {arcturus.dec_deg + 0.4:.5f}")
    client.command("tracking", Tracking="true")
    off = (client.value("rightascension"), client.value("declination"))
    r = client.post("/setup/api/telescope/0/sync", {"id": "star:Arcturus"})
    assert r.status_code == 409 and r.json()["confirm"]  # a sync is never made without a confirmation
    r = client.post("/setup/api/telescope/0/sync", {"id": "star:Arcturus", "confirm": True})
    assert r.status_code == 200, r.text
    _, when = _truth_place(model)
    expected = skyfield_place(objects.lookup("Arcturus"), objects.Site(LATITUDE, *client_site(client)), when)
    assert separation_arcsec(off, expected) > 1000
    read = (client.value("rightascension"), client.value("declination"))
    assert separation_arcsec(read, expected) < 30.0


def test_a_goto_below_the_horizon_is_refused_as_alpaca_refuses_it(server_factory: ServerFactory) -> None:
    _, client, model = _scene(server_factory, "Vega")
    canopus = client.session.get(f"{client.api}/object", params={"id": "Canopus"}, timeout=10).json()
    assert not canopus["above_limits"] and canopus["never_up"]
    r = client.post("/setup/api/telescope/0/goto", {"id": "Canopus"})
    assert r.status_code == 400
    page = r.json()
    alpaca = client.session.put(f"{client.base}/api/v1/telescope/0/slewtocoordinatesasync", timeout=10, data={
        "RightAscension": canopus["ra"], "Declination": canopus["dec"], "ClientID": 77}).json()
    assert page["number"] == alpaca["ErrorNumber"] == 0x401
    assert page["error"].split(":")[0] == alpaca["ErrorMessage"].split(":")[0] == "target is below the horizon limit"
    assert model.snapshot()["slew"] is None


@pytest.mark.parametrize(("path", "status"), [
    ("/setup/api/objects?q=", 400), ("/setup/api/objects?q=" + "x" * 200, 400), ("/setup/api/objects", 400),
    ("/setup/api/objects?q=%00Vega", 400), ("/setup/api/objects?q=99h00m00s+0+0+0", 400),
    ("/setup/api/telescope/0/object?id=Xyzzy+nebula", 404), ("/setup/api/telescope/7/object?id=Vega", 404),
])
def test_junk_queries_get_4xx(client: Client, path: str, status: int) -> None:
    r = client.session.get(f"{client.base}{path}", timeout=10)
    assert r.status_code == status, r.text
    assert "error" in r.json()


def test_search_over_http(client: Client) -> None:
    r = client.session.get(f"{client.base}/setup/api/objects", params={"q": "alpha Lyr"}, timeout=10)
    assert r.status_code == 200
    body = r.json()
    assert body["matches"][0]["name"] == "Vega" and body["matches"][0]["matched"] == "\u03b1 Lyr"
    assert body["confident"] is True and body["note"] is None
    r = client.session.get(f"{client.base}/setup/api/objects", params={"q": "5.588 -5.39"}, timeout=10)
    body = r.json()
    assert r.status_code == 200 and len(body["matches"]) == 2 and body["confident"] is False
    assert "hours or in degrees" in body["note"]
    body = client.session.get(f"{client.base}/setup/api/objects", params={"q": "ISS"}, timeout=10).json()
    assert body == {"matches": [], "confident": False, "note": objects.SATELLITE_NOTE}
    body = client.session.get(f"{client.base}/setup/api/objects", params={"q": "Andromeda"}, timeout=10).json()
    assert (body["matches"][0]["name"], body["matches"][0]["matched"]) == ("M31", "Andromeda Galaxy")


def test_a_long_query_gets_a_friendly_line(client: Client) -> None:
    r = client.session.get(f"{client.base}/setup/api/objects", params={"q": "M" * 81}, timeout=10)
    assert r.status_code == 400
    assert r.json()["error"] == objects.TOO_LONG and "must be" not in r.json()["error"]
    r = client.session.get(f"{client.base}/setup/api/telescope/0/object", params={"id": "5.588 -5.39"}, timeout=10)
    assert r.status_code == 400 and "hours or in degrees" in r.json()["error"]


def test_times_are_given_in_the_sites_zone(server_factory: ServerFactory) -> None:
    """Site in Tokyo: rise/transit/set in its zone with the offset written in, and the zone named."""
    tokyo = 139.6917
    server = server_factory(make_settings(site=SiteSettings(latitude=35.6895, longitude=tokyo, elevation=40.0),
                                          emulator=EmulatorSettings(baud=0)))
    client = Client(f"http://127.0.0.1:{server.port}")
    body = client.session.get(f"{client.api}/object", params={"id": "Mars"}, timeout=10).json()
    # The site's own zone, whatever the server's (issue 43): Japan's, by its database name.
    assert (body["site_zone"], body["site_zone_source"], body["site_zone_name"]) == ("JST, UTC+9", "site", "Asia/Tokyo")
    for key in ("rise", "transit", "set"):
        utc = datetime.fromisoformat(body[key].replace("Z", "+00:00"))
        site = datetime.fromisoformat(body["site_times"][key])
        assert site == utc.replace(microsecond=0) or abs((site - utc).total_seconds()) < 1
        assert body["site_times"][key].endswith("+09:00"), body["site_times"]


def test_goto_needs_the_page_header(client: Client) -> None:
    r = client.post("/setup/api/telescope/0/goto", {"id": "Vega"}, headers={"Content-Type": "application/json"})
    assert r.status_code == 403


def test_the_alpaca_server_never_imports_the_catalogues(tmp_path: Path) -> None:
    """Start, connect, serve Alpaca and the status feed: PyEphem, OpenNGC and Skyfield stay unloaded."""
    script = textwrap.dedent(f"""
        import json, sys
        from pathlib import Path
        import requests
        from tests.conftest import make_settings
        from alpaca_zwo.server import AlpacaZwoServer
        from alpaca_zwo.config.store import SettingsStore
        from alpaca_zwo.web import setup_routes
        server = AlpacaZwoServer(SettingsStore(make_settings(), Path({str(tmp_path)!r}) / "c.toml"), None,
                                 extra_routes_factory=setup_routes)
        server.start()
        base = f"http://127.0.0.1:{{server.port}}"
        requests.put(base + "/api/v1/telescope/0/connected", data={{"Connected": "true"}}, timeout=10)
        requests.get(base + "/api/v1/telescope/0/rightascension", timeout=10).raise_for_status()
        requests.get(base + "/setup/api/telescope/0/status", timeout=10).raise_for_status()
        names = ("ephem", "pyongc", "skyfield", "alpaca_zwo.catalogue.objects", "alpaca_zwo.catalogue.deepsky",
                 "alpaca_zwo.catalogue.coordinates", "alpaca_zwo.catalogue.naming")
        before = [m for m in names if m in sys.modules]
        requests.get(base + "/setup/api/objects", params={{"q": "M31"}}, timeout=10).raise_for_status()
        after = [m for m in names if m in sys.modules]
        server.stop()
        print(json.dumps({{"before": before, "after": after}}))
    """)
    out = subprocess.run([sys.executable, "-c", script], cwd=REPO, capture_output=True, text=True, timeout=120,
                         check=True)
    seen = json.loads(out.stdout.strip().splitlines()[-1])
    assert seen["before"] == []
    assert {"ephem", "pyongc", "alpaca_zwo.catalogue.objects", "alpaca_zwo.catalogue.deepsky",  # a search loads them:
            "alpaca_zwo.catalogue.coordinates"} <= set(seen["after"])  # the check sees


def test_without_pyephem_the_page_says_what_to_install_and_the_rest_serves(tmp_path: Path) -> None:
    """32-bit ARM installs leave PyEphem and pyongc out (no PyPI wheel): the search, the object panel
    and the sky chart answer 503 with one line naming the package and the pip command; Alpaca reads
    and the status feed are unaffected. ``sys.modules[name] = None`` is how Python itself
    marks a module as absent: ``import ephem`` raises ModuleNotFoundError as on such a machine."""
    script = textwrap.dedent(f"""
        import json, sys
        sys.modules["ephem"] = None
        sys.modules["pyongc"] = None
        from pathlib import Path
        import requests
        from tests.conftest import make_settings
        from alpaca_zwo.server import AlpacaZwoServer
        from alpaca_zwo.config.store import SettingsStore
        from alpaca_zwo.web import setup_routes
        server = AlpacaZwoServer(SettingsStore(make_settings(), Path({str(tmp_path)!r}) / "c.toml"), None,
                                 extra_routes_factory=setup_routes)
        server.start()
        base = f"http://127.0.0.1:{{server.port}}"
        requests.put(base + "/api/v1/telescope/0/connected", data={{"Connected": "true"}}, timeout=10)
        replies = {{}}
        for path in ("/setup/api/objects?q=Vega", "/setup/api/telescope/0/object?id=Vega",
                     "/setup/api/telescope/0/sky", "/setup/api/telescope/0/status",
                     "/api/v1/telescope/0/rightascension"):
            r = requests.get(base + path, timeout=10)
            replies[path] = [r.status_code, r.text]
        server.stop()
        print(json.dumps(replies))
    """)
    out = subprocess.run([sys.executable, "-c", script], cwd=REPO, capture_output=True, text=True, timeout=120,
                         check=True)
    replies = json.loads(out.stdout.strip().splitlines()[-1])
    for path in ("/setup/api/objects?q=Vega", "/setup/api/telescope/0/object?id=Vega", "/setup/api/telescope/0/sky"):
        status, body = replies[path]
        assert status == 503, (path, status, body)
        message = json.loads(body)["error"]
        assert "'ephem'" in message and "pip install ephem" in message and "Traceback" not in message, message
    assert replies["/setup/api/telescope/0/status"][0] == 200
    assert replies["/api/v1/telescope/0/rightascension"][0] == 200
    assert json.loads(replies["/api/v1/telescope/0/rightascension"][1])["ErrorNumber"] == 0
