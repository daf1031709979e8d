"""Both home readings through the Alpaca API (issue 39 item 3): the documents' ``N`` and hour angle −6 h
(the default preset), and what real 1.8.8 mounts read at home, ``E`` and +6 h with no ``H``
(``am5-1.8.8``, chosen with ``--emulator-preset``'s override). AtHome, SideOfPier, GOTOs to either side,
FindHome and Park must come out right under both, north and south; and a model name with a suffix
(AM5N, or one still to come) is accepted and shown."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from alpaca_zwo import sky
from alpaca_zwo.emulator import EmulatorServer, MountModel, ScaledClock
from alpaca_zwo.server import AlpacaZwoServer, Overrides
from alpaca_zwo.zwo.firmware import preset
from tests.conftest import ServerFactory
from tests.support.emulator import ENV, ROOT
from tests.support.server import ServerProcess
from tests.support.sites import NORTH, SYDNEY, Site
from tests.telescope.harness import ARCSEC, Api, fast_settings, slew_to_ha, watch_slewing

SITES = (NORTH, SYDNEY)


def _start(server_factory: ServerFactory, name: str, site: Site) -> tuple[AlpacaZwoServer, Api, MountModel]:
    server = server_factory(fast_settings(site=site.settings()), Overrides(emulator_preset=name))
    emulator = server.emulators[0]
    assert emulator is not None
    assert emulator.model.firmware.name == name  # the run's preset, not the config's
    return server, Api(f"http://127.0.0.1:{server.port}").connect(), emulator.model


def _side_matches_the_hour_angle(api: Api) -> None:
    """SideOfPier is the pointing state of the hour angle the server reports (ConformU's rule)."""
    assert api.value("SideOfPier") == int(sky.pointing_state(api.hour_angle()))


@pytest.mark.parametrize("site", SITES, ids=lambda s: s.name)
@pytest.mark.parametrize("name", ["am5-1.9.2", "am5-1.8.8"])
def test_home_side_flips_and_park_under_both_home_readings(
    server_factory: ServerFactory, name: str, site: Site,
) -> None:
    server, api, model = _start(server_factory, name, site)
    at_home_letter = model.pier_letter()
    assert at_home_letter == ("N" if name == "am5-1.9.2" else "E" if site is NORTH else "W")
    assert api.value("AtHome") is True  # powered up at home, whichever way the firmware names it
    assert api.value("Declination") == pytest.approx(site.dec(90.0), abs=ARCSEC)
    assert abs(api.hour_angle()) == pytest.approx(6.0, abs=0.01)
    _side_matches_the_hour_angle(api)

    api.ok("Tracking", Tracking=True)
    for ha in (-2.0, 2.0):  # a GOTO from home to the east, then a flip to the west
        ra = api.ra_at_ha(ha)
        expected = api.value("DestinationSideOfPier", RightAscension=ra, Declination=site.dec(40.0))
        slew_to_ha(api, ha, site.dec(40.0))
        assert api.value("SideOfPier") == expected == int(sky.pointing_state(ha))
        assert api.value("AtHome") is False

    watch_slewing(api, server, model, lambda: api.ok("FindHome"))
    assert api.value("AtHome") is True and api.value("AtPark") is False
    _side_matches_the_hour_angle(api)

    api.ok("Tracking", Tracking=True)
    slew_to_ha(api, -3.0, site.dec(30.0))
    watch_slewing(api, server, model, lambda: api.ok("Park"))
    assert api.value("AtPark") is True and api.value("AtHome") is True  # the default park is home
    assert model.axes() == pytest.approx((-90.0, 90.0), abs=1e-6)  # really there
    api.ok("Unpark")
    assert api.value("AtPark") is False


@pytest.fixture
def am5x() -> Iterator[str]:
    """A mount reporting a model name no preset has (``AM5X``), on its own TCP port."""
    emulator = EmulatorServer(MountModel(ScaledClock(), preset("am5-1.8.8", model="AM5X")),
                              host="127.0.0.1", port=0, baud=0).start()
    yield f"socket://127.0.0.1:{emulator.port}"
    emulator.stop()


def test_a_model_with_a_suffix_is_accepted_and_shown(server_factory: ServerFactory, am5x: str) -> None:
    server = server_factory(fast_settings(), Overrides(device_url=am5x))
    api = Api(f"http://127.0.0.1:{server.port}").connect()
    assert api.value("Description") == "ZWO AM5X (firmware 1.8.8) via alpaca-zwo"


def test_the_am5n_preset_is_shown_as_an_am5n(server_factory: ServerFactory) -> None:
    _server, api, _model = _start(server_factory, "am5n-1.8.8", NORTH)
    assert api.value("Description") == "ZWO AM5N (firmware 1.8.8) via alpaca-zwo"


def test_the_emulator_preset_flag(tmp_path: Path) -> None:
    """``alpaca-zwo --emulator-preset am5n-1.8.8``, run as a user runs it: the built-in mount is that build."""
    server = ServerProcess(tmp_path, "--emulator-preset", "am5n-1.8.8")
    try:
        api = Api(server.base_url).connect()
        assert api.value("Description") == "ZWO AM5N (firmware 1.8.8) via alpaca-zwo"
        assert api.value("AtHome") is True
    finally:
        server.stop()


def test_an_unknown_emulator_preset_is_refused_with_the_choices() -> None:
    done = subprocess.run([sys.executable, "-m", "alpaca_zwo", "--emulator-preset", "am5-9.9.9"],
                          capture_output=True, text=True, timeout=60, env=ENV, cwd=ROOT)
    assert done.returncode == 2
    assert "am5-9.9.9" in done.stderr and "am5n-1.8.8" in done.stderr
