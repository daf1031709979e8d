"""Time and site: UTCDate on the wire and on the mount, the sidereal time, the site, and what persists;
and the ``SiteClock`` part alone on the real emulator.
"""

from __future__ import annotations

import dataclasses
from datetime import datetime, timedelta, timezone
from pathlib import Path

import pytest
import requests
from alpaca import telescope as alpyca_telescope

from alpaca_zwo import sky
from alpaca_zwo._exceptions import InvalidValue, NotConnected
from alpaca_zwo.clients import ClientKey, current_client
from alpaca_zwo.config.file import load_settings, save_settings
from alpaca_zwo.config.settings import Settings
from alpaca_zwo.emulator import MountModel
from alpaca_zwo.mount.timekeeping import TimeSource
from alpaca_zwo.server import AlpacaZwoServer
from alpaca_zwo.telescope.clock import SiteClock
from alpaca_zwo.telescope.connection import Connection
from tests.conftest import ServerFactory
from tests.telescope.harness import (
    ARCSEC,
    INVALID_VALUE,
    OK,
    Api,
    fast_settings,
    mean_lst,
    mount_seconds,
    parse_utc,
    slew_to_ha,
    wrap12,
)
from tests.telescope.parts import Rig, parts_rig


def test_utc_date_is_iso8601_with_z_and_agrees_with_the_mount_clock(server: AlpacaZwoServer, api: Api) -> None:
    emulator = server.emulators[0]
    assert emulator is not None
    reply = api.get("UTCDate")
    value = parse_utc(reply.value)
    assert abs((value - emulator.clock.now()).total_seconds()) < 2.0  # mount seconds: a round trip or two


@pytest.mark.parametrize("text", ["2031-03-04T17:45:31Z", "2031-03-04T17:45:31.123Z",
                                  "2031-03-04T17:45:31.1234567Z", "2031-03-04T17:45:31.5+00:00",
                                  "2031-03-04T17:45:31.123456789Z"])
def test_utc_date_write_reads_back(server: AlpacaZwoServer, api: Api, model: MountModel, text: str) -> None:
    written = datetime.fromisoformat(text)  # Python 3.11 takes Z and truncates a seventh digit
    started = mount_seconds(server)
    api.ok("UTCDate", UTCDate=text)
    read = parse_utc(api.value("UTCDate"))
    elapsed = mount_seconds(server) - started
    assert timedelta(seconds=-0.01) <= read - written <= timedelta(seconds=elapsed + 0.01)
    # The mount itself now runs on that time: its sidereal time matches the server's.
    assert abs(wrap12(model.clock_site.sidereal_time() - api.value("SiderealTime"))) < 2.0 / 3600.0


@pytest.mark.parametrize("text", ["9999-12-31T23:59:59.9999999Z", "0001-01-01T00:00:00Z", "1990-06-01T00:00:00Z",
                                  "2150-06-01T00:00:00Z", "0538-06-03T01:40:42.0852784Z"])
def test_utc_date_the_mount_cannot_hold(api: Api, model: MountModel, text: str) -> None:
    """The mount's clock has a two-digit year. A date outside it is refused (0x401), or, if accepted,
    the mount and the server must still agree on the sky; either way the server keeps answering."""
    reply = api.put("UTCDate", UTCDate=text)  # Api fails on any HTTP status but 200
    assert reply.error in (OK, INVALID_VALUE), reply.body
    for name in ("UTCDate", "SiderealTime", "DeviceState", "Altitude"):
        assert api.get(name).error == OK, name
    ra = api.ra_at_ha(-2.0)
    assert api.value("DestinationSideOfPier", RightAscension=ra, Declination=40.0) == 1
    if reply.error == OK:
        assert abs(wrap12(model.clock_site.sidereal_time() - api.value("SiderealTime"))) < 2.0 / 3600.0, (
            "the mount and the server now disagree about the sidereal time")
    else:
        assert abs((parse_utc(api.value("UTCDate")) - datetime.now(timezone.utc)).total_seconds()) < 3600


def test_utc_date_written_with_alpyca(server: AlpacaZwoServer, api: Api) -> None:
    scope = alpyca_telescope.Telescope(f"127.0.0.1:{server.port}", 0)
    when = datetime(2029, 11, 5, 3, 4, 5, 250000, tzinfo=timezone.utc)
    scope.UTCDate = when
    read = scope.UTCDate
    assert timedelta(0) <= read - when < timedelta(seconds=5)


def test_sidereal_time_agrees_with_site_and_clock(api: Api) -> None:
    for longitude in (-0.0005, 15.0, -120.5):
        api.ok("SiteLongitude", SiteLongitude=longitude)
        state = api.state()
        expected = mean_lst(parse_utc(state["UTCDate"]), longitude)
        assert abs(wrap12(state["SiderealTime"] - expected)) < 2.5 / 3600.0, longitude  # mean vs apparent
        assert api.value("SiteLongitude") == longitude


def test_site_reads_back_exactly_and_reaches_the_mount(api: Api, model: MountModel) -> None:
    """R26: exact values as written (NINA compares with ==); the mount gets them to the arcsecond."""
    values = {"SiteLatitude": 47.123456789012, "SiteLongitude": -122.98765432101, "SiteElevation": 1234.5678}
    for name, value in values.items():
        api.ok(name, **{name: value})
    for name, value in values.items():
        assert api.value(name) == value, name
    assert model.clock_site.latitude() == pytest.approx(values["SiteLatitude"], abs=1.0 * ARCSEC)
    assert model.clock_site.longitude() == pytest.approx(values["SiteLongitude"], abs=1.0 * ARCSEC)
    for name, value in [("SiteLatitude", 90.0), ("SiteLatitude", -90.0), ("SiteLongitude", 180.0),
                        ("SiteLongitude", -180.0), ("SiteElevation", -300.0), ("SiteElevation", 10000.0)]:
        api.ok(name, **{name: value})  # the range ends are valid
        assert api.value(name) == value


def write_config(path: Path, settings: Settings) -> Settings:
    """Write a config file as a user would (no UniqueIDs yet), then load it the way the CLI does."""
    devices = tuple(dataclasses.replace(d, unique_id="") for d in settings.devices)
    save_settings(dataclasses.replace(settings, devices=devices), path)
    return load_settings(path)


def test_site_park_and_unique_id_persist_across_restarts(server_factory: ServerFactory, tmp_path: Path) -> None:
    path = tmp_path / "persist.toml"
    first = server_factory(write_config(path, fast_settings()), config_name=path.name)
    base = f"http://127.0.0.1:{first.port}"
    unique_id = requests.get(f"{base}/management/v1/configureddevices", timeout=10).json()["Value"][0]["UniqueID"]
    api = Api(base).connect()
    api.ok("SiteLatitude", SiteLatitude=48.8566123)
    api.ok("SiteLongitude", SiteLongitude=2.3522219)
    api.ok("SiteElevation", SiteElevation=35.25)
    slew_to_ha(api, -2.0, 40.0)
    api.ok("SetPark")
    first.stop()

    second = server_factory(load_settings(path), config_name=path.name)
    base = f"http://127.0.0.1:{second.port}"
    again = requests.get(f"{base}/management/v1/configureddevices", timeout=10).json()["Value"][0]["UniqueID"]
    assert again == unique_id
    api = Api(base)
    assert api.value("SiteLatitude") == 48.8566123
    assert api.value("SiteLongitude") == 2.3522219
    assert api.value("SiteElevation") == 35.25
    api.connect()
    api.ok("Park")
    api.wait_idle()
    assert api.hour_angle() == pytest.approx(-2.0, abs=0.02)
    assert api.value("Declination") == pytest.approx(40.0, abs=0.01)


# ================================================================================================
# The part alone: SiteClock on a real Mount and emulator, its connection check a real Connection's
# ================================================================================================

CLIENT = ClientKey("192.0.2.30", 5)


def clock_and_connection(rig: Rig) -> tuple[SiteClock, Connection]:
    connection = rig.connection()
    return SiteClock(mount=rig.mount, settings=lambda: rig.settings,
                     require_connected=connection.require_connected), connection


def test_the_sidereal_time_is_the_reference_time_at_the_configured_longitude(tmp_path: Path) -> None:
    with parts_rig(tmp_path) as rig:
        clock, connection = clock_and_connection(rig)
        with pytest.raises(NotConnected):
            clock.sidereal_time()
        with pytest.raises(NotConnected):
            clock.utc_date()
        connection.attach(CLIENT)
        when = clock.utc_now()
        assert clock.lst(when) == sky.local_sidereal_time(when, -0.0005)
        rig.store.update(lambda s: dataclasses.replace(s, site=dataclasses.replace(s.site, longitude=120.0)))
        assert clock.lst(when) == sky.local_sidereal_time(when, 120.0)  # read per call: the store replaces it
        assert abs(wrap12(clock.sidereal_time() - clock.lst(clock.utc_now()))) < 1.0 / 3600.0
        assert abs((clock.utc_date() - rig.model.clock.now()).total_seconds()) < 2.0  # the emulator's clock


def test_a_clients_utc_date_becomes_the_reference_and_the_mounts_clock(tmp_path: Path) -> None:
    with parts_rig(tmp_path) as rig:
        clock, connection = clock_and_connection(rig)
        connection.attach(CLIENT)
        written = datetime(2031, 3, 4, 17, 45, 31, tzinfo=timezone.utc)
        token = current_client.set(CLIENT)
        try:
            clock.set_utc_date(written)
        finally:
            current_client.reset(token)
        view = rig.mount.time.view()
        assert view.source is TimeSource.CLIENT and "client 192.0.2.30 #5 (UTCDate)" in view.reason
        assert timedelta(0) <= clock.utc_date() - written < timedelta(seconds=30)  # mount seconds since
        mount_utc = datetime.fromisoformat(rig.model.snapshot()["mount_utc"])
        assert abs((mount_utc - clock.utc_now()).total_seconds()) < 2.0  # the mount's clock was set


@pytest.mark.parametrize("value", [datetime(1999, 12, 31, tzinfo=timezone.utc),
                                   datetime(2100, 1, 1, tzinfo=timezone.utc), datetime(1, 1, 1)])
def test_a_date_the_mounts_clock_cannot_hold_is_refused_and_changes_nothing(tmp_path: Path, value: datetime) -> None:
    with parts_rig(tmp_path) as rig:
        clock, connection = clock_and_connection(rig)
        connection.attach(CLIENT)
        before = rig.mount.time.view().source
        with pytest.raises(InvalidValue, match="2000-2099"):
            clock.set_time(value, "a test")
        assert rig.mount.time.view().source is before
        assert abs((clock.utc_now() - rig.model.clock.now()).total_seconds()) < 2.0


def test_a_time_set_with_no_link_is_kept_for_the_connect(tmp_path: Path) -> None:
    """The page may set the time before any client connects: the reference takes it, the mount later."""
    with parts_rig(tmp_path) as rig:
        clock, connection = clock_and_connection(rig)
        written = datetime(2030, 6, 1, 22, 0, 0, tzinfo=timezone.utc)
        assert clock.set_time(written, "a browser") is False  # not pushed: no link
        assert rig.mount.time.view().source is TimeSource.CLIENT
        connection.attach(CLIENT)  # the connect pushes the client's time
        mount_utc = datetime.fromisoformat(rig.model.snapshot()["mount_utc"])
        assert abs((mount_utc - clock.utc_now()).total_seconds()) < 2.0
        assert timedelta(0) <= clock.utc_now() - written < timedelta(seconds=60)
