"""Security switches, attacked over real HTTP: listening address, body limits, path traversal,
cross-origin requests, raw mount commands and basic authentication.

``tests/web/test_setup_api.py`` already walks the static directory with the common traversal spellings
and checks the setup API's same-origin rules header by header; this file adds what an attacker
would try next (other prefixes, overlong UTF-8, the Alpaca API itself, requests a hostile page
can send without a CORS preflight) and checks the effect on the mount, not only the status code.
"""

from __future__ import annotations

import base64
import http.client
import socket
import time
from typing import Any

import pytest
import requests

from alpaca_zwo.config.settings import ServerSettings
from alpaca_zwo.server import AlpacaZwoServer
from alpaca_zwo.web import CSRF_HEADER
from tests.conftest import ServerFactory, make_settings
from tests.faults.conftest import RigFactory
from tests.faults.harness import report
from tests.support import AlpacaClient
from tests.support.alpaca import GET_LIMIT_S

TIMEOUT = 10
SECRETS = (b"[project]", b"root:", b"def setup_routes", b"import ", b"[server]", b"basic_auth")
USER, PASSWORD = "astro", "s3cret"


def _raw(port: int, method: str, path: str, headers: dict[str, str] | None = None, body: bytes = b"",
         host: str = "127.0.0.1") -> tuple[int, dict[str, str], bytes]:
    """Send exactly this request line (requests would normalise dot segments and encodings away)."""
    conn = http.client.HTTPConnection(host, port, timeout=TIMEOUT)
    try:
        conn.putrequest(method, path, skip_accept_encoding=True)
        for name, value in (headers or {}).items():
            conn.putheader(name, value)
        if body:
            conn.putheader("Content-Length", str(len(body)))
        conn.endheaders(body or None)
        response = conn.getresponse()
        return response.status, {k.lower(): v for k, v in response.getheaders()}, response.read()
    finally:
        conn.close()


def _settings(**server: Any) -> Any:
    return make_settings(server=ServerSettings(host="127.0.0.1", port=0, discovery_port=0, **server))


# --- listening address --------------------------------------------------------------------------


def test_listens_only_on_the_configured_address(server_factory: ServerFactory) -> None:
    """``server.host`` decides where the API is reachable: bound to 127.0.0.2, 127.0.0.1 gets nothing."""
    server = server_factory(make_settings(server=ServerSettings(host="127.0.0.2", port=0, discovery_port=0)))
    r = requests.get(f"http://127.0.0.2:{server.port}/management/apiversions", timeout=TIMEOUT)
    assert r.status_code == 200 and r.json()["Value"] == [1]
    with pytest.raises(requests.ConnectionError):
        requests.get(f"http://127.0.0.1:{server.port}/management/apiversions", timeout=TIMEOUT)


# --- request body size --------------------------------------------------------------------------


def _tracking_body(size: int) -> bytes:
    body = b"ClientID=5&ClientTransactionID=1&Tracking=true&Pad="
    return body + b"x" * (size - len(body))


def test_oversize_bodies_are_refused_unread(rig_factory: RigFactory) -> None:
    """Over the limit is 413 (never 5xx, never acted on), at the limit works, a lying length does not hang."""
    limit = 2048
    rig = rig_factory(server=ServerSettings(host="127.0.0.1", port=0, discovery_port=0, max_body_bytes=limit))
    main = rig.clients[0]
    main.command("tracking", Tracking="false")
    form = {"Content-Type": "application/x-www-form-urlencoded"}
    path = "/api/v1/telescope/0/tracking"

    status, _, _ = _raw(rig.port, "PUT", path, form, _tracking_body(limit + 1))
    assert status == 413
    status, _, _ = _raw(rig.port, "PUT", path, form, _tracking_body(64 * 1024))
    assert status == 413
    assert main.value("tracking") is False, "an oversize PUT was acted on"

    # Chunked: no Content-Length to check up front; the body still may not exceed the limit.
    chunks = (b"ClientID=5&Tracking=true&Pad=" + b"x" * 1000 for _ in range(64))
    r = requests.put(f"http://127.0.0.1:{rig.port}{path}", data=chunks, headers=form, timeout=TIMEOUT)
    assert r.status_code in (400, 413), r.status_code
    assert main.value("tracking") is False, "an oversize chunked PUT was acted on"

    # A Content-Length far beyond the limit with almost no body: refused at once, not waited for.
    started = time.monotonic()
    with socket.create_connection(("127.0.0.1", rig.port), timeout=TIMEOUT) as sock:
        sock.sendall(b"PUT " + path.encode() + b" HTTP/1.1\r\nHost: x\r\nContent-Type: application/x-www-form-"
                     b"urlencoded\r\nContent-Length: 1000000000\r\n\r\nClientID=5&Tracking=true")
        reply = sock.recv(4096)
    assert reply.startswith(b"HTTP/1.1 413"), reply[:80]
    assert time.monotonic() - started < GET_LIMIT_S

    setup = {"Content-Type": "application/json", CSRF_HEADER: "1"}
    big = b'{"on": true, "pad": "' + b"x" * (limit + 10) + b'"}'
    status, _, _ = _raw(rig.port, "POST", "/setup/api/telescope/0/action/tracking", setup, big)
    assert status == 413
    assert main.value("tracking") is False, "an oversize setup POST was acted on"
    status, _, _ = _raw(rig.port, "PUT", path, form, _tracking_body(limit // 2))
    assert status == 200 and main.value("tracking") is True, "the server stopped serving after the refusals"
    assert not rig.log.problems()


def test_a_body_at_the_limit_is_accepted(rig_factory: RigFactory) -> None:
    """``max_body_bytes`` is the largest body allowed, not the smallest refused."""
    limit = 2048
    rig = rig_factory(server=ServerSettings(host="127.0.0.1", port=0, discovery_port=0, max_body_bytes=limit))
    form = {"Content-Type": "application/x-www-form-urlencoded"}
    status, _, body = _raw(rig.port, "PUT", "/api/v1/telescope/0/tracking", form, _tracking_body(limit))
    assert status == 200, f"a body of exactly max_body_bytes ({limit}) was refused: {status} {body[:100]!r}"
    assert rig.clients[0].value("tracking") is True


# --- static files and other paths -----------------------------------------------------------------


TRAVERSALS = [
    "/setup/%2e%2e/pyproject.toml",
    "/setup/static/..;/pyproject.toml",
    "/setup/static/....//....//pyproject.toml",
    "/setup/static/%c0%ae%c0%ae%c0%afpyproject.toml",
    "/setup/static/%c0%ae%c0%ae/%c0%ae%c0%ae/pyproject.toml",
    "/setup/static/%2e%2e%5c%2e%2e%5cpyproject.toml",
    "/setup/static/%2e%2e%2f%2e%2e%2falpaca_zwo%2fconfig.py",
    "/setup/static/%252e%252e%252f%252e%252e%252fpyproject.toml",
    "/setup/static/~/.ssh/id_rsa",
    "/setup/static/%00../../pyproject.toml",
    "/setup/v1/telescope/0/..%2f..%2f..%2fpyproject.toml",
    "/setup/v1/telescope/0/%2e%2e%2f%2e%2e%2f%2e%2e%2fstatic%2f..%2fpyproject.toml",
    "/static/../pyproject.toml",
    "/static/app.js",
    "/api/v1/telescope/0/../../../../pyproject.toml",
    "/api/v1/telescope/0/%2e%2e%2f%2e%2e%2f%2e%2e%2fpyproject.toml",
    "/management/..%2f..%2fpyproject.toml",
    "//etc/passwd",
    "/%2e%2e/%2e%2e/%2e%2e/etc/passwd",
    "/..%2f..%2f..%2fetc%2fpasswd",
]


@pytest.mark.parametrize("path", TRAVERSALS)
def test_no_path_leaves_static(live_server: AlpacaZwoServer, path: str) -> None:
    status, _, body = _raw(live_server.port, "GET", path)
    assert 400 <= status < 500, (path, status)
    for secret in SECRETS:
        assert secret not in body, (path, secret)


def test_static_serves_its_own_files(live_server: AlpacaZwoServer) -> None:
    """The positive control for the traversal list: the page's own files are served."""
    status, headers, body = _raw(live_server.port, "GET", "/setup/static/app.js")
    assert status == 200 and headers["content-type"].startswith("text/javascript") and body


def test_traversal_behind_basic_auth(server_factory: ServerFactory) -> None:
    """With authentication on, a traversal attempt is 401 unauthenticated and still 4xx authenticated."""
    server = server_factory(_settings(basic_auth_user=USER, basic_auth_password=PASSWORD))
    good = {"Authorization": "Basic " + base64.b64encode(f"{USER}:{PASSWORD}".encode()).decode()}
    for path in ("/setup/static/%2e%2e%2f%2e%2e%2fpyproject.toml", "/static/../pyproject.toml"):
        assert _raw(server.port, "GET", path)[0] == 401, path
        status, _, body = _raw(server.port, "GET", path, good)
        assert 400 <= status < 500 and status != 401, (path, status)
        assert not any(secret in body for secret in SECRETS)


# --- cross-origin requests ------------------------------------------------------------------------


EVIL = "http://evil.example"


def test_alpaca_api_gives_other_origins_nothing(rig_factory: RigFactory) -> None:
    """A hostile page can POST forms and ask for a CORS preflight: neither may change the mount.

    Alpaca's state changes are PUTs, which a browser sends cross-origin only after a preflight; the
    server must never grant one, and a form POST (which needs none) must not be treated as a PUT.
    """
    rig = rig_factory()
    main = rig.clients[0]
    main.command("tracking", Tracking="false")
    form = {"Content-Type": "application/x-www-form-urlencoded", "Origin": EVIL}
    for member, body in (("tracking", b"ClientID=5&Tracking=true"), ("moveaxis", b"ClientID=5&Axis=0&Rate=4"),
                         ("park", b"ClientID=5")):
        status, headers, _ = _raw(rig.port, "POST", f"/api/v1/telescope/0/{member}", form, body)
        assert status in (400, 403, 404, 405), (member, status)
        assert "access-control-allow-origin" not in headers
    status, headers, _ = _raw(rig.port, "OPTIONS", "/api/v1/telescope/0/tracking",
                              {"Origin": EVIL, "Access-Control-Request-Method": "PUT"})
    assert headers.get("access-control-allow-origin") not in ("*", EVIL), headers
    assert "PUT" not in headers.get("access-control-allow-methods", ""), headers
    status, headers, _ = _raw(rig.port, "PUT", "/api/v1/telescope/0/tracking",
                              {**form, "Origin": EVIL}, b"ClientID=5&Tracking=false")
    assert "access-control-allow-origin" not in headers, "a cross-origin page could read the reply"
    time.sleep(0.3)  # a move command has no reply: give one that slipped through time to show
    assert main.value("tracking") is False and rig.snapshot()["moves_deg_s"] == [None, None]
    assert main.value("atpark") is False


@pytest.mark.parametrize(("content_type", "body"), [
    ("text/plain", b'{"on": true}'),  # a fetch() with mode no-cors: no preflight
    ("application/x-www-form-urlencoded", b"on=true"),  # a plain HTML form
    ("multipart/form-data; boundary=x", b'--x\r\nContent-Disposition: form-data; name="on"\r\n\r\ntrue\r\n--x--'),
])
def test_setup_api_refuses_simple_cross_origin_posts(rig_factory: RigFactory, content_type: str, body: bytes) -> None:
    """The requests a hostile page can fire without a preflight never reach the mount controls."""
    rig = rig_factory()
    main = rig.clients[0]
    main.command("tracking", Tracking="false")
    headers = {"Content-Type": content_type, "Origin": EVIL, "Sec-Fetch-Site": "cross-site"}
    for action in ("tracking", "park", "move"):
        status, _, _ = _raw(rig.port, "POST", f"/setup/api/telescope/0/action/{action}", headers, body)
        assert status in (403, 415), (action, status)
    time.sleep(0.3)
    assert main.value("tracking") is False
    assert main.value("atpark") is False and main.value("slewing") is False
    assert rig.snapshot()["moves_deg_s"] == [None, None] and rig.snapshot()["slew"] is None


def test_cross_origin_with_the_header_still_refused_for_motion(rig_factory: RigFactory) -> None:
    """Even a request carrying the custom header (possible only if CORS were granted) from a foreign
    origin cannot jog or park the mount."""
    rig = rig_factory()
    main = rig.clients[0]
    headers = {"Content-Type": "application/json", CSRF_HEADER: "1", "Origin": EVIL}
    for action, body in (("move", b'{"axis": 0, "rate": 1.0}'), ("park", b"{}"), ("home", b"{}")):
        status, _, _ = _raw(rig.port, "POST", f"/setup/api/telescope/0/action/{action}", headers, body)
        assert status == 403, (action, status)
    time.sleep(0.3)
    assert rig.snapshot()["moves_deg_s"] == [None, None] and rig.snapshot()["slew"] is None
    assert main.value("slewing") is False


# --- raw mount commands ---------------------------------------------------------------------------


RAW = [("commandblind", ":Me#"), ("commandbool", ":Te#"), ("commandstring", ":GVP#"), ("commandstring", "Mw")]


def test_raw_commands_are_off_by_default(rig_factory: RigFactory) -> None:
    """CommandBlind/Bool/String bypass every safety check, so by default they never reach the mount."""
    rig = rig_factory()
    main = rig.clients[0]
    assert rig.server.settings.server.allow_raw_commands is False
    before = len(rig.recorder.all())
    for member, command in RAW:
        for raw in ("true", "false"):
            call = main.put(member, Command=command, Raw=raw)
            assert call.status == 200 and call.error_number == 0x400, call.describe()
            assert "allow_raw_commands" in call.error_message, call.error_message
    time.sleep(0.5)
    reached = [e.body for e in rig.recorder.all()[before:] if e.body in ("Me", "Mw", "Te")]
    assert not reached, f"raw commands reached the mount while disabled: {reached}"
    assert rig.snapshot()["moves_deg_s"] == [None, None]


def test_raw_commands_work_only_when_enabled(rig_factory: RigFactory) -> None:
    """The positive control: the configuration switch, and only it, lets them through."""
    rig = rig_factory(server=ServerSettings(host="127.0.0.1", port=0, discovery_port=0, allow_raw_commands=True))
    main = rig.clients[0]
    assert main.put("commandstring", Command=":GVP#", Raw="true").value == "AM5"


def test_setup_page_cannot_enable_raw_commands_or_drop_auth(server_factory: ServerFactory) -> None:
    """The browser page edits network settings, but not the switches that guard the mount or the page."""
    server = server_factory(_settings(basic_auth_user=USER, basic_auth_password=PASSWORD))
    headers = {CSRF_HEADER: "1", "Content-Type": "application/json"}
    for change in ({"allow_raw_commands": True}, {"basic_auth_user": ""}, {"basic_auth_password": ""},
                   {"max_body_bytes": 16 * 1024 * 1024}):
        r = requests.post(f"http://127.0.0.1:{server.port}/setup/api/server", json=change, headers=headers,
                          auth=(USER, PASSWORD), timeout=TIMEOUT)
        assert r.status_code == 400, (change, r.status_code, r.text)
    settings = server.store.settings.server
    assert settings.allow_raw_commands is False and settings.basic_auth_user == USER
    assert settings.max_body_bytes == 65536


# --- basic authentication -------------------------------------------------------------------------


def _basic(text: str) -> str:
    return "Basic " + base64.b64encode(text.encode()).decode()


WRONG = {
    "no credentials": None,
    "wrong password": _basic(f"{USER}:wrong"),
    "wrong user": _basic(f"Astro:{PASSWORD}"),
    "empty password": _basic(f"{USER}:"),
    "empty user": _basic(f":{PASSWORD}"),
    "password with a suffix": _basic(f"{USER}:{PASSWORD}x"),
    "password prefix": _basic(f"{USER}:{PASSWORD[:-1]}"),
    "no colon": _basic(f"{USER}{PASSWORD}"),
    "extra colon": _basic(f"{USER}:{PASSWORD}:"),
    "not base64": "Basic !!!not-base64!!!",
    "bearer token": f"Bearer {PASSWORD}",
    "credentials in clear": f"Basic {USER}:{PASSWORD}",
}
PROTECTED = [
    ("GET", "/api/v1/telescope/0/connected?ClientID=1", b""),
    ("PUT", "/api/v1/telescope/0/connected", b"ClientID=1&Connected=true"),
    ("GET", "/management/v1/configureddevices", b""),
    ("GET", "/setup", b""),
    ("GET", "/setup/api/telescope/0/status", b""),
    ("POST", "/setup/api/telescope/0/action/connect", b"{}"),
]


@pytest.fixture
def guarded(server_factory: ServerFactory) -> AlpacaZwoServer:
    return server_factory(_settings(basic_auth_user=USER, basic_auth_password=PASSWORD))


@pytest.mark.parametrize("case", list(WRONG))
def test_wrong_credentials_are_refused(guarded: AlpacaZwoServer, case: str) -> None:
    authorization = WRONG[case]
    for method, path, body in PROTECTED:
        headers = {"Content-Type": "application/json" if path.startswith("/setup") else
                   "application/x-www-form-urlencoded", CSRF_HEADER: "1"}
        if authorization is not None:
            headers["Authorization"] = authorization
        status, reply_headers, reply = _raw(guarded.port, method, path, headers, body)
        assert status == 401, (case, method, path, status)
        assert reply_headers.get("www-authenticate", "").startswith("Basic "), reply_headers
        assert PASSWORD.encode() not in reply
    # Nothing the refused requests asked for happened.
    assert not guarded.telescopes[0].mount.running


def test_right_credentials_are_accepted(guarded: AlpacaZwoServer) -> None:
    client = AlpacaClient(guarded.port, 1, auth=(USER, PASSWORD))
    client.command("connected", Connected="true")
    assert client.value("connected") is True
    r = requests.get(f"http://127.0.0.1:{guarded.port}/setup", auth=(USER, PASSWORD), timeout=TIMEOUT)
    assert r.status_code == 200
    report("basic auth", wrong_credential_cases=len(WRONG), protected_routes=len(PROTECTED))
