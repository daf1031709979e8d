"""The DNS-rebinding guard's decision (``alpaca_zwo.alpaca.hosts``), with a fixed hostname.

HTTP behaviour (which requests are judged, the 403, the emulator's truth) is in
``tests/faults/test_rebinding.py``; the real browser in ``tests/browser/test_page_rebinding.py``.
"""

from __future__ import annotations

import pytest

from alpaca_zwo._exceptions import ConfigError
from alpaca_zwo.alpaca.advertise import MdnsAdvertiser
from alpaca_zwo.alpaca.hosts import (
    CACHE_SIZE,
    SEARCH_LIST_TTL_S,
    HostGuard,
    HostPolicy,
    host_of_header,
    host_of_origin,
    machine_hostname,
    parse_resolv_conf,
    search_domains,
)
from alpaca_zwo.config.settings import ServerSettings, settings_from_dict

HOSTNAME = "AstroPi"
#: The resolver search list the tests' machine has (a FRITZ!Box hands out fritz.box by DHCP).
SEARCH = ("fritz.box",)


def guard(*allowed: str, hostname: str = HOSTNAME, domains: tuple[str, ...] = SEARCH) -> HostGuard:
    return HostGuard(allowed, hostname=hostname, domains=lambda: domains)


@pytest.mark.parametrize("host", [
    "127.0.0.1", "127.0.0.1:11111", "192.168.1.20:11111", "10.0.0.5", "[::1]:11111", "[::1]", "::1",
    "[fe80::1%25eth0]:11111", "[2001:db8::7]", "localhost", "localhost:11111", "LOCALHOST:11111", "localhost.",
    "astropi", "ASTROPI:11111", "astropi.local", "astropi.local.:80", "AstroPi.Local:11111", "astropi.lan",
    "astropi.home", "astropi.internal", "astropi.localdomain", "ASTROPI.LAN.:11111",
    "astropi.fritz.box:11111", "astropi.home.arpa", "astropi-alpaca-zwo.local:11111",
])
def test_this_machines_names_are_allowed(host: str) -> None:
    assert guard().refusal(host, None) is None


@pytest.mark.parametrize("host", [
    "evil.example", "evil.example:11111", "EVIL.example:11111", "astropi-evil.example", "notastropi.lan",
    "xastropi.local", "local", "localhost.evil.example", "127.0.0.1.evil.example",
    "0x7f.1", "2130706433x", "astropi..lan", "[evil.example]:80", "", " :80", "a b",
    # The hostname under a domain that is neither local nor in the search list: a rebinding page's name.
    "astropi.attacker.example", "astropi.evil.example:11111", "astropi.lan.evil.example", "astropi.sub.lan",
    "astropi.box", "astropi.arpa", "astropi.fritz.box.evil.example", "astropi.example.org",
])
def test_other_names_are_refused(host: str) -> None:
    reason = guard().refusal(host, None) if host.strip() else guard().refusal(host, "http://evil.example")
    assert reason is not None and reason.startswith("Refused:"), host
    assert "\n" not in reason


def test_refusal_says_what_to_do() -> None:
    reason = guard().refusal("evil.example:11111", None)
    assert reason == ("Refused: host 'evil.example' is not allowed here (a guard against DNS rebinding); "
                      "add 'evil.example' to server.allowed_hosts on the setup page, opened by this machine's "
                      "IP address or as astropi.local (or to allowed_hosts in the [server] table of the "
                      "settings file)")


def test_origin_is_judged_too() -> None:
    g = guard()
    assert g.refusal("127.0.0.1:11111", "http://127.0.0.1:11111") is None
    assert g.refusal("astropi.local:11111", "http://astropi.local:11111") is None
    assert g.refusal("127.0.0.1:11111", "https://[::1]:8443") is None
    reason = g.refusal("127.0.0.1:11111", "http://evil.example:11111")
    assert reason is not None and "origin 'http://evil.example:11111'" in reason
    assert "add 'evil.example' to server.allowed_hosts" in reason
    for opaque in ("null", "file://", "http://[broken"):
        reason = g.refusal("127.0.0.1:11111", opaque)
        assert reason is not None and reason.startswith("Refused:"), opaque


def test_without_host_only_origin_decides() -> None:
    """HTTP/1.0 sends no Host: the Origin alone is judged, and no header at all passes."""
    g = guard()
    assert g.refusal(None, None) is None
    assert g.refusal(None, "http://astropi.lan") is None
    assert g.refusal(None, "http://evil.example") is not None


def test_allowed_hosts_adds_names_and_star_turns_the_check_off() -> None:
    g = guard("Telescope.Example.org", "observatory.", "[2001:db8::1]")
    assert g.refusal("telescope.example.org:11111", "http://TELESCOPE.example.org:11111") is None
    assert g.refusal("observatory", None) is None
    assert g.refusal("evil.example", None) is not None
    assert guard("*").refusal("evil.example:11111", "http://evil.example:11111") is None
    assert guard("*").policy.open


def test_set_allowed_applies_at_once_and_drops_cached_decisions() -> None:
    g = guard()
    assert g.refusal("evil.example:11111", None) is not None
    g.set_allowed(["evil.example"])
    assert g.refusal("evil.example:11111", None) is None
    g.set_allowed([])
    assert g.refusal("evil.example:11111", None) is not None


def test_cache_is_bounded_and_keeps_answering_right() -> None:
    g = guard()
    for i in range(CACHE_SIZE * 3):
        assert g.refusal(f"evil{i}.example", None) is not None
        assert len(g._state[1]) <= CACHE_SIZE
    assert g.refusal("127.0.0.1:1", None) is None


def test_a_host_called_localhost_does_not_open_every_domain() -> None:
    """Containers often fall back to the name "localhost": ``localhost.<domain>`` must not pass."""
    g = guard(hostname="localhost")
    assert g.refusal("localhost:11111", None) is None
    assert g.refusal("localhost.evil.example", None) is not None


def test_fully_qualified_hostname_gives_its_short_form() -> None:
    policy = HostPolicy(hostname="astropi.example.org", domains=["example.org", "fritz.box"])
    for name in ("astropi.example.org", "astropi", "astropi.local", "astropi.lan", "astropi.fritz.box",
                 "astropi-alpaca-zwo.local"):
        assert policy.allows(name), name
    assert not policy.allows("astropi.example.com")
    assert policy.always_allowed() == [
        "localhost", "astropi.example.org", "astropi", "astropi.local", "astropi.lan", "astropi.home",
        "astropi.home.arpa", "astropi.internal", "astropi.localdomain", "astropi.fritz.box",
        "astropi-alpaca-zwo.local"]


@pytest.mark.parametrize("hostname", ["raspberrypi", "vm", "astroberry"])
def test_a_default_hostname_under_an_attackers_domain_is_refused(hostname: str) -> None:
    """Issue 32: ``raspberrypi.attacker.example`` (a Pi's default name) passed as "<hostname>.<any domain>"."""
    g = guard(hostname=hostname, domains=())
    for name in (f"{hostname}.attacker.example", f"{hostname}.attacker.example:11111"):
        reason = g.refusal(name, f"http://{name}")
        assert reason is not None and f"add '{hostname}.attacker.example' to server.allowed_hosts" in reason
    assert g.refusal(f"{hostname}.lan", f"http://{hostname}.lan:11111") is None
    assert guard(f"{hostname}.attacker.example", hostname=hostname, domains=()).refusal(
        f"{hostname}.attacker.example", None) is None  # unless the user adds it


def test_resolver_search_list_is_read_from_search_and_domain_lines() -> None:
    text = """# Generated by NetworkManager
domain Example.ORG.
search fritz.box corp.example.org lan ; the router's
search com
nameserver 192.168.178.1
options ndots:1
#search commented.example
"""
    assert parse_resolv_conf(text) == ["example.org", "fritz.box", "corp.example.org", "lan"]
    assert parse_resolv_conf("") == []
    assert parse_resolv_conf("search\nsearch .\n") == []
    assert all(isinstance(d, str) for d in search_domains())  # this machine's, whatever it holds


def test_a_search_list_set_after_the_start_counts_within_a_minute() -> None:
    """A Pi that boots before DHCP: the search list is read again, and the cached refusal goes with it."""
    domains: list[str] = []
    now = [0.0]
    g = HostGuard(hostname="astropi", domains=lambda: list(domains), clock=lambda: now[0])
    assert g.refusal("astropi.fritz.box", None) is not None
    domains.append("fritz.box")
    now[0] += SEARCH_LIST_TTL_S / 2
    assert g.refusal("astropi.fritz.box", None) is not None  # not read again yet
    now[0] += SEARCH_LIST_TTL_S
    assert g.refusal("astropi.fritz.box", None) is None
    assert "astropi.fritz.box" in g.policy.always_allowed()
    domains.clear()
    now[0] += SEARCH_LIST_TTL_S
    assert g.refusal("astropi.fritz.box", None) is not None


def test_the_advertised_mdns_name_is_allowed() -> None:
    """The SRV target ``advertise`` publishes (browsers open the page by it) passes the guard."""
    name = MdnsAdvertiser(11111, "x").host_name  # "<host>-alpaca-zwo.local."
    assert HostGuard().refusal(f"{name}:11111", None) is None
    assert HostGuard().refusal(f"{machine_hostname()}.local:11111", None) is None


def test_header_parsing() -> None:
    assert host_of_header("[::1]:80") == "::1"
    assert host_of_header("Example.ORG.:8080") == "example.org"
    assert host_of_header("2001:db8::1") == "2001:db8::1"
    assert host_of_origin("http://[::1]:8080") == "::1"
    assert host_of_origin("null") is None


@pytest.mark.parametrize("value", [
    ["astropi.example.org", "*", "192.168.1.5", "[fe80::1%eth0]", "::1"],
    [],
])
def test_allowed_hosts_setting_accepts_names(value: list[str]) -> None:
    settings = settings_from_dict({"server": {"allowed_hosts": value}})
    assert settings.server.allowed_hosts == tuple(value)


@pytest.mark.parametrize(("value", "words"), [
    ("astropi", "must be an array"),
    ([1], "must be an array"),
    (["bad name"], "no spaces or control characters"),
    (["bad\x00name"], "no spaces or control characters"),
    (["tab\tname"], "no spaces or control characters"),
    ([""], "1 to 253"),
    (["x" * 254], "1 to 253"),
    (["http://astropi.lan"], "give the name alone"),
    (["astropi.lan:11111"], "without a port"),
])
def test_allowed_hosts_setting_refuses_what_is_not_a_name(value: object, words: str) -> None:
    with pytest.raises(ConfigError, match=r"server\.allowed_hosts") as caught:
        settings_from_dict({"server": {"allowed_hosts": value}})
    assert words in str(caught.value)
    assert ServerSettings().allowed_hosts == ()
