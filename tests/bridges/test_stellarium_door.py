"""Stellarium's port at the door (issue 32): a connection is a client only after a first valid message.

Stellarium sends nothing until its first goto, so its opening "message" is silence: a connection
that stays quiet for ``QUIET_OPENING_S`` becomes a client, as does one whose first bytes are a whole
valid message. An HTTP request (what a web page makes a browser write) cannot begin a Stellarium
message ("GE", "PO" read as a length of thousands): it is closed before it is counted, logged as
connected, sent a position, or makes the bridge connect the mount. Networks: ``allowed_networks``.
"""

from __future__ import annotations

import contextlib
import logging
import socket
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import requests

from alpaca_zwo.bridges.stellarium import BRIDGE_CLIENT, QUIET_OPENING_S
from alpaca_zwo.config.settings import StellariumSettings
from tests.bridges.stellarium_client import StellariumClient, goto_message
from tests.bridges.stellarium_rig import Rig, running_server, wait_until
from tests.bridges.test_admission import HTTP_METHODS
from tests.bridges.test_zwo_port_door import http_request, send_and_read
from tests.conftest import ServerFactory, make_settings

LOGGER = "alpaca_zwo.bridges.stellarium"
TIMEOUT = 10


@pytest.fixture(scope="module")
def rig(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Rig]:
    """No Alpaca client: the bridge alone would connect the mount for a client."""
    with running_server(tmp_path_factory.mktemp("stellarium-door"), connect_alpaca=False) as rig:
        yield rig


def test_a_web_pages_request_is_closed_before_it_is_a_client(rig: Rig, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger=LOGGER)
    bridge, port = rig.server.stellarium, rig.stellarium_port
    before = bridge.status()["turned_away"]
    attempts = 0
    for method in HTTP_METHODS:
        for byte_at_a_time in (False, True):
            # Not a byte back: a pending connection is sent no position.
            assert send_and_read(port, http_request(method, port, goto_message(3.0, 20.0)),
                                 byte_at_a_time=byte_at_a_time) == b"", method
            attempts += 1
    status = bridge.status()
    assert status["clients"] == [] and status["last_command"] is None
    assert status["turned_away"] - before == attempts
    assert "not Stellarium's protocol (message length" in status["last_turned_away"]["message"]
    assert BRIDGE_CLIENT not in rig.server.telescopes[0].connection.clients()  # the mount was never connected
    assert rig.server.emulators[0].model.snapshot()["slew"] is None  # type: ignore[union-attr]
    messages = [r.getMessage() for r in caplog.records if r.name == LOGGER]
    assert not any("connected from" in m for m in messages), messages
    refusals = [m for m in messages if "closed:" in m]
    assert len(refusals) <= 1, refusals  # at most once a minute (an earlier test may have used this minute)


def test_silence_is_stellariums_opening(rig: Rig, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger=LOGGER)
    started = time.monotonic()
    client = StellariumClient(rig.stellarium_port)
    address = f"127.0.0.1:{client.sock.getsockname()[1]}"
    try:
        first = client.read_position(timeout=TIMEOUT)  # the bridge connects the mount for it, then streams
        assert first.received - started >= QUIET_OPENING_S * 0.9
        assert [c["address"] for c in rig.server.stellarium.status()["clients"]] == [address]
        assert BRIDGE_CLIENT in rig.server.telescopes[0].connection.clients()
        assert any(f"Stellarium connected from {address}" in r.getMessage() for r in caplog.records)
    finally:
        client.close()
    wait_until(lambda: not rig.server.stellarium.status()["clients"], TIMEOUT, "the client to be gone")


def test_a_valid_first_message_makes_a_client_at_once(rig: Rig) -> None:
    assert rig.server.settings.site.latitude > 10.0
    client = StellariumClient(rig.stellarium_port)
    try:
        client.send_raw(goto_message(3.0, -85.0))  # under the horizon of a northern site: refused, nothing moves
        first = client.read_position(timeout=TIMEOUT)
        assert first.status == 0
        wait_until(lambda: (rig.server.stellarium.status()["last_command"] or {}).get("dec_degrees", 0) < -84.9,
                   TIMEOUT, "the goto to be read")
        assert "below the horizon" in rig.server.stellarium.status()["last_error"]["message"]
        assert len(rig.server.stellarium.status()["clients"]) == 1
    finally:
        client.close()


def test_allowed_networks_refuse_at_the_door_and_the_page_changes_them_at_once(server_factory: ServerFactory) -> None:
    settings = make_settings(stellarium=StellariumSettings(enabled=True, host="127.0.0.1", port=0,
                                                           allowed_networks=("192.0.2.0/24",)))
    server = server_factory(settings)
    port = server.stellarium.port
    with socket.create_connection(("127.0.0.1", port), timeout=TIMEOUT) as sock, \
            contextlib.suppress(ConnectionResetError):
        assert sock.recv(64) == b""  # closed unread: no position
    status = server.stellarium.status()
    assert status["turned_away"] == 1 and status["clients"] == []
    assert "127.0.0.1 is not in stellarium.allowed_networks" in status["last_turned_away"]["message"]
    reply = requests.post(f"http://127.0.0.1:{server.port}/setup/api/server",
                          json={"allowed_networks": {"stellarium": ["local"]}}, headers={"X-Alpaca-Zwo": "1"},
                          timeout=TIMEOUT)
    assert reply.status_code == 200, reply.text
    client = StellariumClient(port)
    try:
        assert client.read_position(timeout=TIMEOUT).status == 0
    finally:
        client.close()
    assert server.settings.stellarium.allowed_networks == ("local",)
    assert server.settings.zwo_port.allowed_networks == ("local",)  # the other bridge's list untouched


def test_a_begun_message_that_never_ends_is_closed(rig: Rig, tmp_path: Path) -> None:
    """One byte (half a length) and then nothing: not silence, not a message; closed, never a client."""
    from alpaca_zwo.bridges.stellarium import OPENING_TIMEOUT_S

    with socket.create_connection(("127.0.0.1", rig.stellarium_port), timeout=OPENING_TIMEOUT_S + TIMEOUT) as sock:
        sock.sendall(b"\x14")
        started = time.monotonic()
        with contextlib.suppress(ConnectionResetError):
            assert sock.recv(64) == b""
        assert time.monotonic() - started >= OPENING_TIMEOUT_S * 0.9
    assert "unfinished first message (1 bytes)" in rig.server.stellarium.status()["last_turned_away"]["message"]
