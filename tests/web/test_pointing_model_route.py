"""The page's pointing model route (``/setup/api/telescope/{n}/pointing-model``): read without a client
connected, changed only by a same-origin POST with valid keys, and showing the syncs made over Alpaca
with where on the sky each was taken (docs/pointing-model.md)."""

from __future__ import annotations

import pytest

from alpaca_zwo import sky
from tests.support import wait_until
from tests.web.test_setup_api import TIMEOUT, Client

PATH = "/setup/api/telescope/0/pointing-model"


@pytest.fixture
def client(base_url: str) -> Client:
    return Client(base_url)


def _read(client: Client) -> dict[str, object]:
    r = client.session.get(f"{client.base}{PATH}", timeout=TIMEOUT)
    assert r.status_code == 200, r.text
    body = r.json()
    assert isinstance(body, dict)
    return body


def test_the_model_reads_without_a_client_and_refuses_bad_changes(client: Client) -> None:
    assert _read(client)["points"] == [] and _read(client)["enabled"] is True
    for body, word in (({"clear": False}, "clear"), ({"enabled": "off"}, "enabled"), ({"terms": []}, "unknown")):
        r = client.post(PATH, body)
        assert r.status_code == 400 and word in r.json()["error"], (body, r.text)
    assert client.post(PATH, {"enabled": False}, headers={"Content-Type": "application/json"}).status_code == 403
    assert _read(client)["enabled"] is True  # nothing changed by the refused requests
    assert client.post(PATH, {"enabled": False}).json()["enabled"] is False
    assert _read(client)["enabled"] is False
    assert client.session.get(f"{client.base}/setup/api/telescope/1/pointing-model", timeout=TIMEOUT).status_code == 404


def test_syncs_show_on_the_page_and_clear_forgets_them(client: Client) -> None:
    client.command("connected", Connected="true")
    client.command("tracking", Tracking="true")
    expected = []
    for ha, dec in ((-2.0, 30.0), (2.0, 50.0)):
        ra = (client.value("siderealtime") - ha) % 24.0
        client.command("slewtocoordinatesasync", RightAscension=ra, Declination=dec)
        wait_until(lambda: client.value("slewing") is False, 60, "the slew to end")
        synced = ((ra + 0.01) % 24.0, dec + 0.1)
        expected.append((client.value("siderealtime") - synced[0], synced[1]))  # its hour angle at the sync
        client.command("synctocoordinates", RightAscension=synced[0], Declination=synced[1])
    points = _read(client)["points"]
    assert isinstance(points, list) and len(points) == 2
    latitude = client.value("sitelatitude")
    for point, (ha, dec) in zip(points, expected, strict=True):
        alt, az = sky.equatorial_to_horizontal(ha, dec, latitude)
        assert point["alt"] == pytest.approx(alt, abs=0.05) and point["az"] == pytest.approx(az, abs=0.1), point
    assert client.post(PATH, {"clear": True}).json()["points"] == []
    assert _read(client)["points"] == []
