"""The Telescope's connection: reference-counted across clients, the mount link opened by the first
and lingering a while after the last, so a client that reconnects finds it open."""

from __future__ import annotations

import logging
import threading
import time
from typing import TYPE_CHECKING

from .._exceptions import (
    ERR_LINK,
    AlpacaError,
    DriverError,
    LinkError,
    MountReplyError,
    NotConnected,
    Parked,
    ProtocolError,
    mount_errors,
)
from ..clients import ClientKey, ClientRegistry, current_client
from ..config.settings import Settings
from ..motion import MotionSupervisor
from ..mount.operations import Mount
from ..zwo.wire_values import MeridianSettings, TrackRate

log = logging.getLogger(__name__)


class ConnectionMixin:
    """Connected / Connect / Disconnect / Connecting of :class:`~alpaca_zwo.telescope.device.Telescope`."""

    mount: Mount
    registry: ClientRegistry
    motion: MotionSupervisor
    linger_s: float
    link_grace_s: float
    _lock: threading.RLock
    _clients_lock: threading.Lock
    _clients: set[ClientKey]
    _connecting: bool
    _linger_timer: threading.Timer | None
    _meridian: MeridianSettings

    if TYPE_CHECKING:  # provided by Telescope
        @property
        def settings(self) -> Settings: ...

    # -- connection (reference-counted across clients) ---------------------------------------

    def _caller(self) -> ClientKey:
        return current_client.get() or ClientKey("internal", 0)

    def connected(self) -> bool:
        key = current_client.get()
        with self._clients_lock:
            has_client = bool(self._clients) if key is None else key in self._clients
        return has_client and self._device_up()

    def _device_up(self) -> bool:
        if not self.mount.running:
            return False
        status = self.mount.link.status
        return status.connected or time.time() - status.since < self.link_grace_s

    def set_connected(self, value: bool) -> None:
        key = self._caller()
        if value:
            self._open_mount()
            with self._clients_lock:
                self._clients.add(key)
                self._cancel_linger()
            log.info("client %s connected (%d connected)", key, len(self._clients))
        else:
            self._release(key)

    def connect(self) -> None:
        key = self._caller()
        with self._clients_lock:
            if self._connecting:
                return
            self._connecting = True

        def run() -> None:
            try:
                self._open_mount()
                with self._clients_lock:
                    self._clients.add(key)
                    self._cancel_linger()
            except AlpacaError as exc:
                log.error("connect failed: %s", exc.message)
            finally:
                with self._clients_lock:
                    self._connecting = False

        threading.Thread(target=run, name="telescope-connect", daemon=True).start()

    def disconnect(self) -> None:
        self._release(self._caller())

    def connecting(self) -> bool:
        return self._connecting

    def _open_mount(self) -> None:
        with self._lock:
            if self.mount.running:
                return
            try:
                self.mount.connect()
            except (LinkError, ProtocolError, MountReplyError) as exc:
                raise DriverError(f"cannot connect to the mount at {self.mount.link.url}: {exc}", ERR_LINK) from exc
            self._load_mount_settings()

    def connected_clients(self) -> frozenset[ClientKey]:
        """Who holds the device connected (the setup page lists them)."""
        with self._clients_lock:
            return frozenset(self._clients)

    def _configured_meridian(self) -> MeridianSettings:
        limits = self.settings.limits
        return MeridianSettings(False, limits.meridian_track_past, round(limits.meridian_limit_deg))

    def set_meridian_settings(self, meridian: MeridianSettings) -> None:
        """Write the mount's meridian behaviour and remember it: DestinationSideOfPier depends on it."""
        with mount_errors("setting the meridian behaviour"):
            self.mount.set_meridian(meridian)
        self._meridian = meridian

    def _load_mount_settings(self) -> None:
        """The configuration is the single source of truth: a replaced or reset mount gets it back."""
        settings = self.mount.read_settings()
        wanted = self._configured_meridian()
        if settings.meridian is not None:
            self._meridian = settings.meridian
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

    def _release(self, key: ClientKey) -> None:
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

    def _cancel_linger(self) -> None:
        if self._linger_timer is not None:
            self._linger_timer.cancel()
            self._linger_timer = None

    def _linger_expired(self) -> None:
        with self._lock:
            with self._clients_lock:
                if self._clients or self.motion.motion is not None:
                    return
            log.info("no client for %.0f s: closing the mount link", self.linger_s)
            self.mount.disconnect()

    def _require_connected(self) -> None:
        """The device is connected while at least one client holds it (the link may linger longer)."""
        with self._clients_lock:
            held = bool(self._clients)
        if not held or not self.mount.running:
            raise NotConnected("the telescope is not connected: set Connected=true or call Connect first")

    def _require_unparked(self, what: str) -> None:
        if self.motion.parked:
            raise Parked(f"{what} is not allowed while the telescope is parked; unpark it first")
