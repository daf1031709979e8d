"""One verdict before GoTo (issue 33 item 2): ``Telescope.goto_limit``, the check every GoTo runs first.

Against the real Telescope on the emulator, north, at Sydney and on the equator: each limit blocks and is
named (the server's horizon profile and minimum altitude, the mount's horizon and the altitude limits
stored in the mount, set through ``zwo:AltitudeLimits`` as a client would, a target that sinks under one
before the slew lands), and for a grid of targets the verdict says blocked exactly when the GoTo is refused,
by the server before anything reaches the mount, never by the mount itself. Targets are placed by Alt/Az
for the server's sidereal time now, at least 2° from any limit (except the landing case, which runs on
a real-time clock), so the sky turning while a test runs cannot change an answer.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

import pytest

from alpaca_zwo.config.settings import EmulatorSettings, LimitSettings
from alpaca_zwo.emulator import MountModel
from alpaca_zwo.server import AlpacaZwoServer
from alpaca_zwo.telescope import pointing
from alpaca_zwo.telescope.device import Telescope
from tests.conftest import ServerFactory, make_settings
from tests.support import wait_until
from tests.support.sites import EQUATOR, SITE_IDS, SITES, Site
from tests.telescope.harness import INVALID_VALUE, MOTION_TIMEOUT_S, OK, SPEED, Api

#: The server's limits in these tests: a hill of 25° between azimuths 80° and 120°, 5° elsewhere.
HILL = ((79.0, 5.0), (80.0, 25.0), (120.0, 25.0), (121.0, 5.0))
LIMITS = LimitSettings(min_altitude_deg=5.0, horizon=HILL)


class Rig:
    """A connected server at ``site``: its Telescope (the verdict), a client (the GoTo), the emulator."""

    def __init__(self, server: AlpacaZwoServer, site: Site) -> None:
        self.server = server
        self.site = site
        self.telescope: Telescope = server.telescopes[0]
        self.api = Api(f"http://127.0.0.1:{server.port}").connect()
        emulator = server.emulators[0]
        assert emulator is not None
        self.model: MountModel = emulator.model
        wait_until(lambda: self.telescope.mount.position() is not None, what="a first position")

    def mount_limits(self, **limits: Any) -> None:
        """Set the mount's own altitude limits as a client does (the Action reads them back)."""
        reply = self.api.put("Action", Action="zwo:AltitudeLimits", Parameters=json.dumps(limits))
        assert reply.error == OK, reply.body

    def place(self, azimuth: float, altitude: float) -> tuple[float, float]:
        """The RA/Dec standing at ``azimuth``/``altitude`` now (the server's sidereal time)."""
        telescope = self.telescope
        return pointing.radec_from_altaz(telescope.settings, telescope.clock.lst(), azimuth, altitude)

    def goto(self, ra: float, dec: float) -> tuple[int, str]:
        """Try the GoTo; if it started, stop it and wait for rest. The error number and message."""
        reply = self.api.put("SlewToCoordinatesAsync", RightAscension=ra, Declination=dec)
        if reply.error == OK:
            self.api.ok("AbortSlew")
            self.api.wait_idle(MOTION_TIMEOUT_S)
        return reply.error, str(reply.body["ErrorMessage"])


@pytest.fixture(params=SITES, ids=SITE_IDS)
def rig(request: pytest.FixtureRequest, server_factory: ServerFactory) -> Iterator[Rig]:
    site: Site = request.param
    server = server_factory(make_settings(site=site.settings(), limits=LIMITS,
                                          emulator=EmulatorSettings(speed=SPEED, baud=0)))
    yield Rig(server, site)


def _named(rig: Rig, azimuth: float, altitude: float) -> pointing.Blocked | None:
    return rig.telescope.goto_limit(*rig.place(azimuth, altitude))


def test_each_limit_blocks_and_is_named(rig: Rig) -> None:
    assert _named(rig, 200.0, 30.0) is None
    hill = _named(rig, 100.0, 20.0)
    assert hill is not None and hill.limit == pointing.HORIZON and hill.says == "below the horizon (25.0° there)"
    low = _named(rig, 200.0, 3.0)
    assert low is not None and low.limit == pointing.MIN_ALTITUDE
    assert low.says == "below the minimum altitude of 5°"
    assert _named(rig, 200.0, 10.0) is None  # the mount's limits are off (the factory setting)

    rig.mount_limits(enabled=True, lower=15, upper=80)
    limit = _named(rig, 200.0, 10.0)
    assert limit is not None and limit.limit == pointing.MOUNT_LOWER
    assert limit.says == "below the mount's altitude limit of 15°"
    assert limit.detail.startswith("below the mount's altitude limit of 15° (zwo:AltitudeLimits): altitude 10.0")
    # Under both floors: the higher one is named (the one to wait for).
    both = _named(rig, 200.0, 3.0)
    assert both is not None and both.limit == pointing.MOUNT_LOWER
    hill = _named(rig, 100.0, 20.0)
    assert hill is not None and hill.limit == pointing.HORIZON
    high = _named(rig, 200.0, 85.0)
    assert high is not None and high.limit == pointing.MOUNT_UPPER
    assert high.says == "above the mount's upper altitude limit of 80°"
    assert _named(rig, 200.0, 40.0) is None

    rig.mount_limits(enabled=False)
    assert _named(rig, 200.0, 10.0) is None and _named(rig, 200.0, 85.0) is None


def test_the_mounts_horizon_blocks_where_the_servers_floor_is_lower(server_factory: ServerFactory) -> None:
    site = EQUATOR
    server = server_factory(make_settings(site=site.settings(), limits=LimitSettings(min_altitude_deg=-5.0),
                                          emulator=EmulatorSettings(speed=SPEED, baud=0)))
    rig = Rig(server, site)
    ra, dec = rig.place(250.0, -2.0)
    blocked = rig.telescope.goto_limit(ra, dec)
    assert blocked is not None and blocked.limit == pointing.MOUNT_HORIZON
    assert blocked.says == "below the mount's horizon (0°)"
    error, message = rig.goto(ra, dec)
    assert (error, message.split(":")[0]) == (INVALID_VALUE, "target is below the mount's horizon")
    assert rig.telescope.goto_limit(*rig.place(250.0, 5.0)) is None


@pytest.mark.parametrize("site", SITES, ids=SITE_IDS)
def test_a_target_sinking_under_the_limit_before_the_slew_lands_is_refused(server_factory: ServerFactory,
                                                                           site: Site) -> None:
    """Above the mount's 15° now, under it by the time a slew from home lands: refused, and said so. On a
    real-time clock, so the few milliseconds between placing the target and judging it move it 0.0001°."""
    server = server_factory(make_settings(site=site.settings(), emulator=EmulatorSettings(speed=1.0, baud=0)))
    rig = Rig(server, site)
    rig.mount_limits(enabled=True, lower=15)
    ra, dec = rig.place(260.0, 15.02)  # in the west: setting, about 0.004° a second at most
    blocked = rig.telescope.goto_limit(ra, dec)
    assert blocked is not None and blocked.limit == pointing.MOUNT_LOWER and blocked.after_s > 5.0
    assert blocked.says.startswith("sinks below the mount's altitude limit of 15° before the slew lands (in about ")
    assert blocked.altitude < 15.0
    rising = rig.place(100.0, 15.02)  # in the east it climbs: reachable now and at landing
    assert rig.telescope.goto_limit(*rising) is None
    error, message = rig.goto(ra, dec)
    assert error == INVALID_VALUE and "before the slew lands" in message


def test_verdict_and_goto_agree_on_a_grid(rig: Rig) -> None:
    """For targets all over the sky, with every limit in play: blocked by the verdict exactly when the GoTo
    is refused, and every refusal is the server's (InvalidValue), none the mount's (e5#/e6#)."""
    rig.mount_limits(enabled=True, lower=15, upper=80)
    disagreements = []
    for azimuth in (100.0, 250.0):
        for altitude in (-3.0, 3.0, 10.0, 20.0, 45.0, 85.0):
            ra, dec = rig.place(azimuth, altitude)
            blocked = rig.telescope.goto_limit(ra, dec)
            error, message = rig.goto(ra, dec)
            if (blocked is not None) != (error != OK) or error not in (OK, INVALID_VALUE):
                disagreements.append((azimuth, altitude, blocked, hex(error), message))
            elif blocked is not None:
                assert message == f"target is {blocked.detail}"
    assert not disagreements
    assert rig.model.snapshot()["slew"] is None


def test_slew_to_alt_az_runs_the_same_check(rig: Rig) -> None:
    rig.mount_limits(enabled=True, lower=15)
    rig.api.ok("Tracking", Tracking=False)
    reply = rig.api.put("SlewToAltAzAsync", Azimuth=200.0, Altitude=10.0)
    assert reply.error == INVALID_VALUE
    assert str(reply.body["ErrorMessage"]).startswith("target is below the mount's altitude limit of 15°")


def test_a_limit_changed_behind_the_servers_back_is_refused_by_the_mount_then_known(rig: Rig) -> None:
    """ZWO's app can change the limits over WiFi: the mount refuses (e6#), and the refusal makes the server
    read its settings again, so the next verdict names the limit."""
    ra, dec = rig.place(200.0, 10.0)
    assert rig.telescope.goto_limit(ra, dec) is None
    rig.model.flash.set_limits_enabled(True)
    assert rig.model.flash.set_lower_limit(15)
    error, message = rig.goto(ra, dec)
    # The mount's e6# is the same refusal as the server's own verdict: InvalidValue, in words that say which.
    assert error == INVALID_VALUE and "altitude limits (e6)" in message, (hex(error), message)

    def named() -> str | None:
        blocked = rig.telescope.goto_limit(*rig.place(200.0, 10.0))
        return None if blocked is None else blocked.limit

    wait_until(lambda: named() == pointing.MOUNT_LOWER, what="the verdict to know the mount's new limit")
