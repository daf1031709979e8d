"""Tests for the optional mDNS advertisement of the setup page.

Anything that sends mDNS runs in private network namespaces (tests/netns.py): the advertiser in
one, a stock zeroconf ServiceBrowser in another, so the test sees what a real browser on the LAN
would see. Tests in the host's namespace only build records and never open a socket.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from alpaca_zwo.alpaca.advertise import SERVICE_TYPE, SETUP_PATH, MdnsAdvertiser
from tests.netns import REPO_ROOT, Namespace, NetnsLan, NsProcess, lan_fixture

HTTP_PORT = 11111
EVENT_TIMEOUT = 15.0  # mDNS probing alone takes ~1 s; this is a ceiling, not a wait

lan = lan_fixture(2)
lan3 = lan_fixture(3)

# A stock zeroconf browser: one "EVENT <json>" line per add/remove, stops on stdin EOF.
BROWSER = r"""
import json, sys, threading
from zeroconf import ServiceBrowser, ServiceListener, Zeroconf
lock = threading.Lock()
def emit(kind, **data):
    with lock:
        print(kind, json.dumps(data), flush=True)
class Listener(ServiceListener):
    def add_service(self, zc, type_, name):
        info = zc.get_service_info(type_, name, timeout=5000)
        if info is None:
            emit("UNRESOLVED", name=name)
            return
        props = {k.decode(): None if v is None else v.decode() for k, v in info.properties.items()}
        emit("ADDED", name=name, port=info.port, properties=props,
             addresses=sorted(info.parsed_addresses()), server=info.server)
    def update_service(self, zc, type_, name):
        pass
    def remove_service(self, zc, type_, name):
        emit("REMOVED", name=name)
zc = Zeroconf()
browser = ServiceBrowser(zc, sys.argv[1], Listener())
emit("READY")
sys.stdin.readline()
browser.cancel()
zc.close()
"""

# The advertiser under test; start()/stop() are each called twice to show they are idempotent.
ADVERTISER = r"""
import json, sys
from alpaca_zwo.alpaca.advertise import MdnsAdvertiser
addresses = json.loads(sys.argv[3])
adv = MdnsAdvertiser(int(sys.argv[1]), sys.argv[2], addresses)
adv.start()
adv.start()
print("READY", json.dumps({"name": adv.registered_name, "running": adv.running}), flush=True)
sys.stdin.readline()
adv.stop()
adv.stop()
print("STOPPED", json.dumps({"running": adv.running}), flush=True)
"""


def _event(proc: NsProcess, kind: str) -> dict[str, object]:
    return json.loads(proc.expect(kind + " ", EVENT_TIMEOUT).split(" ", 1)[1])


def _start_browser(host: Namespace) -> NsProcess:
    browser = host.spawn_python(BROWSER, SERVICE_TYPE)
    _event(browser, "READY")
    return browser


def _start_advertiser(host: Namespace, name: str, addresses: list[str] | None = None) -> NsProcess:
    adv = host.spawn_python(ADVERTISER, str(HTTP_PORT), name, json.dumps(addresses))
    ready = _event(adv, "READY")
    assert ready["running"] is True
    return adv


# -- no network ---------------------------------------------------------------------------------


def test_importing_costs_nothing() -> None:
    code = (
        "import sys, alpaca_zwo.alpaca.advertise, alpaca_zwo.alpaca.discovery;"
        "print(sorted(m for m in ('zeroconf', 'ifaddr') if m in sys.modules))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO_ROOT, check=True, timeout=30
    )
    assert out.stdout.strip() == "[]"


def test_service_records() -> None:
    adv = MdnsAdvertiser(HTTP_PORT, "ZWO AM5 v1.2", addresses=["192.168.7.2", "fd00::2"])
    info = adv.service_info()
    assert info.type == SERVICE_TYPE == "_http._tcp.local."
    assert info.name == "ZWO AM5 v1-2._http._tcp.local.", "a dot would split the instance name"
    assert info.port == HTTP_PORT
    assert info.properties == {b"path": SETUP_PATH.encode(), b"alpaca": b"1"}
    assert sorted(info.parsed_addresses()) == ["192.168.7.2", "fd00::2"]
    assert info.server is not None and info.server.endswith("-alpaca-zwo.local.")
    assert not adv.running and adv.registered_name is None
    adv.stop()  # before start: harmless


def test_long_names_are_cut_to_one_dns_label() -> None:
    adv = MdnsAdvertiser(HTTP_PORT, "é" * 40, addresses=["192.168.7.2"])
    assert adv.server_name == "é" * 31  # 62 bytes; a 64th byte would split a character
    assert len(adv.server_name.encode()) <= 63


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((0, "x"), "http_port"),
        ((80, "   "), "server_name"),
        ((80, "x", ["not-an-ip"]), "does not appear to be an IPv4 or IPv6 address"),
    ],
)
def test_bad_arguments_are_rejected_at_construction(args: tuple[object, ...], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        MdnsAdvertiser(*args)  # type: ignore[arg-type]


# -- across network namespaces ------------------------------------------------------------------


def test_browser_on_another_host_finds_then_loses_the_service(lan: NetnsLan) -> None:
    a, b = lan.hosts
    browser = _start_browser(a)
    adv = _start_advertiser(b, "AM5 test mount")

    added = _event(browser, "ADDED")
    assert added["name"] == f"AM5 test mount.{SERVICE_TYPE}"
    assert added["port"] == HTTP_PORT
    assert added["properties"] == {"path": "/setup", "alpaca": "1"}
    # default addresses: every non-loopback address of B (its link-local IPv6 is left out)
    assert added["addresses"] == [b.ipv4]

    adv.send("stop")
    assert json.loads(adv.expect("STOPPED").split(" ", 1)[1]) == {"running": False}
    assert _event(browser, "REMOVED")["name"] == added["name"]
    assert adv.stop() == 0


def test_explicit_addresses_are_published(lan: NetnsLan) -> None:
    a, b = lan.hosts
    browser = _start_browser(a)
    _start_advertiser(b, "pinned", addresses=[b.ipv4, "fd00:231::2"])
    added = _event(browser, "ADDED")
    assert added["addresses"] == sorted([b.ipv4, "fd00:231::2"])
    assert added["port"] == HTTP_PORT


def test_name_conflict_is_resolved_by_renaming(lan3: NetnsLan) -> None:
    a, b, c = lan3.hosts
    browser = _start_browser(a)
    first = _start_advertiser(b, "mount")
    second = _start_advertiser(c, "mount")
    names = {_event(browser, "ADDED")["name"], _event(browser, "ADDED")["name"]}
    assert len(names) == 2 and f"mount.{SERVICE_TYPE}" in names
    for proc in (first, second):
        proc.send("stop")
        proc.expect("STOPPED")
