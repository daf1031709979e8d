"""Who is talking to the server: the per-request caller and a registry of recent callers.

The HTTP layer sets :data:`current_client` for the duration of each request; layers below it
(the Telescope) read it when they must know *who* asked, e.g. to reference-count ``Connected``
or to stop a ``MoveAxis`` whose client has gone silent. A contextvar keeps that knowledge out of
every method signature while staying correct under waitress's thread pool.
"""

from __future__ import annotations

import contextvars
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field


@dataclass(frozen=True)
class ClientKey:
    """A client as seen on the wire: ClientIDs are not unique across hosts, so the address is part of it."""

    address: str
    client_id: int

    def __str__(self) -> str:
        return f"{self.address}#{self.client_id}"


#: The client making the current request; ``None`` outside a request (tests, internal calls).
current_client: contextvars.ContextVar[ClientKey | None] = contextvars.ContextVar("current_client", default=None)


@dataclass
class ClientActivity:
    """What the setup page shows about one client."""

    key: ClientKey
    first_seen: float
    last_seen: float
    requests: int = 0
    user_agent: str = ""


@dataclass
class ClientRegistry:
    """Last-seen times per client, bounded so a scanner cycling ClientIDs cannot grow it forever.

    The bound evicts the least recently seen client, except one a protector names: the MoveAxis
    watchdog judges a move's owner by its last-seen time, so churn from other ClientIDs must not
    erase the owner of a running move (issue 23, item 2).
    """

    max_clients: int = 256
    _clients: dict[ClientKey, ClientActivity] = field(default_factory=dict)
    _lock: threading.Lock = field(default_factory=threading.Lock)
    _protectors: list[Callable[[], Iterable[ClientKey]]] = field(default_factory=list)

    def protect(self, owners: Callable[[], Iterable[ClientKey]]) -> None:
        """Never evict the keys ``owners()`` names (called under the registry lock: it must not block)."""
        with self._lock:
            self._protectors.append(owners)

    def unprotect(self, owners: Callable[[], Iterable[ClientKey]]) -> None:
        with self._lock:
            if owners in self._protectors:
                self._protectors.remove(owners)

    def _evict_one(self) -> None:
        """Drop the least recently seen unprotected client (none if every entry is protected)."""
        kept = {key for owners in self._protectors for key in owners()}
        candidates = [a for a in self._clients.values() if a.key not in kept]
        if candidates:
            del self._clients[min(candidates, key=lambda a: a.last_seen).key]

    def touch(self, key: ClientKey, user_agent: str = "", now: float | None = None) -> None:
        stamp = time.monotonic() if now is None else now
        with self._lock:
            activity = self._clients.get(key)
            if activity is None:
                if len(self._clients) >= self.max_clients:
                    self._evict_one()
                activity = ClientActivity(key, stamp, stamp, 0, user_agent)
                self._clients[key] = activity
            activity.last_seen = stamp
            activity.requests += 1
            if user_agent:
                activity.user_agent = user_agent

    def last_seen(self, key: ClientKey) -> float | None:
        with self._lock:
            activity = self._clients.get(key)
            return activity.last_seen if activity else None

    def snapshot(self, active_within: float | None = None, now: float | None = None) -> list[ClientActivity]:
        stamp = time.monotonic() if now is None else now
        with self._lock:
            items = [ClientActivity(a.key, a.first_seen, a.last_seen, a.requests, a.user_agent)
                     for a in self._clients.values()]
        if active_within is not None:
            items = [a for a in items if stamp - a.last_seen <= active_within]
        return sorted(items, key=lambda a: a.last_seen, reverse=True)
