"""The site from a GPS receiver (issue 31.3), against gpsd itself: Debian's ``gpsfake`` replays an NMEA
log written here (GGA, GSA, RMC each second of GPS time) into a private gpsd on a free loopback port.

One log, one timeline (0.3 s of real time per epoch): a fix 5 m from the configured site (held, but
too close to change anything), the fix lost, a fix at Siding Spring held past 10 s (applied, and sent
to the mount), lost again, a fix at La Palma for under 10 s (not applied), and gpsd gone at the end.
"""

from __future__ import annotations

import functools
import operator
import shutil
import socket
import subprocess
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
import requests

from alpaca_zwo.bridges.gpsd import ground_distance_m
from alpaca_zwo.config.settings import SiteSettings
from alpaca_zwo.server import AlpacaZwoServer
from tests.conftest import make_settings
from tests.support import AlpacaClient, wait_until

EPOCH_S = 0.3  # gpsfake -c 0.1: three sentences an epoch
HOME = (51.4769, -0.0005, 46.0)  # the configured site
NEAR_HOME = (51.47694, -0.0005, 80.0)  # 4.4 m north, 34 m higher: not a new site
SIDING_SPRING = (-31.2733, 149.0617, 1165.0)
LA_PALMA = (28.7606, -17.8816, 2396.0)


def _checksum(body: str) -> str:
    return f"{functools.reduce(operator.xor, body.encode(), 0):02X}"


def _angle(value: float, hemispheres: str, width: int) -> str:
    whole, minutes = int(abs(value)), (abs(value) - int(abs(value))) * 60.0
    return f"{whole:0{width}d}{minutes:07.4f},{hemispheres[0] if value >= 0 else hemispheres[1]}"


def nmea_epochs(place: tuple[float, float, float] | None, count: int, first: int) -> list[str]:
    """``count`` seconds of NMEA from a receiver at ``place`` (None: no fix), GPS time from ``first``."""
    lines = []
    for second in range(first, first + count):
        stamp = f"21{second // 60:02d}{second % 60:02d}.00"
        lat, lon, alt = place or (0.0, 0.0, 0.0)
        where = f"{_angle(lat, 'NS', 2)},{_angle(lon, 'EW', 3)}" if place else ",,,"
        quality, mode, status = (1, 3, "A") if place else (0, 1, "V")
        for body in (f"GPGGA,{stamp},{where},{quality},08,0.9,{alt:.1f},M,46.9,M,,",
                     f"GPGSA,A,{mode},04,05,09,12,24,,,,,,,,2.5,1.3,2.1",
                     f"GPRMC,{stamp},{status},{where},0.0,0.0,261126,,,A"):
            lines.append(f"${body}*{_checksum(body)}\r\n")
    return lines


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


@pytest.fixture
def gpsfake(tmp_path: Path) -> Iterator[Callable[[list[str]], tuple[int, subprocess.Popen[bytes]]]]:
    """Replay NMEA lines once through gpsfake's own gpsd; returns the gpsd port (loopback only) and gpsfake."""
    if shutil.which("gpsfake") is None:
        pytest.fail("gpsfake not found: `apt-get install -y gpsd gpsd-clients` (scripts/run-tests does)")
    started: list[subprocess.Popen[bytes]] = []

    def start(lines: list[str]) -> tuple[int, subprocess.Popen[bytes]]:
        log = tmp_path / "night.nmea"
        log.write_text("".join(lines))
        port = _free_port()
        process = subprocess.Popen(["gpsfake", "-1", "-q", "-c", "0.1", "-P", str(port), str(log)],
                                   stdout=subprocess.DEVNULL, stderr=(tmp_path / "gpsfake.log").open("w"),
                                   env={"PATH": "/usr/bin:/bin:/usr/sbin:/sbin", "TMPDIR": str(tmp_path)})
        started.append(process)
        wait_until(lambda: _listening(port) or process.poll() is not None, 20, "gpsfake's gpsd to listen")
        assert process.poll() is None, (tmp_path / "gpsfake.log").read_text()
        return port, process

    yield start
    for process in started:
        if process.poll() is None:
            process.terminate()
            process.wait(10)


def _listening(port: int) -> bool:
    try:
        socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
    except OSError:
        return False
    return True


def _gps(server: AlpacaZwoServer) -> dict[str, object]:
    reply = requests.get(f"http://127.0.0.1:{server.port}/setup/api/telescope/0/status", timeout=10).json()
    site: dict[str, object] = reply["site"]
    gps = site["gps"]
    assert isinstance(gps, dict)
    return gps


def test_a_held_3d_fix_becomes_the_site_and_a_lost_one_changes_nothing(
        server_factory: Callable[..., AlpacaZwoServer],
        gpsfake: Callable[[list[str]], tuple[int, subprocess.Popen[bytes]]]) -> None:
    log = (nmea_epochs(NEAR_HOME, 45, 0) + nmea_epochs(None, 10, 45) + nmea_epochs(SIDING_SPRING, 45, 55)
           + nmea_epochs(None, 10, 100) + nmea_epochs(LA_PALMA, 20, 110) + nmea_epochs(None, 5, 130))
    assert 20 * EPOCH_S < 10.0 < 36 * EPOCH_S  # the La Palma fix is too short to count, the others long enough
    port, replay = gpsfake(log)
    lat, lon, elev = HOME
    server = server_factory(make_settings(site=SiteSettings(latitude=lat, longitude=lon, elevation=elev,
                                                            gpsd=f"127.0.0.1:{port}")))
    client = AlpacaClient(server.port, 3)
    client.command("connected", Connected="true")
    model = server.emulators[0].model  # type: ignore[union-attr]

    wait_until(lambda: _gps(server)["fix"] == "3D", 20, "a 3D fix")
    wait_until(lambda: (_gps(server)["fix_held_s"] or 0) > 11, 20, "the fix near home to hold past 10 s")
    assert ground_distance_m(lat, lon, *NEAR_HOME[:2]) < 10
    assert (client.value("sitelatitude"), client.value("siteelevation")) == (lat, elev), "churn: a 4 m move applied"
    assert _gps(server)["applied"] is None

    wait_until(lambda: client.value("sitelatitude") != lat, 40, "the Siding Spring fix to become the site")
    assert client.value("sitelatitude") == pytest.approx(SIDING_SPRING[0], abs=1e-6)
    assert client.value("sitelongitude") == pytest.approx(SIDING_SPRING[1], abs=1e-6)
    assert client.value("siteelevation") == pytest.approx(SIDING_SPRING[2], abs=0.5)
    gps = _gps(server)
    assert gps["site_from_gps"] is True, gps
    assert model.clock_site.latitude() == pytest.approx(SIDING_SPRING[0], abs=1 / 3600)  # sent to the mount
    assert model.clock_site.longitude() == pytest.approx(SIDING_SPRING[1], abs=1 / 3600)

    wait_until(lambda: _gps(server)["fix"] == "3D" and _gps(server)["position"]["latitude"] > 0,  # type: ignore[index]
               40, "the short La Palma fix")
    wait_until(lambda: _gps(server)["fix"] == "none", 20, "the fix to be lost at the end of the log")
    replay.terminate()  # and gpsd with it
    wait_until(lambda: not _gps(server)["connected"], 20, "gpsd to go away")
    assert client.value("sitelatitude") == pytest.approx(SIDING_SPRING[0], abs=1e-6), "a lost or short fix moved it"
    assert server.settings.site.latitude == pytest.approx(SIDING_SPRING[0], abs=1e-6)
