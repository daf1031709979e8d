"""Syncs: to coordinates, the target and Alt/Az; what a sync needs, and the motions it conflicts with."""

from __future__ import annotations

import pytest

from tests.conftest import ServerFactory, make_settings
from tests.support import wait_until
from tests.telescope.harness import INVALID_OPERATION, OK, Api, assert_at, slew_to_ha


def test_sync_to_coordinates_reads_back_within_one_arcsecond(api: Api) -> None:
    """R23: after a sync, the next read equals the sync coordinates within 1"; targets follow."""
    slew_to_ha(api, -2.0, 30.0)
    state = api.state()
    ra, dec = (state["RightAscension"] + 0.0123456) % 24.0, state["Declination"] - 0.0234567
    api.ok("SyncToCoordinates", RightAscension=ra, Declination=dec)
    assert_at(api, ra, dec, tolerance_arcsec=1.0)
    assert api.value("TargetRightAscension") == ra and api.value("TargetDeclination") == dec
    assert api.value("Slewing") is False


def test_sync_to_target(api: Api) -> None:
    slew_to_ha(api, 2.0, 35.0)
    state = api.state()
    ra, dec = (state["RightAscension"] - 0.01) % 24.0, state["Declination"] + 0.05
    api.ok("TargetRightAscension", TargetRightAscension=ra)
    api.ok("TargetDeclination", TargetDeclination=dec)
    api.ok("SyncToTarget")
    assert_at(api, ra, dec, tolerance_arcsec=1.0)


def test_sync_to_alt_az(api: Api) -> None:
    api.ok("Tracking", Tracking=False)
    api.ok("SlewToAltAz", Azimuth=140.0, Altitude=40.0)
    altitude, azimuth = api.value("Altitude"), api.value("Azimuth")
    api.ok("SyncToAltAz", Azimuth=azimuth + 0.5, Altitude=altitude - 0.5)
    assert api.value("Altitude") == pytest.approx(altitude - 0.5, abs=0.01)
    assert api.value("Azimuth") == pytest.approx(azimuth + 0.5, abs=0.01)


def test_sync_while_not_tracking_is_an_invalid_operation(api: Api) -> None:
    """R23 / ITelescopeV3: SyncToCoordinates and SyncToTarget need tracking on (0x40B otherwise)."""
    slew_to_ha(api, -2.0, 30.0)
    api.ok("Tracking", Tracking=False)
    state = api.state()
    reply = api.put("SyncToCoordinates", RightAscension=state["RightAscension"],
                    Declination=state["Declination"] + 0.01)
    assert reply.error == INVALID_OPERATION, reply.body


def test_a_sync_the_mount_refuses_is_an_error_not_a_silent_success(api: Api) -> None:
    slew_to_ha(api, -2.0, 30.0)
    state = api.state()
    reply = api.put("SyncToCoordinates", RightAscension=state["RightAscension"],
                    Declination=state["Declination"] - 25.0)  # far beyond any sync the mount accepts
    assert reply.error != OK
    assert_at(api, state["RightAscension"], state["Declination"], tolerance_arcsec=30.0)


def test_motion_conflicts_answer_0x40b(server_factory: ServerFactory) -> None:
    """During a GOTO: syncs, pulses and MoveAxis are invalid operations (real-time emulator: a long slew)."""
    server = server_factory(make_settings())
    api = Api(f"http://127.0.0.1:{server.port}").connect()
    api.ok("SlewToCoordinatesAsync", RightAscension=api.ra_at_ha(4.0), Declination=-10.0)
    try:
        for name, args in [("SyncToCoordinates", {"RightAscension": 1.0, "Declination": 10.0}),
                           ("PulseGuide", {"Direction": 0, "Duration": 500}),
                           ("MoveAxis", {"Axis": 0, "Rate": 1.0})]:
            assert api.value("Slewing") is True, "the slew ended too early for this test"
            reply = api.put(name, **args)
            assert reply.error == INVALID_OPERATION, f"{name} during a GOTO: {reply.body}"
        assert api.value("IsPulseGuiding") is False
    finally:
        api.ok("AbortSlew")
        wait_until(lambda: api.value("Slewing") is False, 30.0, "AbortSlew")
