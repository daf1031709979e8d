"""The setup page's HTTP side against a real server on the emulator: pages, assets, JSON API, security.

Every control is checked through the Alpaca API afterwards, because the page is only useful if
what it changes is exactly what N.I.N.A. and the other clients then see.
"""

from __future__ import annotations

import ast
import http.client
import logging
import math
import socket
import time
from collections.abc import Callable
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import Any

import pytest
import requests

from alpaca_zwo import sky
from alpaca_zwo.config.file import load_settings
from alpaca_zwo.config.settings import EmulatorSettings, ServerSettings, StellariumSettings
from alpaca_zwo.config.store import SettingsStore
from alpaca_zwo.server import AlpacaZwoServer
from alpaca_zwo.sky import SIDEREAL_DEG_S
from alpaca_zwo.web import CSRF_HEADER, setup_routes, static_dir
from tests.conftest import make_settings
from tests.support import AlpacaClient, wait_until

HEADERS = {CSRF_HEADER: "1", "Content-Type": "application/json"}
TIMEOUT = 10


class Client(AlpacaClient):
    """The page's API and the Alpaca API of one server: the shared Alpaca client plus the page's calls."""

    def __init__(self, base: str, client_id: int = 77) -> None:
        super().__init__(base, client_id, timeout=TIMEOUT, call_timeout=TIMEOUT)
        self.api = f"{self.base}/setup/api/telescope/0"

    def status(self) -> dict[str, Any]:
        r = self.session.get(f"{self.api}/status", timeout=TIMEOUT)
        assert r.status_code == 200, r.text
        return r.json()

    def settings(self) -> dict[str, Any]:
        r = self.session.get(f"{self.api}/settings", timeout=TIMEOUT)
        assert r.status_code == 200, r.text
        return r.json()

    def post(self, path: str, body: object = None, headers: dict[str, str] | None = None) -> requests.Response:
        return self.session.post(f"{self.base}{path}", json=body if body is not None else {},
                                 headers=headers if headers is not None else HEADERS, timeout=TIMEOUT)

    def action(self, name: str, body: object = None) -> dict[str, Any]:
        r = self.post(f"/setup/api/telescope/0/action/{name}", body)
        assert r.status_code == 200, r.text
        return r.json()

    def change(self, body: dict[str, Any]) -> dict[str, Any]:
        r = self.post("/setup/api/telescope/0/settings", body)
        assert r.status_code == 200, r.text
        return r.json()


def raw_get(port: int, path: str) -> tuple[int, bytes]:
    """GET exactly ``path``: requests/urllib3 would normalise the dot segments these tests need."""
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=TIMEOUT)
    try:
        conn.putrequest("GET", path, skip_accept_encoding=True)
        conn.endheaders()
        response = conn.getresponse()
        return response.status, response.read()
    finally:
        conn.close()


@pytest.fixture
def client(base_url: str) -> Client:
    return Client(base_url)


@pytest.fixture
def connected(client: Client) -> Client:
    """A client that has connected the telescope through the Alpaca API, as N.I.N.A. would."""
    client.command("connected", Connected="true")
    wait_until(lambda: client.status()["position"] is not None, what="a first position")
    return client


# --- pages and assets ----------------------------------------------------------------------------


def test_setup_pages_are_html_with_security_headers(client: Client) -> None:
    for path in ("/setup", "/setup/v1/telescope/0/setup"):
        r = client.session.get(client.base + path, timeout=TIMEOUT)
        assert r.status_code == 200
        assert r.headers["Content-Type"].startswith("text/html")
        assert "<title>alpaca-zwo setup</title>" in r.text
        assert r.headers["Cache-Control"] == "no-cache"
        assert "frame-ancestors 'none'" in r.headers["Content-Security-Policy"]
        assert r.headers["X-Content-Type-Options"] == "nosniff"
        # Nothing may come from the internet: every asset is local.
        assert "http://" not in r.text and "https://" not in r.text


@pytest.mark.parametrize("path", [
    "/setup/v1/telescope/1/setup",
    "/setup/v1/telescope/00/setup",
    "/setup/v1/telescope/-1/setup",
    "/setup/v1/camera/0/setup",
    "/setup/v1/Telescope/0/setup",
    "/setup/v1/telescope/0/connect",
])
def test_unknown_device_setup_page_is_403(client: Client, path: str) -> None:
    r = client.session.get(client.base + path, timeout=TIMEOUT)
    assert r.status_code == 403
    assert r.headers["Content-Type"].startswith("text/html")  # the Management API documents HTML here
    assert "No setup page for" in r.text


@pytest.mark.parametrize(("name", "content_type"), [
    ("app.js", "text/javascript"),
    ("style.css", "text/css"),
    ("index.html", "text/html"),
    ("favicon.svg", "image/svg+xml"),
])
def test_static_assets_have_types_and_revalidate(client: Client, name: str, content_type: str) -> None:
    url = f"{client.base}/setup/static/{name}"
    r = client.session.get(url, timeout=TIMEOUT)
    assert r.status_code == 200
    assert r.headers["Content-Type"].startswith(content_type)
    assert r.headers["Cache-Control"] == "no-cache"
    assert r.content == (static_dir() / name).read_bytes()
    again = client.session.get(url, headers={"If-None-Match": r.headers["ETag"]}, timeout=TIMEOUT)
    assert again.status_code == 304
    assert again.content == b""


def test_page_assets_reference_only_local_files() -> None:
    for name in ("index.html", "app.js", "style.css"):
        text = (static_dir() / name).read_text()
        assert "https://" not in text and "//cdn" not in text and "@import" not in text, name


TRAVERSALS = [
    "/setup/static/../setup.py",
    "/setup/static/..%2fsetup.py",
    "/setup/static/..%2F..%2Fpyproject.toml",
    "/setup/static/%2e%2e%2f%2e%2e%2fpyproject.toml",
    "/setup/static/%2e%2e/%2e%2e/pyproject.toml",
    "/setup/static/..",
    "/setup/static/%2e%2e",
    "/setup/static/%2fetc%2fpasswd",
    "/setup/static//etc/passwd",
    "/setup/static/%2Fetc%2Fpasswd",
    "/setup/static/..%5c..%5cpyproject.toml",
    "/setup/static/..\\..\\pyproject.toml",
    "/setup/static/C:%5cWindows%5cwin.ini",
    "/setup/static/.%2e/.%2e/alpaca_zwo/config.py",
    "/setup/static/app.js%00.html",
    "/setup/static/index.html/",
    "/setup/static/.gitignore",
    "/setup/static/%252e%252e%252fpyproject.toml",
]


@pytest.mark.parametrize("path", TRAVERSALS)
def test_static_paths_cannot_leave_the_static_directory(live_server: AlpacaZwoServer, path: str) -> None:
    status, body = raw_get(live_server.port, path)
    assert status in (400, 404), (path, status)
    for secret in (b"[project]", b"root:", b"def setup_routes", b"[fonts]", b"import "):
        assert secret not in body, (path, secret)


def test_static_symlinks_are_not_followed(tmp_path: Path, server_factory: Callable[..., AlpacaZwoServer]) -> None:
    root = tmp_path / "static"
    root.mkdir()
    (root / "index.html").write_text("<!DOCTYPE html><title>t</title>")
    (root / "ok.js").write_text("// fine\n")
    secret = tmp_path / "secret.js"
    secret.write_text("SECRET")
    (root / "leak.js").symlink_to(secret)
    (root / "inner.js").symlink_to(root / "ok.js")  # even a link that stays inside is refused
    (root / "dir.css").mkdir()

    store = SettingsStore(make_settings(), tmp_path / "config.toml")
    server = AlpacaZwoServer(store, extra_routes_factory=lambda s: setup_routes(s, static_root=root))
    server.start()
    try:
        assert raw_get(server.port, "/setup/static/ok.js") == (200, b"// fine\n")
        for name in ("leak.js", "inner.js", "dir.css", "secret.js", "..%2fsecret.js"):
            status, body = raw_get(server.port, f"/setup/static/{name}")
            assert status == 404, name
            assert b"SECRET" not in body
    finally:
        server.stop()


# --- status ----------------------------------------------------------------------------------


def test_status_before_any_client_connects(client: Client) -> None:
    s = client.status()
    assert s["device"] == 0
    assert s["connected"] is False
    assert s["link"]["state"] == "closed"
    assert s["position"] is None
    assert s["slewing"] is False
    assert len(s["sky"]["floor"]) == 120
    assert s["sky"]["latitude"] == pytest.approx(51.4769)


def test_status_lists_no_bridges_when_none_runs(client: Client) -> None:
    assert client.status()["bridges"] == []
    assert client.session.get(f"{client.base}/setup/api/server", timeout=TIMEOUT).json()["bridges"] == []


def test_status_shows_a_running_bridge_and_its_programs(server_factory: Callable[..., AlpacaZwoServer]) -> None:
    settings = make_settings(stellarium=StellariumSettings(enabled=True, host="127.0.0.1", port=0))
    server = server_factory(settings)
    client = Client(f"http://127.0.0.1:{server.port}")
    (bridge,) = client.status()["bridges"]
    assert bridge["name"] == "stellarium" and bridge["enabled"] is True and bridge["port"] > 0
    with socket.create_connection(("127.0.0.1", bridge["port"]), timeout=TIMEOUT):
        shown = wait_until(lambda: client.status()["bridges"][0]["clients"], what="the Stellarium program listed")
        assert len(shown) == 1
    wait_until(lambda: not client.status()["bridges"][0]["clients"], what="the program gone from the list")


@pytest.mark.parametrize(("preset", "shown"), [("am5-1.9.2", ("AM5", "1.9.2")), ("am5n-1.6.3", ("AM5N", "1.6.3"))])
def test_the_built_in_emulator_is_the_configured_preset(server_factory: Callable[..., AlpacaZwoServer], preset: str,
                                                         shown: tuple[str, str]) -> None:
    server = server_factory(make_settings(emulator=EmulatorSettings(speed=1.0, baud=0, preset=preset)))
    client = Client(f"http://127.0.0.1:{server.port}")
    client.command("connected", Connected="true")
    mount = wait_until(lambda: client.status()["mount"], what="the mount's identity")
    assert (mount["model"], mount["firmware"]) == shown


def test_status_matches_the_alpaca_api(connected: Client) -> None:
    s = connected.status()
    assert s["connected"] is True
    assert s["link"]["state"] == "connected"
    assert s["initialised"] is True
    assert s["mount"]["model"] == "AM5"
    pos = s["position"]
    ra, dec = connected.value("rightascension"), connected.value("declination")
    assert pos["ra"] == pytest.approx(ra, abs=2 / 3600)
    assert pos["dec"] == pytest.approx(dec, abs=2 / 3600)
    assert pos["alt"] == pytest.approx(connected.value("altitude"), abs=0.05)
    assert abs((pos["az"] - connected.value("azimuth") + 180) % 360 - 180) < 0.5  # at the pole az is touchy
    assert s["time"]["lst"] == pytest.approx(connected.value("siderealtime"), abs=5 / 3600)
    assert 0 <= pos["age_s"] < 5
    assert s["pier_side"] in ("east", "west")
    assert {0: "east", 1: "west"}[connected.value("sideofpier")] == s["pier_side"]
    assert s["tracking"] is connected.value("tracking")
    assert s["at_park"] is False
    assert s["guide_rate"] == pytest.approx(connected.value("guideraterightascension") / SIDEREAL_DEG_S, abs=0.01)
    utc = datetime.fromisoformat(s["time"]["utc"].replace("Z", "+00:00"))
    assert abs((utc - datetime.now(timezone.utc)).total_seconds()) < 5
    # The Alpaca client is listed as connected; the page itself has not connected.
    rows = [c for c in s["clients"] if not c["setup_page"]]
    assert any(c["client_id"] == connected.client_id and c["connected"] for c in rows)
    assert s["page_connected"] is False


def test_status_shows_slew_and_target(connected: Client) -> None:
    connected.command("tracking", Tracking="true")
    lst = connected.value("siderealtime")
    ra = (lst + 2.0) % 24  # HA -2 h, Dec 30: well above the horizon from latitude 51
    connected.command("slewtocoordinatesasync", RightAscension=ra, Declination=30)
    s = connected.status()
    assert s["slewing"] is True
    assert s["target"]["ra"] == pytest.approx(ra, abs=1e-6)
    assert s["target"]["dec"] == pytest.approx(30)
    wait_until(lambda: not connected.status()["slewing"], 90, "the GOTO to finish")
    done = connected.status()
    assert done["target"] is None
    assert done["position"]["ra"] == pytest.approx(ra, abs=3 / 3600)
    assert done["position"]["dec"] == pytest.approx(30, abs=3 / 3600)
    assert done["pier_side"] == "west"
    assert done["meridian"]["minutes_to_limit"] == pytest.approx(120 * 0.99727, abs=2)


# --- controls ----------------------------------------------------------------------------------


def test_page_connects_and_releases_the_mount(client: Client) -> None:
    client.action("connect")
    s = wait_until(lambda: (st := client.status())["position"] is not None and st, what="a position")
    assert s["connected"] is True and s["page_connected"] is True
    assert any(c["setup_page"] and c["connected"] for c in s["clients"])
    # The page's connection is its own: an Alpaca client is not connected by it.
    assert client.value("connected") is False
    client.action("disconnect")
    assert client.status()["page_connected"] is False


def test_tracking_and_rates_are_visible_through_alpaca(connected: Client) -> None:
    connected.action("tracking", {"on": True})
    assert connected.value("tracking") is True
    connected.action("tracking", {"on": False})
    assert connected.value("tracking") is False
    connected.action("tracking_rate", {"rate": 1})
    assert connected.value("trackingrate") == 1
    assert connected.status()["tracking_rate_name"] == "lunar"
    connected.action("tracking_rate", {"rate": 0})
    connected.action("guide_rate", {"rate": 0.3})
    assert connected.value("guideraterightascension") == pytest.approx(0.3 * SIDEREAL_DEG_S, rel=1e-3)
    assert connected.value("guideratedeclination") == pytest.approx(0.3 * SIDEREAL_DEG_S, rel=1e-3)
    assert connected.status()["guide_rate"] == pytest.approx(0.3)


def test_jog_moves_and_stops(connected: Client) -> None:
    before = connected.status()["position"]
    connected.action("move", {"axis": 1, "rate": -20 * SIDEREAL_DEG_S})
    assert connected.value("slewing") is True
    assert connected.status()["moving_axes"] == [1]
    wait_until(lambda: connected.status()["position"]["dec"] < before["dec"] - 0.05, 20, "Dec to decrease")
    connected.action("move", {"axis": 1, "rate": 0})
    wait_until(lambda: not connected.value("slewing"), 10, "the move to stop")
    assert connected.status()["moving_axes"] == []


def test_stop_aborts_a_goto(connected: Client) -> None:
    connected.command("tracking", Tracking="true")
    lst = connected.value("siderealtime")
    connected.command("slewtocoordinatesasync", RightAscension=(lst - 3.0) % 24, Declination=-5)
    wait_until(lambda: connected.status()["position"]["dec"] < 80, 30, "the slew to get going")
    connected.action("abort")
    wait_until(lambda: not connected.value("slewing"), 10, "Slewing to clear")
    # The axes brake for a moment (the mount decelerates); then Dec must stay put.
    readings: list[float] = []

    def settled() -> bool:
        readings.append(connected.status()["position"]["dec"])
        return len(readings) > 5 and max(readings[-5:]) - min(readings[-5:]) < 5 / 3600

    wait_until(settled, 15, "the axes to come to rest")
    assert readings[-1] > 40  # it stopped far short of the target at Dec -5
    assert connected.status()["slewing"] is False


def test_park_unpark_home_and_set_park(connected: Client) -> None:
    connected.action("park")
    wait_until(lambda: connected.value("atpark"), 60, "AtPark")
    s = connected.status()
    assert s["at_park"] is True and s["tracking"] is False
    r = connected.post("/setup/api/telescope/0/action/move", {"axis": 0, "rate": SIDEREAL_DEG_S})
    assert r.status_code == 409
    assert "parked" in r.json()["error"]
    connected.action("abort")  # Stop is always allowed, even when parked
    connected.action("unpark")
    assert connected.value("atpark") is False
    connected.action("find_home")
    wait_until(lambda: not connected.value("slewing"), 60, "the home slew")
    assert connected.value("athome") is True
    connected.command("tracking", Tracking="true")
    lst = connected.value("siderealtime")
    connected.command("slewtocoordinatesasync", RightAscension=(lst + 1.0) % 24, Declination=20)
    wait_until(lambda: not connected.value("slewing"), 90, "the GOTO")
    park = connected.action("set_park")["park"]
    assert park["mode"] == "custom"
    assert park["ha_hours"] == pytest.approx(-1.0, abs=0.01)
    assert park["dec_deg"] == pytest.approx(20, abs=0.01)
    assert connected.settings()["park"] == park


def test_time_from_the_browser_sets_utcdate(connected: Client) -> None:
    wanted = datetime.now(timezone.utc) + timedelta(hours=1)
    connected.action("time", {"utc": wanted.isoformat().replace("+00:00", "Z")})
    utc = datetime.fromisoformat(connected.value("utcdate").replace("Z", "+00:00"))
    assert abs((utc - wanted).total_seconds()) < 5
    assert connected.status()["time"]["offset_s"] == pytest.approx(3600, abs=5)
    r = connected.post("/setup/api/telescope/0/action/time", {"utc": "2025-01-01T00:00:00"})
    assert r.status_code == 400 and "zone" in r.json()["error"]


def test_control_errors_are_json(client: Client) -> None:
    r = client.post("/setup/api/telescope/0/action/park")
    assert r.status_code == 409  # not connected
    assert "connected" in r.json()["error"].lower()
    assert r.json()["number"] == 0x407
    for body, word in (({"axis": 5, "rate": 0}, "axis"), ({"axis": 0}, "rate"), ({"axis": 0, "rate": "x"}, "rate")):
        r = client.post("/setup/api/telescope/0/action/move", body)
        assert r.status_code == 400 and word in r.json()["error"], body
    r = client.post("/setup/api/telescope/0/action/selfdestruct")
    assert r.status_code == 404 and "unknown action" in r.json()["error"]
    r = client.post("/setup/api/telescope/3/action/park")
    assert r.status_code == 404
    assert client.session.get(f"{client.base}/setup/api/telescope/1/status", timeout=TIMEOUT).status_code == 404


# --- settings ----------------------------------------------------------------------------------


def test_site_settings_apply_to_the_alpaca_api(client: Client) -> None:
    result = client.change({"site": {"latitude": -33.8568, "longitude": 151.2153, "elevation": 58.5}})
    assert result["site"] == {"latitude": -33.8568, "longitude": 151.2153, "elevation": 58.5, "gpsd": ""}
    assert client.value("sitelatitude") == -33.8568
    assert client.value("sitelongitude") == 151.2153
    assert client.value("siteelevation") == 58.5
    sky_view = client.status()["sky"]
    assert sky_view["pole"] == [180.0, pytest.approx(33.8568)]


def test_bad_settings_change_nothing(client: Client) -> None:
    before = client.settings()
    cases = [
        {"site": {"latitude": 95}},
        {"site": {"latitude": 10, "longitude": "east"}},
        {"site": {"latitude": 10, "altitude": 3}},
        {"limits": {"min_altitude_deg": 80}},
        {"limits": {"horizon": [[10, 5], [10, 6]]}},
        {"limits": {"horizon": "low"}},
        {"park": {"mode": "anywhere"}},
        {"safety": {"moveaxis_watchdog_s": 0}},
        {"safety": {"not_a_key": 1}},
        {"colour": "red"},
        {"park": 3},
        {"device": {"unique_id": "mine"}},
        {"device": {"name": ""}},
        {"site": {"latitude": 10}, "park": {"ha_hours": 13}},
    ]
    for body in cases:
        r = client.post("/setup/api/telescope/0/settings", body)
        assert r.status_code == 400, (body, r.text)
        assert r.json()["error"], body
    assert client.settings() == before


def test_mount_settings_need_the_mount(client: Client) -> None:
    r = client.post("/setup/api/telescope/0/settings", {"buzzer": 0})
    assert r.status_code == 409
    assert "connect" in r.json()["error"]


def test_mount_settings_round_trip(connected: Client) -> None:
    s = connected.change({"meridian": {"track_after": True, "limit_degrees": 10},
                          "mount_limits": {"enabled": True, "upper": 80, "lower": 10},
                          "heavy_duty": True, "buzzer": 0})
    mount = s["mount"]
    assert mount["meridian"]["track_after"] is True and mount["meridian"]["limit_degrees"] == 10
    assert (mount["limits_enabled"], mount["upper_limit"], mount["lower_limit"]) == (True, 80, 10)
    assert mount["heavy_duty"] is True and mount["buzzer"] == 0
    assert s["limits"]["meridian_limit_deg"] == 10 and s["limits"]["meridian_track_past"] is True
    # A fresh read from the mount agrees.
    assert connected.settings()["mount"] == mount
    status = connected.status()
    assert status["meridian"]["limit_deg"] == 10
    assert status["sky"]["mount_limits"] == {"lower": 10, "upper": 80}
    assert status["sky"]["flip_line"]
    # DestinationSideOfPier follows the new limit at once: HA +0.3 h (4.5°) is within 10° past the meridian.
    lst = connected.value("siderealtime")
    ra = (lst - 0.3) % 24
    assert connected.value("destinationsideofpier", RightAscension=ra, Declination=40) == int(sky.PierSide.WEST)
    for body in ({"buzzer": 3}, {"mount_limits": {"upper": 50}}, {"heavy_duty": "yes"},
                 {"meridian": {"track_after": True, "limit_degrees": 20}}):
        r = connected.post("/setup/api/telescope/0/settings", body)
        assert r.status_code == 400, body
    # All or nothing: a bad file-held value stops the mount-held ones from being sent.
    r = connected.post("/setup/api/telescope/0/settings", {"buzzer": 2, "limits": {"min_altitude_deg": 99}})
    assert r.status_code == 400
    assert connected.settings()["mount"]["buzzer"] == 0
    connected.change({"meridian": {"track_after": False, "limit_degrees": 0}, "mount_limits": {"enabled": False},
                      "heavy_duty": False, "buzzer": 1})
    assert connected.value("destinationsideofpier", RightAscension=ra, Declination=40) == int(sky.PierSide.EAST)


def test_the_page_and_destinationsideofpier_draw_one_flip_line(connected: Client) -> None:
    """A negative limit is the flip line whatever "track past" says (ZWO: "stop n° before the meridian";
    sky.flip_line_deg). The page once drew the meridian for it (``limit if track_after``) while
    DestinationSideOfPier predicted with the limit: a target 4.5° before the meridian read pierEast from
    DestinationSideOfPier and "before the flip line" on the page."""
    connected.change({"meridian": {"track_after": False, "limit_degrees": -10}})
    status = connected.status()
    assert status["meridian"]["track_after"] is False
    assert status["meridian"]["limit_deg"] == -10
    assert status["sky"]["flip_line"], "the page draws the flip line 10° before the meridian"
    lst = connected.value("siderealtime")

    def destination(ha_hours: float) -> int:
        return int(connected.value("destinationsideofpier", RightAscension=(lst - ha_hours) % 24, Declination=40))

    # Either side of the page's line, DestinationSideOfPier agrees with it (HA -0.3 h = -4.5°, -0.9 h = -13.5°).
    assert destination(-0.3) == int(sky.PierSide.EAST)
    assert destination(-0.9) == int(sky.PierSide.WEST)


def test_horizon_limits_refuse_gotos(connected: Client) -> None:
    s = connected.change({"limits": {"min_altitude_deg": 20, "horizon": [[90, 30], [270, 5]]}})
    assert s["limits"]["horizon"] == [[90.0, 30.0], [270.0, 5.0]]
    floor = dict((az, alt) for az, alt in connected.status()["sky"]["floor"])
    assert floor[90] == 30 and floor[270] == 20 and floor[0] == pytest.approx(20)
    lst = connected.value("siderealtime")
    r = connected.session.put(f"{connected.base}/api/v1/telescope/0/slewtocoordinatesasync",
                           data={"RightAscension": (lst + 5) % 24, "Declination": 0, "ClientID": 77}, timeout=TIMEOUT)
    assert r.json()["ErrorNumber"] == 0x401  # HA -5 h, Dec 0: low in the east, under the 30° profile


def test_park_safety_and_name(base_url: str, client: Client) -> None:
    s = client.change({"park": {"mode": "custom", "ha_hours": 1.5, "dec_deg": 45},
                       "safety": {"moveaxis_watchdog_s": 5, "on_shutdown": "park"},
                       "device": {"name": "Backyard AM5"}})
    assert s["park"] == {"mode": "custom", "ha_hours": 1.5, "dec_deg": 45.0}
    assert s["safety"] == {"moveaxis_watchdog_s": 5.0, "on_shutdown": "park", "monitor": "", "roof": "",
                           "poll_s": 5.0, "unreachable_s": 30.0, "on_unsafe": "park"}
    assert s["device"]["name"] == "Backyard AM5"
    devices = requests.get(f"{base_url}/management/v1/configureddevices", timeout=TIMEOUT).json()["Value"]
    assert devices[0]["DeviceName"] == "Backyard AM5"
    assert client.value("name") == "Backyard AM5"


def test_observatory_settings_are_checked_and_saved(client: Client) -> None:
    """The page's Observatory group: a URL that is not an Alpaca SafetyMonitor (or Dome) is a 400 naming the
    key, and nothing is saved; valid ones are saved in their canonical spelling."""
    bad = client.post("/setup/api/telescope/0/settings",
                      {"safety": {"monitor": "http://192.168.1.30:11111/api/v1/dome/0"}})
    assert bad.status_code == 400 and "safety.monitor" in bad.text, bad.text
    assert client.settings()["safety"]["monitor"] == ""
    s = client.change({"safety": {"monitor": "HTTP://127.0.0.1:9/api/v1/SafetyMonitor/0/", "roof": "",
                                  "poll_s": 2, "unreachable_s": 20, "on_unsafe": "stop"}})
    assert {k: s["safety"][k] for k in ("monitor", "poll_s", "unreachable_s", "on_unsafe")} == {
        "monitor": "http://127.0.0.1:9/api/v1/safetymonitor/0", "poll_s": 2.0, "unreachable_s": 20.0,
        "on_unsafe": "stop"}
    # Nothing listens on port 9: unknown (motion refused) until unreachable_s, then unsafe.
    wait_until(lambda: client.status()["safety"]["state"] == "unknown", 10, "the interlock to wait for the monitor")
    assert client.status()["safety"]["safe"] is False
    client.change({"safety": {"monitor": ""}})
    wait_until(lambda: client.status()["safety"]["state"] == "off", 10, "the interlock to turn off")


def test_refusals_name_what_the_page_calls_things(connected: Client) -> None:
    """The page's refusals say "turning tracking on", not Alpaca's "Tracking=true"; Alpaca clients still get
    the member's name (their authors look for it)."""
    connected.action("park")
    wait_until(lambda: connected.status()["at_park"], 60, "the mount to park")
    r = connected.post("/setup/api/telescope/0/action/tracking", {"on": True})
    assert r.status_code == 409, r.text
    assert r.json()["error"] == "turning tracking on is not allowed while the telescope is parked; unpark it first"
    alpaca = connected.put("tracking", Tracking="true")
    assert alpaca.error_number != 0 and "Tracking=true" in alpaca.error_message, alpaca


def test_the_time_source_is_checked_saved_and_in_effect(tmp_path: Path,
                                                       server_factory: Callable[..., AlpacaZwoServer]) -> None:
    """time.source (issue 31) from the page: a value that is not auto, host or mount, or another key, is a 400
    and nothing changes; a valid one is in the running server at once, in the file, and after a restart."""
    first = server_factory(make_settings(), config_name="time.toml")
    client = Client(f"http://127.0.0.1:{first.port}")
    assert client.settings()["time"] == {"source": "auto"}
    for bad in ({"source": "sundial"}, {"source": 3}, {"zone": "UTC"}, "host"):
        r = client.post("/setup/api/telescope/0/settings", {"time": bad})
        assert r.status_code == 400, (bad, r.status_code, r.text)
        assert client.settings()["time"] == {"source": "auto"}
    assert client.change({"time": {"source": "host"}})["time"] == {"source": "host"}
    assert first.settings.time.source == "host"  # the time keeper's policy reads this on each decision
    client.session.close()
    first.stop()
    second = server_factory(load_settings(tmp_path / "time.toml"), config_name="time.toml")
    assert Client(f"http://127.0.0.1:{second.port}").settings()["time"] == {"source": "host"}


def test_settings_persist_across_a_restart(tmp_path: Path, server_factory: Callable[..., AlpacaZwoServer]) -> None:
    first = server_factory(make_settings(), config_name="persist.toml")
    c1 = Client(f"http://127.0.0.1:{first.port}")
    c1.change({"site": {"latitude": 40.4168, "longitude": -3.7038, "elevation": 667},
               "park": {"mode": "custom", "ha_hours": -2, "dec_deg": 10},
               "limits": {"min_altitude_deg": 12.5, "horizon": [[100, 20]]},
               "device": {"name": "Madrid"}})
    c1.session.close()
    first.stop()

    second = server_factory(load_settings(tmp_path / "persist.toml"), config_name="persist.toml")
    c2 = Client(f"http://127.0.0.1:{second.port}")
    s = c2.settings()
    assert s["site"] == {"latitude": 40.4168, "longitude": -3.7038, "elevation": 667.0, "gpsd": ""}
    assert s["park"] == {"mode": "custom", "ha_hours": -2.0, "dec_deg": 10.0}
    assert s["limits"]["min_altitude_deg"] == 12.5 and s["limits"]["horizon"] == [[100.0, 20.0]]
    assert c2.value("sitelatitude") == 40.4168
    assert c2.value("sitelongitude") == -3.7038
    assert c2.value("name") == "Madrid"


def test_network_settings_are_saved_for_the_next_start(tmp_path: Path, client: Client,
                                                       live_server: AlpacaZwoServer) -> None:
    r = client.post("/setup/api/server", {"port": 12345, "discovery_port": 0, "location": "garden"})
    assert r.status_code == 200, r.text
    assert r.json()["restart_required"] is True
    saved = load_settings(tmp_path / "config.toml")
    assert saved.server.port == 12345 and saved.server.location == "garden"
    assert live_server.port != 12345  # not applied to the running server
    r = client.post("/setup/api/server", {"port": 99999})
    assert r.status_code == 400
    r = client.post("/setup/api/server", {"basic_auth_password": "x"})
    assert r.status_code == 400
    info = client.session.get(f"{client.base}/setup/api/server", timeout=TIMEOUT).json()
    assert info["version"] and info["devices"][0]["number"] == 0 and info["port"] == live_server.port


# --- same-origin protection ------------------------------------------------------------------


def test_state_changes_need_the_custom_header(connected: Client) -> None:
    connected.command("tracking", Tracking="false")
    r = connected.post("/setup/api/telescope/0/action/tracking", {"on": True},
                       headers={"Content-Type": "application/json"})
    assert r.status_code == 403
    assert r.headers["Content-Type"].startswith("text/plain")
    assert connected.value("tracking") is False


@pytest.mark.parametrize("extra", [
    {"Origin": "http://evil.example"},
    {"Origin": "null"},
    {"Origin": "http://127.0.0.1:1"},
    {"Origin": "https://127.0.0.1"},
    {"Origin": "file://"},
    {"Sec-Fetch-Site": "cross-site"},
    {"Sec-Fetch-Site": "same-site"},
])
def test_cross_origin_posts_are_refused(connected: Client, extra: dict[str, str]) -> None:
    connected.command("tracking", Tracking="false")
    for path, body in (("/setup/api/telescope/0/action/tracking", {"on": True}),
                       ("/setup/api/telescope/0/settings", {"site": {"latitude": 1}}),
                       ("/setup/api/server", {"location": "x"})):
        r = connected.post(path, body, headers={**HEADERS, **extra})
        assert r.status_code == 403, (path, extra)
        assert r.headers["Content-Type"].startswith("text/plain")
    assert connected.value("tracking") is False
    assert connected.value("sitelatitude") == pytest.approx(51.4769)


def test_same_origin_posts_are_accepted(connected: Client, live_server: AlpacaZwoServer) -> None:
    origin = f"http://127.0.0.1:{live_server.port}"
    r = connected.post("/setup/api/telescope/0/action/tracking", {"on": True},
                       headers={**HEADERS, "Origin": origin, "Sec-Fetch-Site": "same-origin"})
    assert r.status_code == 200, r.text
    assert connected.value("tracking") is True


def test_bodies_must_be_json_objects(client: Client) -> None:
    url = f"{client.base}/setup/api/telescope/0/settings"
    r = client.session.post(url, data="{not json", headers=HEADERS, timeout=TIMEOUT)
    assert r.status_code == 400 and "JSON" in r.json()["error"]
    r = client.session.post(url, data="[1, 2]", headers=HEADERS, timeout=TIMEOUT)
    assert r.status_code == 400 and "object" in r.json()["error"]
    form = {CSRF_HEADER: "1", "Content-Type": "application/x-www-form-urlencoded"}
    r = client.session.post(url, data="site=1", headers=form, timeout=TIMEOUT)
    assert r.status_code == 415
    r = client.session.post(url, data=b"\xff\xfe", headers=HEADERS, timeout=TIMEOUT)
    assert r.status_code == 400


def test_gets_do_not_change_state(client: Client) -> None:
    for path in ("/setup/api/telescope/0/action/connect", "/setup/api/telescope/0/action/park"):
        r = client.session.get(client.base + path, timeout=TIMEOUT)
        assert r.status_code == 405, path
    assert client.status()["connected"] is False


def test_basic_auth_covers_the_setup_page(server_factory: Callable[..., AlpacaZwoServer]) -> None:
    settings = make_settings(server=ServerSettings(host="127.0.0.1", port=0, discovery_port=0,
                                                   basic_auth_user="astro", basic_auth_password="s3cret"))
    server = server_factory(settings)
    base = f"http://127.0.0.1:{server.port}"
    for path in ("/setup", "/setup/static/app.js", "/setup/api/telescope/0/status", "/setup/api/log.txt"):
        assert requests.get(base + path, timeout=TIMEOUT).status_code == 401, path
        assert requests.get(base + path, auth=("astro", "s3cret"), timeout=TIMEOUT).status_code == 200, path
    r = requests.post(base + "/setup/api/telescope/0/action/connect", json={}, headers=HEADERS, timeout=TIMEOUT)
    assert r.status_code == 401


# --- diagnostics ----------------------------------------------------------------------------------


def test_trace_shows_the_serial_exchanges(connected: Client) -> None:
    r = connected.session.get(f"{connected.api}/trace", timeout=TIMEOUT)
    entries = r.json()["entries"]
    requests_sent = [e["request"] for e in entries]
    assert ":GVP#" in requests_sent and ":GMEQ#" in requests_sent
    last = entries[-1]["time"]
    newer = connected.session.get(f"{connected.api}/trace", params={"after": last}, timeout=TIMEOUT).json()["entries"]
    assert all(e["time"] > last for e in newer)
    text = connected.session.get(f"{connected.api}/trace.txt", timeout=TIMEOUT)
    assert text.headers["Content-Disposition"].startswith("attachment;")
    assert ":GVP#" in text.text
    assert connected.session.get(f"{connected.api}/trace", params={"after": "nan"}, timeout=TIMEOUT).status_code == 400


def test_log_view_and_download(client: Client, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="alpaca_zwo")
    client.change({"park": {"mode": "home"}})
    entries = client.session.get(f"{client.base}/setup/api/log", timeout=TIMEOUT).json()["entries"]
    assert any("settings changed: park" in e["message"] for e in entries)
    last = entries[-1]["seq"]
    assert client.session.get(f"{client.base}/setup/api/log", params={"after": last},
                           timeout=TIMEOUT).json()["entries"] == []
    r = client.session.get(f"{client.base}/setup/api/log.txt", timeout=TIMEOUT)
    assert r.status_code == 200
    assert r.headers["Content-Type"].startswith("text/plain")
    assert r.headers["Content-Disposition"].startswith('attachment; filename="alpaca-zwo-log-')
    assert "settings changed: park" in r.text


def test_status_never_waits_for_the_mount(connected: Client) -> None:
    """A slow mount line must not slow the page: status is served from snapshots."""
    starts = []
    for _ in range(20):
        started = time.perf_counter()
        connected.status()
        starts.append(time.perf_counter() - started)
    assert sorted(starts)[len(starts) // 2] < 0.05
    assert not math.isnan(sum(starts))


def test_the_web_package_talks_to_the_server_only_through_the_facade() -> None:
    """Layering: web/ may import the facade and itself, never the mount, link or Telescope directly; besides,
    only what holds no server state: the errors, the pure sky arithmetic and the object catalogue."""
    package = Path(__file__).resolve().parents[2] / "alpaca_zwo" / "web"
    stateless = ("..facade", ".._exceptions", "..sky", "..catalogue")
    for module in sorted(package.glob("*.py")):
        tree = ast.parse(module.read_text(), str(module))
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.level:
                target = "." * node.level + (node.module or "")
                allowed = node.level == 1 or target in stateless or target.startswith("..catalogue.")
                assert allowed, f"{module.name} imports {target}"
            elif isinstance(node, ast.Import | ast.ImportFrom):
                names = [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module or ""]
                assert not any(n.startswith("alpaca_zwo") for n in names), f"{module.name} imports {names}"
        assert "mount.link" not in module.read_text(), module.name
        assert ".motion.motion" not in module.read_text(), module.name
    # Nor does the facade reach past the Telescope's parts into theirs (the link behind the mount, the
    # supervisor's fields): the parts offer accessors (Connection.link_status, MotionSupervisor.running).
    facade = (package.parent / "facade.py").read_text()
    assert ".mount.link." not in facade and ".motion.motion" not in facade
