"""The Telescope's connection: reference-counted across clients, the mount link opened by the first
and lingering a while after the last, so a client that reconnects finds it open.

Locks, both owned by :class:`Connection` (motion has its own, see ``motion/supervisor.py``):

- ``_clients_lock`` guards the client set, the connecting flag and the linger timer; it is never
  held across I/O, so a GET never waits on the serial line.
- ``_link_lock`` (re-entrant) serialises opening and closing the mount link; it is held across I/O.
- ``_settings_read_lock`` makes programs asking for the mount's stored settings at once share one read
  (:meth:`Connection.mount_settings`); held across that read, it takes no other lock.

Lock order: ``_link_lock`` → ``_clients_lock`` (the linger expiry holds both), never the reverse.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

from .._exceptions import (
    ERR_LINK,
    AlpacaError,
    DriverError,
    LinkError,
    MountReplyError,
    NotConnected,
    ProtocolError,
    mount_errors,
)
from ..clients import ClientKey, current_client
from ..config.settings import Settings
from ..motion import MotionSupervisor
from ..mount.operations import Mount
from ..mount.state import MountSettings
from ..zwo.wire_values import MeridianSettings, TrackRate

log = logging.getLogger(__name__)


class Connection:
    """Who holds the device connected, and the mount link's life: opened (with the configured mount
    settings pushed) by the first client, closed ``linger_s`` after the last one let go.

    The members (Connected, Connect, Disconnect, Connecting) name their client by the request context
    (``clients.current_client``, set by the Alpaca door and the bridges; none: an internal caller);
    ``attach``/``release`` take it from a caller that holds the device for itself (the observatory's
    response), so this part knows nothing of HTTP or bridges.
    """

    def __init__(self, *, mount: Mount, motion: MotionSupervisor, settings: Callable[[], Settings],
                 linger_s: float, link_grace_s: float) -> None:
        self.mount = mount
        self.motion = motion  # stopped when the last client lets go; a running motion keeps the link open
        self._settings = settings
        self.linger_s = linger_s  # the link stays open this long after the last client
        self.link_grace_s = link_grace_s  # Connected stays true this long into a link outage
        self._link_lock = threading.RLock()
        self._clients_lock = threading.Lock()
        self._clients: set[ClientKey] = set()
        self._connecting = False
        self._linger_timer: threading.Timer | None = None
        self._settings_read_lock = threading.Lock()
        #: The mount's meridian setting as last read or written: DestinationSideOfPier and pier flips
        #: depend on it.
        self.meridian = MeridianSettings()

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
                if self._clients or self.motion.motion is not None:
                    return
            log.info("no client for %.0f s: closing the mount link", self.linger_s)
            self.mount.disconnect()

    # -- mount settings a connect pushes -----------------------------------------------------

    def _configured_meridian(self) -> MeridianSettings:
        limits = self._settings().limits
        return MeridianSettings(False, limits.meridian_track_past, round(limits.meridian_limit_deg))

    def set_meridian_settings(self, meridian: MeridianSettings) -> None:
        """Write the mount's meridian behaviour and remember it: DestinationSideOfPier depends on it."""
        with mount_errors("setting the meridian behaviour"):
            self.mount.set_meridian(meridian)
        self.meridian = meridian

    def _load_mount_settings(self) -> None:
        """The configuration is the single source of truth: a replaced or reset mount gets it back."""
        settings = self.mount.read_settings()
        wanted = self._configured_meridian()
        if settings.meridian is not None:
            self.meridian = settings.meridian
            if settings.meridian != wanted:
                try:
                    self.set_meridian_settings(wanted)
                    log.info("mount meridian setting %s replaced by the configured %s", settings.meridian, wanted)
                except DriverError as exc:
                    log.warning("could not apply the configured meridian setting: %s", exc.message)
        try:
            self.mount.set_tracking_rate(TrackRate.SIDEREAL)  # "start up with a known tracking rate"
        except (LinkError, ProtocolError) as exc:
            log.warning("could not select the sidereal rate: %s", exc)

    # -- the mount's stored settings, for the shared ZWO port (bridges/zwo_backend.py) -------------

    def mount_settings(self) -> MountSettings:
        """The mount-stored settings from the Mount's one shared cache (the page and the Actions read it
        too): read from the mount only when never read, marked stale by a command since, or a minute
        old; that read refills the cache for everyone."""
        with self._settings_read_lock:
            cache = self.mount.settings_cache
            cached = cache.value
            if cached is None or cache.due():
                return self.mount.read_settings()
            return cached
