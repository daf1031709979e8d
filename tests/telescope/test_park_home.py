"""Park, Unpark, SetPark, FindHome."""

from __future__ import annotations

import pytest

from alpaca_zwo.config.file import load_settings
from alpaca_zwo.emulator import MountModel
from alpaca_zwo.server import AlpacaZwoServer
from tests.telescope.harness import ARCSEC, Api, slew_to_ha, watch_slewing


def test_park_defaults_to_home_and_unpark(server: AlpacaZwoServer, api: Api, model: MountModel) -> None:
    slew_to_ha(api, 3.0, 20.0)
    watch_slewing(api, server, model, lambda: api.ok("Park"))
    assert api.value("AtPark") is True
    assert api.value("AtHome") is True  # the default park position is the home position
    assert api.value("Declination") == pytest.approx(90.0, abs=ARCSEC)
    assert api.value("Tracking") is False
    api.ok("Park")  # parking twice is harmless
    assert api.value("AtPark") is True and api.value("Slewing") is False
    api.ok("Unpark")
    assert api.value("AtPark") is False
    api.wait_idle()
    api.ok("Unpark")  # and so is unparking twice
    assert api.value("AtPark") is False
    api.ok("Tracking", Tracking=True)
    assert api.value("Tracking") is True


def test_set_park_moves_the_park_position(server: AlpacaZwoServer, api: Api, model: MountModel) -> None:
    slew_to_ha(api, -2.0, 40.0)
    api.ok("SetPark")
    slew_to_ha(api, 3.0, 10.0)
    watch_slewing(api, server, model, lambda: api.ok("Park"))
    assert api.value("AtPark") is True and api.value("AtHome") is False
    # The mount no longer tracks, so the hour angle is what stays put. A GOTO ends where its target RA has
    # got to by arrival, so the tolerance allows a minute of sky rotation (0.017 h) for the slew itself.
    assert api.hour_angle() == pytest.approx(-2.0, abs=0.02)
    assert api.value("Declination") == pytest.approx(40.0, abs=0.01)
    saved = load_settings(server.store.path)
    assert saved.park.mode == "custom" and saved.park.dec_deg == pytest.approx(40.0, abs=0.01)


def test_find_home(server: AlpacaZwoServer, api: Api, model: MountModel) -> None:
    slew_to_ha(api, 3.0, 20.0)
    assert api.value("AtHome") is False
    watch_slewing(api, server, model, lambda: api.ok("FindHome"))
    assert api.value("AtHome") is True
    assert api.value("AtPark") is False
    assert api.value("Declination") == pytest.approx(90.0, abs=ARCSEC)
    assert api.hour_angle() == pytest.approx(-6.0, abs=0.01)
    assert api.value("Tracking") is False  # homing stops tracking
    api.ok("Tracking", Tracking=True)
    slew_to_ha(api, -1.0, 30.0)
    assert api.value("AtHome") is False  # any slew leaves home
