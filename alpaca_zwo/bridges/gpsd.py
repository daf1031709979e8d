"""The site from a GPS receiver, through gpsd (opt-in: ``site.gpsd = "localhost:2947"``).

gpsd speaks JSON, one object a line (https://gpsd.io/gpsd_json.html). After the client's
``?WATCH={"enable":true,"json":true};`` it sends VERSION, DEVICES and WATCH, then a TPV object at
every fix: ``mode`` (0/1 no fix, 2 a 2D fix, 3 a 3D fix), ``lat``, ``lon`` (degrees, east positive)
and the height above mean sea level, ``altMSL`` (gpsd 3.20 and later; ``alt`` before, which is MSL
there too). This small reader needs no client library.

The rules (issue 31): once a 3D fix has held for :data:`HOLD_S` (TPVs in 3D mode with no gap over
:data:`GAP_S`), the mean of its positions becomes the site, through the Telescope like any client's
site (saved, then sent to the mount), but only when it lies more than :data:`MIN_MOVE_M` from the
site in use, measured along the ground: a GPS's height wanders by tens of metres, and rewriting the
mount's stored site at every start for nothing is churn. One decision per fix: a lost fix changes
nothing, a new fix that holds is considered again, and a site a person sets while the fix holds is
left alone. gpsd going away is retried with a growing delay.

Thread: ``gpsd-site`` (the socket, the decisions). ``_lock`` guards the fields ``status()`` reads.
"""

from __future__ import annotations

import contextlib
import json
import logging
import math
import socket
import threading
import time
from collections.abc import Callable, Mapping
from datetime import datetime, timezone
from typing import TYPE_CHECKING, Any

from .._exceptions import AlpacaError

if TYPE_CHECKING:
    from ..telescope.device import Telescope

log = logging.getLogger(__name__)

__all__ = ["GAP_S", "HOLD_S", "MIN_MOVE_M", "GpsdSite", "ground_distance_m", "parse_address"]

HOLD_S = 10.0
GAP_S = 5.0  # a fix with no report for this long is lost
MIN_MOVE_M = 10.0
WATCH = b'?WATCH={"enable":true,"json":true};\n'
RETRY_S = (1.0, 2.0, 5.0, 10.0)
MAX_LINE = 1 << 20  # gpsd's objects are a few kB; anything longer is not gpsd
EARTH_RADIUS_M = 6_371_008.8


def parse_address(address: str) -> tuple[str, int]:
    """``host:port`` or ``[v6]:port`` (the setting is checked already) as a socket address."""
    host, _, port = address.strip().rpartition(":")
    return host.removeprefix("[").removesuffix("]"), int(port)


def ground_distance_m(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Great-circle distance on the mean Earth sphere (haversine): metres along the ground."""
    p1, p2 = math.radians(lat1), math.radians(lat2)
    dp, dl = p2 - p1, math.radians((lon2 - lon1 + 180.0) % 360.0 - 180.0)
    a = math.sin(dp / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(dl / 2) ** 2
    return 2 * EARTH_RADIUS_M * math.asin(min(1.0, math.sqrt(a)))


def _number(report: Mapping[str, Any], *keys: str) -> float | None:
    for key in keys:
        value = report.get(key)
        if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
            return float(value)
    return None


class GpsdSite:
    """Reads gpsd on its own thread and applies a held 3D fix as the site of ``telescope``."""

    def __init__(self, telescope: Telescope, address: str, *, hold_s: float = HOLD_S,
                 monotonic: Callable[[], float] = time.monotonic) -> None:
        self.telescope = telescope
        self.address = address
        self.hold_s = hold_s
        self._monotonic = monotonic
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._sock: socket.socket | None = None
        self.connected = False
        self.last_error = ""
        self.mode = 0  # the last TPV's fix mode
        self.position: tuple[float, float] | None = None  # the last 3D fix's latitude, longitude
        self._hold_start: float | None = None
        self._last_fix = 0.0
        self._samples: list[tuple[float, float, float | None]] = []
        self._decided = False  # this fix has been considered (applied or found close enough)
        self.applied: dict[str, Any] | None = None

    # -- lifecycle ---------------------------------------------------------------------------

    def start(self) -> GpsdSite:
        self._thread = threading.Thread(target=self._run, name="gpsd-site", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        sock = self._sock
        if sock is not None:
            with contextlib.suppress(OSError):
                sock.shutdown(socket.SHUT_RDWR)  # wakes the reader at once
        if self._thread is not None:
            self._thread.join(timeout=5)

    def _run(self) -> None:
        failures = 0
        while not self._stop.is_set():
            try:
                self._session()
                failures = 0
            except (OSError, ValueError) as exc:
                with self._lock:
                    self.connected, self.last_error = False, f"gpsd at {self.address}: {exc}"
                (log.warning if failures == 0 else log.debug)("site from GPS: %s (retrying)", self.last_error)
                failures += 1
            self._lost(self._monotonic())
            self._stop.wait(RETRY_S[min(failures, len(RETRY_S) - 1)])

    def _session(self) -> None:
        with socket.create_connection(parse_address(self.address), timeout=5.0) as sock:
            self._sock = sock
            sock.sendall(WATCH)
            sock.settimeout(1.0)
            with self._lock:
                self.connected, self.last_error = True, ""
            log.info("site from GPS: reading gpsd at %s", self.address)
            pending = b""
            while not self._stop.is_set():
                try:
                    chunk = sock.recv(65536)
                except TimeoutError:
                    self._quiet(self._monotonic())
                    continue
                if not chunk:
                    raise ConnectionError("gpsd closed the connection")
                pending += chunk
                *lines, pending = pending.split(b"\n")
                if len(pending) > MAX_LINE:
                    raise ValueError("a line of over 1 MiB: this is not gpsd")
                for line in lines:
                    self._line(line)

    def _line(self, line: bytes) -> None:
        try:
            report = json.loads(line)
        except (ValueError, UnicodeDecodeError):
            log.debug("gpsd: not JSON: %r", line[:120])
            return
        if isinstance(report, dict):
            self.feed(report, self._monotonic())

    # -- the rules ---------------------------------------------------------------------------

    def feed(self, report: Mapping[str, Any], now: float) -> None:
        """One gpsd object; a TPV moves the fix's hold forward and may apply the site."""
        if report.get("class") != "TPV":
            return
        mode = report.get("mode")
        lat, lon = _number(report, "lat"), _number(report, "lon")
        if mode != 3 or lat is None or lon is None or not (-90 <= lat <= 90 and -180 <= lon <= 180):
            if isinstance(mode, int) and not isinstance(mode, bool):
                with self._lock:
                    self.mode = mode
                if mode < 3:
                    self._lost(now)
            return
        with self._lock:
            self.mode, self.position = 3, (lat, lon)
            if self._hold_start is None or now - self._last_fix > GAP_S:
                self._hold_start, self._samples, self._decided = now, [], False
            self._last_fix = now
            if not self._decided:
                self._samples.append((lat, lon, _number(report, "altMSL", "alt")))
            fix = None
            if not self._decided and now - self._hold_start >= self.hold_s:
                self._decided, fix = True, self._mean()
        if fix is not None:
            self._consider(*fix)

    def _quiet(self, now: float) -> None:
        """No report for a while: past GAP_S the fix counts as lost."""
        with self._lock:
            silent = self._hold_start is not None and now - self._last_fix > GAP_S
        if silent:
            self._lost(now)

    def _lost(self, _now: float) -> None:
        """The fix is gone: nothing changes but the next fix's hold starts from zero."""
        with self._lock:
            if self._hold_start is not None:
                log.info("site from GPS: the fix was lost; the site stays as it is")
            self._hold_start, self._samples, self._decided = None, [], False
            if self.mode == 3:
                self.mode = 0

    def _mean(self) -> tuple[float, float, float | None]:
        """The mean position of the hold (longitudes unwrapped around the first, for the antimeridian)."""
        samples = self._samples
        lon0 = samples[0][1]
        lat = sum(s[0] for s in samples) / len(samples)
        lon = lon0 + sum((s[1] - lon0 + 180.0) % 360.0 - 180.0 for s in samples) / len(samples)
        heights = [s[2] for s in samples if s[2] is not None]
        return lat, (lon + 180.0) % 360.0 - 180.0, sum(heights) / len(heights) if heights else None

    def _consider(self, lat: float, lon: float, elevation: float | None) -> None:
        site = self.telescope.settings.site
        moved = ground_distance_m(site.latitude, site.longitude, lat, lon)
        if moved <= MIN_MOVE_M:
            log.info("site from GPS: the fix (%.6f, %.6f) is %.1f m from the site in use: unchanged", lat, lon, moved)
            return
        values = {"latitude": round(lat, 7), "longitude": round(lon, 7)}
        if elevation is not None:
            values["elevation"] = round(elevation, 1)
        with self._lock:  # recorded first, so the page says "site from GPS" the moment the site changes
            previous, self.applied = self.applied, {**values, "moved_m": round(moved, 1),
                                                    "at": datetime.now(timezone.utc).isoformat()}
        try:
            self.telescope.capabilities.set_site(values)
        except AlpacaError as exc:
            with self._lock:
                self.applied = previous
                self.last_error = f"the GPS site could not be applied: {exc.message}"
                self._decided = False  # try again with the next hold
                self._hold_start = None
            log.error("site from GPS: %s", self.last_error)
            return
        log.warning("site from GPS: latitude %.6f, longitude %.6f, elevation %s m (%.0f m from the previous site)",
                    lat, lon, "unknown" if elevation is None else f"{elevation:.0f}", moved)

    # -- the page --------------------------------------------------------------------------

    def status(self) -> dict[str, Any]:
        """For the page: connection, fix, how long it has held, and the site it applied (if in use)."""
        now = self._monotonic()
        site = self.telescope.settings.site
        with self._lock:
            applied = self.applied
            in_use = applied is not None and (applied["latitude"], applied["longitude"]) == (site.latitude,
                                                                                           site.longitude)
            held = None if self._hold_start is None else round(now - self._hold_start, 1)
            return {"address": self.address, "connected": self.connected, "fix": {0: "none", 1: "none", 2: "2D",
                    3: "3D"}.get(self.mode, "none"), "fix_held_s": held, "applied": applied,
                    "position": None if self.position is None else {"latitude": self.position[0],
                                                                    "longitude": self.position[1]},
                    "site_from_gps": in_use, "last_error": self.last_error}
