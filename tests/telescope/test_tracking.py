"""Tracking: on and off really tracks; the drive rates and the rate offsets that exist only on sidereal."""

from __future__ import annotations

import pytest

from alpaca_zwo.emulator import MountModel
from alpaca_zwo.server import AlpacaZwoServer
from alpaca_zwo.sky import SIDEREAL_HOURS_PER_S
from tests.support import wait_until
from tests.telescope.harness import INVALID_OPERATION, OK, Api, mount_seconds, slew_to_ha, wrap12


def test_tracking_on_off_really_tracks(server: AlpacaZwoServer, api: Api, model: MountModel) -> None:
    """R22: Tracking=false stops the drive (RA drifts at the sidereal rate); true holds RA still."""
    slew_to_ha(api, -2.0, 30.0)
    api.ok("Tracking", Tracking=False)
    assert api.value("Tracking") is False and not model.status().tracking
    ra0, t0 = api.value("RightAscension"), mount_seconds(server)
    wait_until(lambda: mount_seconds(server) > t0 + 40.0, 30.0, "40 s of mount time")
    drift_h = wrap12(api.value("RightAscension") - ra0)
    elapsed = mount_seconds(server) - t0
    assert drift_h == pytest.approx(elapsed * SIDEREAL_HOURS_PER_S, abs=15.0 / 3600.0)  # one poll period
    api.ok("Tracking", Tracking=True)
    assert api.value("Tracking") is True and model.status().tracking
    ra1, t1 = api.value("RightAscension"), mount_seconds(server)
    wait_until(lambda: mount_seconds(server) > t1 + 40.0, 30.0, "40 s of mount time")
    assert abs(wrap12(api.value("RightAscension") - ra1)) < 1.5 / 3600.0


@pytest.mark.parametrize("code,mount_rate", [(1, "lunar"), (2, "solar"), (0, "sidereal")])
def test_tracking_rates(api: Api, model: MountModel, code: int, mount_rate: str) -> None:
    assert api.value("TrackingRates") == [0, 1, 2]
    assert api.value("TrackingRate") == 0  # a known rate at start-up
    api.ok("TrackingRate", TrackingRate=code)
    assert api.value("TrackingRate") == code
    assert model.tracking_rate() == mount_rate
    # Rate offsets read 0.0 off sidereal and cannot be set there (Platform 7); on sidereal they can.
    assert api.value("RightAscensionRate") == 0.0 and api.value("DeclinationRate") == 0.0
    expected = OK if mount_rate == "sidereal" else INVALID_OPERATION
    assert api.put("RightAscensionRate", RightAscensionRate=0.05 / 15).error == expected
    assert api.put("DeclinationRate", DeclinationRate=0.5).error == expected
