"""Whole sessions: several mounts in one server, and a night's calls through alpyca."""

from __future__ import annotations

import pytest
import requests
from alpaca import exceptions as alpyca_exceptions
from alpaca import telescope as alpyca_telescope

from alpaca_zwo.config.settings import DeviceSettings
from alpaca_zwo.emulator import MountModel
from alpaca_zwo.server import AlpacaZwoServer
from tests.conftest import ServerFactory
from tests.support import wait_until
from tests.telescope.harness import MOTION_TIMEOUT_S, NOT_CONNECTED, VALUE_NOT_SET, Api, assert_400, fast_settings


def test_two_devices_are_independent(server_factory: ServerFactory) -> None:
    settings = fast_settings(devices=(DeviceSettings(name="North pier"), DeviceSettings(name="South pier")))
    server = server_factory(settings)
    url = f"http://127.0.0.1:{server.port}"
    assert len(server.emulators) == 2 and all(e is not None for e in server.emulators)
    devices = requests.get(url + "/management/v1/configureddevices", timeout=10).json()["Value"]
    assert [(d["DeviceName"], d["DeviceNumber"]) for d in devices] == [("North pier", 0), ("South pier", 1)]
    assert devices[0]["UniqueID"] != devices[1]["UniqueID"]

    north, south = Api(url, device=0).connect(), Api(url, device=1)
    assert north.value("Name") == "North pier" and south.value("Name") == "South pier"
    assert south.get("RightAscension").error == NOT_CONNECTED  # connecting 0 did not connect 1
    south.connect()
    north.ok("TargetRightAscension", TargetRightAscension=2.5)
    assert south.get("TargetRightAscension").error == VALUE_NOT_SET

    south_before = south.state()
    north.ok("SlewToCoordinatesAsync", RightAscension=north.ra_at_ha(-2.0), Declination=30.0)
    assert north.value("Slewing") is True and south.value("Slewing") is False
    emulators = [e for e in server.emulators if e is not None]
    assert emulators[0].model.slewing() and not emulators[1].model.slewing()
    north.wait_idle()
    assert south.value("AtHome") is True and south.state()["Declination"] == south_before["Declination"]

    south.ok("Park")
    south.wait_idle()
    assert south.value("AtPark") is True and north.value("AtPark") is False
    north.ok("Connected", Connected=False)
    assert south.value("Connected") is True
    scope = alpyca_telescope.Telescope(f"127.0.0.1:{server.port}", 1)
    with pytest.raises(alpyca_exceptions.ParkedException):
        scope.SlewToCoordinatesAsync(3.0, 20.0)
    assert_400(requests.get(url + "/api/v1/telescope/2/name", timeout=10), "telescope/2")


def test_alpyca_session(server: AlpacaZwoServer, model: MountModel) -> None:
    scope = alpyca_telescope.Telescope(f"127.0.0.1:{server.port}", 0)
    assert scope.Connected is False
    with pytest.raises(alpyca_exceptions.NotConnectedException):
        _ = scope.RightAscension
    scope.Connect()
    wait_until(lambda: scope.Connecting is False, 5.0, "alpyca Connect")
    assert scope.Connected is True
    assert scope.InterfaceVersion == 4
    assert scope.AlignmentMode == alpyca_telescope.AlignmentModes.algGermanPolar
    assert scope.EquatorialSystem == alpyca_telescope.EquatorialCoordinateType.equTopocentric
    rates = scope.AxisRates(alpyca_telescope.TelescopeAxes.axisPrimary)
    assert rates and rates[0].Minimum < rates[0].Maximum
    scope.Tracking = True
    ra, dec = (scope.SiderealTime + 3.0) % 24.0, 25.0
    side = scope.DestinationSideOfPier(ra, dec)
    scope.SlewToCoordinatesAsync(ra, dec)
    assert scope.Slewing is True
    wait_until(lambda: scope.Slewing is False, MOTION_TIMEOUT_S, "alpyca slew")
    assert scope.SideOfPier == side == alpyca_telescope.PierSide.pierWest
    assert scope.TargetRightAscension == ra
    scope.PulseGuide(alpyca_telescope.GuideDirections.guideNorth, 4000)
    assert scope.IsPulseGuiding is True and scope.Slewing is False
    wait_until(lambda: scope.IsPulseGuiding is False, MOTION_TIMEOUT_S, "alpyca pulse")
    scope.MoveAxis(alpyca_telescope.TelescopeAxes.axisSecondary, 1.0)
    assert scope.Slewing is True
    scope.MoveAxis(alpyca_telescope.TelescopeAxes.axisSecondary, 0.0)
    wait_until(lambda: scope.Slewing is False, 30.0, "alpyca MoveAxis stop")
    scope.TrackingRate = alpyca_telescope.DriveRates.driveLunar
    assert scope.TrackingRate == alpyca_telescope.DriveRates.driveLunar
    scope.TrackingRate = alpyca_telescope.DriveRates.driveSidereal
    with pytest.raises(alpyca_exceptions.InvalidValueException):
        scope.TargetDeclination = 100.0
    with pytest.raises(alpyca_exceptions.InvalidOperationException):
        scope.SideOfPier = alpyca_telescope.PierSide.pierEast  # 3 h east of the meridian: pierWest only
    assert scope.Slewing is False
    scope.Park()
    wait_until(lambda: scope.Slewing is False, MOTION_TIMEOUT_S, "alpyca park")
    assert scope.AtPark is True
    with pytest.raises(alpyca_exceptions.ParkedException):
        scope.Tracking = True
    scope.Tracking = False
    scope.Unpark()
    assert scope.AtPark is False
    state = {item["Name"]: item["Value"] for item in scope.DeviceState}
    assert state["AtPark"] is False
    scope.Disconnect()
    wait_until(lambda: scope.Connecting is False, 5.0, "alpyca Disconnect")
    assert scope.Connected is False
