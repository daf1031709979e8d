"""Slews: async and sync, to coordinates, targets and Alt/Az; Slewing never has a false gap."""

from __future__ import annotations

import pytest

from alpaca_zwo.emulator import MountModel
from alpaca_zwo.server import AlpacaZwoServer
from tests.support import wait_until
from tests.telescope.harness import INVALID_VALUE, MOTION_TIMEOUT_S, Api, assert_at, mount_seconds, watch_slewing


def test_slew_to_coordinates_async_keeps_slewing_true_until_arrival(server: AlpacaZwoServer, api: Api,
                                                                      model: MountModel) -> None:
    api.ok("Tracking", Tracking=True)
    ra, dec = api.ra_at_ha(3.0), 20.0
    reads = watch_slewing(api, server, model,
                          lambda: api.ok("SlewToCoordinatesAsync", RightAscension=ra, Declination=dec))
    assert len(reads) > 5  # it was polled throughout, not just once
    assert_at(api, ra, dec)
    assert api.value("TargetRightAscension") == ra and api.value("TargetDeclination") == dec
    assert api.value("Tracking") is True  # the GOTO ends tracking
    assert api.value("AtHome") is False and api.value("AtPark") is False


def test_slew_to_target_async(server: AlpacaZwoServer, api: Api, model: MountModel) -> None:
    ra, dec = api.ra_at_ha(-2.0), 45.0
    api.ok("TargetRightAscension", TargetRightAscension=ra)
    api.ok("TargetDeclination", TargetDeclination=dec)
    watch_slewing(api, server, model, lambda: api.ok("SlewToTargetAsync"))
    assert_at(api, ra, dec)


def test_slew_to_alt_az_async_lands_on_the_requested_alt_az(server: AlpacaZwoServer, api: Api,
                                                             model: MountModel) -> None:
    api.ok("TargetRightAscension", TargetRightAscension=1.25)
    api.ok("TargetDeclination", TargetDeclination=-5.5)
    api.ok("Tracking", Tracking=False)  # ConformU and NINA turn tracking off before Alt/Az slews
    watch_slewing(api, server, model, lambda: api.ok("SlewToAltAzAsync", Azimuth=155.0, Altitude=55.0))
    assert api.value("Altitude") == pytest.approx(55.0, abs=0.25)
    assert api.value("Azimuth") == pytest.approx(155.0, abs=0.25)
    assert api.value("Tracking") is False  # an Alt/Az position is held by not tracking
    # ASCOM: "The TargetRightAscension and TargetDeclination properties are not changed by this method."
    assert api.value("TargetRightAscension") == 1.25 and api.value("TargetDeclination") == -5.5


def test_synchronous_slews_return_on_arrival(server: AlpacaZwoServer, api: Api, model: MountModel) -> None:
    ra, dec = api.ra_at_ha(-1.5), 50.0
    api.ok("SlewToCoordinates", RightAscension=ra, Declination=dec)
    assert api.value("Slewing") is False and not model.slewing()
    assert_at(api, ra, dec)
    ra, dec = api.ra_at_ha(2.0), 10.0
    api.ok("TargetRightAscension", TargetRightAscension=ra)
    api.ok("TargetDeclination", TargetDeclination=dec)
    api.ok("SlewToTarget")
    assert api.value("Slewing") is False and not model.slewing()
    assert_at(api, ra, dec)
    api.ok("Tracking", Tracking=False)
    api.ok("SlewToAltAz", Azimuth=150.0, Altitude=50.0)
    assert api.value("Slewing") is False and not model.slewing()
    assert api.value("Altitude") == pytest.approx(50.0, abs=0.25)
    assert api.value("Azimuth") == pytest.approx(150.0, abs=0.25)


def test_slew_settle_time_extends_slewing(server: AlpacaZwoServer, api: Api, model: MountModel) -> None:
    """Slewing stays true for SlewSettleTime (mount) seconds after the mount has arrived."""
    api.ok("SlewSettleTime", SlewSettleTime=5)
    assert api.value("SlewSettleTime") == 5
    api.ok("SlewToCoordinatesAsync", RightAscension=api.ra_at_ha(-1.0), Declination=30.0)
    wait_until(lambda: not model.slewing(), MOTION_TIMEOUT_S, "the mount to arrive")
    arrived = mount_seconds(server)
    api.wait_idle()
    assert mount_seconds(server) - arrived >= 4.0


def test_abort_slew_stops_a_goto(api: Api, model: MountModel) -> None:
    api.ok("AbortSlew")  # harmless when nothing moves (ConformU calls it idle first)
    api.ok("SlewToCoordinatesAsync", RightAscension=api.ra_at_ha(4.0), Declination=-10.0)
    assert api.value("Slewing") is True and model.slewing()
    api.ok("AbortSlew")
    wait_until(lambda: api.value("Slewing") is False, 30.0, "Slewing false after AbortSlew")
    assert not model.slewing()


def test_a_new_slew_replaces_the_running_one(server: AlpacaZwoServer, api: Api, model: MountModel) -> None:
    api.ok("SlewToCoordinatesAsync", RightAscension=api.ra_at_ha(4.0), Declination=-10.0)
    ra, dec = api.ra_at_ha(-2.0), 40.0
    api.ok("SlewToCoordinatesAsync", RightAscension=ra, Declination=dec)
    assert api.value("Slewing") is True
    api.wait_idle()
    assert_at(api, ra, dec)


def test_slew_below_the_horizon_is_refused(api: Api, model: MountModel) -> None:
    reply = api.put("SlewToCoordinatesAsync", RightAscension=api.ra_at_ha(12.0), Declination=-60.0)
    assert reply.error == INVALID_VALUE
    assert api.value("Slewing") is False and not model.slewing()
