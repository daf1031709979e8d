"""ASCOM Alpaca discovery responder (protocol-rules §10, clients.md R10).

Clients find Alpaca servers by sending ``alpacadiscovery1`` as a UDP broadcast (IPv4) or to the
link-local multicast group ``ff12::a1:9aca`` (IPv6) on port 32227; every server answers by unicast
with ``{"AlpacaPort": N}``. This module is that answer and nothing else: the HTTP side, the
management API and the decision whether to run discovery at all belong to the server.
"""

from __future__ import annotations

import contextlib
import ipaddress
import json
import logging
import selectors
import socket
import struct
import threading
import time
from collections.abc import Callable

__all__ = [
    "DEFAULT_DISCOVERY_PORT",
    "DISCOVERY_MESSAGE",
    "IPV6_DISCOVERY_GROUP",
    "MAX_DISCOVERY_DATAGRAM",
    "DiscoveryResponder",
    "RateLimiter",
    "is_discovery_request",
]

log = logging.getLogger(__name__)

DEFAULT_DISCOVERY_PORT = 32227
DISCOVERY_MESSAGE = b"alpacadiscovery1"
IPV6_DISCOVERY_GROUP = "ff12::a1:9aca"

# The specification defines a 64-byte message (16 used, 48 reserved). Anything far larger is not
# a discovery request from a real client, so it is dropped rather than answered.
MAX_DISCOVERY_DATAGRAM = 1024

# Large enough for any UDP payload, so an oversize datagram is seen whole (and recognised as
# oversize) instead of being silently truncated into something that looks valid.
_RECV_BUFFER = 65536

# Interfaces come and go (USB WiFi on a Pi, a cable plugged in after boot); re-joining the IPv6
# group this often keeps late interfaces discoverable without a restart.
_GROUP_RESCAN_SECONDS = 30.0

_STOP_TIMEOUT = 1.0
_WILDCARD_HOSTS = frozenset({"", "0.0.0.0", "::"})


def is_discovery_request(datagram: bytes) -> bool:
    """Decide whether ``datagram`` deserves an answer.

    Kept apart from the socket loop so the acceptance rule can be checked without a network. A
    prefix match rather than equality is deliberate: bytes 16..63 are reserved for future protocol
    revisions, and some clients pad the message. A different version character is a different
    protocol, so ``alpacadiscovery2`` is not answered with a version-1 reply.
    """
    return len(datagram) <= MAX_DISCOVERY_DATAGRAM and datagram.startswith(DISCOVERY_MESSAGE)


class RateLimiter:
    """Token bucket per source address.

    A UDP responder answers whatever source address a datagram claims, so without a cap it could
    be aimed at a victim by spoofing. A real client sends a handful of probes per search, far below
    the cap, so only abuse is throttled. Not thread-safe: the responder's single loop owns it.
    """

    def __init__(
        self,
        rate: float = 20.0,
        burst: int = 20,
        max_sources: int = 4096,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        if rate <= 0 or burst < 1 or max_sources < 1:
            raise ValueError("rate, burst and max_sources must be positive")
        self._rate = float(rate)
        self._burst = float(burst)
        self._max_sources = max_sources
        self._clock = clock
        self._buckets: dict[str, tuple[float, float]] = {}

    def allow(self, source: str) -> bool:
        """Spend one token for ``source``; False means drop the reply."""
        now = self._clock()
        bucket = self._buckets.get(source)
        if bucket is None:
            if len(self._buckets) >= self._max_sources:
                self._prune(now)
            tokens = self._burst
        else:
            tokens = min(self._burst, bucket[0] + (now - bucket[1]) * self._rate)
        if tokens < 1.0:
            self._buckets[source] = (tokens, now)
            return False
        self._buckets[source] = (tokens - 1.0, now)
        return True

    def _prune(self, now: float) -> None:
        # Spoofed sources could otherwise grow the table without bound. A bucket idle long enough
        # to have refilled carries no information, so forgetting it changes no decision.
        refill = self._burst / self._rate
        self._buckets = {k: v for k, v in self._buckets.items() if now - v[1] < refill}
        if len(self._buckets) >= self._max_sources:
            self._buckets.clear()


def _open_udp_socket(family: socket.AddressFamily, host: str, port: int) -> socket.socket:
    """Open a shared, non-blocking UDP socket bound to ``(host, port)``.

    Shared mode (SO_REUSEADDR plus SO_REUSEPORT where it exists) is what revision 12 of the
    Alpaca reference asks for, so this server coexists with ASCOM Remote or another Alpaca server
    on the same host. SO_BROADCAST is deliberately not set: replies are unicast, and without it
    the kernel refuses to send to a broadcast address a spoofed request might name.
    """
    sock = socket.socket(family, socket.SOCK_DGRAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        if hasattr(socket, "SO_REUSEPORT"):
            try:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
            except OSError as exc:  # defined by the headers but refused by this kernel
                log.debug("SO_REUSEPORT not supported: %s", exc)
        if family == socket.AF_INET6:
            # Keep IPv4 on its own socket so the IPv4 responder does not depend on IPv6 existing.
            sock.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_V6ONLY, 1)
        sock.bind((host, port))
        sock.setblocking(False)
    except BaseException:
        sock.close()
        raise
    return sock


class DiscoveryResponder:
    """Answers Alpaca discovery requests on IPv4 (always) and IPv6 (when available).

    ``bind_host`` is "" (or "0.0.0.0"/"::") for all interfaces, which is what discovery needs:
    on Linux a socket bound to a unicast address never sees broadcasts, so binding an IPv4
    address restricts the responder to unicast requests to that address. An IPv4 literal serves
    IPv4 only and an IPv6 literal serves IPv6 only (unicast; no group is joined).

    One daemon thread serves both sockets through a selector; ``stop()`` wakes it through a
    socket pair, so shutdown does not wait for a poll interval.
    """

    def __init__(
        self,
        alpaca_port: int,
        discovery_port: int = DEFAULT_DISCOVERY_PORT,
        bind_host: str = "",
        ipv6: bool = True,
    ) -> None:
        if not 1 <= alpaca_port <= 65535:
            raise ValueError(f"alpaca_port out of range: {alpaca_port}")
        if not 0 <= discovery_port <= 65535:
            raise ValueError(f"discovery_port out of range: {discovery_port}")
        self.alpaca_port = alpaca_port
        self.discovery_port = discovery_port
        self.bind_host = bind_host.strip()
        self.ipv6 = ipv6
        self._v4_host, self._v6_host = self._split_bind_host(self.bind_host, ipv6)
        #: The port actually bound; equals ``discovery_port`` until ``start()`` resolves port 0.
        self.port = discovery_port
        self._reply = json.dumps({"AlpacaPort": alpaca_port}).encode("ascii")
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._stopping = threading.Event()
        self._v4: socket.socket | None = None
        self._v6: socket.socket | None = None
        self._wake_r: socket.socket | None = None
        self._wake_w: socket.socket | None = None
        self._selector: selectors.BaseSelector | None = None
        self._joined: set[int] = set()
        self._limiter = RateLimiter()

    @staticmethod
    def _split_bind_host(host: str, ipv6: bool) -> tuple[str | None, str | None]:
        if host in _WILDCARD_HOSTS:
            return "", ("::" if ipv6 else None)
        try:
            version = ipaddress.ip_address(host.split("%", 1)[0]).version
        except ValueError:
            raise ValueError(f"bind_host must be '' or an IP address literal, not {host!r}") from None
        if version == 4:
            return host, None
        if not ipv6:
            raise ValueError(f"bind_host {host!r} is IPv6 but ipv6=False")
        return None, host

    @property
    def running(self) -> bool:
        """True between a successful ``start()`` and ``stop()``."""
        return self._thread is not None

    @property
    def ipv6_active(self) -> bool:
        """True when the IPv6 socket is open (it may still have joined no interface)."""
        return self._v6 is not None

    def start(self) -> None:
        """Bind the sockets and start answering; a no-op when already running.

        Binding and group joins happen here, before returning, so a caller that starts the
        responder and then announces readiness is telling the truth. IPv4 failures raise (IPv4
        support is expected of every device); IPv6 failures only warn.
        """
        with self._lock:
            if self._thread is not None:
                return
            self._stopping.clear()
            self._limiter = RateLimiter()
            self._joined = set()
            try:
                self._open_sockets()
                self._wake_r, self._wake_w = socket.socketpair()
                self._wake_r.setblocking(False)
                selector = selectors.DefaultSelector()
                selector.register(self._wake_r, selectors.EVENT_READ)
                for sock in (self._v4, self._v6):
                    if sock is not None:
                        selector.register(sock, selectors.EVENT_READ)
                self._selector = selector
                thread = threading.Thread(target=self._run, name="alpaca-discovery", daemon=True)
                thread.start()
            except BaseException:
                self._close_all()
                raise
            self._thread = thread
            log.info(
                "Alpaca discovery listening on UDP port %d (IPv4 %s, IPv6 %s), answering AlpacaPort %d",
                self.port,
                "on" if self._v4 else "off",
                "on" if self._v6 else "off",
                self.alpaca_port,
            )

    def stop(self) -> None:
        """Stop answering and release the port; safe to call repeatedly or before ``start()``."""
        with self._lock:
            thread = self._thread
            if thread is None:
                return
            self._stopping.set()
            if self._wake_w is not None:
                with contextlib.suppress(OSError):
                    self._wake_w.send(b"\0")
            thread.join(_STOP_TIMEOUT)
            if thread.is_alive():
                log.warning("discovery thread did not stop within %.1f s", _STOP_TIMEOUT)
            self._close_all()
            self._thread = None

    def __enter__(self) -> DiscoveryResponder:
        self.start()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.stop()

    # -- socket setup ---------------------------------------------------------------------------

    def _open_sockets(self) -> None:
        port = self.discovery_port
        if self._v4_host is not None:
            self._v4 = _open_udp_socket(socket.AF_INET, self._v4_host, port)
            port = self._v4.getsockname()[1]
        if self._v6_host is not None:
            try:
                self._v6 = _open_udp_socket(socket.AF_INET6, self._v6_host, port)
            except OSError as exc:
                if self._v4 is None:
                    raise
                log.warning("IPv6 discovery unavailable, answering IPv4 only: %s", exc)
            else:
                port = self._v6.getsockname()[1]
                if self._v6_host == "::":
                    self._join_groups()
                    if not self._joined:
                        log.warning(
                            "IPv6 discovery: no interface accepted multicast group %s; "
                            "only unicast IPv6 requests will be answered",
                            IPV6_DISCOVERY_GROUP,
                        )
        self.port = port

    def _join_groups(self) -> None:
        """Join the discovery group on every interface not yet joined.

        The kernel knows which interfaces carry IPv6; asking it per interface and accepting a
        refusal is simpler and more reliable than predicting it.
        """
        sock = self._v6
        if sock is None:
            return
        try:
            interfaces = socket.if_nameindex()
        except OSError as exc:
            log.debug("cannot list interfaces: %s", exc)
            return
        present = {index for index, _ in interfaces}
        # The kernel drops a membership when its interface goes away; forget it too so that an
        # interface re-created under the same index is joined again.
        self._joined &= present
        group = socket.inet_pton(socket.AF_INET6, IPV6_DISCOVERY_GROUP)
        for index, name in interfaces:
            if index in self._joined:
                continue
            try:
                sock.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_JOIN_GROUP, group + struct.pack("@I", index))
            except OSError as exc:
                log.debug("not joining %s on %s: %s", IPV6_DISCOVERY_GROUP, name, exc)
                continue
            self._joined.add(index)
            log.debug("joined %s on %s", IPV6_DISCOVERY_GROUP, name)

    def _close_all(self) -> None:
        if self._selector is not None:
            self._selector.close()
            self._selector = None
        for attr in ("_v4", "_v6", "_wake_r", "_wake_w"):
            sock = getattr(self, attr)
            if sock is not None:
                with contextlib.suppress(OSError):
                    sock.close()
                setattr(self, attr, None)

    # -- serving --------------------------------------------------------------------------------

    def _run(self) -> None:
        selector = self._selector
        assert selector is not None
        rescan = self._v6 is not None and self._v6_host == "::"
        next_rescan = time.monotonic() + _GROUP_RESCAN_SECONDS
        while not self._stopping.is_set():
            timeout = max(0.0, next_rescan - time.monotonic()) if rescan else None
            try:
                events = selector.select(timeout)
                for key, _ in events:
                    if key.fileobj is self._wake_r:
                        continue  # the loop condition sees the stop request
                    self._serve_one(key.fileobj)  # type: ignore[arg-type]
                if rescan and time.monotonic() >= next_rescan:
                    self._join_groups()
                    next_rescan = time.monotonic() + _GROUP_RESCAN_SECONDS
            except Exception:
                # A responder that dies silently makes the server undiscoverable with no symptom
                # but absence, so nothing may end this loop except stop(). The short wait keeps a
                # persistent fault from spinning a CPU.
                log.debug("discovery loop error", exc_info=True)
                self._stopping.wait(0.05)

    def _serve_one(self, sock: socket.socket) -> None:
        try:
            data, addr = sock.recvfrom(_RECV_BUFFER)
        except (BlockingIOError, InterruptedError):
            return
        except OSError as exc:
            log.debug("discovery receive failed: %s", exc)
            return
        source = addr[0]
        if len(data) > MAX_DISCOVERY_DATAGRAM:
            log.debug("ignoring oversize %d-byte datagram from %s", len(data), source)
            return
        if not is_discovery_request(data):
            log.debug("ignoring non-discovery datagram (%d bytes) from %s: %r", len(data), source, data[:32])
            return
        if addr[1] == 0:
            log.debug("ignoring discovery request from %s with source port 0", source)
            return
        if not self._limiter.allow(source):
            log.debug("rate limit: not answering %s", source)
            return
        try:
            sock.sendto(self._reply, addr)
        except OSError as exc:
            log.debug("discovery reply to %s failed: %s", addr, exc)
            return
        log.debug("answered discovery request from %s:%s", source, addr[1])
