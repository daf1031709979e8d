"""A mount parked by its own firmware (``:hP#``): before the server connects and while it is connected.

Real mounts keep that park across power cycles and refuse every motion with ``e14#`` until ``:Spu#``
(real-transcripts-1.8.8.md §1 "Park, home, unpark", §2 items 2 and 6). The ZWO app, ASIAIR or a hand
controller park it so; the server must show it, refuse motion in words that say so, and release it.
Run against the default preset and the real-transcript one.
"""

from __future__ import annotations

from typing import Any

import pytest
import requests

from alpaca_zwo.config.settings import EmulatorSettings
from alpaca_zwo.emulator import MountModel
from alpaca_zwo.server import AlpacaZwoServer
from tests.conftest import ServerFactory, make_settings
from tests.support import wait_until
from tests.telescope.harness import SPEED, Api

PARKED = 0x408
PRESETS = ["am5-1.9.2", "am5-1.8.8", "am5n-1.8.8"]


@pytest.fixture(params=PRESETS)
def server(request: pytest.FixtureRequest, server_factory: ServerFactory) -> AlpacaZwoServer:
    return server_factory(make_settings(emulator=EmulatorSettings(speed=SPEED, baud=0, preset=request.param)))


def _park_from_elsewhere(model: MountModel, server: AlpacaZwoServer) -> None:
    """What the ZWO app does: tracking off (1.8.8 ignores :hP# while tracking), then :hP#, sent to the
    mount itself, not through the server; wait until the mount says parked."""
    emulator = server.emulators[0]
    assert emulator is not None
    emulator.server.responder.handle("Td")
    emulator.server.responder.handle("hP")
    wait_until(lambda: model.park_status() == 2, 60, "the mount to park itself")


def _page_status(url: str) -> dict[str, Any]:
    reply = requests.get(f"{url}/setup/api/telescope/0/status", timeout=10)
    assert reply.status_code == 200, reply.text
    body: dict[str, Any] = reply.json()
    return body


def _assert_motion_refused_as_parked(api: Api) -> None:
    ra = api.ra_at_ha(-1.0)
    attempts: list[tuple[str, dict[str, object]]] = [
        ("SlewToCoordinatesAsync", {"RightAscension": ra, "Declination": 30.0}),
        ("SlewToAltAzAsync", {"Azimuth": 120.0, "Altitude": 40.0}),
        ("MoveAxis", {"Axis": 0, "Rate": 1.0}),
        ("PulseGuide", {"Direction": 0, "Duration": 100}),
        ("Tracking", {"Tracking": True}),
        ("FindHome", {}),
        ("SyncToCoordinates", {"RightAscension": ra, "Declination": 30.0}),
    ]
    for member, params in attempts:
        reply = api.put(member, **params)
        assert reply.error == PARKED, f"{member}: 0x{reply.error:X} {reply.body['ErrorMessage']}"
        assert "parked itself" in reply.body["ErrorMessage"], reply.body["ErrorMessage"]


def _assert_unpark_releases(api: Api, model: MountModel) -> None:
    api.ok("Unpark")  # answered only once the mount confirmed it
    assert model.park_status() == 0
    assert api.value("AtPark") is False
    api.ok("Tracking", Tracking=True)
    assert api.value("Tracking") is True


def test_a_mount_parked_before_the_server_connects(server: AlpacaZwoServer, fresh: Api, model: MountModel,
                                                    url: str) -> None:
    _park_from_elsewhere(model, server)
    api = fresh.connect()
    assert api.value("AtPark") is True
    assert api.value("Slewing") is False  # a parked mount's status word has no 'N': still not a slew
    assert _page_status(url)["parked_by_mount"] is True
    _assert_motion_refused_as_parked(api)
    assert model.park_status() == 2  # nothing reached the mount to unpark it
    _assert_unpark_releases(api, model)
    assert _page_status(url)["parked_by_mount"] is False


def test_a_mount_parked_by_another_program_while_connected(server: AlpacaZwoServer, api: Api,
                                                            model: MountModel, url: str) -> None:
    assert api.value("AtPark") is False
    _park_from_elsewhere(model, server)
    wait_until(lambda: api.value("AtPark") is True, 10, "the server to see the mount's own park")
    api.wait_idle()
    status = _page_status(url)
    assert status["parked_by_mount"] is True and status["at_park"] is True
    _assert_motion_refused_as_parked(api)
    api.ok("Park")  # parking a parked mount is harmless
    _assert_unpark_releases(api, model)
