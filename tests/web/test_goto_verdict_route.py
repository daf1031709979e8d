"""The page's GoTo verdict over HTTP (issue 33 item 2): ``GET /setup/api/telescope/{n}/goto/verdict?ra=&dec=``
and the object card's ``verdict``, against a real server on the emulator.

Bad input gets a 400 with a sentence a person can act on, never a 500; a good one gets the verdict the
GoTo itself would reach (``Telescope.goto_limit``, then the state a GoTo needs), and a GoTo through the
page agrees with it.
"""

from __future__ import annotations

import json

import pytest

from alpaca_zwo.config.settings import EmulatorSettings
from alpaca_zwo.server import AlpacaZwoServer
from alpaca_zwo.telescope import pointing
from tests.conftest import ServerFactory, make_settings
from tests.support import wait_until
from tests.web.test_setup_api import TIMEOUT, Client

ROUTE = "/setup/api/telescope/{n}/goto/verdict"


@pytest.fixture
def server(server_factory: ServerFactory) -> AlpacaZwoServer:
    return server_factory(make_settings(emulator=EmulatorSettings(speed=10.0, baud=0)))


@pytest.fixture
def client(server: AlpacaZwoServer) -> Client:
    return Client(f"http://127.0.0.1:{server.port}")


def connect(client: Client) -> None:
    client.command("connected", Connected="true")
    wait_until(lambda: client.status()["position"] is not None, what="a first position")


def verdict(client: Client, query: str, number: int = 0) -> tuple[int, dict[str, object]]:
    r = client.session.get(f"{client.base}{ROUTE.format(n=number)}?{query}", timeout=TIMEOUT)
    assert r.headers["Content-Type"].startswith("application/json"), r.text
    return r.status_code, r.json()


def place(server: AlpacaZwoServer, azimuth: float, altitude: float) -> tuple[float, float]:
    """The RA/Dec at ``azimuth``/``altitude`` now (the server's sidereal time)."""
    telescope = server.telescopes[0]
    return pointing.radec_from_altaz(telescope.settings, telescope.clock.lst(), azimuth, altitude)


def at(server: AlpacaZwoServer, azimuth: float, altitude: float) -> str:
    ra, dec = place(server, azimuth, altitude)
    return f"ra={ra!r}&dec={dec!r}"


@pytest.mark.parametrize(("query", "says"), [
    ("", "ra: give hours as a decimal number, such as ra=5.5881"),
    ("ra=5.5", "dec: give degrees as a decimal number, such as dec=-5.391"),
    ("ra=&dec=1", "ra: give hours"),
    ("ra=abc&dec=1", "ra must be hours as a decimal number, such as ra=5.5881, not 'abc'"),
    ("ra=5h35m&dec=1", "ra must be hours as a decimal number"),
    ("ra=nan&dec=1", "ra must be hours as a decimal number"),
    ("ra=inf&dec=1", "ra must be hours as a decimal number"),
    ("ra=1e400&dec=1", "ra must be hours as a decimal number"),
    ("ra=1_0&dec=1", "ra must be hours as a decimal number"),
    ("ra=" + "1" * 500 + "&dec=1", "ra must be hours as a decimal number"),
    ("ra=24&dec=1", "ra 24 is outside 0 to under 24 hours"),
    ("ra=-0.5&dec=1", "ra -0.5 is outside 0 to under 24 hours"),
    ("ra=5&dec=90.5", "dec 90.5 is outside -90 to 90 degrees"),
    ("ra=5&dec=-1e9", "dec -1e+09 is outside -90 to 90 degrees"),
    ("ra=5&dec=%00", "dec must be degrees as a decimal number"),
])
def test_bad_input_is_a_400_with_a_clear_message(client: Client, query: str, says: str) -> None:
    status, body = verdict(client, query)
    assert status == 400
    assert str(body["error"]).startswith(says), body


def test_an_unknown_telescope_is_404(client: Client) -> None:
    status, body = verdict(client, "ra=5&dec=1", number=7)
    assert status == 404 and "error" in body


def test_the_verdict_names_the_mounts_limit_and_the_page_goto_agrees(server: AlpacaZwoServer,
                                                                      client: Client) -> None:
    status, body = verdict(client, at(server, 200.0, 10.0))
    assert status == 200 and body["reachable"] is False and body["state"] == "not connected"
    assert body["says"] == "within the limits, but the mount is not connected"
    connect(client)
    status, body = verdict(client, at(server, 200.0, 10.0))
    assert status == 200 and body["reachable"] is True and body["says"] == "reachable: above the horizon and limits"
    client.command("action", Action="zwo:AltitudeLimits", Parameters=json.dumps({"enabled": True, "lower": 15}))
    status, body = verdict(client, at(server, 200.0, 10.0))
    assert status == 200, body
    assert (body["reachable"], body["limit"], body["says"]) == (
        False, "mount altitude limit", "below the mount's altitude limit of 15°")
    assert str(body["detail"]).startswith("target is below the mount's altitude limit of 15° (zwo:AltitudeLimits)")
    status, body = verdict(client, at(server, 200.0, 40.0))
    assert body["reachable"] is True
    # The object card carries the same verdict as the route, for the same place.
    card = client.session.get(f"{client.api}/object", params={"id": "Polaris"}, timeout=TIMEOUT).json()
    status, body = verdict(client, f"ra={card['ra']!r}&dec={card['dec']!r}")
    assert card["verdict"]["says"] == body["says"] and card["above_limits"] is (body["limit"] is None)


def test_a_parked_mount_is_named_and_its_goto_refused(server: AlpacaZwoServer, client: Client) -> None:
    connect(client)
    client.command("park")
    wait_until(lambda: client.value("atpark") is True and client.value("slewing") is False, 60.0, "the park")
    status, body = verdict(client, at(server, 200.0, 40.0))
    assert (status, body["reachable"], body["state"], body["limit"]) == (200, False, "parked", None)
    assert body["says"] == "within the limits, but the mount is parked: Unpark first"
    ra, dec = place(server, 200.0, 40.0)
    call = client.put("slewtocoordinatesasync", RightAscension=ra, Declination=dec)
    assert call.error_number == 0x408
