"""The Telescope's connection: reference-counted across clients, the mount link opened by the first
and lingering a while after the last, so a client that reconnects finds it open.

Locks, both owned by :class:`Connection` (motion has its own, see ``motion/supervisor.py``):

- ``_clients_lock`` guards the client set, the connecting flag and the linger timer; it is never
  held across I/O, so a GET never waits on the serial line.
- ``_link_lock`` (re-entrant) serialises opening and closing the mount link; it is held across I/O.

Lock order: ``_link_lock`` → ``_clients_lock`` (the linger expiry holds both), never the reverse.
"""

from __future__ import annotations

import logging
import threading
import time

from .._exceptions import ERR_LINK, AlpacaError, DriverError, LinkError, MountReplyError, NotConnected, ProtocolError
from ..clients import ClientKey, current_client
from ..motion import MotionSupervisor
from ..mount.operations import Mount
from ..zwo.link import LinkCounters, LinkStatus, TraceEntry
from ..zwo.wire_values import TrackRate
from .stored_settings import StoredSettings

log = logging.getLogger(__name__)


class Connection:
    """Who holds the device connected, and the mount link's life: opened (with the configured mount
    settings pushed) by the first client, closed ``linger_s`` after the last one let go.

    The members (Connected, Connect, Disconnect, Connecting) name their client by the request context
    (``clients.current_client``, set by the Alpaca door and the bridges; none: an internal caller);
    ``attach``/``release`` take it from a caller that holds the device for itself (the observatory's
    response), so this part knows nothing of HTTP or bridges.
    """

    def __init__(self, *, mount: Mount, motion: MotionSupervisor, stored: StoredSettings,
                 linger_s: float, link_grace_s: float) -> None:
        self.mount = mount
        self.motion = motion  # stopped when the last client lets go; a running motion keeps the link open
        self.stored = stored  # the mount's stored settings: the configured meridian setting is pushed at open
        self.linger_s = linger_s  # the link stays open this long after the last client
        self.link_grace_s = link_grace_s  # Connected stays true this long into a link outage
        self._link_lock = threading.RLock()
        self._clients_lock = threading.Lock()
        self._clients: set[ClientKey] = set()
        self._connecting = False
        self._linger_timer: threading.Timer | None = None

    # -- members -----------------------------------------------------------------------------

    def connected(self) -> bool:
        """The calling client holds the device (an internal caller: anyone does) and the link is up or in its grace."""
        return self.held_by(current_client.get())

    def set_connected(self, value: bool) -> None:
        if value:
            self.attach(self._caller())
        else:
            self.release(self._caller())

    def connect(self) -> None:
        self.connect_in_background(self._caller())

    def disconnect(self) -> None:
        self.release(self._caller())

    def connecting(self) -> bool:
        return self._connecting

    @staticmethod
    def _caller() -> ClientKey:
        return current_client.get() or ClientKey("internal", 0)

    # -- clients -----------------------------------------------------------------------------

    def held_by(self, key: ClientKey | None) -> bool:
        """``key`` holds the device (``None``: anyone does) and the link is up or within its grace."""
        with self._clients_lock:
            has_client = bool(self._clients) if key is None else key in self._clients
        return has_client and self._device_up()

    def _device_up(self) -> bool:
        if not self.mount.running:
            return False
        status = self.mount.link.status
        return status.connected or time.time() - status.since < self.link_grace_s

    def attach(self, key: ClientKey) -> None:
        """Connected=true: open the link if needed (raises if it cannot), then count ``key`` in."""
        self._open_link()
        with self._clients_lock:
            self._clients.add(key)
            self._cancel_linger()
        log.info("client %s connected (%d connected)", key, len(self._clients))

    def connect_in_background(self, key: ClientKey) -> None:
        """Connect(): attach ``key`` on a thread while Connecting reads true; a failure is only logged."""
        with self._clients_lock:
            if self._connecting:
                return
            self._connecting = True

        def run() -> None:
            try:
                self._open_link()
                with self._clients_lock:
                    self._clients.add(key)
                    self._cancel_linger()
            except AlpacaError as exc:
                log.error("connect failed: %s", exc.message)
            finally:
                with self._clients_lock:
                    self._connecting = False

        threading.Thread(target=run, name="telescope-connect", daemon=True).start()

    def clients(self) -> frozenset[ClientKey]:
        """Who holds the device connected (the setup page lists them)."""
        with self._clients_lock:
            return frozenset(self._clients)

    def release(self, key: ClientKey) -> None:
        """``key`` lets go; after the last one, manual motion stops and the link lingers, then closes."""
        with self._clients_lock:
            self._clients.discard(key)
            remaining = len(self._clients)
        if remaining == 0 and self.mount.running:
            self.motion.stop_manual("the last client disconnected")
            with self._clients_lock:
                if not self._clients:
                    self._cancel_linger()
                    timer = threading.Timer(self.linger_s, self._linger_expired)
                    timer.daemon = True
                    self._linger_timer = timer
                    timer.start()
        log.info("client %s disconnected (%d still connected)", key, remaining)

    def link_status(self) -> LinkStatus:
        """The mount link's state, URL, last error and reconnects (the page; DeviceState's age)."""
        return self.mount.link.status

    def link_counters(self) -> LinkCounters:
        """The link's traffic: exchanges, timeouts, resyncs, bytes each way."""
        return self.mount.link.counters

    def link_trace(self) -> list[TraceEntry]:
        """The recent serial exchanges, oldest first (the page's trace view)."""
        return self.mount.link.trace()

    def require_connected(self) -> None:
        """The device is connected while at least one client holds it (the link may linger longer)."""
        with self._clients_lock:
            held = bool(self._clients)
        if not held or not self.mount.running:
            raise NotConnected("the telescope is not connected: set Connected=true or call Connect first")

    def close(self) -> None:
        """Server shutdown: no linger timer may close the link behind the owner's back."""
        with self._clients_lock:
            self._cancel_linger()

    # -- the link ----------------------------------------------------------------------------

    def _open_link(self) -> None:
        with self._link_lock:
            if self.mount.running:
                return
            try:
                self.mount.connect()
            except (LinkError, ProtocolError, MountReplyError) as exc:
                raise DriverError(f"cannot connect to the mount at {self.mount.link.url}: {exc}", ERR_LINK) from exc
            self._load_mount_settings()

    def _cancel_linger(self) -> None:
        """Callers hold ``_clients_lock``."""
        if self._linger_timer is not None:
            self._linger_timer.cancel()
            self._linger_timer = None

    def _linger_expired(self) -> None:
        with self._link_lock:
            with self._clients_lock:
                if self._clients or self.motion.running() is not None:
                    return
            log.info("no client for %.0f s: closing the mount link", self.linger_s)
            self.mount.disconnect()

    # -- what a connect pushes -------------------------------------------------------------------

    def _load_mount_settings(self) -> None:
        """The configured meridian setting (the stored settings' owner), then the sidereal rate."""
        self.stored.push_configured()
        try:
            self.mount.set_tracking_rate(TrackRate.SIDEREAL)  # "start up with a known tracking rate"
        except (LinkError, ProtocolError) as exc:
            log.warning("could not select the sidereal rate: %s", exc)
