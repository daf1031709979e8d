"""The shared ZWO port's door over real sockets (issue 32): what is not a driver is closed before anything runs.

A web page can make any browser write an HTTP request into the port; its no-cors POST body is ZWO
commands. Each test sends the bytes a browser (or a TLS client, or noise) would, checks that the
connection was closed without a reply, that it never became a program, that the mount did not move
(the emulator's truth) and the settings file kept its bytes; and that real drivers' openings, and
noise after a driver's first command, still work. The rule itself: ``test_admission.py``; Chromium
doing it: ``tests/browser/test_bridge_ports.py``; networks by address: ``test_bridge_networks_netns.py``.
"""

from __future__ import annotations

import contextlib
import logging
import socket
import ssl
from pathlib import Path

import pytest
import requests
import tomllib

from alpaca_zwo.bridges.zwo_port import BRIDGE_KEY
from alpaca_zwo.config.settings import EmulatorSettings, ZwoPortSettings
from alpaca_zwo.server import AlpacaZwoServer
from tests.bridges.test_admission import HTTP_METHODS
from tests.conftest import ServerFactory, make_settings
from tests.support import AlpacaClient, wait_until
from tests.support.zwo_client import ZwoClient

TIMEOUT = 10
#: The attack's body: a GOTO, a manual move, tracking, and a new site (which the server would save).
ATTACK = b":Sr03:00:00#:Sd+20*00:00#:MS#:Me#:Te#:St+10*00#:Sg+020*00#"
LOGGER = "alpaca_zwo.bridges.zwo_port"


@pytest.fixture
def server(server_factory: ServerFactory) -> AlpacaZwoServer:
    settings = make_settings(emulator=EmulatorSettings(speed=1.0, baud=0),
                             zwo_port=ZwoPortSettings(enabled=True, host="127.0.0.1", port=0))
    server = server_factory(settings)
    # The settings file exists (the attack's :St/:Sg would rewrite it): its bytes are the reference.
    write_settings_file(server)
    return server


def write_settings_file(server: AlpacaZwoServer) -> None:
    reply = requests.post(f"http://127.0.0.1:{server.port}/setup/api/server", json={"location": "backyard"},
                          headers={"X-Alpaca-Zwo": "1"}, timeout=TIMEOUT)
    assert reply.status_code == 200, reply.text


def hold_connected(server: AlpacaZwoServer) -> AlpacaClient:
    """An Alpaca client holding the mount connected with tracking off: a command that got through would show."""
    client = AlpacaClient(server.port, timeout=TIMEOUT, call_timeout=TIMEOUT)
    client.command("connected", Connected="true")
    client.command("tracking", Tracking="false")
    return client


@pytest.fixture
def alpaca(server: AlpacaZwoServer) -> AlpacaClient:
    return hold_connected(server)


def http_request(method: str, port: int, body: bytes = ATTACK) -> bytes:
    """What Chromium writes for fetch(url, {method, mode: "no-cors", body}) from a foreign page."""
    head = (f"{method} / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: keep-alive\r\n"
            f"Content-Type: text/plain;charset=UTF-8\r\nOrigin: http://evil.example\r\n"
            f"Content-Length: {len(body)}\r\n\r\n").encode()
    return head + body


def send_and_read(port: int, data: bytes, *, byte_at_a_time: bool = False) -> bytes:
    """Connect, send (all at once or a byte per segment), then read until the server closes."""
    with socket.create_connection(("127.0.0.1", port), timeout=TIMEOUT) as sock:
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        with contextlib.suppress(OSError):  # the server may close after the first byte: later sends fail
            for chunk in ([data[i:i + 1] for i in range(len(data))] if byte_at_a_time else [data]):
                sock.sendall(chunk)
        received = b""
        with contextlib.suppress(ConnectionResetError):
            while chunk := sock.recv(4096):
                received += chunk
        return received


def settled_truth(server: AlpacaZwoServer) -> dict[str, object]:
    """The emulator's truth after a poll that started after now (so anything queued has reached it)."""
    mount = server.telescopes[0].mount
    before = mount.state.position_time
    wait_until(lambda: mount.state.position_time != before, TIMEOUT, "a fresh poll")
    return server.emulators[0].model.snapshot()  # type: ignore[union-attr,no-any-return]


@pytest.mark.usefixtures("alpaca")
def test_a_web_pages_post_is_closed_unexecuted_and_is_never_a_program(server: AlpacaZwoServer,
                                                                      tmp_path: Path,
                                                                      caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger=LOGGER)
    config = tmp_path / "config.toml"
    before, truth_before = config.read_bytes(), settled_truth(server)
    port = server.zwo_port.port

    attempts = 0
    for method in HTTP_METHODS:
        for byte_at_a_time in (False, True):
            reply = send_and_read(port, http_request(method, port), byte_at_a_time=byte_at_a_time)
            assert reply == b"", (method, reply)  # not even the mount's "1" for :Sr
            attempts += 1

    truth = settled_truth(server)
    assert truth["moves_deg_s"] == [None, None] and truth["slew"] is None and truth["tracking"] is False
    assert (truth["latitude"], truth["longitude_east"]) == (truth_before["latitude"], truth_before["longitude_east"])
    assert config.read_bytes() == before
    status = server.zwo_port.status()
    assert status["programs"] == [] and status["last_command"] is None
    assert status["turned_away"] == attempts
    assert "not a ZWO command" in status["last_turned_away"]["reason"]
    assert BRIDGE_KEY not in server.telescopes[0].connection.clients()  # no connection made for them
    messages = [r.getMessage() for r in caplog.records if r.name == LOGGER]
    assert not any("connected" in m for m in messages), messages
    refusals = [m for m in messages if "closed" in m]
    assert len(refusals) == 1 and "not a ZWO command" in refusals[0], refusals  # once a minute, not 20 times


@pytest.mark.usefixtures("alpaca")
def test_tls_and_noise_are_closed_before_anything_runs(server: AlpacaZwoServer) -> None:
    port = server.zwo_port.port
    with socket.create_connection(("127.0.0.1", port), timeout=TIMEOUT) as raw:
        context = ssl.create_default_context()
        with pytest.raises((ssl.SSLError, ConnectionError)):
            context.wrap_socket(raw, server_hostname="astropi.local")  # a real ClientHello, then the close
    for noise in (b"\x00\x01\x02\x03" + ATTACK, b"\xff\xfb\x18\xff\xfd\x03" + ATTACK, b"GVP#" + ATTACK):
        assert send_and_read(port, noise) == b""
    truth = settled_truth(server)
    assert truth["moves_deg_s"] == [None, None] and truth["slew"] is None and truth["tracking"] is False
    status = server.zwo_port.status()
    assert status["turned_away"] == 4 and status["programs"] == []


@pytest.mark.parametrize("opening", [b":GVP#", b"\x06:GVP#", b"\r\n:GVP#", b"#:GVP#", b"\x00:GVP#", b":GVP#\n"])
def test_real_drivers_openings_are_answered_at_once_and_byte_by_byte(server: AlpacaZwoServer,
                                                                      opening: bytes) -> None:
    port = server.zwo_port.port
    for byte_at_a_time in (False, True):
        with socket.create_connection(("127.0.0.1", port), timeout=TIMEOUT) as sock:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            for chunk in ([opening[i:i + 1] for i in range(len(opening))] if byte_at_a_time else [opening]):
                sock.sendall(chunk)
            reply = b""
            while not reply.endswith(b"#"):
                chunk = sock.recv(1)
                assert chunk, f"closed after {opening!r}"
                reply += chunk
            assert reply == b"AM5#"
    assert server.zwo_port.status()["turned_away"] == 0


def test_a_drivers_connection_that_later_meets_noise_is_resynchronised(server: AlpacaZwoServer) -> None:
    """After its first command a connection is a program: noise, even an HTTP request, is skipped as today."""
    client = ZwoClient(server.zwo_port.port)
    try:
        assert client.ask(":GVP#") == b"AM5#"
        for noise in (b"\x00\xff\x16\x03\x01", b"GET / HTTP/1.1\r\nHost: x\r\n\r\n", b"\r\n\x06##"):
            client.sock.sendall(noise)
            assert client.ask(":GVP#") == b"AM5#"
        status = server.zwo_port.status()
        assert [p["last_command"] for p in status["programs"]] == [":GVP#"]
        assert status["turned_away"] == 0
    finally:
        client.close()


def test_until_its_first_command_a_connection_is_not_a_program(server: AlpacaZwoServer,
                                                               caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger=LOGGER)
    silent = socket.create_connection(("127.0.0.1", server.zwo_port.port), timeout=TIMEOUT)
    driver = ZwoClient(server.zwo_port.port)
    try:
        assert driver.ask(":GR#").endswith(b"#")
        programs = server.zwo_port.status()["programs"]
        assert [p["address"] for p in programs] == [f"127.0.0.1:{driver.sock.getsockname()[1]}"]
        connected = [r.getMessage() for r in caplog.records if "connected (" in r.getMessage()]
        assert connected == [f"ZWO port: program {programs[0]['address']} connected (1 connected)"]
        silent.sendall(b":GVP#")  # its first command: now it is a program too
        wait_until(lambda: len(server.zwo_port.status()["programs"]) == 2, TIMEOUT, "the second program")
    finally:
        silent.close()
        driver.close()


def test_allowed_networks_refuse_at_the_door_and_the_page_changes_them_at_once(server_factory: ServerFactory,
                                                                              tmp_path: Path) -> None:
    settings = make_settings(zwo_port=ZwoPortSettings(enabled=True, host="127.0.0.1", port=0,
                                                      allowed_networks=("10.0.0.0/8",)))
    server = server_factory(settings)
    port = server.zwo_port.port
    assert send_and_read(port, b":GVP#") == b""  # 127.0.0.1 is not in 10.0.0.0/8
    status = server.zwo_port.status()
    assert status["turned_away"] == 1 and status["programs"] == []
    assert "127.0.0.1 is not in zwo_port.allowed_networks" in status["last_turned_away"]["reason"]
    assert status["allowed_networks"] == ["10.0.0.0/8"]

    url = f"http://127.0.0.1:{server.port}/setup/api/server"
    view = requests.get(url, timeout=TIMEOUT).json()
    assert view["allowed_networks"] == {"zwo_port": ["10.0.0.0/8"], "stellarium": ["local"]}
    assert "127.0.0.0/8" in view["local_networks"] and "::1/128" in view["local_networks"]
    reply = requests.post(url, json={"allowed_networks": {"zwo_port": ["local", "10.8.0.0/24"]}},
                          headers={"X-Alpaca-Zwo": "1"}, timeout=TIMEOUT)
    assert reply.status_code == 200, reply.text
    assert reply.json()["allowed_networks"]["zwo_port"] == ["local", "10.8.0.0/24"]
    assert reply.json()["restart_required"] is False
    saved = tomllib.loads((tmp_path / "config.toml").read_text(encoding="utf-8"))
    assert saved["zwo_port"]["allowed_networks"] == ["local", "10.8.0.0/24"]
    client = ZwoClient(port)  # in effect for the next connection, no restart
    try:
        assert client.ask(":GVP#") == b"AM5#"
    finally:
        client.close()
    assert "10.8.0.0/24" in server.zwo_port.status()["allowed_networks"]


@pytest.mark.parametrize(("body", "words"), [
    ({"allowed_networks": {"zwo_port": []}}, "at least one network"),
    ({"allowed_networks": {"zwo_port": ["evil"]}}, "'evil' is not a network"),
    ({"allowed_networks": {"stellarium": "local"}}, "must be an array"),
    ({"allowed_networks": {"alpaca": ["local"]}}, "unknown allowed_networks bridge(s): alpaca"),
    ({"allowed_networks": ["local"]}, "allowed_networks must be an object"),
])
def test_the_page_refuses_what_is_not_a_network_list(live_server: AlpacaZwoServer, body: dict[str, object],
                                                     words: str) -> None:
    url = f"http://127.0.0.1:{live_server.port}/setup/api/server"
    reply = requests.post(url, json=body, headers={"X-Alpaca-Zwo": "1"}, timeout=TIMEOUT)
    assert reply.status_code == 400 and words in reply.text, reply.text
    assert live_server.settings.zwo_port.allowed_networks == ("local",)
