"""Tests for the Alpaca discovery responder (protocol-rules §10, clients.md R10).

Tests in the host's own namespace bind only to loopback and never send broadcast or multicast.
Everything that needs a real link (broadcast, multicast, other clients) runs in private network
namespaces from tests/netns.py, with the responder and the client in separate namespaces.

Where a test must show that something did *not* get an answer, it sends a valid request after
the bad ones and waits for that reply: the responder handles one socket in arrival order and
loopback delivers synchronously, so any reply to an earlier datagram would already be queued.
"""

from __future__ import annotations

import json
import math
import os
import socket
import threading
import time
from collections.abc import Iterator

import pytest

from alpaca_zwo.alpaca.discovery import (
    DEFAULT_DISCOVERY_PORT,
    DISCOVERY_MESSAGE,
    IPV6_DISCOVERY_GROUP,
    MAX_DISCOVERY_DATAGRAM,
    DiscoveryResponder,
    RateLimiter,
    is_discovery_request,
)
from tests.netns import Namespace, NetnsLan, NsProcess, lan_fixture

ALPACA_PORT = 11111
REPLY_TIMEOUT = 5.0

lan = lan_fixture(2)
lan3 = lan_fixture(3)

# A responder in a namespace: READY <port> <ipv6 active> once bound and joined; stops on stdin EOF.
RESPONDER = r"""
import logging, sys
from alpaca_zwo.alpaca.discovery import DiscoveryResponder
logging.basicConfig(level=logging.WARNING, stream=sys.stdout, format="LOG %(levelname)s %(message)s")
alpaca_port, port = int(sys.argv[1]), int(sys.argv[2])
bind_host = sys.argv[3] if len(sys.argv) > 3 else ""
if len(sys.argv) > 4 and sys.argv[4] == "block-ipv6":
    import socket
    blocker = socket.socket(socket.AF_INET6, socket.SOCK_DGRAM)
    blocker.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_V6ONLY, 1)
    blocker.bind(("::", port))  # exclusive: no SO_REUSEADDR/SO_REUSEPORT
r = DiscoveryResponder(alpaca_port, port, bind_host=bind_host)
r.start()
print("READY", r.port, int(r.ipv6_active), flush=True)
sys.stdin.readline()
r.stop()
print("STOPPED", flush=True)
"""

# One discovery request, then replies until `want` arrived or the deadline passed; prints JSON.
PROBE = r"""
import json, socket, sys, time
dest, port, want, timeout = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4])
ifname = sys.argv[5] if len(sys.argv) > 5 else ""
if ":" in dest:
    s = socket.socket(socket.AF_INET6, socket.SOCK_DGRAM)
    index = socket.if_nametoindex(ifname) if ifname else 0
    if index:
        s.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_MULTICAST_IF, index)
    target = (dest, port, 0, index)
else:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
    target = (dest, port)
s.sendto(b"alpacadiscovery1", target)
replies = []
deadline = time.monotonic() + timeout
while len(replies) < want and (remaining := deadline - time.monotonic()) > 0:
    s.settimeout(remaining)
    try:
        data, addr = s.recvfrom(4096)
    except TimeoutError:
        break
    replies.append([addr[0], data.decode("utf-8", "replace")])
print(json.dumps(replies))
"""

ALPYCA_SEARCH = r"""
import json, sys
from alpaca import discovery
search = getattr(discovery, sys.argv[1])
# alpyca sleeps timeout/2 after each send, so replies are already queued when it starts reading;
# its total run time is about 2.5 x timeout per interface.
print(json.dumps(search(numquery=1, timeout=float(sys.argv[2]))))
"""


# -- helpers ------------------------------------------------------------------------------------


def _udp(family: socket.AddressFamily = socket.AF_INET, bind: str = "127.0.0.1") -> socket.socket:
    sock = socket.socket(family, socket.SOCK_DGRAM)
    sock.bind((bind, 0))
    sock.settimeout(REPLY_TIMEOUT)
    return sock


def _assert_queue_empty(sock: socket.socket) -> None:
    sock.setblocking(False)
    try:
        extra = sock.recvfrom(4096)
    except BlockingIOError:
        return
    finally:
        sock.settimeout(REPLY_TIMEOUT)
    pytest.fail(f"unexpected extra reply {extra!r}")


def _ask(sock: socket.socket, port: int, host: str = "127.0.0.1") -> bytes:
    sock.sendto(DISCOVERY_MESSAGE, (host, port))
    data, addr = sock.recvfrom(4096)
    assert addr[1] == port, "reply must come from the discovery port"
    return data


def _discovery_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "alpaca-discovery"]


def _probe(lan: NetnsLan, dest: str, want: int, ifname: str = "") -> list[list[str]]:
    a = lan.hosts[0]
    out = a.python(PROBE, dest, str(DEFAULT_DISCOVERY_PORT), str(want), str(REPLY_TIMEOUT), ifname)
    return json.loads(out)


def _spawn_responder(host: Namespace, alpaca_port: int, *extra: str) -> tuple[NsProcess, list[str]]:
    proc = host.spawn_python(RESPONDER, str(alpaca_port), str(DEFAULT_DISCOVERY_PORT), *extra)
    ready = proc.expect("READY").split()
    assert int(ready[1]) == DEFAULT_DISCOVERY_PORT
    return proc, ready


@pytest.fixture
def responder() -> Iterator[DiscoveryResponder]:
    r = DiscoveryResponder(ALPACA_PORT, 0, bind_host="127.0.0.1", ipv6=False)
    r.start()
    try:
        yield r
    finally:
        r.stop()


# -- pure rules ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("datagram", "answered"),
    [
        (b"alpacadiscovery1", True),
        (b"alpacadiscovery1" + b"\0" * 48, True),  # reserved bytes 16..63
        (b"alpacadiscovery1\r\n", True),  # padding some clients add
        (b"", False),
        (b"alpacadiscovery", False),
        (b"alpacadiscovery2", False),  # a future protocol version
        (b"ALPACADISCOVERY1", False),
        (b" alpacadiscovery1", False),
        (b"alpacadiscovery1" + b"x" * MAX_DISCOVERY_DATAGRAM, False),
    ],
)
def test_is_discovery_request(datagram: bytes, answered: bool) -> None:
    assert is_discovery_request(datagram) is answered


def test_rate_limiter_is_per_source_and_refills() -> None:
    now = [0.0]
    limiter = RateLimiter(rate=20, burst=20, clock=lambda: now[0])
    assert sum(limiter.allow("10.0.0.1") for _ in range(50)) == 20
    assert limiter.allow("10.0.0.2"), "another source has its own budget"
    now[0] += 0.1  # two tokens' worth
    assert [limiter.allow("10.0.0.1") for _ in range(3)] == [True, True, False]
    now[0] += 100.0
    assert sum(limiter.allow("10.0.0.1") for _ in range(50)) == 20, "refill is capped at the burst"


def test_rate_limiter_table_is_bounded() -> None:
    now = [0.0]
    limiter = RateLimiter(rate=20, burst=20, max_sources=8, clock=lambda: now[0])
    for i in range(1000):
        assert limiter.allow(f"10.0.{i // 256}.{i % 256}")
        now[0] += 0.001
    assert len(limiter._buckets) <= 8


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"alpaca_port": 0}, "alpaca_port"),
        ({"alpaca_port": 1, "discovery_port": 70000}, "discovery_port"),
        ({"alpaca_port": 1, "bind_host": "localhost"}, "literal"),
        ({"alpaca_port": 1, "bind_host": "::1", "ipv6": False}, "ipv6=False"),
    ],
)
def test_bad_arguments_are_rejected_at_construction(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        DiscoveryResponder(**kwargs)  # type: ignore[arg-type]


# -- loopback, host namespace -------------------------------------------------------------------


def test_unicast_reply_is_exactly_alpacaport_json(responder: DiscoveryResponder) -> None:
    assert responder.port != 0, ".port must report the bound ephemeral port"
    with _udp() as client:
        data = _ask(client, responder.port)
    assert json.loads(data) == {"AlpacaPort": ALPACA_PORT}
    assert data == b'{"AlpacaPort": 11111}'


def test_garbage_and_near_misses_get_no_reply_and_responder_keeps_answering(
    responder: DiscoveryResponder,
) -> None:
    bad = [
        b"",
        b"hello",
        b"alpacadiscovery",
        b"alpacadiscovery2",
        b"ALPACADISCOVERY1",
        b"xalpacadiscovery1",
        b"\xff\xfe\x00alpacadiscovery1",
        b"alpacadiscovery1" + b"A" * 2000,  # oversize
        os.urandom(60000),
    ]
    with _udp() as client:
        for datagram in bad:
            client.sendto(datagram, ("127.0.0.1", responder.port))
        assert json.loads(_ask(client, responder.port)) == {"AlpacaPort": ALPACA_PORT}
        _assert_queue_empty(client)
        # and once more, to show the loop is still alive after the sentinel
        assert json.loads(_ask(client, responder.port)) == {"AlpacaPort": ALPACA_PORT}
    assert responder.running and len(_discovery_threads()) == 1


def test_padded_request_is_answered(responder: DiscoveryResponder) -> None:
    with _udp() as client:
        client.sendto(DISCOVERY_MESSAGE + bytes(48), ("127.0.0.1", responder.port))
        data, _ = client.recvfrom(4096)
    assert json.loads(data) == {"AlpacaPort": ALPACA_PORT}


def test_ipv6_unicast_on_loopback() -> None:
    with DiscoveryResponder(ALPACA_PORT, 0, bind_host="::1") as r:
        assert r.ipv6_active
        with _udp(socket.AF_INET6, "::1") as client:
            client.sendto(DISCOVERY_MESSAGE, ("::1", r.port))
            data, addr = client.recvfrom(4096)
    assert json.loads(data) == {"AlpacaPort": ALPACA_PORT}
    assert addr[0] == "::1"


def test_rate_limit_per_sender(responder: DiscoveryResponder) -> None:
    flood = 100
    with _udp(bind="127.0.0.1") as attacker, _udp(bind="127.0.0.2") as bystander:
        start = time.monotonic()
        for _ in range(flood):
            attacker.sendto(DISCOVERY_MESSAGE, ("127.0.0.1", responder.port))
        # The bystander's reply is the sentinel: after it, every flood reply has been sent.
        assert json.loads(_ask(bystander, responder.port)) == {"AlpacaPort": ALPACA_PORT}
        elapsed = time.monotonic() - start
        attacker.setblocking(False)
        answered = 0
        while True:
            try:
                attacker.recvfrom(4096)
            except BlockingIOError:
                break
            answered += 1
        assert 20 <= answered <= 20 + math.ceil(20 * elapsed) + 1 < flood

        # The budget refills: poll, with a deadline, until the flooding source is answered again.
        attacker.settimeout(0.2)
        deadline = time.monotonic() + REPLY_TIMEOUT
        while True:
            attacker.sendto(DISCOVERY_MESSAGE, ("127.0.0.1", responder.port))
            try:
                data, _ = attacker.recvfrom(4096)
                break
            except TimeoutError:
                assert time.monotonic() < deadline, "rate-limited source never answered again"
        assert json.loads(data) == {"AlpacaPort": ALPACA_PORT}


def test_two_responders_share_the_port_and_survive_each_other() -> None:
    first = DiscoveryResponder(1111, 0, bind_host="127.0.0.1", ipv6=False)
    first.start()
    try:
        second = DiscoveryResponder(2222, first.port, bind_host="127.0.0.1", ipv6=False)
        second.start()  # would raise EADDRINUSE without SO_REUSEADDR/SO_REUSEPORT
        try:
            assert second.port == first.port
            with _udp() as client:
                # Unicast reaches one member of the group; which one is the kernel's choice.
                assert json.loads(_ask(client, first.port))["AlpacaPort"] in (1111, 2222)
                first.stop()
                assert json.loads(_ask(client, second.port)) == {"AlpacaPort": 2222}
        finally:
            second.stop()
    finally:
        first.stop()


def test_start_stop_idempotent_fast_and_releases_port() -> None:
    r = DiscoveryResponder(ALPACA_PORT, 0, bind_host="127.0.0.1", ipv6=False)
    r.stop()  # before start: harmless
    r.start()
    port = r.port
    r.start()  # already running: no second socket or thread
    assert r.port == port and len(_discovery_threads()) == 1
    with _udp() as client:
        _ask(client, port)
    began = time.monotonic()
    r.stop()
    assert time.monotonic() - began < 1.0
    assert not r.running and _discovery_threads() == []
    r.stop()
    # An exclusive bind (no reuse options) fails while any socket still holds the port.
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", port))
    # and it can be started again afterwards
    with r, _udp() as client:
        assert json.loads(_ask(client, r.port)) == {"AlpacaPort": ALPACA_PORT}


def test_start_failure_raises_and_leaves_nothing_behind() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as holder:
        holder.bind(("127.0.0.1", 0))  # exclusive holder
        r = DiscoveryResponder(ALPACA_PORT, holder.getsockname()[1], bind_host="127.0.0.1", ipv6=False)
        with pytest.raises(OSError):
            r.start()
    assert not r.running and _discovery_threads() == []


# -- across network namespaces ------------------------------------------------------------------


@pytest.mark.parametrize("target", ["limited-broadcast", "subnet-broadcast", "unicast"])
def test_ipv4_request_from_another_host(lan: NetnsLan, target: str) -> None:
    b = lan.hosts[1]
    _spawn_responder(b, ALPACA_PORT)
    dest = {"limited-broadcast": "255.255.255.255", "subnet-broadcast": lan.broadcast, "unicast": b.ipv4}
    replies = _probe(lan, dest[target], want=1)
    assert replies == [[b.ipv4, '{"AlpacaPort": 11111}']]


def test_ipv6_multicast_from_another_host(lan: NetnsLan) -> None:
    a, b = lan.hosts
    _, ready = _spawn_responder(b, ALPACA_PORT)
    assert ready[2] == "1", "IPv6 socket should be open"
    replies = _probe(lan, IPV6_DISCOVERY_GROUP, want=1, ifname=a.ifname)
    assert len(replies) == 1
    source, payload = replies[0]
    assert source.split("%")[0] == b.ipv6_ll
    assert json.loads(payload) == {"AlpacaPort": ALPACA_PORT}


def test_ipv6_group_joined_on_the_link(lan: NetnsLan) -> None:
    b = lan.hosts[1]
    _spawn_responder(b, ALPACA_PORT)
    group_hex = socket.inet_pton(socket.AF_INET6, IPV6_DISCOVERY_GROUP).hex()
    memberships = b.run("cat", "/proc/net/igmp6").stdout.split("\n")
    joined = {line.split()[1] for line in memberships if group_hex in line}
    assert b.ifname in joined


def test_two_responders_on_one_host_both_answer_broadcast(lan: NetnsLan) -> None:
    b = lan.hosts[1]
    _spawn_responder(b, 1111)
    _spawn_responder(b, 2222)
    replies = _probe(lan, lan.broadcast, want=2)
    assert sorted(json.loads(p)["AlpacaPort"] for _, p in replies) == [1111, 2222]
    assert {src for src, _ in replies} == {b.ipv4}


def test_ipv6_unavailable_falls_back_to_ipv4_with_warning(lan: NetnsLan) -> None:
    b = lan.hosts[1]
    proc = b.spawn_python(RESPONDER, str(ALPACA_PORT), str(DEFAULT_DISCOVERY_PORT), "", "block-ipv6")
    warning = proc.expect("LOG ")
    assert warning.startswith("LOG WARNING IPv6 discovery unavailable")
    assert proc.expect("READY").split()[2] == "0"
    assert _probe(lan, lan.broadcast, want=1) == [[b.ipv4, '{"AlpacaPort": 11111}']]


def test_stopped_responder_in_namespace_exits_cleanly(lan: NetnsLan) -> None:
    b = lan.hosts[1]
    proc, _ = _spawn_responder(b, ALPACA_PORT)
    proc.send("stop")
    assert proc.expect("STOPPED") == "STOPPED"
    assert proc.stop() == 0
    # nothing answers any more: an exclusive bind of the port succeeds in B
    b.python(
        "import socket; s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); s.bind(('', 32227));"
        "t = socket.socket(socket.AF_INET6, socket.SOCK_DGRAM);"
        "t.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_V6ONLY, 1); t.bind(('::', 32227))"
    )


def test_alpyca_search_ipv4_finds_responder(lan: NetnsLan) -> None:
    a, b = lan.hosts
    _spawn_responder(b, ALPACA_PORT)
    found = json.loads(a.python(ALPYCA_SEARCH, "search_ipv4", "0.5"))
    assert found == [f"{b.ipv4}:{ALPACA_PORT}"]


def test_alpyca_search_ipv6_finds_responder(lan: NetnsLan) -> None:
    a, b = lan.hosts
    _spawn_responder(b, ALPACA_PORT)
    found = json.loads(a.python(ALPYCA_SEARCH, "search_ipv6", "0.5"))
    assert len(found) == 1
    assert found[0].startswith(f"[{b.ipv6_ll}%") and found[0].endswith(f"]:{ALPACA_PORT}")


def test_alpyca_search_ipv4_finds_every_host_on_the_lan(lan3: NetnsLan) -> None:
    a, b, c = lan3.hosts
    _spawn_responder(b, 1111)
    _spawn_responder(c, 2222)
    found = json.loads(a.python(ALPYCA_SEARCH, "search_ipv4", "0.5"))
    assert sorted(found) == sorted([f"{b.ipv4}:1111", f"{c.ipv4}:2222"])
