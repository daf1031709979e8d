"""A night in the field (issue 31): the server's clock 3 h behind and unsynchronised, the mount's right.

The server runs as users run it (``python -m alpaca_zwo``) under Debian's ``faketime -f -3h``, so its
clock is wrong the way a Raspberry Pi's is after booting without network; whether the kernel calls
the clock synchronised is injected with ``ALPACA_ZWO_HOST_CLOCK`` (the machine running the tests has
its own answer). The mount is an emulator in its own process with the true clock, judged through its
control port: its own clock (``mount_utc``) against the true one (``true_utc``), and where its axes
really point (``raw_ha_h``) against the true sidereal time.

The site's zone (issue 43 point 3): the server on another zone (``TZ``) than its site's, its wall clock moved
by faketime onto the emulator's date (``--start-time``, December or June), sets the mount in the site's zone.
"""

from __future__ import annotations

import shutil
import time
from collections.abc import Callable, Iterator
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import Any

import pytest
import requests

from alpaca_zwo import sky
from tests.support import AlpacaClient, EmulatorProcess, wait_until
from tests.support.server import FAKETIME_ENV, ServerProcess

LATITUDE, LONGITUDE = 51.4769, -0.0005  # the server's configured site; the emulator's flash holds the same
BEHIND = ["faketime", "-f", "-3h"]
TIMEOUT = 20.0


def _faketime(shift: str = BEHIND[-1]) -> list[str]:
    """The wrapper that moves the server's wall clock by ``shift`` ("-3h", "+1234.567")."""
    if shutil.which("faketime") is None:
        pytest.fail("faketime not found: install it with `apt-get install -y faketime` (scripts/run-tests does)")
    return [*BEHIND[:-1], shift]


def _mount(*extra: str) -> EmulatorProcess:
    return EmulatorProcess("--control-port", "0", "--baud", "0", "--latitude", str(LATITUDE),
                           "--longitude", str(LONGITUDE), *extra)


@pytest.fixture
def processes() -> Iterator[list[Any]]:
    """Emulators and servers a test starts; all are stopped afterwards (servers first)."""
    started: list[Any] = []
    yield started
    for process in reversed(started):
        process.stop() if isinstance(process, ServerProcess) else process.terminate()


Start = Callable[..., tuple[EmulatorProcess, ServerProcess, AlpacaClient]]


@pytest.fixture
def field(tmp_path: Path, processes: list[Any]) -> Start:
    """An emulated mount (``initialized``: its clock set, as by ZWO's app; else just powered up) and a
    server 3 h behind it whose kernel reports the clock ``synchronised`` or not; connected."""

    def start(initialized: bool, synchronised: bool, config: str = "[server]\nmdns = false\n") -> tuple[
            EmulatorProcess, ServerProcess, AlpacaClient]:
        mount = _mount(*(["--initialized"] if initialized else []))
        processes.append(mount)
        env = {**FAKETIME_ENV, "ALPACA_ZWO_HOST_CLOCK": "synchronised" if synchronised else "unsynchronised"}
        server = ServerProcess(tmp_path, "--device", f"socket://127.0.0.1:{mount.port()}", wrapper=_faketime(),
                               env=env, config=config)
        processes.append(server)
        client = AlpacaClient(server.port, 31, timeout=TIMEOUT)
        client.command("connected", Connected="true")
        return mount, server, client

    return start


def _utc(text: str) -> datetime:
    value = datetime.fromisoformat(text.replace("Z", "+00:00"))
    return value if value.tzinfo else value.replace(tzinfo=timezone.utc)


def mount_clock_error_s(mount: EmulatorProcess) -> float:
    """The mount's own clock minus the true time, seconds (the emulator's truth)."""
    truth = mount.state()
    return (_utc(truth["mount_utc"]) - _utc(truth["true_utc"])).total_seconds()


def true_lst(mount: EmulatorProcess) -> float:
    return sky.local_sidereal_time(_utc(mount.state()["true_utc"]), LONGITUDE)


def status(server: ServerProcess) -> dict[str, Any]:
    reply = requests.get(server.base_url + "/setup/api/telescope/0/status", timeout=TIMEOUT)
    assert reply.status_code == 200, reply.text
    result: dict[str, Any] = reply.json()
    return result


def goto_true_sky(client: AlpacaClient, mount: EmulatorProcess, hour_angle: float, dec: float) -> float:
    """GOTO a target ``hour_angle`` west of the true meridian, its RA computed from the true time as a
    planetarium with a right clock does; return how far (seconds of RA) from it the axes really point:
    the true sidereal time minus their hour angle against the ground (the emulator's mechanical truth)."""
    client.command("tracking", Tracking="true")
    target = (true_lst(mount) - hour_angle) % 24.0
    client.command("slewtocoordinatesasync", RightAscension=target, Declination=dec)
    wait_until(lambda: not client.value("slewing"), 120, "the GOTO to end")
    truth = mount.state()
    assert truth["raw_dec_deg"] == pytest.approx(dec, abs=5 / 3600)
    pointed = sky.local_sidereal_time(_utc(truth["true_utc"]), LONGITUDE) - truth["raw_ha_h"]
    miss: float = sky.wrap_hours_12(pointed - target) * 3600.0
    return miss


def test_a_set_mount_clock_is_kept_and_followed(field: Start) -> None:
    """The issue's night: before, Connected=true wrote −10,800 s into the mount and a GOTO ended 3.97 h
    of hour angle away. Now the mount keeps its clock and everything reads the mount's time."""
    mount, server, client = field(initialized=True, synchronised=False)
    assert abs(mount_clock_error_s(mount)) < 1.5, "the server wrote its wrong clock into the mount"
    truth_now = _utc(mount.state()["true_utc"])
    utcdate = _utc(client.value("utcdate"))
    assert abs((utcdate - truth_now).total_seconds()) < 1.5, (utcdate, truth_now)
    lst = client.value("siderealtime")
    assert abs(sky.wrap_hours_12(lst - true_lst(mount))) < 2 / 3600, (lst, true_lst(mount))

    clock = status(server)["time"]
    assert clock["source"] == "mount", clock
    assert "not synchronised" in clock["reason"] and "3 h 0 min" in clock["reason"], clock["reason"]
    assert clock["host_synchronised"] is False
    assert clock["host_offset_s"] == pytest.approx(10800, abs=5)
    assert abs(_utc(clock["utc"]) - truth_now) < timedelta(seconds=3)

    miss = goto_true_sky(client, mount, 1.0, 30.0)
    assert abs(miss) < 2.0, f"the GOTO ended {miss:.1f} s of RA from its target on the true sky"
    truth = mount.state()
    alt, az = client.value("altitude"), client.value("azimuth")  # the server's horizon checks use these
    assert alt == pytest.approx(truth["alt_deg"], abs=0.01) and az == pytest.approx(truth["az_deg"], abs=0.01)

    client.command("connected", Connected="false")  # a reconnect reads the mount's clock again: still kept
    client.command("connected", Connected="true")
    assert abs(mount_clock_error_s(mount)) < 1.5
    assert server.log().count("the mount's time is kept") == 1, "said more than once:\n" + server.log()


def test_a_mount_just_powered_up_gets_the_server_time_and_a_client_fixes_both(field: Start) -> None:
    """A mount with no time (date 2000) takes the server's, wrong as it is, and the page says the host
    clock is not known to be right; N.I.N.A.'s time sync (UTCDate) then fixes server and mount."""
    mount, server, client = field(initialized=False, synchronised=False)
    assert mount_clock_error_s(mount) == pytest.approx(-10800, abs=2), "the mount did not get the server's time"
    clock = status(server)["time"]
    assert clock["source"] == "host" and "no time" in clock["reason"], clock

    client.command("utcdate", UTCDate=datetime.now(timezone.utc).isoformat().replace("+00:00", "Z"))
    assert abs(mount_clock_error_s(mount)) < 1.5
    assert status(server)["time"]["source"] == "client"
    miss = goto_true_sky(client, mount, -1.5, 45.0)
    assert abs(miss) < 2.0, f"the GOTO ended {miss:.1f} s of RA from its target on the true sky"


def test_a_synchronised_host_clock_still_sets_the_mount(field: Start) -> None:
    """The control experiment: a host clock the kernel calls synchronised is trusted, as before, even
    when it is wrong; so the rule above is the synchronised status's doing."""
    mount, server, _ = field(initialized=True, synchronised=True)
    assert mount_clock_error_s(mount) == pytest.approx(-10800, abs=2)
    assert status(server)["time"]["source"] == "host"


def test_time_source_host_overrides_an_unsynchronised_clock(field: Start) -> None:
    mount, server, _ = field(initialized=True, synchronised=False, config='[time]\nsource = "host"\n')
    assert mount_clock_error_s(mount) == pytest.approx(-10800, abs=2)
    assert 'time.source is "host"' in status(server)["time"]["reason"]


# -- the site's zone (issue 43 point 3) ---------------------------------------------------------------

SYDNEY, BERLIN = (-33.8688, 151.2093), (52.52, 13.405)
DECEMBER = datetime(2026, 12, 15, 9, 0, tzinfo=timezone.utc)
JUNE = datetime(2026, 6, 15, 9, 0, tzinfo=timezone.utc)


def mount_local_minus_true_h(mount: EmulatorProcess) -> float:
    """The mount's wall clock (what its hand controller and ZWO's apps show) minus true UTC, in hours."""
    truth = mount.state()
    local = datetime.fromisoformat(truth["mount_local"])
    return round((local - _utc(truth["true_utc"]).replace(tzinfo=None)).total_seconds() / 60.0) / 60.0


def server_in_zone(where: Path, mount: EmulatorProcess, site: tuple[float, float], host_zone: str,
                   synchronised: bool, behind_s: float = 0.0) -> ServerProcess:
    """A server on ``host_zone`` (the TZ variable: a Pi left on UTC or on London) at ``site``, whose wall
    clock is the emulator's true one (which runs at another date) less ``behind_s``."""
    before = time.time()
    true = _utc(mount.state()["true_utc"]).timestamp()
    shift = true - (before + time.time()) / 2.0 - behind_s
    where.mkdir()
    env = {**FAKETIME_ENV, "TZ": host_zone,
           "ALPACA_ZWO_HOST_CLOCK": "synchronised" if synchronised else "unsynchronised"}
    config = f"[server]\nmdns = false\n[site]\nlatitude = {site[0]}\nlongitude = {site[1]}\n"
    return ServerProcess(where, "--device", f"socket://127.0.0.1:{mount.port()}", wrapper=_faketime(f"{shift:+.3f}"),
                         env=env, config=config)


@pytest.mark.parametrize(("site", "when", "host_zone", "zone", "hours"), [
    (SYDNEY, DECEMBER, "UTC", "Australia/Sydney", 11.0),  # AEDT
    (SYDNEY, JUNE, "UTC", "Australia/Sydney", 10.0),  # AEST
    (BERLIN, DECEMBER, "Europe/London", "Europe/Berlin", 1.0),  # CET while London is on UTC+0
    (BERLIN, JUNE, "Europe/London", "Europe/Berlin", 2.0),  # CEST while London is on UTC+1
], ids=["sydney-december-host-utc", "sydney-june-host-utc", "berlin-december-host-london",
        "berlin-june-host-london"])
def test_the_mount_shows_the_sites_local_time_whatever_the_hosts_zone(
        tmp_path: Path, processes: list[Any], site: tuple[float, float], when: datetime, host_zone: str,
        zone: str, hours: float) -> None:
    """A mount just powered up takes the site's local time and zone (daylight saving as at that date),
    not the host's, and its UTC is exact; a second server, its clock 3 h wrong and not synchronised,
    then reads the mount's clock back (``:GG``, ``:GL``, ``:GC``) as the true UTC."""
    mount = _mount("--start-time", when.isoformat())
    processes.append(mount)
    server = server_in_zone(tmp_path / "setting", mount, site, host_zone, synchronised=True)
    processes.append(server)
    client = AlpacaClient(server.port, 31, timeout=TIMEOUT)
    client.command("connected", Connected="true")
    assert mount.state()["utc_offset_h"] == hours and mount.state()["dst"] is False
    assert mount_local_minus_true_h(mount) == hours
    assert abs(mount_clock_error_s(mount)) < 1.5, "the mount's UTC is not the true one"
    assert f"the mount's clock is set in the site's zone, {zone}" in server.log()
    client.command("connected", Connected="false")
    server.stop()

    reader = server_in_zone(tmp_path / "reading", mount, site, host_zone, synchronised=False, behind_s=10800.0)
    processes.append(reader)
    client = AlpacaClient(reader.port, 31, timeout=TIMEOUT)
    client.command("connected", Connected="true")
    assert status(reader)["time"]["source"] == "mount"
    truth_now = _utc(mount.state()["true_utc"])
    utcdate = _utc(client.value("utcdate"))
    assert abs((utcdate - truth_now).total_seconds()) < 1.5, (utcdate, truth_now)
    assert mount.state()["utc_offset_h"] == hours, "reading the clock changed the mount's zone"


def test_a_site_a_client_sets_brings_its_zone_at_the_next_setting(tmp_path: Path, processes: list[Any]) -> None:
    """Sydney in December (UTC+11), then a client writes Berlin's site and sets UTCDate: the mount's clock
    is set again, in Berlin's zone (UTC+1), still exact."""
    mount = _mount("--start-time", DECEMBER.isoformat())
    processes.append(mount)
    server = server_in_zone(tmp_path / "server", mount, SYDNEY, "UTC", synchronised=True)
    processes.append(server)
    client = AlpacaClient(server.port, 31, timeout=TIMEOUT)
    client.command("connected", Connected="true")
    assert mount.state()["utc_offset_h"] == 11.0
    client.command("sitelatitude", SiteLatitude=BERLIN[0])
    client.command("sitelongitude", SiteLongitude=BERLIN[1])
    truth_now = _utc(mount.state()["true_utc"])
    client.command("utcdate", UTCDate=truth_now.isoformat().replace("+00:00", "Z"))
    assert mount.state()["utc_offset_h"] == 1.0 and mount_local_minus_true_h(mount) == 1.0
    assert abs(mount_clock_error_s(mount)) < 1.5
