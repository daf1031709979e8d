"""Which host names may reach this server: the guard against DNS rebinding.

A page on any web site can re-point its own name at this machine (DNS rebinding). The browser
then treats the server as that site: its requests carry ``Host: evil.example`` and
``Origin: http://evil.example``, which agree with each other, so a same-origin check passes. What
the page cannot change is the *name*: a request naming a host that is not one of this machine's
names is refused. Allowed without configuration are the names a person or a program really uses
for this machine: IP literals, ``localhost``, the machine's hostname and its short form,
``<short>.local`` (mDNS), the ``<short>-alpaca-zwo.local`` name the mDNS advertiser publishes,
``<short>.<domain>`` for the local suffixes home routers hand out (:data:`LOCAL_SUFFIXES`:
``astropi.lan``, ``astropi.home.arpa``) and for the domains of this machine's resolver search list
(``astropi.fritz.box`` when the router's DHCP gives ``fritz.box``), and the names in
``server.allowed_hosts``, where ``*`` turns the check off. ``<short>`` under any other domain is
refused: a rebinding page at ``raspberrypi.attacker.example`` carries the default hostname of a Pi.

Pure apart from reading the hostname once and the resolver's search list (``/etc/resolv.conf``'s
``search`` and ``domain`` lines; on Windows the TCP/IP parameters in the registry; again at most once
a minute, so a search list that DHCP set after the start counts). The HTTP side (which requests are
judged, the 403) lives in :mod:`alpaca_zwo.alpaca.app`.
"""

from __future__ import annotations

import contextlib
import functools
import ipaddress
import re
import socket
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from urllib.parse import urlsplit

#: The allowlist entry that turns the check off.
ANY_HOST = "*"
#: The suffix of the mDNS host name ``alpaca_zwo.alpaca.advertise`` publishes (a test ties the two).
MDNS_SUFFIX = "-alpaca-zwo.local"
#: Decisions remembered per (Host, Origin) pair; a flood of invented names only refills it.
CACHE_SIZE = 256
_SHOWN_MAX = 80
#: Domains under which ``<short>.<domain>`` is this machine: home routers' and RFC 8375/6762 local names.
LOCAL_SUFFIXES = ("local", "lan", "home", "home.arpa", "internal", "localdomain")
#: How often the resolver's search list is read again.
SEARCH_LIST_TTL_S = 60.0
RESOLV_CONF = Path("/etc/resolv.conf")


@functools.cache
def machine_hostname() -> str:
    """This machine's hostname, read once: it is consulted on every guarded request."""
    return socket.gethostname()


def normalise(name: str) -> str:
    """A host name as compared: lower case, without IPv6 brackets or the root's trailing dot."""
    name = name.strip().lower()
    if name.startswith("[") and name.endswith("]"):
        name = name[1:-1]
    if name.endswith(".") and not name.endswith(".."):
        name = name[:-1]
    return name


def is_ip_literal(name: str) -> bool:
    """True for an IPv4 or IPv6 address (with or without brackets, with a zone such as ``%eth0``)."""
    name = normalise(name).replace("%25", "%")
    try:
        ipaddress.ip_address(name)
    except ValueError:
        return False
    return True


def host_of_header(value: str) -> str:
    """The name in a ``Host`` header, port dropped: ``[::1]:80`` -> ``::1``, ``a.b:80`` -> ``a.b``."""
    value = value.strip()
    if value.startswith("["):
        end = value.find("]")
        return normalise(value[: end + 1] if end > 0 else value)
    if value.count(":") == 1:
        value = value.partition(":")[0]
    return normalise(value)  # more than one colon: a bare IPv6 address, which has no port


def host_of_origin(value: str) -> str | None:
    """The host an ``Origin`` header names, or None for an opaque origin (``null``, ``file://``)."""
    try:
        host = urlsplit(value.strip()).hostname
    except ValueError:  # e.g. an unbalanced bracket
        return None
    return normalise(host) if host else None


def shown(value: str) -> str:
    """A header value as it may appear in a one-line reply: printable, bounded."""
    text = "".join(c if c.isprintable() else "?" for c in value[:_SHOWN_MAX])
    return text + ("..." if len(value) > _SHOWN_MAX else "")


def parse_resolv_conf(text: str) -> list[str]:
    """The domains of ``search`` and ``domain`` lines, lower case, without the root's dot.

    A single-label entry counts only when it is a local suffix: ``search com`` (a misconfiguration)
    must not make ``raspberrypi.com`` one of this machine's names.
    """
    found: list[str] = []
    for line in text.splitlines():
        fields = line.split("#", 1)[0].split(";", 1)[0].split()
        if len(fields) < 2 or fields[0] not in ("search", "domain"):
            continue
        for domain in fields[1:]:
            name = normalise(domain)
            if name and (name.count(".") >= 1 or name in LOCAL_SUFFIXES) and name not in found:
                found.append(name)
    return found


def _windows_search_domains() -> list[str]:  # pragma: no cover - Windows only
    """The DNS suffix search list and the primary and connection-specific suffixes, from the registry."""
    found: list[str] = []
    if sys.platform == "win32":
        import winreg

        base = "SYSTEM\\CurrentControlSet\\Services\\Tcpip\\Parameters"
        keys = [base]
        with contextlib.suppress(OSError), winreg.OpenKey(winreg.HKEY_LOCAL_MACHINE, base + "\\Interfaces") as root:
            keys += [base + "\\Interfaces\\" + winreg.EnumKey(root, i) for i in range(winreg.QueryInfoKey(root)[0])]
        for key in keys:
            with contextlib.suppress(OSError), winreg.OpenKey(winreg.HKEY_LOCAL_MACHINE, key) as handle:
                for value in ("SearchList", "Domain", "DhcpDomain"):
                    with contextlib.suppress(OSError):
                        found += str(winreg.QueryValueEx(handle, value)[0]).replace(",", " ").split()
    return parse_resolv_conf("search " + " ".join(found)) if found else []


def search_domains() -> list[str]:
    """This machine's resolver search list (what a bare name is completed with), read locally."""
    if sys.platform == "win32":
        with contextlib.suppress(OSError, ValueError):
            return _windows_search_domains()
        return []
    try:
        return parse_resolv_conf(RESOLV_CONF.read_text(encoding="utf-8", errors="replace"))
    except OSError:
        return []


def mdns_label(hostname: str) -> str:
    """The DNS label the mDNS advertiser derives from the hostname (same rule as ``advertise``)."""
    label = re.sub(r"[^a-z0-9-]+", "-", hostname.split(".", 1)[0].lower()).strip("-")
    return label or "host"


class HostPolicy:
    """An immutable decision: is this name one of this machine's (or one the user allowed)?

    ``domains`` is the resolver's search list (:func:`search_domains`, read by :class:`HostGuard`).
    """

    def __init__(self, allowed: Iterable[str] = (), hostname: str | None = None,
                 domains: Sequence[str] = ()) -> None:
        full = normalise(machine_hostname() if hostname is None else hostname)
        self.hostname = full
        self.short = full.split(".", 1)[0] if not is_ip_literal(full) else full
        self.domains = tuple(domains)
        entries = tuple(allowed)
        #: True when ``*`` is listed: every name passes.
        self.open = ANY_HOST in entries
        self.extra = frozenset(normalise(e) for e in entries if e != ANY_HOST)
        names = ["localhost", full, self.short, f"{self.short}.local"]
        # "<short>.<local domain>": not for a machine called "localhost" (every container's fallback).
        if self.short and self.short != "localhost":
            names += [f"{self.short}.{d}" for d in (*LOCAL_SUFFIXES, *self.domains)]
        names.append(mdns_label(full) + MDNS_SUFFIX)
        self._shown = [n for n in dict.fromkeys(names) if n]
        self.names = frozenset(self._shown)

    def allows(self, name: str) -> bool:
        """Whether ``name`` (already :func:`normalise`-d) may be named in Host or Origin."""
        if self.open or name in self.names or name in self.extra:
            return True
        return is_ip_literal(name)

    def always_allowed(self) -> list[str]:
        """The names allowed without configuration, for the setup page and the refusal text."""
        return list(self._shown)


def _refusal(what: str, name: str, policy: HostPolicy) -> str:
    return (f"Refused: {what} is not allowed here (a guard against DNS rebinding); add {name!r} to "
            f"server.allowed_hosts on the setup page, opened by this machine's IP address or as "
            f"{policy.short}.local (or to allowed_hosts in the [server] table of the settings file)")


class HostGuard:
    """The live judge: the current policy plus a bounded cache of decisions per header pair.

    Shared by every waitress thread; the policy and its cache are replaced together in one
    assignment when ``server.allowed_hosts`` changes, so a request sees either the old pair or the
    new one, never a new policy with stale decisions.
    """

    def __init__(self, allowed: Iterable[str] = (), hostname: str | None = None,
                 domains: Callable[[], Sequence[str]] = search_domains,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self._hostname = hostname
        self._allowed = tuple(allowed)
        self._domains = domains
        self._clock = clock
        self._domains_read = clock()
        self._state: tuple[HostPolicy, dict[object, str | None]] = (
            HostPolicy(self._allowed, hostname, domains()), {})

    @property
    def policy(self) -> HostPolicy:
        self._follow_search_list()
        return self._state[0]

    def set_allowed(self, allowed: Iterable[str]) -> None:
        """Apply a new ``server.allowed_hosts`` from the next request on (no restart)."""
        self._allowed = tuple(allowed)
        self._state = (HostPolicy(self._allowed, self._hostname, self._domains()), {})

    def _follow_search_list(self) -> None:
        """Re-read the resolver's search list once a minute; a change gives a new policy (and cache)."""
        now = self._clock()
        if now - self._domains_read < SEARCH_LIST_TTL_S:
            return
        self._domains_read = now
        domains = tuple(self._domains())
        if domains != self._state[0].domains:
            self._state = (HostPolicy(self._allowed, self._hostname, domains), {})

    def refusal(self, host: str | None, origin: str | None) -> str | None:
        """None when the request may proceed, else the one-line reason for its 403.

        ``host`` is the Host header (None or empty when absent, as in HTTP/1.0: judged by Origin
        alone); ``origin`` the Origin header (None when absent, as from every non-browser client).
        """
        self._follow_search_list()
        policy, cache = self._state
        key: object = host if origin is None else (host, origin)
        try:
            return cache[key]
        except KeyError:
            pass
        reason = self._judge(policy, host, origin)
        if len(cache) >= CACHE_SIZE:
            cache.clear()
        cache[key] = reason
        return reason

    @staticmethod
    def _judge(policy: HostPolicy, host: str | None, origin: str | None) -> str | None:
        if policy.open:
            return None
        if host:
            name = host_of_header(host)
            if not policy.allows(name):
                return _refusal(f"host {shown(name)!r}", shown(name), policy)
        if origin is not None:
            name_or_none = host_of_origin(origin)
            if name_or_none is None:
                return f"Refused: a request from the opaque origin {shown(origin)!r} (a sandboxed or local page)"
            if not policy.allows(name_or_none):
                return _refusal(f"origin {shown(origin)!r}", shown(name_or_none), policy)
        return None
