"""Shared pieces of the Stellarium bridge tests: a live server on the emulator and ERFA references.

The reference conversions use a different ERFA route from the server's (atoc13/atco13 on
"observed" RA with zero pressure, i.e. no refraction) so a mistake in either shows up.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

import erfa
import requests

from alpaca_zwo.config.settings import SiteSettings, StellariumSettings
from alpaca_zwo.config.store import SettingsStore
from alpaca_zwo.server import AlpacaZwoServer
from tests.conftest import make_settings
from tests.faults.harness import parse_alpaca_time, wait_until

SITE = SiteSettings(latitude=51.4769, longitude=-0.0005, elevation=46.0)
ARCSEC = 1.0 / 3600.0


# --- reference astrometry ----------------------------------------------------------------------


def _utc(t: datetime) -> tuple[float, float]:
    return erfa.dtf2d("UTC", t.year, t.month, t.day, t.hour, t.minute, t.second + t.microsecond / 1e6)


def _site_args(site: SiteSettings) -> tuple[float, float, float]:
    return math.radians(site.longitude), math.radians(site.latitude), site.elevation


def reference_to_j2000(ra_hours: float, dec_deg: float, when: datetime,
                       site: SiteSettings = SITE) -> tuple[float, float]:
    """Apparent topocentric RA/Dec of date (equinox-based) -> ICRS, via erfa.atoc13 with no refraction."""
    utc1, utc2 = _utc(when)
    tt1, tt2 = erfa.taitt(*erfa.utctai(utc1, utc2))
    eo = erfa.eo06a(tt1, tt2)  # CIO RA = equinox RA + eo
    rc, dc = erfa.atoc13("R", erfa.anp(math.radians(ra_hours * 15.0) + eo), math.radians(dec_deg),
                         utc1, utc2, 0.0, *_site_args(site), 0.0, 0.0, 0.0, 0.0, 0.0, 0.55)
    return math.degrees(rc) / 15.0, math.degrees(dc)


def reference_to_apparent(ra_hours: float, dec_deg: float, when: datetime,
                          site: SiteSettings = SITE) -> tuple[float, float]:
    """ICRS -> apparent topocentric RA/Dec of date, via erfa.atco13 (zero pressure: no refraction)."""
    utc1, utc2 = _utc(when)
    _, _, _, dob, rob, eo = erfa.atco13(math.radians(ra_hours * 15.0), math.radians(dec_deg), 0.0, 0.0, 0.0, 0.0,
                                        utc1, utc2, 0.0, *_site_args(site), 0.0, 0.0, 0.0, 0.0, 0.0, 0.55)
    return math.degrees(erfa.anp(rob - eo)) / 15.0, math.degrees(dob)


def separation_arcsec(ra1: float, dec1: float, ra2: float, dec2: float) -> float:
    return math.degrees(erfa.seps(math.radians(ra1 * 15.0), math.radians(dec1),
                                  math.radians(ra2 * 15.0), math.radians(dec2))) * 3600.0


# --- a small Alpaca client (plain HTTP, so every reply's error is visible) ------------------------


class Alpaca:
    """Alpaca calls on telescope 0 as one client; raises on any ASCOM error."""

    def __init__(self, port: int, client_id: int = 4242) -> None:
        self.base = f"http://127.0.0.1:{port}/api/v1/telescope/0/"
        self.client_id = client_id
        self.session = requests.Session()
        self.transaction = 0

    def _ids(self) -> dict[str, str]:
        self.transaction += 1
        return {"ClientID": str(self.client_id), "ClientTransactionID": str(self.transaction)}

    def get(self, member: str) -> object:
        reply = self.session.get(self.base + member, params=self._ids(), timeout=10).json()
        if reply["ErrorNumber"]:
            raise AssertionError(f"GET {member}: {reply['ErrorNumber']:#x} {reply['ErrorMessage']}")
        return reply["Value"]

    def put(self, member: str, **params: object) -> None:
        data = {k: str(v) for k, v in params.items()} | self._ids()
        reply = self.session.put(self.base + member, data=data, timeout=30).json()
        if reply["ErrorNumber"]:
            raise AssertionError(f"PUT {member}: {reply['ErrorNumber']:#x} {reply['ErrorMessage']}")

    def radec_and_time(self) -> tuple[float, float, datetime]:
        ra, dec = float(self.get("rightascension")), float(self.get("declination"))
        return ra, dec, parse_alpaca_time(str(self.get("utcdate")))

    def wait_slew_done(self, timeout: float = 120.0) -> None:
        wait_until(lambda: not self.get("slewing"), timeout, "the slew to end", interval=0.2)


@dataclass
class Rig:
    server: AlpacaZwoServer
    alpaca: Alpaca

    @property
    def stellarium_port(self) -> int:
        return self.server.stellarium.port

    def point_high(self, hours_east: float = -1.0, dec: float = 40.0) -> None:
        """Slew (through Alpaca) to a point well above the horizon and wait until it is there."""
        lst = float(self.alpaca.get("siderealtime"))
        self.alpaca.put("slewtocoordinatesasync", RightAscension=(lst - hours_east) % 24.0, Declination=dec)
        self.alpaca.wait_slew_done()


@contextmanager
def running_server(tmp: Path, equinox: str = "J2000", connect_alpaca: bool = True,
                   site: SiteSettings = SITE) -> Iterator[Rig]:
    """A real server on the emulator (real time) with Stellarium's server on a free loopback port."""
    settings = make_settings(site=site, stellarium=StellariumSettings(enabled=True, host="127.0.0.1", port=0,
                                                                      equinox=equinox))
    server = AlpacaZwoServer(SettingsStore(settings, tmp / "config.toml"))
    server.start()
    try:
        alpaca = Alpaca(server.port)
        if connect_alpaca:
            alpaca.put("connected", Connected=True)
            alpaca.put("tracking", Tracking=True)
        yield Rig(server, alpaca)
    finally:
        server.stop()


def rate_hz(times: list[float]) -> float:
    return (len(times) - 1) / (times[-1] - times[0])


__all__ = ["ARCSEC", "SITE", "Alpaca", "Rig", "rate_hz", "reference_to_apparent", "reference_to_j2000",
           "running_server", "separation_arcsec", "wait_until"]
