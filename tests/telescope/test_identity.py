"""Identity, modes, DeviceState and the management API."""

from __future__ import annotations

import math
import re

import erfa
import pytest
import requests
from alpaca import management as alpyca_management

from alpaca_zwo import __version__
from alpaca_zwo.emulator import MountModel
from alpaca_zwo.server import AlpacaZwoServer
from alpaca_zwo.telescope.actions import supported_actions
from alpaca_zwo.zwo.wire_values import MountMode
from tests.telescope.harness import ARCSEC, Api, mean_lst, parse_utc, slew_to_ha, wrap12


def test_driver_identity(fresh: Api) -> None:
    assert fresh.value("InterfaceVersion") == 4
    assert fresh.value("Name") == "ZWO AM5"
    assert fresh.value("DriverVersion") == __version__
    assert fresh.value("DriverInfo") and fresh.value("Description")
    assert fresh.value("SupportedActions") == supported_actions()


def test_equatorial_system_and_alignment_mode(api: Api) -> None:
    assert api.value("EquatorialSystem") == 1  # topocentric (JNow), R15
    assert api.value("AlignmentMode") == 2  # German polar: the mount is in EQ mode


def test_alignment_mode_follows_the_mount_mode(url: str, model: MountModel) -> None:
    model.flash.request_mode(MountMode.ALTAZ)
    model.power_cycle()  # the mode takes effect at power-up, before the server connects
    api = Api(url).connect()
    assert api.value("AlignmentMode") == 0


def test_device_state_is_coherent(api: Api, server: AlpacaZwoServer) -> None:
    slew_to_ha(api, -2.0, 30.0)
    state = api.state()
    names = ["Altitude", "AtHome", "AtPark", "Azimuth", "Declination", "IsPulseGuiding", "RightAscension",
             "SideOfPier", "SiderealTime", "Slewing", "Tracking", "UTCDate"]
    assert set(state) in ({*names}, {*names, "TimeStamp"})
    for name in ("AtHome", "AtPark", "IsPulseGuiding", "Slewing", "Tracking"):
        assert isinstance(state[name], bool) and state[name] == api.value(name), name  # at rest: no change
    assert isinstance(state["SideOfPier"], int) and state["SideOfPier"] == api.value("SideOfPier")
    for name in ("Altitude", "Azimuth", "Declination", "RightAscension", "SiderealTime"):
        assert isinstance(state[name], float)
    assert state["Declination"] == pytest.approx(api.value("Declination"), abs=ARCSEC)
    utc = parse_utc(state["UTCDate"])
    if "TimeStamp" in state:
        assert parse_utc(state["TimeStamp"]) <= utc
    assert abs(wrap12(state["SiderealTime"] - mean_lst(utc, -0.0005))) < 2.5 / 3600.0
    # Alt/Az derived from RA/Dec, LST and latitude (pyerfa, independent of the server's sky.py).
    ha = math.radians(wrap12(state["SiderealTime"] - state["RightAscension"]) * 15.0)
    azimuth, altitude = erfa.hd2ae(ha, math.radians(state["Declination"]), math.radians(51.4769))
    assert state["Altitude"] == pytest.approx(math.degrees(altitude), abs=0.01)
    assert state["Azimuth"] == pytest.approx(math.degrees(azimuth), abs=0.01)


def test_management_api(server: AlpacaZwoServer, url: str) -> None:
    for path, expected in [("/management/apiversions", [1])]:
        body = requests.get(url + path, params={"ClientTransactionID": "12"}, timeout=10).json()
        assert body["Value"] == expected and body["ClientTransactionID"] == 12
    description = requests.get(url + "/management/v1/description", timeout=10).json()["Value"]
    assert set(description) >= {"ServerName", "Manufacturer", "ManufacturerVersion", "Location"}
    assert description["ManufacturerVersion"] == __version__
    devices = requests.get(url + "/management/v1/configureddevices", timeout=10).json()["Value"]
    assert devices == [{"DeviceName": "ZWO AM5", "DeviceType": "Telescope", "DeviceNumber": 0,
                        "UniqueID": server.settings.devices[0].unique_id}]
    assert re.fullmatch(r"[0-9a-f]{8}-[0-9a-f]{4}-4[0-9a-f]{3}-[89ab][0-9a-f]{3}-[0-9a-f]{12}", devices[0]["UniqueID"])
    address = f"127.0.0.1:{server.port}"
    assert alpyca_management.apiversions(address) == [1]
    assert alpyca_management.description(address)["ManufacturerVersion"] == __version__
    assert alpyca_management.configureddevices(address) == devices
    for bad in ("/management/v1/nosuch", "/management/v2/description"):
        assert requests.get(url + bad, timeout=10).status_code in (400, 403, 404)
