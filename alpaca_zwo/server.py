"""Composition root: settings -> link -> mount -> telescope -> app -> waitress, plus discovery.

Everything with a lifetime is started here and stopped here, in reverse order, so shutdown can
make the mounts safe (stop manual motion, optionally park) before their links close.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from . import __version__
from .alpaca.app import create_app
from .alpaca.hosts import HostGuard
from .alpaca.http import HttpServer
from .alpaca.local_addresses import local_networks, page_urls
from .alpaca.management import ServerInfo
from .clients import ClientRegistry
from .config.settings import DeviceSettings, Settings
from .config.store import SettingsStore
from .facade import ServerFacade
from .motion.interlock import Interlock
from .mount.host_clock import HostClockWatch
from .mount.operations import Mount, utc_now
from .mount.timekeeping import TimeKeeper
from .observatory import SafetyResponder, SafetyWatch
from .telescope.device import Telescope
from .zwo.link import Link

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Overrides:
    """Command-line choices that apply to this run only and are never written to the config file."""

    host: str | None = None
    port: int | None = None
    discovery_port: int | None = None
    device_url: str | None = None
    mdns: bool | None = None
    emulator_speed: float | None = None
    emulator_baud: int | None = None
    emulator_mode: str | None = None  # --emulator-mode eq|altaz
    emulator_preset: str | None = None  # --emulator-preset NAME: the built-in emulator's firmware (zwo/firmware.py)
    stellarium_port: int | None = None  # --stellarium-port N: Stellarium's telescope server on N
    zwo_port: int | None = None  # --zwo-port N: serve the shared ZWO-protocol port on N for this run


class EmbeddedEmulator:
    """The built-in mount, served on a loopback TCP port so the whole driver stack is exercised."""

    def __init__(self, settings: Settings, speed: float, baud: int, mode: str | None = None,
                 preset_name: str | None = None) -> None:
        from .emulator import EmulatorServer, MountModel, ScaledClock, preset
        from .emulator.imperfection import Imperfection
        from .zwo.wire_values import MountMode

        self.clock = ScaledClock(speed=speed)
        config = settings.emulator
        overrides = {"model": config.model, "version": config.firmware}
        firmware = preset(preset_name or config.preset, **{key: value for key, value in overrides.items() if value})
        altaz = (mode or config.mode) == "altaz"
        imperfection = Imperfection.of(config.pointing_errors, config.pointing_noise, config.pointing_seed)
        self.model = MountModel(self.clock, firmware=firmware, mode=MountMode.ALTAZ if altaz else MountMode.EQUATORIAL,
                                imperfection=imperfection)
        self.server = EmulatorServer(self.model, host="127.0.0.1", port=0, baud=baud)
        self.server.start()
        self.url = f"socket://127.0.0.1:{self.server.port}"
        log.info("built-in emulator (%s, speed %gx) at %s", firmware.describe(), speed, self.url)

    def now(self) -> datetime:
        return self.clock.now()

    def stop(self) -> None:
        self.server.stop()


class AlpacaZwoServer:
    """The running product. ``start()`` returns once HTTP is serving; ``stop()`` is idempotent."""

    def __init__(self, store: SettingsStore, overrides: Overrides | None = None,
                 extra_routes_factory: Callable[[AlpacaZwoServer], list[tuple[str, Any]]] | None = None) -> None:
        self.store = store
        self.overrides = overrides or Overrides()
        self.registry = ClientRegistry()
        self.emulators: list[EmbeddedEmulator | None] = []
        self.telescopes: list[Telescope] = []
        self.http: HttpServer | None = None
        self.discovery: Any = None
        self.advertiser: Any = None
        self.stellarium: Any = None  # bridges.stellarium.StellariumBridge when [stellarium] is on
        self.zwo_port: Any = None  # bridges.zwo_port.ZwoPortBridge when [zwo_port] is on
        #: The observatory interlock (docs/guide/observatory.md): one gate for every telescope, the watch that
        #: polls the SafetyMonitor and roof into it, and the responder that parks or stops the mounts.
        self.interlock = Interlock()
        self.safety_watch: SafetyWatch | None = None
        self.safety_responder: SafetyResponder | None = None
        self._extra_routes_factory = extra_routes_factory
        self._facade: ServerFacade | None = None
        #: Is this computer's clock synchronised? Read by every mount's time reference (mount/timekeeping.py).
        self.host_clock = HostClockWatch()
        self.gpsd: Any = None  # bridges.gpsd.GpsdSite when site.gpsd is set
        #: The DNS-rebinding guard; follows server.allowed_hosts live (no restart).
        self.host_guard = HostGuard(store.settings.server.allowed_hosts)
        store.subscribe(lambda settings: self.host_guard.set_allowed(settings.server.allowed_hosts))
        self._stopped = threading.Event()

    @property
    def settings(self) -> Settings:
        return self.store.settings

    @property
    def port(self) -> int:
        assert self.http is not None
        return self.http.port

    @property
    def facade(self) -> ServerFacade:
        """What the setup page may see and do (``alpaca_zwo.web`` talks to nothing else)."""
        if self._facade is None:
            self._facade = ServerFacade(self)
        return self._facade

    def bridges(self) -> dict[str, Any]:
        """The running bridges by name, each with a ``status()`` dict the setup page shows."""
        named = {"stellarium": self.stellarium, "zwo_port": self.zwo_port}
        return {name: bridge for name, bridge in named.items() if bridge is not None}

    def _device_url(self, index: int, device: DeviceSettings) -> str:
        if index == 0 and self.overrides.device_url is not None:
            return self.overrides.device_url
        return device.url

    def start(self) -> None:
        settings = self.settings
        for index, device in enumerate(settings.devices):
            url = self._device_url(index, device)
            clock: Callable[[], datetime] = utc_now
            monotonic: Callable[[], float] = time.monotonic
            clock_rate = 1.0
            emulator = None
            if not url:
                speed = self.overrides.emulator_speed or settings.emulator.speed
                baud = settings.emulator.baud if self.overrides.emulator_baud is None else self.overrides.emulator_baud
                emulator = EmbeddedEmulator(settings, speed, baud, self.overrides.emulator_mode,
                                            self.overrides.emulator_preset)
                url, clock, monotonic, clock_rate = emulator.url, emulator.now, emulator.clock.seconds, speed
            self.emulators.append(emulator)
            link = Link(url, baud=device.baud, timeout=device.timeout, trace_size=settings.logging.trace_size)
            keeper = TimeKeeper(clock, monotonic, watch=self.host_clock, policy=lambda: self.settings.time.source)
            mount = Mount(link, self._site, clock=clock, monotonic=monotonic, clock_rate=clock_rate,
                          time_keeper=keeper)
            self.telescopes.append(Telescope(mount, self.store, index, registry=self.registry,
                                             interlock=self.interlock))
        self._start_safety_watch()  # before HTTP serves: a configured monitor refuses motion until it answers

        server = settings.server
        info = ServerInfo(server_name="alpaca-zwo", manufacturer="alpaca-zwo project",
                          manufacturer_version=__version__, location=server.location)
        auth = (server.basic_auth_user, server.basic_auth_password) if server.basic_auth_user else None
        extra = self._extra_routes_factory(self) if self._extra_routes_factory else []
        app = create_app(self.telescopes, self.registry, info, max_body_bytes=server.max_body_bytes,
                         basic_auth=auth, extra_routes=extra, host_guard=self.host_guard)
        host = self.overrides.host or server.host
        port = server.port if self.overrides.port is None else self.overrides.port
        # waitress refuses oversize bodies before reading them in; the app checks again per request.
        # waitress counts a body at the limit as too large; the app's own check enforces the exact limit.
        self.http = HttpServer(app, host, port, threads=server.threads,
                               max_request_body_size=server.max_body_bytes + 1,
                               max_connections_per_address=server.max_connections_per_address)
        logging.getLogger("waitress.queue").setLevel(logging.ERROR)  # "task queue depth" under load is expected
        self.http.start()
        self._start_stellarium()

        self._start_zwo_port()
        self._start_gpsd()

        discovery_port = self.overrides.discovery_port
        if discovery_port is None:
            discovery_port = server.discovery_port
        if discovery_port:
            from .alpaca.discovery import DiscoveryResponder

            self.discovery = DiscoveryResponder(self.http.port, discovery_port)
            try:
                self.discovery.start()
            except OSError as exc:
                log.error("discovery responder could not bind UDP port %d: %s", discovery_port, exc)
                self.discovery = None
        mdns = server.mdns if self.overrides.mdns is None else self.overrides.mdns
        if mdns:
            from .alpaca.advertise import MdnsAdvertiser

            self.advertiser = MdnsAdvertiser(self.http.port, f"alpaca-zwo on port {self.http.port}")
            try:
                self.advertiser.start()
            except OSError as exc:  # no multicast route: the API works without the advertisement
                log.error("mDNS advertisement failed: %s", exc)
                self.advertiser = None

    def _start_safety_watch(self) -> None:
        responder = SafetyResponder(self.telescopes, self.interlock, lambda: self.settings, self._record_safety)
        self.safety_responder = responder
        self.safety_watch = SafetyWatch(self.store, self.interlock, on_change=responder.verdict_changed)
        responder.start()
        self.safety_watch.start()

    def _record_safety(self, kind: str, text: str) -> None:
        if self.safety_watch is not None:
            self.safety_watch.record(kind, text)

    def _start_zwo_port(self) -> None:
        """The shared ZWO-protocol TCP port for INDI and other ZWO/LX200 drivers, bound to Telescope 0."""
        config = self.settings.zwo_port
        if not (config.enabled or self.overrides.zwo_port is not None) or not self.telescopes:
            return
        from .bridges.zwo_port import ZwoPortBridge

        port = config.port if self.overrides.zwo_port is None else self.overrides.zwo_port
        host = self.overrides.host or config.host  # --host binds every listener to that address
        bridge = ZwoPortBridge(self.telescopes[0], host=host, port=port, local_networks=local_networks)
        try:
            bridge.start()
        except OSError as exc:  # the port is taken: Alpaca still serves, the log says why INDI cannot connect
            log.error("ZWO-protocol port %s:%d could not be opened: %s", host, port, exc)
            return
        self.zwo_port = bridge

    def _start_gpsd(self) -> None:
        """The site from a GPS receiver through gpsd (site.gpsd), applied through Telescope 0."""
        address = self.settings.site.gpsd
        if not address or not self.telescopes:
            return
        from .bridges.gpsd import GpsdSite

        self.gpsd = GpsdSite(self.telescopes[0], address).start()

    def _start_stellarium(self) -> None:
        """Stellarium's telescope server, bound to Telescope 0."""
        config = self.settings.stellarium
        if not (config.enabled or self.overrides.stellarium_port is not None) or not self.telescopes:
            return
        from .bridges.stellarium import StellariumBridge

        port = config.port if self.overrides.stellarium_port is None else self.overrides.stellarium_port
        host = self.overrides.host or config.host  # --host binds every listener to that address
        try:
            bridge = StellariumBridge(self.telescopes[0], host=host, port=port, equinox=config.equinox,
                                      local_networks=local_networks)
        except ValueError as exc:  # J2000 without pyerfa (32-bit ARM): say what to do, keep serving Alpaca
            log.error("Stellarium server not started: %s", exc)
            return
        try:
            bridge.start()
        except OSError as exc:  # the port is taken: Alpaca still serves, the log says why Stellarium cannot connect
            log.error("%s", exc)
            bridge.stop()
            return
        self.stellarium = bridge

    def _site(self) -> tuple[float, float]:
        site = self.settings.site
        return site.latitude, site.longitude

    def urls(self) -> list[str]:
        host = self.overrides.host or self.settings.server.host
        shown = "127.0.0.1" if host in ("0.0.0.0", "::", "") else host
        base = f"http://{shown}:{self.port}"
        lines = [f"Alpaca API:   {base}/api/v1/telescope/{i}/" for i in range(len(self.telescopes))]
        lines.append(f"Setup page:   {base}/setup")
        if host in ("0.0.0.0", "::", ""):
            # From a phone or another computer: this machine's LAN addresses and its .local name.
            lines += [f"              {url}" for url in page_urls(host, self.port)]
            lines.append(f"(listening on all interfaces, port {self.port})")
        if self.discovery is not None:
            lines.append(f"Discovery:    UDP port {self.discovery.port}")
        if self.stellarium is not None:
            lines.append(f"Stellarium:   TCP port {self.stellarium.port} ({self.stellarium.equinox})")
        return lines

    def stop(self) -> None:
        """Make the mounts safe, then close everything; safe to call twice."""
        if self._stopped.is_set():
            return
        self._stopped.set()
        on_shutdown = self.settings.safety.on_shutdown
        # Before the telescopes: no program may start motion during shutdown (Stellarium a goto, the ZWO
        # port anything), no site may be pushed, and the safety responder must not connect a mount then.
        for part in (self.stellarium, self.zwo_port, self.gpsd, self.safety_watch, self.safety_responder):
            if part is not None:
                part.stop()
        for telescope in self.telescopes:
            telescope.shutdown(park=on_shutdown == "park")
        if self.advertiser is not None:
            self.advertiser.stop()
        if self.discovery is not None:
            self.discovery.stop()
        if self.http is not None:
            self.http.close()
        for emulator in self.emulators:
            if emulator is not None:
                emulator.stop()

