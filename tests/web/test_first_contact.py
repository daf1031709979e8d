"""First contact (issue 25 item 5): finding the page from another device, and a clear start.

- ``http://host:11111/`` redirects to ``/setup``; every other unmatched path keeps the Alpaca
  answers ConformU checks (400 malformed device path, 403 unknown management method, 404 else).
- Listening on all interfaces, the start banner lists the page's URL at each of this machine's
  LAN addresses and at ``<hostname>.local``: checked inside private network namespaces
  (tests/netns.py) whose veth addresses exist nowhere else, and one of those URLs is then opened
  from the other namespace, as a phone on the LAN would.
- A port already in use gives one line naming it, the running server's page and ``--port``.
- The page's API names the mount really driven: a ``--device`` URL is not "the built-in emulator".
"""

from __future__ import annotations

import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
import requests

from alpaca_zwo.emulator import EmulatorServer, MountModel, ScaledClock
from alpaca_zwo.server import AlpacaZwoServer, Overrides
from tests.conftest import ServerFactory
from tests.netns import NetnsLan, NsProcess, lan_fixture
from tests.support import wait_until

ENV = {"PYTHONPATH": str(Path(__file__).resolve().parents[2]), "PATH": "/usr/bin:/bin"}
TIMEOUT = 10
lan = lan_fixture(2)


# ================================================================================================
# http://host:11111/ finds the page; other paths keep their Alpaca answers
# ================================================================================================


def test_root_redirects_to_the_setup_page(live_server: AlpacaZwoServer, base_url: str) -> None:
    for path in ("/", "/index.html"):
        reply = requests.get(base_url + path, allow_redirects=False, timeout=TIMEOUT)
        assert reply.status_code == 302, (path, reply.status_code, reply.text)  # not 301: never cached for good
        assert reply.headers["Location"] in ("/setup", f"{base_url}/setup"), reply.headers
        head = requests.head(base_url + path, allow_redirects=False, timeout=TIMEOUT)
        assert head.status_code == 302
    page = requests.get(base_url + "/", timeout=TIMEOUT)  # followed, as a browser does
    assert page.status_code == 200 and page.url == base_url + "/setup"
    assert "text/html" in page.headers["Content-Type"] and "<title>alpaca-zwo setup</title>" in page.text


@pytest.mark.parametrize(("path", "status"), [
    ("/api/v1/Telescope/0/connected", 400),  # wrong case: malformed device path (Alpaca §2.5.2)
    ("/api/v2/telescope/0/connected", 400),
    ("/api", 400),
    ("/management/v1/nosuchmethod", 403),  # unknown management method, as the management spec lists
    ("/management/nosuch", 400),
    ("/index.htm", 404),
    ("/setup/", 404),
    ("/x/", 404),
])
def test_only_the_root_redirects(base_url: str, path: str, status: int) -> None:
    reply = requests.get(base_url + path, allow_redirects=False, timeout=TIMEOUT)
    assert reply.status_code == status, (path, reply.status_code, reply.text)
    assert "Location" not in reply.headers


def test_root_is_behind_the_host_check(live_server: AlpacaZwoServer) -> None:
    """The redirect is not an open path: an open "/" would open every path (HostCheck's prefixes)."""
    reply = requests.get(f"http://127.0.0.1:{live_server.port}/api/v1/telescope/0/connected",
                         headers={"Host": "evil.example"}, timeout=TIMEOUT)
    assert reply.status_code == 403
    reply = requests.get(f"http://127.0.0.1:{live_server.port}/", headers={"Host": "evil.example"},
                         allow_redirects=False, timeout=TIMEOUT)
    assert reply.status_code == 403


# ================================================================================================
# The banner names the page's URL at this machine's LAN addresses
# ================================================================================================

SERVE = """
import sys
from alpaca_zwo.cli import server_main
sys.exit(server_main(sys.argv[1:]))
"""


def _banner(lan: NetnsLan, tmp_path: Path, host: str) -> tuple[list[str], int, NsProcess]:
    """Start ``alpaca-zwo --host HOST --port 0`` in the first namespace; its banner lines and port."""
    config = tmp_path / f"config-{host.replace(':', '6')}.toml"
    config.write_text("[server]\nmdns = false\n")
    server = lan.hosts[0].spawn_python(SERVE, "--config", str(config), "--host", host, "--port", "0",
                                       "--discovery-port", "0")
    lines = [server.expect("alpaca-zwo ", timeout=30)]
    while not lines[-1].startswith("(listening on all interfaces"):
        lines.append(server.readline(TIMEOUT).strip())
    port = int(lines[-1].rsplit(" ", 1)[1].rstrip(")"))
    return lines, port, server


def _stop(server: NsProcess) -> None:
    """SIGTERM, as systemd stops it (the server does not read stdin, NsProcess.stop's first request)."""
    server.proc.terminate()
    assert server.proc.wait(TIMEOUT) == 0


def test_banner_lists_the_page_at_each_lan_address(lan: NetnsLan, tmp_path: Path) -> None:
    """IPv4 on 0.0.0.0; IPv4, global IPv6 and never link-local on ::; the .local name on both."""
    a, b = lan.hosts
    a.run("ip", "addr", "add", "fd42:25::1/64", "dev", a.ifname, "nodad")
    local = socket.gethostname().split(".")[0] + ".local"  # the namespaces share this host's name

    lines, port, server = _banner(lan, tmp_path, "0.0.0.0")
    text = "\n".join(lines)
    assert f"http://{a.ipv4}:{port}/setup" in text, text
    assert f"http://{local}:{port}/setup" in text, text
    assert "fd42:25::1" not in text and "fe80" not in text, text  # 0.0.0.0 serves IPv4 only
    # The printed URL works from another host on the LAN, / included.
    reply = b.python("import sys, urllib.request\n"
                     "r = urllib.request.urlopen(sys.argv[1], timeout=10)\n"
                     "print(r.status, r.url, 'alpaca-zwo setup' in r.read().decode())",
                     f"http://{a.ipv4}:{port}/")
    assert reply.split() == ["200", f"http://{a.ipv4}:{port}/setup", "True"], reply
    _stop(server)

    lines, port, server = _banner(lan, tmp_path, "::")
    text = "\n".join(lines)
    for url in (f"http://{a.ipv4}:{port}/setup", f"http://[fd42:25::1]:{port}/setup", f"http://{local}:{port}/setup"):
        assert url in text, (url, text)
    assert "fe80" not in text and "[::1]" not in text, text
    _stop(server)


def test_banner_on_one_address_names_only_that_address(live_server: AlpacaZwoServer) -> None:
    lines = live_server.urls()
    assert f"Setup page:   http://127.0.0.1:{live_server.port}/setup" in lines
    assert not any(".local" in line for line in lines), lines


# ================================================================================================
# A port already in use: one line, the port, the running server's page and --port
# ================================================================================================




def _start_line(*arguments: str) -> list[str]:
    done = subprocess.run([sys.executable, "-m", "alpaca_zwo", *arguments], capture_output=True, text=True,
                          env=ENV, timeout=60)
    assert done.returncode != 0
    return [line for line in (done.stdout + done.stderr).splitlines() if line.strip()]


def test_port_in_use_says_which_and_what_to_do(tmp_path: Path, listener: int) -> None:
    config = tmp_path / "config.toml"
    config.write_text("[server]\nmdns = false\n")
    output = _start_line("--config", str(config), "--host", "127.0.0.1", "--port", str(listener),
                         "--discovery-port", "0")
    assert len(output) == 1, output  # one line, no traceback
    line = output[0]
    assert line.startswith("alpaca-zwo: cannot start:"), line
    assert f"server.port {listener} is in use" in line, line
    assert "is alpaca-zwo already running?" in line and f"http://127.0.0.1:{listener}/setup" in line, line
    assert "--port 11111" in line, line


# ================================================================================================
# The page names the mount it really drives
# ================================================================================================


@pytest.fixture
def external_mount() -> Iterator[str]:
    """An emulator on its own TCP port: to the server, a real mount at a socket:// URL (its WiFi)."""
    emulator = EmulatorServer(MountModel(ScaledClock()), host="127.0.0.1", port=0, baud=0).start()
    yield f"socket://127.0.0.1:{emulator.port}"
    emulator.stop()


def _page_api(server: AlpacaZwoServer, path: str) -> dict[str, object]:
    reply = requests.get(f"http://127.0.0.1:{server.port}/setup/api/telescope/0/{path}", timeout=TIMEOUT)
    assert reply.status_code == 200, reply.text
    data: dict[str, object] = reply.json()
    return data


def test_a_device_url_is_named_not_called_the_emulator(server_factory: ServerFactory, external_mount: str) -> None:
    server = server_factory(None, Overrides(device_url=external_mount))
    settings = _page_api(server, "settings")
    assert settings["device"]["url"] == external_mount, settings["device"]  # type: ignore[index]
    link = _page_api(server, "status")["link"]
    assert link["emulated"] is False and link["url"] == external_mount, link  # type: ignore[index]


def test_the_built_in_emulator_is_named_as_such(live_server: AlpacaZwoServer) -> None:
    assert _page_api(live_server, "settings")["device"]["url"] == "(built-in emulator)"  # type: ignore[index]
    wait_until(lambda: "emulated" in _page_api(live_server, "status")["link"], TIMEOUT, "the status feed")  # type: ignore[operator]
    assert _page_api(live_server, "status")["link"]["emulated"] is True  # type: ignore[index]
