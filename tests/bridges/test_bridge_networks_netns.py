"""The bridges' ``allowed_networks`` on a real link (issue 32), inside private network namespaces.

``alpaca-zwo`` runs in the first namespace (10.231.0.1/24) with both bridges on and the default
setting, ``"local"``: loopback plus this machine's own networks. The second namespace is a machine
with two addresses: 10.231.0.2, on the server's LAN, and 192.168.77.2, on a network the server has no
interface in (as a routed or VPN network would be). From the first address both bridges answer; from
the second both close the connection unread, and the log says so once a minute however often it
is tried. A line added on the setup page lets the second address in at once. The veth link and its
addresses exist only inside the namespaces (tests/netns.py): nothing reaches the host's network.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.netns import Namespace, NetnsLan, NsProcess, lan_fixture
from tests.support import wait_until

lan = lan_fixture(2)
TIMEOUT = 30
OTHER_NETWORK = "192.168.77"  # the client's second address is .2 in it; the server has no address there

SERVE = """
import sys
from alpaca_zwo.cli import server_main
sys.exit(server_main(sys.argv[1:]))
"""

#: Runs in the client namespace: one connection to each bridge from each given source address.
PROBE = """
import json, socket, sys
server, sources = sys.argv[1], sys.argv[2:]

def zwo(source):
    with socket.create_connection((server, 4030), timeout=10, source_address=(source, 0)) as sock:
        sock.sendall(b":GVP#")
        reply = b""
        try:
            while not reply.endswith(b"#"):
                chunk = sock.recv(1)
                if not chunk:
                    break
                reply += chunk
        except ConnectionResetError:
            pass
        return reply.decode()

def stellarium(source):
    with socket.create_connection((server, 10001), timeout=20, source_address=(source, 0)) as sock:
        got = b""
        try:
            while len(got) < 24:
                chunk = sock.recv(24 - len(got))
                if not chunk:
                    break
                got += chunk
        except ConnectionResetError:
            pass
        return len(got)

print(json.dumps({source: {"zwo": zwo(source), "stellarium": stellarium(source)} for source in sources}))
"""

PAGE = """
import json, sys, urllib.request
body = sys.argv[1].encode() if len(sys.argv) > 1 else None
request = urllib.request.Request("http://127.0.0.1:11111/setup/api/server", data=body,
                                 headers={"Content-Type": "application/json", "X-Alpaca-Zwo": "1"})
print(urllib.request.urlopen(request, timeout=10).read().decode())
"""


def _start(lan: NetnsLan, tmp_path: Path) -> NsProcess:
    config = tmp_path / "config.toml"
    config.write_text('[server]\nport = 11111\ndiscovery_port = 0\nmdns = false\n'
                      '[zwo_port]\nenabled = true\nport = 4030\n'
                      '[stellarium]\nenabled = true\nport = 10001\nequinox = "JNow"\n')
    server = lan.hosts[0].spawn_python(SERVE, "--config", str(config))
    server.expect("alpaca-zwo ", timeout=TIMEOUT)
    line = ""
    while not line.startswith("(listening on all interfaces"):
        line = server.readline(TIMEOUT).strip()
    return server


def _probe(client: Namespace, server: Namespace, *sources: str) -> dict[str, dict[str, object]]:
    result: dict[str, dict[str, object]] = json.loads(client.python(PROBE, server.ipv4, *sources, timeout=60))
    return result


def _lines(server: NsProcess, words: str) -> list[str]:
    return [line for line in server.stderr.splitlines() if words in line]


def test_only_allowed_networks_reach_the_bridges(lan: NetnsLan, tmp_path: Path) -> None:
    a, b = lan.hosts
    other = f"{OTHER_NETWORK}.2"
    b.run("ip", "addr", "add", f"{other}/24", "dev", b.ifname)  # the client's second address
    server = _start(lan, tmp_path)
    try:
        view = json.loads(a.python(PAGE))
        assert view["allowed_networks"] == {"zwo_port": ["local"], "stellarium": ["local"]}
        assert "10.231.0.0/24" in view["local_networks"] and "127.0.0.0/8" in view["local_networks"]
        assert not any(n.startswith(OTHER_NETWORK) for n in view["local_networks"]), view["local_networks"]

        # The LAN address gets through to both bridges.
        result = _probe(b, a, b.ipv4)
        assert result[b.ipv4] == {"zwo": "AM5#", "stellarium": 24}, result

        # The other address is closed unread by both, three times over; each refusal is logged once.
        for _ in range(3):
            result = _probe(b, a, other)
            assert result[other] == {"zwo": "", "stellarium": 0}, result
        _probe(b, a, b.ipv4)  # a later, allowed connection: its log lines come after every refusal's
        wait_until(lambda: len(_lines(server, f"program {b.ipv4}:")) >= 4, TIMEOUT, "the last program's log lines")
        zwo_refusals = _lines(server, f"ZWO port: connection from {other}:")
        stellarium_refusals = _lines(server, f"Stellarium port: connection from {other}:")
        assert len(zwo_refusals) == 1 and len(stellarium_refusals) == 1, server.stderr
        assert f"{other} is not in zwo_port.allowed_networks (add its network on the setup page)" in zwo_refusals[0]
        assert f"{other} is not in stellarium.allowed_networks" in stellarium_refusals[0]
        assert not _lines(server, f"program {other}:") and not _lines(server, f"Stellarium connected from {other}")

        # A line for the other network, saved on the page, lets it in at once (the ZWO port only).
        change = {"allowed_networks": {"zwo_port": ["local", f"{OTHER_NETWORK}.0/24"]}}
        view = json.loads(a.python(PAGE, json.dumps(change)))
        assert view["allowed_networks"]["zwo_port"] == ["local", f"{OTHER_NETWORK}.0/24"]
        result = _probe(b, a, other, b.ipv4)
        assert result[other] == {"zwo": "AM5#", "stellarium": 0}, result
        assert result[b.ipv4] == {"zwo": "AM5#", "stellarium": 24}, result
    finally:
        server.proc.terminate()
        assert server.proc.wait(TIMEOUT) == 0, server.stderr


@pytest.mark.parametrize("entries", [["10.231.0.2"], ["local"]])
def test_a_single_address_or_local_decides_for_the_lan_too(lan: NetnsLan, tmp_path: Path, entries: list[str]) -> None:
    """A list without "local" replaces it: only that address (and not loopback) gets in."""
    a, b = lan.hosts
    server = _start(lan, tmp_path)
    try:
        a.python(PAGE, json.dumps({"allowed_networks": {"zwo_port": entries, "stellarium": entries}}))
        result = _probe(b, a, b.ipv4)
        assert result[b.ipv4] == {"zwo": "AM5#", "stellarium": 24}, result
        local = json.loads(a.python(PROBE, "127.0.0.1", "127.0.0.1"))  # the server's own machine, by loopback
        expected = {"zwo": "AM5#", "stellarium": 24} if entries == ["local"] else {"zwo": "", "stellarium": 0}
        assert local["127.0.0.1"] == expected, local
    finally:
        server.proc.terminate()
        assert server.proc.wait(TIMEOUT) == 0, server.stderr
