"""N.I.N.A.'s meridian flip, step by step through alpyca, ends on the other pier side (issue 24.4).

The mount tracked its target across the meridian on pierWest (counterweight up) and the target is
now at HA +0.02 h. N.I.N.A.'s ``AscomTelescope.MeridianFlip`` then: Tracking on; the side it
expects (HA >= 0: pierEast); ``SideOfPier = expected`` when CanSetPierSide, waiting while Slewing;
``SlewToCoordinatesAsync(target)`` and wait while Slewing; the side check (only when
CanSetPierSide). Whatever it believes, the emulator's truth must show the mount through the pole on
pierEast, pointing at the target, for the mount's meridian setting "track past 5°", "0°" and "off",
and under both readings of how a GOTO chooses its side (docs/meridian.md). Then guide pulses must
move the sky the commanded way on the new side. North of the equator for every setting, and at
Sydney and on the equator (issue 30: the target's declination mirrored toward the elevated pole)
for "track past 5°" under both readings and for "off", on a faster emulator clock (where the mount
ends is judged, not timing).

Before this change CanSetPierSide was false and the plain GOTO stayed on pierWest with "track past
5°" (the mount only flips past its limit): the 5° cases failed on the emulator's pier letter.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import pytest
from alpaca.telescope import GuideDirections, PierSide
from alpaca.telescope import Telescope as AlpycaTelescope

from alpaca_zwo import sky
from alpaca_zwo.config.settings import EmulatorSettings, LimitSettings
from alpaca_zwo.emulator import MountModel
from alpaca_zwo.server import AlpacaZwoServer
from alpaca_zwo.zwo.wire_values import MeridianSettings
from tests.conftest import ServerFactory, make_settings
from tests.support.sites import EQUATOR, NORTH, SYDNEY, Site
from tests.support.wait import wait_until

DEC = 30.0  # toward the elevated pole: 68° up at the meridian from Greenwich, 86° from Sydney
FLIP_HA = 0.02  # hours past the meridian when N.I.N.A. flips
#: Emulated seconds per real second: the checks are of where the mount ends, not of timing.
SPEED = 4.0
SETTINGS = {  # the mount's meridian setting: (track past, limit in degrees)
    "track-past-5": (True, 5),
    "track-past-0": (True, 0),
    "track-past-off": (False, 5),
}


@dataclass
class Rig:
    server: AlpacaZwoServer
    scope: AlpycaTelescope
    model: MountModel
    flips_at_meridian: bool  # the emulator's GOTO side rule once the scene is set
    site: Site = NORTH

    @property
    def dec(self) -> float:
        return self.site.dec(DEC)

    def truth(self) -> dict[str, object]:
        state: dict[str, object] = self.model.snapshot()
        return state

    def wait_at_rest(self, what: str) -> None:
        wait_until(lambda: not self.scope.Slewing, 120.0, what)


CASES = [(NORTH, name, False) for name in SETTINGS] + [(NORTH, "track-past-5", True)] + [
    (site, name, at_meridian) for site in (SYDNEY, EQUATOR)
    for name, at_meridian in (("track-past-5", False), ("track-past-5", True), ("track-past-off", False))]


def _case_id(case: tuple[Site, str, bool]) -> str:
    site, name, at_meridian = case
    return f"{site.name}-{name}{'-mount-flips-at-meridian' if at_meridian else ''}"


@pytest.fixture(params=CASES, ids=[_case_id(case) for case in CASES])
def rig(request: pytest.FixtureRequest, server_factory: ServerFactory) -> Iterator[Rig]:
    site, name, at_meridian = request.param
    track_past, limit = SETTINGS[name]
    settings = make_settings(site=site.settings(), emulator=EmulatorSettings(speed=site.speed(SPEED), baud=0),
                             limits=LimitSettings(meridian_track_past=track_past, meridian_limit_deg=limit))
    server = server_factory(settings)
    model = server.emulators[0].model
    assert model is not None
    scope = AlpycaTelescope(f"127.0.0.1:{server.port}", 0)
    scope.Connected = True
    yield Rig(server, scope, model, at_meridian, site)
    scope.Connected = False


def _tracked_past_the_meridian(rig: Rig) -> tuple[float, float]:
    """Leave the mount tracking its target at HA +0.02 h on pierWest, as after tracking across the
    meridian: the GOTO runs under "track past 5°" on the mount (so it lands on pierWest), then the
    mount gets its configured setting back. Returns the target (RA, Dec)."""
    configured = rig.model.flash.meridian()
    rig.model.flash.set_meridian(MeridianSettings(False, True, 5))
    target_ra = sky.wrap_hours_24(rig.scope.SiderealTime - FLIP_HA)
    rig.scope.Tracking = True
    rig.scope.SlewToCoordinatesAsync(target_ra, rig.dec)
    rig.wait_at_rest("the slew to the target")
    rig.model.flash.set_meridian(configured)
    rig.model.firmware.goto_flip_at_meridian = rig.flips_at_meridian
    truth = rig.truth()
    # pierWest: looking east, the Dec axis inside ±90° in the north and through the pole in the south.
    assert truth["side"] == "WEST" and truth["through_pole"] is (rig.site.pole < 0), truth
    return target_ra, rig.dec


def _nina_meridian_flip(rig: Rig, target_ra: float, target_dec: float) -> bool:
    """AscomTelescope.MeridianFlip (N.I.N.A. 3.x, summarised in shared/alpaca/clients.md §1.5)."""
    scope = rig.scope
    if not scope.Tracking:
        scope.Tracking = True
    ha = sky.wrap_hours_12(scope.SiderealTime - target_ra)
    expected = PierSide.pierWest if -12.0 < ha <= 0.0 else PierSide.pierEast
    assert expected == PierSide.pierEast
    side_ok = not scope.CanSetPierSide  # without it N.I.N.A. considers the side done up front
    if not side_ok:
        scope.SideOfPier = expected
        rig.wait_at_rest("the SideOfPier flip")
        side_ok = True
    scope.SlewToCoordinatesAsync(target_ra, target_dec)
    rig.wait_at_rest("the flip GOTO")
    if scope.CanSetPierSide:
        side_ok = scope.SideOfPier == expected
    return side_ok


def _pulse_moves(rig: Rig, direction: GuideDirections) -> tuple[float, float]:
    """Truth RA (arcsec of sky, east positive) and Dec (arcsec) moved by one 2 s pulse."""
    before = rig.truth()
    rig.scope.PulseGuide(direction, 2000)
    wait_until(lambda: not rig.scope.IsPulseGuiding, 10.0, "the pulse")
    wait_until(lambda: not any(rig.truth()["pulses"]), 5.0, "the mount's pulse")  # type: ignore[arg-type]
    after = rig.truth()
    d_ra = sky.wrap_hours_12(float(after["ra_h"]) - float(before["ra_h"]))  # type: ignore[arg-type]
    d_dec = float(after["dec_deg"]) - float(before["dec_deg"])  # type: ignore[arg-type]
    cos_dec = 0.866  # cos 30°
    return d_ra * 15 * 3600 * cos_dec, d_dec * 3600


def test_nina_flip_ends_on_the_other_side_and_guides_the_right_way(rig: Rig) -> None:
    target_ra, target_dec = _tracked_past_the_meridian(rig)
    assert _nina_meridian_flip(rig, target_ra, target_dec), "N.I.N.A. would retry: the side check failed"

    truth = rig.truth()
    assert truth["side"] == "EAST", f"the mount did not flip: {truth['pier']} {truth['secondary_deg']}"
    assert truth["through_pole"] is (rig.site.pole > 0), truth  # the Dec axis swung through the pole
    separation = sky.angular_separation(float(truth["ra_h"]), float(truth["dec_deg"]),  # type: ignore[arg-type]
                                        target_ra, target_dec)
    assert separation * 3600 < 10.0, f"{separation * 3600:.1f}″ from the target after the flip"
    assert rig.scope.SideOfPier == PierSide.pierEast
    assert truth["tracking"] is True
    track_past, limit = configured_meridian(rig)
    own = {"flip": False, "track_after": track_past, "limit_degrees": limit}
    wait_until(lambda: rig.truth()["meridian"] == own, 5.0, "the mount's own meridian setting back after the flip")

    # The guide rate is 0.5x sidereal: a 2 s pulse moves about 15″; insist on half of it, the right way.
    for direction, (east, north) in {GuideDirections.guideNorth: (0, 1), GuideDirections.guideSouth: (0, -1),
                                     GuideDirections.guideEast: (1, 0), GuideDirections.guideWest: (-1, 0)}.items():
        d_east, d_north = _pulse_moves(rig, direction)
        moved, other = (d_east, d_north) if east else (d_north, d_east)
        sign = east or north
        assert moved * sign > 5.0 and abs(other) < 2.0, \
            f"{direction.name} on pierEast moved the sky {d_east:+.1f}″ east, {d_north:+.1f}″ north"
    assert rig.truth()["side"] == "EAST"


def configured_meridian(rig: Rig) -> tuple[bool, int]:
    """The configured (track past, limit) of this rig's server, as written to the mount."""
    limits = rig.server.store.settings.limits
    return limits.meridian_track_past, round(limits.meridian_limit_deg)


@pytest.fixture
def rig5(server_factory: ServerFactory) -> Iterator[Rig]:
    """One rig with "track past 5°" and the default GOTO rule (A1)."""
    settings = make_settings(emulator=EmulatorSettings(speed=SPEED, baud=0),
                             limits=LimitSettings(meridian_track_past=True, meridian_limit_deg=5))
    server = server_factory(settings)
    model = server.emulators[0].model
    assert model is not None
    scope = AlpycaTelescope(f"127.0.0.1:{server.port}", 0)
    scope.Connected = True
    yield Rig(server, scope, model, False)


def test_side_of_pier_write_is_a_slew_that_aborts_and_always_restores_the_meridian_setting(rig5: Rig) -> None:
    """Writing the side held does nothing; a flip is Slewing at once, AbortSlew stops it, and the mount's
    own meridian setting is back after the abort and when the server stops in the middle of a flip."""
    rig = rig5
    own = {"flip": False, "track_after": True, "limit_degrees": 5}
    _tracked_past_the_meridian(rig)
    link = rig.server.telescopes[0].mount.link
    start = len(link.trace())
    rig.scope.SideOfPier = PierSide.pierWest  # already there
    assert not rig.scope.Slewing
    assert not any(entry.request.startswith(":STa") or entry.request == ":MS#" for entry in link.trace()[start:])

    rig.scope.SideOfPier = PierSide.pierEast
    assert rig.scope.Slewing, "a SideOfPier write is a slew"
    assert rig.truth()["meridian"] == {"flip": False, "track_after": False, "limit_degrees": 0}
    rig.scope.AbortSlew()
    rig.wait_at_rest("the aborted flip")
    wait_until(lambda: rig.truth()["meridian"] == own, 5.0, "the meridian setting back after AbortSlew")
    assert rig.truth()["slew"] is None

    rig.scope.SideOfPier = PierSide.pierEast  # again, and the server stops in the middle of it
    assert rig.truth()["meridian"]["limit_degrees"] == 0  # type: ignore[index]
    rig.server.stop()
    assert rig.truth()["meridian"] == own, "the server closed the link with the flip's limit on the mount"
