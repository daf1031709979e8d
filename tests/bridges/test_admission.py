"""The bridges' door (``alpaca_zwo.bridges.admission``): the ZWO port's first-bytes rule, the network
allowlist, the once-a-minute refusal log, and this machine's own networks.

The openings of real drivers are the bytes their sources write first:

- INDI ``indi_lx200am5``: ``Handshake`` -> ``LX200AM5::checkConnection`` -> ``getLX200RA`` = ``:GR#``
  (indilib/indi @ 3371faeb0, ``drivers/telescope/lx200am5.cpp`` 236-251, ``lx200driver.h`` 117);
- INDI's generic LX200 drivers: ``check_lx200_connection`` writes ACK (0x06), twice if unanswered
  (``drivers/telescope/lx200driver.cpp`` 64-100);
- citrascope's ZWO driver: ``connect`` sends ``:GVP#`` first (citra-space/citrascope @ 63ff1c3,
  ``citrasense/hardware/devices/mount/zwo_am_mount.py`` 232-245, ``zwo_am_protocol.py`` 183-184);
- a person with ``nc``: ``:GVP#`` and Enter.

Over real sockets: ``test_zwo_port_door.py``, ``test_stellarium_door.py``, ``test_bridge_networks_netns.py``.
"""

from __future__ import annotations

import ipaddress
import json
import logging
import ssl
import subprocess

import pytest

from alpaca_zwo._exceptions import ConfigError
from alpaca_zwo.alpaca.local_addresses import interface_networks, local_networks, parse_ifconfig
from alpaca_zwo.bridges.admission import DoorLog, NetworkAllowlist, NotZwo, ZwoOpening, peer_ip
from alpaca_zwo.config.settings import StellariumSettings, ZwoPortSettings, settings_from_dict

DRIVER_OPENINGS = {
    "indi_lx200am5": b":GR#",
    "indi generic lx200 (ACK, ACK, then a command)": b"\x06\x06:GR#",
    "citrascope": b":GVP#",
    "nc, a person typing": b":GVP#\n",
    "nc, Enter pressed first": b"\r\n\n:GVP#\r\n",
    "a driver clearing the line with #": b"#:GVP#",
    "a command with colons in its argument": b":SL22:05:09#",
    "a little line noise first": b"\x00\xff:GVP#",
    "three bytes of noise": b"\x7f\x00\x80 :GR#",
    "a stray colon": b": :GR#",
}

#: Every method a browser can put on a request line (no-cors allows GET/HEAD/POST; a preflight is OPTIONS;
#: WebSocket is a GET; an HTTP/2 prior-knowledge preface is PRI).
HTTP_METHODS = ("GET", "HEAD", "POST", "PUT", "DELETE", "OPTIONS", "PATCH", "CONNECT", "TRACE", "PRI")


def opening(data: bytes, *, byte_at_a_time: bool = False) -> bool:
    judge = ZwoOpening()
    if not byte_at_a_time:
        return judge.feed(data)
    done = False
    for i in range(len(data)):
        done = judge.feed(data[i:i + 1])
        if done:
            break
    return done


def client_hello() -> bytes:
    """The bytes a real TLS client (Python's ssl, as a browser's https://) writes first."""
    context = ssl.create_default_context()
    incoming, outgoing = ssl.MemoryBIO(), ssl.MemoryBIO()
    tls = context.wrap_bio(incoming, outgoing, server_hostname="astropi.local")
    with pytest.raises(ssl.SSLWantReadError):
        tls.do_handshake()
    return outgoing.read()


# ================================================================================================
# The ZWO port's first bytes
# ================================================================================================


@pytest.mark.parametrize("name", DRIVER_OPENINGS)
@pytest.mark.parametrize("byte_at_a_time", [False, True])
def test_real_drivers_openings_are_accepted(name: str, byte_at_a_time: bool) -> None:
    assert opening(DRIVER_OPENINGS[name], byte_at_a_time=byte_at_a_time), name


def test_undecided_until_the_first_command_is_complete() -> None:
    judge = ZwoOpening()
    for part in (b"\r\n", b":", b"G", b"VP"):
        assert judge.feed(part) is False and not judge.accepted
    assert judge.feed(b"#:GR#") is True and judge.accepted
    assert judge.feed(b"POST / HTTP/1.1\r\n") is True  # after the opening the framer judges, not this


@pytest.mark.parametrize("method", HTTP_METHODS)
@pytest.mark.parametrize("byte_at_a_time", [False, True])
def test_an_http_request_is_refused_at_its_first_byte(method: str, byte_at_a_time: bool) -> None:
    """The attack of issue 32: a no-cors POST whose body is ZWO commands; refused before the body."""
    request = (f"{method} / HTTP/1.1\r\nHost: astropi.local:4030\r\nContent-Type: text/plain;charset=UTF-8\r\n"
               f"Content-Length: 33\r\n\r\n:Sr03:00:00#:Sd+20*00:00#:MS#").encode()
    judge = ZwoOpening()
    with pytest.raises(NotZwo, match="not a ZWO command") as refused:
        if byte_at_a_time:
            for i in range(len(request)):
                judge.feed(request[i:i + 1])
        else:
            judge.feed(request)
    assert f"began {method[0]!r}" in str(refused.value)
    judge = ZwoOpening()
    with pytest.raises(NotZwo):
        judge.feed(method[:1].encode())  # decided on the very first byte
    lower = ZwoOpening()
    with pytest.raises(NotZwo):
        lower.feed(b"get /:GVP# http/1.0\r\n")  # typed by hand: still text before any ':'


def test_a_tls_client_hello_is_refused_at_its_first_byte() -> None:
    hello = client_hello()
    assert hello[0] == 0x16 and hello[1] == 0x03  # a handshake record
    for data in (hello, hello[:1]):
        with pytest.raises(NotZwo, match="TLS handshake"):
            ZwoOpening().feed(data)


@pytest.mark.parametrize(("data", "words"), [
    (b"\x00\x01\x02\x03:GVP#", "more than 3 bytes of noise"),
    (b"\xff\xfb\x18\xff\xfd\x03", "more than 3 bytes of noise"),  # a telnet client's option negotiation
    (b"\x00\x03\x00\x10\x21\x12\xa4\x42", "more than 3 bytes of noise"),  # a STUN/TURN header (WebRTC)
    (b":::::GVP#", "more than 3 bytes of noise"),  # colons that start no command are noise
    (b":1:2:3:4:GVP#", "more than 3 bytes of noise"),
    (b"\r\n" * 17 + b":GVP#", "line endings"),
    (b":" + b"G" * 63 + b"#", "longer than the mount's 62"),
    (b":GVP\r\n", "byte 0x0d inside the first command"),
    (b":G\x00VP#", "byte 0x00"),
    (b":G\xc3\xa9#", "byte 0xc3"),
    (b"SSH-2.0-OpenSSH_9.2\r\n", "not a ZWO command"),
    (b"GVP#", "not a ZWO command"),  # a person who forgot the colon
    (b"\x06#\r\nGET / HTTP/1.1", "not a ZWO command"),
])
@pytest.mark.parametrize("byte_at_a_time", [False, True])
def test_noise_and_other_protocols_are_refused(data: bytes, words: str, byte_at_a_time: bool) -> None:
    with pytest.raises(NotZwo, match=words):
        opening(data, byte_at_a_time=byte_at_a_time)


def test_the_limits_are_as_documented() -> None:
    assert opening(b"\r\n" * 16 + b":GVP#")  # 32 idle bytes
    assert opening(b"\x00\x00\x00:GVP#")  # 3 noise bytes
    assert opening(b":" + b"G" * 62 + b"#")  # the mount's longest command


# ================================================================================================
# Networks: the allowlist, peer addresses, this machine's networks
# ================================================================================================


def test_local_is_loopback_plus_the_given_networks() -> None:
    lan = [ipaddress.ip_network("192.168.1.0/24"), ipaddress.ip_network("fd00:1::/64")]
    allow = NetworkAllowlist(lambda: ["local"], lambda: [*map(ipaddress.ip_network, ("127.0.0.0/8", "::1/128")), *lan])
    for address in ("127.0.0.1", "127.8.9.1", "::1", "192.168.1.77", "fd00:1::5", "::ffff:192.168.1.77",
                    "::ffff:127.0.0.1"):
        assert allow.allows(address), address
    for address in ("192.168.2.1", "10.8.0.6", "fd00:2::5", "8.8.8.8", "::ffff:10.0.0.1", "not an address", ""):
        assert not allow.allows(address), address
    assert [str(n) for n in allow.networks()] == ["127.0.0.0/8", "::1/128", "192.168.1.0/24", "fd00:1::/64"]


def test_without_a_provider_local_is_loopback_only() -> None:
    allow = NetworkAllowlist(lambda: ["local"])
    assert allow.allows("127.0.0.1") and allow.allows("::1")
    assert not allow.allows("192.168.1.5")


def test_listed_networks_add_to_local_or_replace_it_and_follow_the_setting() -> None:
    entries = ["local", "10.8.0.0/24"]
    allow = NetworkAllowlist(lambda: entries, lambda: [])
    assert allow.allows("10.8.0.9") and not allow.allows("10.8.1.9") and not allow.allows("127.0.0.1")
    entries[:] = ["192.168.1.7", "2001:db8::/32"]  # a single address is a /32; no "local": no loopback
    assert allow.allows("192.168.1.7") and allow.allows("::ffff:192.168.1.7") and allow.allows("2001:db8::1")
    assert not allow.allows("192.168.1.8") and not allow.allows("10.8.0.9")
    entries[:] = ["0.0.0.0/0", "::/0"]  # anyone, written out
    assert allow.allows("203.0.113.5") and allow.allows("2a00::1")


def test_peer_addresses_of_a_dual_stack_socket_are_judged_as_ipv4() -> None:
    assert str(peer_ip("::ffff:192.0.2.1")) == "192.0.2.1"
    assert str(peer_ip("fe80::1%eth0")) == "fe80::1%eth0"
    assert peer_ip("example.org") is None


def _ip_addr_networks() -> set[str]:
    """The interface networks as iproute2 sees them (its own netlink reader), for comparison."""
    done = subprocess.run(["ip", "-j", "addr", "show"], capture_output=True, text=True, check=True, timeout=10)
    found = set()
    for link in json.loads(done.stdout):
        for info in link.get("addr_info", []):
            peer = info.get("address") or info.get("local")  # the on-link side (a point-to-point peer)
            network = ipaddress.ip_network(f"{peer}/{info['prefixlen']}", strict=False)
            if network.prefixlen and not network.is_loopback:
                found.add(str(network))
    return found


def test_this_machines_networks_are_what_iproute2_reports() -> None:
    assert {str(n) for n in interface_networks()} == _ip_addr_networks()
    assert {str(n) for n in local_networks()} >= {"127.0.0.0/8", "::1/128"}


def test_ifconfig_output_of_macos_and_the_bsds() -> None:
    text = """lo0: flags=8049<UP,LOOPBACK,RUNNING,MULTICAST> mtu 16384
\tinet 127.0.0.1 netmask 0xff000000
\tinet6 ::1 prefixlen 128
\tinet6 fe80::1%lo0 prefixlen 64 scopeid 0x1
en0: flags=8863<UP,BROADCAST,SMART,RUNNING,SIMPLEX,MULTICAST> mtu 1500
\tether 3c:22:fb:00:00:01
\tinet6 fe80::1c2b:3a4d:5e6f:7081%en0 prefixlen 64 secured scopeid 0x4
\tinet 192.168.1.23 netmask 0xffffff00 broadcast 192.168.1.255
\tinet6 2a02:810d:4b3f:e100:1c2b:3a4d:5e6f:7082 prefixlen 64 autoconf secured
em1: flags=8843<UP,BROADCAST,RUNNING,SIMPLEX,MULTICAST> metric 0 mtu 1500
\tinet 10.0.5.2 netmask 255.255.0.0 broadcast 10.0.255.255
utun3: flags=8051<UP,POINTOPOINT,RUNNING,MULTICAST> mtu 1380
\tinet 10.8.0.6 --> 10.8.0.5 netmask 0xffffffff
"""
    assert [str(n) for n in parse_ifconfig(text)] == [
        "127.0.0.0/8", "::1/128", "fe80::/64", "fe80::/64", "192.168.1.0/24", "2a02:810d:4b3f:e100::/64",
        "10.0.0.0/16", "10.8.0.6/32"]


# ================================================================================================
# The refusal log and the setting
# ================================================================================================


def test_a_refusal_is_logged_at_most_once_a_minute_per_kind(caplog: pytest.LogCaptureFixture) -> None:
    now = [0.0]
    door = DoorLog(logging.getLogger("tests.door"), clock=lambda: now[0])
    caplog.set_level(logging.WARNING, logger="tests.door")
    assert door.refused("network", "refused A")
    for second in range(1, 60):
        now[0] = float(second)
        assert not door.refused("network", f"refused B{second}")
    assert door.refused("protocol", "refused C")  # another kind has its own minute
    now[0] = 60.0
    assert door.refused("network", "refused D")
    assert [r.getMessage() for r in caplog.records] == [
        "refused A", "refused C", "refused D (59 more like it in the last 60 s were not logged)"]


def test_allowed_networks_setting_defaults_to_local_and_is_checked() -> None:
    assert ZwoPortSettings().allowed_networks == ("local",) == StellariumSettings().allowed_networks
    settings = settings_from_dict({"zwo_port": {"allowed_networks": ["local", "10.8.0.0/24", "fd00::7"]},
                                   "stellarium": {"allowed_networks": ["0.0.0.0/0"]}})
    assert settings.zwo_port.allowed_networks == ("local", "10.8.0.0/24", "fd00::7")
    assert settings.stellarium.allowed_networks == ("0.0.0.0/0",)
    for bad, words in (([], "at least one network"), (["lan"], "'lan' is not a network"),
                       (["10.8.0.0/33"], "is not a network"), ("local", "must be an array"), ([7], "must be an array")):
        for section in ("zwo_port", "stellarium"):
            with pytest.raises(ConfigError, match=rf"{section}\.allowed_networks") as caught:
                settings_from_dict({section: {"allowed_networks": bad}})
            assert words in str(caught.value)
