"""The setup page costs the serial line nothing (issue 23 item 7).

Each page GET is answered from what the server already knows; the line is judged at the emulator,
which logs every request as it arrives (its DEBUG log) and counts every exchange (its stats), so
nothing here trusts the server's own account of what it sent.
"""

from __future__ import annotations

import collections
import logging
import re
import socket
from collections.abc import Iterator
from typing import Any

import pytest
import requests

from alpaca_zwo.config.settings import ServerSettings
from alpaca_zwo.emulator import EmulatorServer
from alpaca_zwo.server import AlpacaZwoServer
from tests.conftest import ServerFactory, make_settings
from tests.support import AlpacaClient, wait_until

HEADERS = {"X-Alpaca-Zwo": "1", "Content-Type": "application/json"}
TIMEOUT = 10
#: The queries that read the mount's stored settings (none of them is part of the position poll).
SETTINGS_QUERIES = frozenset({"GTa", "GRl", "GLC", "GLH", "GLL", "GBu", "Ggr", "GH"})
#: The page's GETs: every one of them must be answered without a serial exchange.
PAGE_GETS = ("/setup/api/telescope/0/settings", "/setup/api/telescope/0/status", "/setup/api/telescope/0/trace",
             "/setup/api/log", "/setup/api/server")
_REQUEST = re.compile(r"^line \d+ :(.*?)# -> ")


class Arrivals(logging.Handler):
    """Every request the emulator received, by command code, taken from its own DEBUG log line."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.codes: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        match = _REQUEST.match(record.getMessage())
        if match:
            body = match.group(1)
            self.codes.append(next((c for c in sorted(SETTINGS_QUERIES | {"GU", "GMEQ", "GAT", "Gm"},
                                                      key=len, reverse=True) if body.startswith(c)), body))

    def since(self, start: int) -> collections.Counter[str]:
        return collections.Counter(self.codes[start:])


@pytest.fixture
def arrivals() -> Iterator[Arrivals]:
    logger = logging.getLogger("alpaca_zwo.emulator.server")
    handler, level = Arrivals(), logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.DEBUG)
    yield handler
    logger.removeHandler(handler)
    logger.setLevel(level)


@pytest.fixture
def rig(server_factory: ServerFactory) -> tuple[AlpacaZwoServer, AlpacaClient]:
    """A server on the built-in emulator, connected through the Alpaca API as N.I.N.A. would."""
    server = server_factory()
    client = AlpacaClient(f"http://127.0.0.1:{server.port}", 77, timeout=TIMEOUT, call_timeout=TIMEOUT)
    client.command("connected", Connected="true")
    wait_until(lambda: server.telescopes[0].mount.state.position_time is not None, what="a first position")
    return server, client


def _emulator(server: AlpacaZwoServer) -> EmulatorServer:
    embedded = server.emulators[0]
    assert embedded is not None
    return embedded.server


def _get(client: AlpacaClient, path: str) -> dict[str, Any]:
    r = client.session.get(f"{client.base}{path}", timeout=TIMEOUT)
    assert r.status_code == 200, r.text
    body: dict[str, Any] = r.json()
    return body


def _mount_view(client: AlpacaClient) -> dict[str, Any]:
    view: dict[str, Any] = _get(client, "/setup/api/telescope/0/settings")["mount"]
    return view


def test_page_gets_add_no_serial_exchanges(rig: tuple[AlpacaZwoServer, AlpacaClient], arrivals: Arrivals) -> None:
    """30 rounds of every GET the page makes: the line carries the poller's queries and nothing else.

    Before: each settings GET sent 9 exchanges (8 settings queries and a fresh :GU#), 270 for 30.
    """
    server, client = rig
    wait_until(lambda: _mount_view(client) is not None, what="the mount settings read at connect")
    emulator = _emulator(server)
    start, exchanges_before = len(arrivals.codes), emulator.stats()["total"]["exchanges"]
    for _ in range(30):
        for path in PAGE_GETS:
            _get(client, path)
    seen = arrivals.since(start)
    exchanges = emulator.stats()["total"]["exchanges"] - exchanges_before
    polls = seen["GMEQ"]
    # One settings refresh may fall in the window (the connect-time re-read after the meridian push):
    # it is one per change, not one per GET.
    assert sum(seen[c] for c in SETTINGS_QUERIES) <= len(SETTINGS_QUERIES), seen
    assert seen["GU"] <= polls + 1, seen  # :GU# only as part of a poll
    assert exchanges <= 4 * (polls + 1) + len(SETTINGS_QUERIES), (exchanges, seen)


def _post(client: AlpacaClient, body: dict[str, Any]) -> dict[str, Any]:
    r = requests.post(f"{client.base}/setup/api/telescope/0/settings", json=body, headers=HEADERS, timeout=TIMEOUT)
    assert r.status_code == 200, r.text
    reply: dict[str, Any] = r.json()
    return reply


def test_settings_get_shows_changes_made_through_the_server(rig: tuple[AlpacaZwoServer, AlpacaClient]) -> None:
    """A page POST and a zwo:* Action each show in the very next GET (no waiting for a refresh)."""
    server, client = rig
    model = _emulator(server).model
    _post(client, {"buzzer": 0, "mount_limits": {"upper": 85}})
    assert model.flash.buzzer() == 0 and model.flash.altitude_limits()[1] == 85  # the mount has them
    view = _mount_view(client)
    assert view["buzzer"] == 0 and view["upper_limit"] == 85
    client.command("action", Action="zwo:BuzzerVolume", Parameters='{"volume": 2}')
    client.command("action", Action="zwo:HeavyDutyMode", Parameters='{"enabled": true}')
    assert model.flash.buzzer() == 2 and model.flash.max_speed() == 720
    view = _mount_view(client)
    assert view["buzzer"] == 2 and view["heavy_duty"] is True
    client.command("action", Action="zwo:AltitudeLimits", Parameters='{"lower": 12}')
    assert _mount_view(client)["lower_limit"] == 12


def test_change_behind_the_servers_back_shows_within_the_refresh_period(
        rig: tuple[AlpacaZwoServer, AlpacaClient]) -> None:
    """A second line to the mount (ZWO's app over WiFi) changes a setting: the page shows it within
    the periodic refresh (shortened here from its 60 s default), with no GET asking for it."""
    server, client = rig
    mount = server.telescopes[0].mount
    mount.settings_cache.refresh_s = 1.5
    assert _mount_view(client)["buzzer"] != 0
    with socket.create_connection(("127.0.0.1", _emulator(server).port), timeout=TIMEOUT) as app:
        app.sendall(b":SBu0#:SLH75#:GLH#")  # :SBu# and :SLH answer nothing/1; :GLH# proves they arrived
        reply = b""
        while not reply.endswith(b"75#"):
            chunk = app.recv(64)
            assert chunk, reply
            reply += chunk
    assert _emulator(server).model.flash.buzzer() == 0
    view = wait_until(lambda: (v := _mount_view(client))["buzzer"] == 0 and v, timeout=1.5 + 2 * mount.poll_slow_s + 3,
                      what="the app's change on the page")
    assert view["upper_limit"] == 75


def test_raw_command_through_the_server_shows_at_the_next_poll(server_factory: ServerFactory) -> None:
    """A setting changed by a raw command (Alpaca CommandBlind; the shared ZWO port's allowed commands
    take the same path) marks the copy stale: the page shows it a poll later, not after the 60 s period."""
    server = server_factory(make_settings(server=ServerSettings(host="127.0.0.1", port=0, discovery_port=0,
                                                                allow_raw_commands=True)))
    client = AlpacaClient(f"http://127.0.0.1:{server.port}", 77, timeout=TIMEOUT, call_timeout=TIMEOUT)
    client.command("connected", Connected="true")
    mount = server.telescopes[0].mount
    assert mount.settings_cache.refresh_s == 60.0
    assert _mount_view(client)["heavy_duty"] is False
    client.command("commandblind", Command=":SRl720#", Raw="true")
    assert _emulator(server).model.flash.max_speed() == 720
    wait_until(lambda: _mount_view(client)["heavy_duty"] is True, timeout=2 * mount.poll_slow_s + 3,
               what="the raw command's change on the page")
