"""Interoperability with the ASCOM Initiative's official Python client, alpyca."""

from __future__ import annotations

from datetime import datetime, timezone

import pytest

from tests.alpaca.conftest import SERVER_INFO, Alpaca

alpaca_telescope = pytest.importorskip("alpaca.telescope")
alpaca_management = pytest.importorskip("alpaca.management")
alpaca_exceptions = pytest.importorskip("alpaca.exceptions")


@pytest.fixture
def scope(alpaca: Alpaca):
    return alpaca_telescope.Telescope(f"127.0.0.1:{alpaca.server.port}", 0)


def test_properties(scope, alpaca: Alpaca) -> None:
    assert scope.Connected is False
    scope.Connected = True
    assert scope.Connected is True
    assert scope.InterfaceVersion == 4
    assert scope.Name == "Stand-in telescope"
    assert scope.CanSlewAsync is True
    assert scope.RightAscension == 5.5
    assert scope.AlignmentMode == alpaca_telescope.AlignmentModes.algGermanPolar
    assert scope.SupportedActions == ["echo"]
    assert scope.TrackingRates == [0, 1, 2]
    rates = scope.AxisRates(alpaca_telescope.TelescopeAxes.axisPrimary)
    assert [(r.Minimum, r.Maximum) for r in rates] == [(0.0, 4.0)]
    assert scope.UTCDate == datetime(2024, 1, 31, 21, 5, 0, 123456, tzinfo=timezone.utc)
    state = scope.DeviceState
    assert {item["Name"] for item in state} >= {"Tracking", "UTCDate"}


def test_put_methods_reach_the_device(scope, alpaca: Alpaca) -> None:
    scope.Tracking = True
    assert scope.Tracking is True
    scope.SlewToCoordinatesAsync(10.25, -20.5)
    assert alpaca.device.called("slew_to_coordinates_async")[-1].kwargs == {"right_ascension": 10.25,
                                                                            "declination": -20.5}
    assert scope.TargetRightAscension == 10.25
    scope.MoveAxis(alpaca_telescope.TelescopeAxes.axisSecondary, 1.5)
    assert alpaca.device.called("move_axis")[-1].kwargs == {"axis": 1, "rate": 1.5}
    assert scope.Action("echo", "hello") == "hello"
    assert scope.Action("echo") == ""  # alpyca omits an empty Parameters field


def test_utc_date_written_as_datetime(scope, alpaca: Alpaca) -> None:
    # alpyca sends datetime.isoformat() ("+00:00", not "Z"); the server accepts explicit offsets.
    scope.UTCDate = datetime(2025, 6, 1, 22, 30, 15, 250000, tzinfo=timezone.utc)
    assert alpaca.device.called("set_utc_date")[-1].args == (datetime(2025, 6, 1, 22, 30, 15, 250000,
                                                                      tzinfo=timezone.utc),)
    scope.UTCDate = "2016-03-04T17:45:31.1234567Z"
    assert scope.UTCDate == datetime(2016, 3, 4, 17, 45, 31, 123456, tzinfo=timezone.utc)


def test_ascom_errors_map_to_alpyca_exceptions(scope) -> None:
    with pytest.raises(alpaca_exceptions.ValueNotSetException):
        _ = scope.TargetDeclination
    with pytest.raises(alpaca_exceptions.InvalidValueException):
        scope.SiteLatitude = 95.0
    scope.Park()
    with pytest.raises(alpaca_exceptions.ParkedException):
        scope.Tracking = True
    with pytest.raises(alpaca_exceptions.NotImplementedException):
        scope.CommandBlind(":Q#", True)
    with pytest.raises(alpaca_exceptions.ActionNotImplementedException):
        scope.Action("nope")


def test_management_functions(alpaca: Alpaca) -> None:
    address = f"127.0.0.1:{alpaca.server.port}"
    assert alpaca_management.apiversions(address) == [1]
    description = alpaca_management.description(address)
    assert description["ServerName"] == SERVER_INFO.server_name
    assert description["ManufacturerVersion"] == SERVER_INFO.manufacturer_version
    devices = alpaca_management.configureddevices(address)
    assert devices == [{"DeviceName": "Stand-in telescope", "DeviceType": "Telescope", "DeviceNumber": 0,
                        "UniqueID": alpaca.device.unique_id}]
