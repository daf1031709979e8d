"""Which host names may reach this server: the guard against DNS rebinding.

A page on any web site can re-point its own name at this machine (DNS rebinding). The browser
then treats the server as that site: its requests carry ``Host: evil.example`` and
``Origin: http://evil.example``, which agree with each other, so a same-origin check passes. What
the page cannot change is the *name*: a request naming a host that is not one of this machine's
names is refused. Allowed without configuration are the names a person or a program really uses
for this machine: IP literals, ``localhost``, the machine's hostname and its short form,
``<short>.local`` (mDNS), ``<short>.<any domain>`` (router names such as ``astropi.lan``), the
``<short>-alpaca-zwo.local`` name the mDNS advertiser publishes, and the names in
``server.allowed_hosts``, where ``*`` turns the check off.

Pure apart from reading the hostname once. The HTTP side (which requests are judged, the 403)
lives in :mod:`alpaca_zwo.alpaca.app`.
"""

from __future__ import annotations

import functools
import ipaddress
import re
import socket
from collections.abc import Iterable
from urllib.parse import urlsplit

#: The allowlist entry that turns the check off.
ANY_HOST = "*"
#: The suffix of the mDNS host name ``alpaca_zwo.alpaca.advertise`` publishes (a test ties the two).
MDNS_SUFFIX = "-alpaca-zwo.local"
#: Decisions remembered per (Host, Origin) pair; a flood of invented names only refills it.
CACHE_SIZE = 256
_SHOWN_MAX = 80


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


def mdns_label(hostname: str) -> str:
    """The DNS label the mDNS advertiser derives from the hostname (same rule as ``advertise``)."""
    label = re.sub(r"[^a-z0-9-]+", "-", hostname.split(".", 1)[0].lower()).strip("-")
    return label or "host"


class HostPolicy:
    """An immutable decision: is this name one of this machine's (or one the user allowed)?"""

    def __init__(self, allowed: Iterable[str] = (), hostname: str | None = None) -> None:
        full = normalise(machine_hostname() if hostname is None else hostname)
        self.hostname = full
        self.short = full.split(".", 1)[0] if not is_ip_literal(full) else full
        entries = tuple(allowed)
        #: True when ``*`` is listed: every name passes.
        self.open = ANY_HOST in entries
        self.extra = frozenset(normalise(e) for e in entries if e != ANY_HOST)
        names = {"localhost", full, self.short, f"{self.short}.local", mdns_label(full) + MDNS_SUFFIX}
        self.names = frozenset(n for n in names if n)
        # "<short>.<any domain>": not for a machine called "localhost" (every container's fallback),
        # where it would allow localhost.evil.example.
        self._domain_prefix = f"{self.short}." if self.short and self.short != "localhost" else None

    def allows(self, name: str) -> bool:
        """Whether ``name`` (already :func:`normalise`-d) may be named in Host or Origin."""
        if self.open or name in self.names or name in self.extra:
            return True
        prefix = self._domain_prefix
        if prefix is not None and name.startswith(prefix) and len(name) > len(prefix) and ".." not in name:
            return True
        return is_ip_literal(name)

    def always_allowed(self) -> list[str]:
        """The names allowed without configuration, for the setup page and the refusal text."""
        names = ["localhost", self.hostname]
        if self.short != self.hostname:
            names.append(self.short)
        names.append(f"{self.short}.local")
        if self._domain_prefix:
            names.append(f"{self.short}.<any domain>")
        names.append(mdns_label(self.hostname) + MDNS_SUFFIX)
        return names


def _refusal(what: str, name: str, policy: HostPolicy) -> str:
    return (f"Refused: {what} is not allowed here (a guard against DNS rebinding); add {name!r} to "
            f"server.allowed_hosts on the setup page, opened by this machine's IP address or as "
            f"{policy.short}.local")


class HostGuard:
    """The live judge: the current policy plus a bounded cache of decisions per header pair.

    Shared by every waitress thread; the policy and its cache are replaced together in one
    assignment when ``server.allowed_hosts`` changes, so a request sees either the old pair or the
    new one, never a new policy with stale decisions.
    """

    def __init__(self, allowed: Iterable[str] = (), hostname: str | None = None) -> None:
        self._hostname = hostname
        self._state: tuple[HostPolicy, dict[object, str | None]] = (HostPolicy(allowed, hostname), {})

    @property
    def policy(self) -> HostPolicy:
        return self._state[0]

    def set_allowed(self, allowed: Iterable[str]) -> None:
        """Apply a new ``server.allowed_hosts`` from the next request on (no restart)."""
        self._state = (HostPolicy(allowed, self._hostname), {})

    def refusal(self, host: str | None, origin: str | None) -> str | None:
        """None when the request may proceed, else the one-line reason for its 403.

        ``host`` is the Host header (None or empty when absent, as in HTTP/1.0: judged by Origin
        alone); ``origin`` the Origin header (None when absent, as from every non-browser client).
        """
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
