"""DNS rebinding over real HTTP: a request naming a foreign host (Host or Origin) changes nothing.

A page on evil.example that re-points its name at this machine sends ``Host: evil.example:PORT``
and ``Origin: http://evil.example:PORT``, which agree, so same-origin checks pass. Each test sends
exactly those headers (``http.client`` with ``skip_host``), judges the mount by the emulator's truth
and the settings by the file's bytes, and checks that the names real clients use still work.
The decision table itself is in ``tests/alpaca/test_hosts.py``; a real browser in
``tests/browser/test_page_rebinding.py``.
"""

from __future__ import annotations

import http.client
import json
import socket
from pathlib import Path

from alpaca_zwo.config.settings import ServerSettings
from alpaca_zwo.web import CSRF_HEADER
from tests.faults.conftest import Rig, RigFactory
from tests.support import AlpacaClient, wait_until

TIMEOUT = 10
FORM = "application/x-www-form-urlencoded"
HOSTNAME = socket.gethostname()


def request(port: int, method: str, path: str, headers: dict[str, str], body: bytes = b"") -> tuple[int, str, str]:
    """One request with exactly these headers (no Host unless given); (status, content type, body text)."""
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=TIMEOUT)
    try:
        conn.putrequest(method, path, skip_host=True, skip_accept_encoding=True)
        for name, value in headers.items():
            conn.putheader(name, value)
        if body or method in ("PUT", "POST"):
            conn.putheader("Content-Length", str(len(body)))
        conn.endheaders(body or None)
        response = conn.getresponse()
        return response.status, response.getheader("Content-Type") or "", response.read().decode()
    finally:
        conn.close()


def rebound(port: int) -> dict[str, str]:
    """What Chromium sends from a page at http://evil.example:PORT that resolves to this machine."""
    return {"Host": f"evil.example:{port}", "Origin": f"http://evil.example:{port}"}


def assert_refused(status: int, content_type: str, text: str, name: str = "evil.example") -> None:
    assert status == 403, (status, text)
    assert content_type.startswith("text/plain"), content_type
    assert text.count("\n") == 1 and text.endswith("\n"), text  # one line
    assert f"add '{name}' to server.allowed_hosts on the setup page" in text, text


def settle(rig: Rig) -> None:
    """Wait for a poll that started after now: the link sends commands before polls, so any command a
    request queued has reached the emulator by then (a move command has no reply to wait for)."""
    before = rig.mount.state.position_time
    wait_until(lambda: rig.mount.state.position_time != before, 10, "a fresh poll")


def put(rig: Rig, member: str, headers: dict[str, str], body: str) -> tuple[int, str, str]:
    return request(rig.port, "PUT", f"/api/v1/telescope/0/{member}", {"Content-Type": FORM, **headers}, body.encode())


def test_alpaca_puts_from_a_rebound_name_move_nothing(rig_factory: RigFactory) -> None:
    rig = rig_factory()
    main = rig.clients[0]
    main.command("tracking", Tracking="false")
    port = rig.port
    attacks = [rebound(port), {"Host": f"evil.example:{port}"},  # a page's GET-less PUT may omit Origin
               {"Host": f"127.0.0.1:{port}", "Origin": f"http://evil.example:{port}"}]
    for headers in attacks:
        assert_refused(*put(rig, "moveaxis", headers, "ClientID=5&Axis=0&Rate=4"))
        assert_refused(*put(rig, "moveaxis", headers, "ClientID=5&Axis=1&Rate=-4"))
        assert_refused(*put(rig, "tracking", headers, "ClientID=5&Tracking=true"))
        assert_refused(*put(rig, "slewtoaltazasync", headers, "ClientID=5&Azimuth=90&Altitude=30"))
    settle(rig)
    truth = rig.snapshot()
    assert truth["moves_deg_s"] == [None, None] and truth["slew"] is None and truth["tracking"] is False

    # The same request by this machine's names moves the mount: the refusal above is the guard's.
    for host in (f"127.0.0.1:{port}", f"localhost:{port}", f"{HOSTNAME}:{port}", f"{HOSTNAME}.local:{port}",
                 f"{HOSTNAME}.lan:{port}", f"[::1]:{port}"):
        status, _, text = put(rig, "moveaxis", {"Host": host}, "ClientID=5&Axis=0&Rate=1")
        assert status == 200 and json.loads(text)["ErrorNumber"] == 0, (host, text)
    wait_until(lambda: rig.snapshot()["moves_deg_s"][0] is not None, 10, "the allowed MoveAxis to move")
    main.command("moveaxis", Axis=0, Rate=0)


def test_alpaca_gets_and_management_need_an_allowed_name_too(rig_factory: RigFactory) -> None:
    """Alpaca GETs read the site's coordinates like the setup API does; clients by IP or name still read."""
    rig = rig_factory()
    for path in ("/api/v1/telescope/0/sitelatitude", "/api/v1/telescope/0/devicestate", "/management/v1/description"):
        assert_refused(*request(rig.port, "GET", path, rebound(rig.port)))
        status, _, text = request(rig.port, "GET", path, {"Host": f"{HOSTNAME}.local:{rig.port}"})
        assert status == 200 and json.loads(text)["ErrorNumber"] == 0, (path, text)
    # A client by name, as ConformU or alpyca given "localhost:PORT": no Origin, Host the name it dialled.
    client = AlpacaClient(f"http://localhost:{rig.port}", 7)
    try:
        assert client.command("tracking", Tracking="true").ok
    finally:
        client.close()
    settle(rig)
    assert rig.snapshot()["tracking"] is True


def _setup_post(port: int, path: str, body: object, headers: dict[str, str]) -> tuple[int, str, str]:
    return request(port, "POST", path, {"Content-Type": "application/json", CSRF_HEADER: "1", **headers},
                   json.dumps(body).encode())


def test_setup_api_posts_from_a_rebound_name_change_nothing(rig_factory: RigFactory, tmp_path: Path) -> None:
    rig = rig_factory()
    port = rig.port
    config = tmp_path / "config.toml"
    local = {"Host": f"127.0.0.1:{port}", "Origin": f"http://127.0.0.1:{port}"}
    status, _, text = _setup_post(port, "/setup/api/server", {"location": "backyard"}, local)
    assert status == 200, text  # the file now exists: its bytes must survive the attack
    before = config.read_bytes()
    settings_before = rig.server.settings
    latitude_before = rig.snapshot()["latitude"]

    attacks = [
        ("/setup/api/telescope/0/action/move", {"axis": 0, "rate": 4.0}),
        ("/setup/api/telescope/0/action/tracking", {"on": True}),
        ("/setup/api/telescope/0/settings", {"site": {"latitude": -33.0, "longitude": 151.0}}),
        ("/setup/api/telescope/0/settings", {"safety": {"moveaxis_watchdog_s": 600}}),
        ("/setup/api/server", {"host": "203.0.113.9"}),  # would make the next start fail
        ("/setup/api/server", {"allowed_hosts": ["*"]}),
    ]
    for path, body in attacks:
        for headers in (rebound(port), {"Host": f"evil.example:{port}"}):
            assert_refused(*_setup_post(port, path, body, headers))
    settle(rig)
    truth = rig.snapshot()
    assert truth["moves_deg_s"] == [None, None] and truth["tracking"] is False
    assert truth["latitude"] == latitude_before
    assert config.read_bytes() == before
    assert rig.server.settings == settings_before


def test_setup_api_reads_need_an_allowed_name_the_page_itself_does_not(rig_factory: RigFactory) -> None:
    rig = rig_factory()
    port = rig.port
    reads = ["/setup/api/server", "/setup/api/log", "/setup/api/log.txt", "/setup/api/telescope/0/status",
             "/setup/api/telescope/0/settings", "/setup/api/telescope/0/trace", "/setup/api/telescope/0/trace.txt"]
    for path in reads:
        assert_refused(*request(port, "GET", path, rebound(port)))
        assert_refused(*request(port, "GET", path, {"Host": f"evil.example:{port}"}))
        assert_refused(*request(port, "GET", path, {"Host": f"127.0.0.1:{port}", "Origin": "http://evil.example"}))
        for host in (f"127.0.0.1:{port}", f"{HOSTNAME}.local:{port}"):
            status, _, text = request(port, "GET", path, {"Host": host})
            assert status == 200, (path, host, text)
    # The page and its files hold nothing private: served, so its first API call can say what to do.
    for path in ("/setup", "/setup/static/app.js", "/setup/v1/telescope/0/setup"):
        status, _, _ = request(port, "GET", path, rebound(port))
        assert status == 200, path


def test_a_request_without_host_is_judged_by_origin(rig_factory: RigFactory) -> None:
    """HTTP/1.0 may send no Host: Origin alone decides, and with neither the request is served."""
    rig = rig_factory()
    main = rig.clients[0]
    main.command("tracking", Tracking="false")

    def put_10(extra: bytes) -> bytes:
        body = b"ClientID=5&Tracking=true"
        with socket.create_connection(("127.0.0.1", rig.port), timeout=TIMEOUT) as sock:
            sock.sendall(b"PUT /api/v1/telescope/0/tracking HTTP/1.0\r\nContent-Type: " + FORM.encode() +
                         b"\r\nContent-Length: " + str(len(body)).encode() + b"\r\n" + extra + b"\r\n" + body)
            reply = b""
            while chunk := sock.recv(4096):
                reply += chunk
        return reply

    reply = put_10(b"Origin: http://evil.example\r\n")
    assert reply.startswith(b"HTTP/1.0 403") and b"server.allowed_hosts" in reply, reply
    settle(rig)
    assert rig.snapshot()["tracking"] is False
    reply = put_10(b"")
    assert reply.startswith(b"HTTP/1.0 200"), reply
    settle(rig)
    assert rig.snapshot()["tracking"] is True


def test_allowed_hosts_from_the_page_apply_at_once(rig_factory: RigFactory, tmp_path: Path) -> None:
    rig = rig_factory()
    main = rig.clients[0]
    main.command("tracking", Tracking="false")
    port = rig.port
    local = {"Host": f"127.0.0.1:{port}"}
    assert_refused(*put(rig, "tracking", rebound(port), "ClientID=5&Tracking=true"))

    status, _, text = _setup_post(port, "/setup/api/server", {"allowed_hosts": ["Evil.Example"]}, local)
    assert status == 200, text
    view = json.loads(text)
    assert view["allowed_hosts"] == ["Evil.Example"] and view["restart_required"] is False
    assert f"{HOSTNAME.split('.')[0].lower()}.local" in view["host_names"]
    assert "Evil.Example" in (tmp_path / "config.toml").read_text()  # saved, and in effect without a restart
    status, _, text = put(rig, "tracking", rebound(port), "ClientID=5&Tracking=true")
    assert status == 200 and json.loads(text)["ErrorNumber"] == 0, text
    settle(rig)
    assert rig.snapshot()["tracking"] is True
    assert_refused(*put(rig, "tracking", {"Host": "other.example"}, "ClientID=5&Tracking=false"), "other.example")

    status, _, text = _setup_post(port, "/setup/api/server", {"allowed_hosts": ["*"]}, local)
    assert status == 200 and json.loads(text)["allowed_hosts"] == ["*"]
    status, _, _ = put(rig, "tracking", {"Host": "other.example"}, "ClientID=5&Tracking=false")
    assert status == 200

    for bad in (["bad name"], ["astropi.lan:11111"], ["x\u0007"], "evil.example"):
        status, _, text = _setup_post(port, "/setup/api/server", {"allowed_hosts": bad}, local)
        assert status == 400 and "allowed_hosts" in text, (bad, status, text)
    status, _, _ = _setup_post(port, "/setup/api/server", {"allowed_hosts": []}, local)
    assert status == 200
    assert_refused(*put(rig, "tracking", rebound(port), "ClientID=5&Tracking=true"))


def test_refused_before_basic_auth_asks_for_a_password(rig_factory: RigFactory) -> None:
    """A rebinding page must not make the browser show a password prompt for evil.example."""
    rig = rig_factory(connect=False, server=ServerSettings(host="127.0.0.1", port=0, discovery_port=0,
                                                           basic_auth_user="astro", basic_auth_password="s3cret"))
    status, _, text = request(rig.port, "GET", "/setup/api/server", rebound(rig.port))
    assert_refused(status, "text/plain", text)
    status, _, _ = request(rig.port, "GET", "/setup/api/server", {"Host": f"127.0.0.1:{rig.port}"})
    assert status == 401
