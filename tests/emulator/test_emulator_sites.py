"""The emulated mount at every latitude: one mechanical model, the site's hemisphere choosing what its
axes point at (docs/southern.md). Each test runs north of the equator, at Sydney, on the equator and
at ±70°, with declinations mirrored toward the site's elevated pole, so one test states one rule for
every site. Emulated time moves only through the ManualClock. The mount (tests/emulator/conftest.py)
leaves the factory set to Suzhou, north: each site is set as a client sets it, so the southern ones
cross the equator while the mount is powered."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from alpaca_zwo import sky
from alpaca_zwo.emulator import EmulatorServer, FirmwareVariant, ManualClock, MountModel
from alpaca_zwo.emulator.model import FACTORY_LATITUDE, FACTORY_LONGITUDE
from alpaca_zwo.sky import SIDEREAL_DEG_S, PierSide
from alpaca_zwo.zwo import protocol, wire_values
from alpaca_zwo.zwo.wire_values import MountMode
from tests.emulator.emuclient import MountClient, flags, slew, target_at, wait_slew

ARCSEC = 1.0 / 3600.0


@dataclass(frozen=True)
class Site:
    name: str
    latitude: float
    longitude: float  # east positive

    @property
    def pole(self) -> float:
        """+1 where the north celestial pole is up (the equator counts as north, as on the mount)."""
        return 1.0 if self.latitude >= 0.0 else -1.0

    def dec(self, toward_pole: float) -> float:
        """A declination ``toward_pole`` degrees toward the elevated pole from the equator."""
        return self.pole * toward_pole


SITES = [Site("north", 51.4769, -0.0005), Site("sydney", -33.8688, 151.2093), Site("equator", 0.0, 36.8),
         Site("north70", 70.0, 25.0), Site("south70", -70.0, -60.0)]


@pytest.fixture(params=SITES, ids=[site.name for site in SITES])
def site(request: pytest.FixtureRequest) -> Site:
    site: Site = request.param
    return site


def set_site(client: MountClient, site: Site) -> None:
    assert client.exact(protocol.set_latitude(site.latitude).text) == "1"
    assert client.exact(protocol.set_longitude(site.longitude).text) == "1"


@pytest.fixture
def ready(mount: MountClient, clock: ManualClock, site: Site) -> MountClient:
    """Date, time (UTC) and the test's site set, as a client does at connect: the site crosses the
    equator while the mount is powered for the southern ones."""
    now = clock.now()
    assert mount.exact(protocol.set_utc_offset(0.0).text) == "1"
    assert mount.exact(f":SL{now:%H:%M:%S}#") == "1"
    assert mount.exact(f":SC{now:%m/%d/%y}#") == "1"
    set_site(mount, site)
    return mount


def goto_ha(client: MountClient, model: MountModel, clock: ManualClock, ha: float, dec: float) -> None:
    slew(client, clock, target_at(model, ha), dec)


def hour_angle(model: MountModel) -> float:
    return sky.hour_angle(model.clock_site.sidereal_time(), model.position()[0])


def truth(model: MountModel) -> PierSide:
    return PierSide[str(model.snapshot()["side"])]


# --------------------------------------------------------------------------------------------
# Home, park, the equator
# --------------------------------------------------------------------------------------------


def test_home_points_at_the_elevated_pole(ready: MountClient, model: MountModel, site: Site) -> None:
    """South of the equator :GD# reads -90 at home; the altitude there is the site's |latitude|, due
    north or due south; RA = LST - 6 h in the south (the north's home mirrored: an assumption)."""
    assert ready.ask(":Gm#") == "N#"
    assert ready.ask(":GD#") == ("+90*00:00#" if site.pole > 0 else "-90*00:00#")
    altitude, azimuth = model.horizontal()
    assert altitude == pytest.approx(abs(site.latitude), abs=ARCSEC)  # the wire carries arcseconds
    if site.latitude != 0.0:
        assert azimuth == pytest.approx(0.0 if site.pole > 0 else 180.0, abs=1e-6)
    lst = wire_values.parse_hms(ready.ask(":GS#")[:-1])
    ra = wire_values.parse_hms(ready.ask(":GR#")[:-1])
    assert sky.wrap_hours_12(ra - lst - 6.0 * site.pole) == pytest.approx(0.0, abs=1.5 / 3600)


def test_a_mount_at_home_on_the_equator_may_track(ready: MountClient, model: MountModel, clock: ManualClock,
                                                   site: Site) -> None:
    """Home points at the pole, which stands on the horizon at the equator: tracking starts there."""
    assert ready.exact(":Te#") == "1"
    clock.advance(600.0)
    assert ready.ask(":GAT#") == "1#"


def test_factory_park_points_at_the_horizon_east_in_the_north_and_west_in_the_south(
        ready: MountClient, model: MountModel, clock: ManualClock, site: Site) -> None:
    ready.send(":hP#")
    wait_slew(ready, clock)
    altitude, azimuth = model.horizontal()
    assert altitude == pytest.approx(0.0, abs=1e-6)
    assert azimuth == pytest.approx(90.0 if site.pole > 0 else 270.0, abs=1e-6)
    assert model.axes() == pytest.approx((-90.0, 0.0))  # the same mechanical position everywhere


# --------------------------------------------------------------------------------------------
# GOTO, tracking, meridian
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("ha", [-3.0, -0.05, 0.05, 3.0])
def test_goto_side_follows_the_hour_angle(ready: MountClient, model: MountModel, clock: ManualClock, site: Site,
                                          ha: float) -> None:
    """A target east of the meridian lands pierWest (looking east), west of it pierEast: ASCOM's
    pointing state in both hemispheres, with the factory meridian setting."""
    goto_ha(ready, model, clock, ha, site.dec(40.0))
    assert sky.angular_separation(*model.position(), *model.target()) < ARCSEC
    expected = sky.pointing_state(ha)
    assert truth(model) is expected
    assert ready.ask(":Gm#") == ("W#" if expected is PierSide.WEST else "E#")
    # The mechanics: looking east is the Dec axis inside ±90° in the north and through the pole in the south.
    assert model.snapshot()["through_pole"] is ((expected is PierSide.EAST) == (site.pole > 0))


def test_tracking_holds_the_target_with_the_ra_axis_turning_the_hemisphere_s_way(
        ready: MountClient, model: MountModel, clock: ManualClock, site: Site) -> None:
    goto_ha(ready, model, clock, -2.0, site.dec(30.0))
    ra0, dec0 = model.position()
    primary0 = model.axes()[0]
    clock.advance(3600.0)
    ra1, dec1 = model.position()
    assert sky.angular_separation(ra0, dec0, ra1, dec1) < 0.01 * ARCSEC
    assert (model.axes()[0] - primary0) == pytest.approx(site.pole * 3600.0 * SIDEREAL_DEG_S, rel=1e-9)


def test_factory_setting_stops_tracking_one_degree_past_the_meridian(
        ready: MountClient, model: MountModel, clock: ManualClock, site: Site) -> None:
    goto_ha(ready, model, clock, -0.05, site.dec(20.0))
    assert ready.ask(":Gm#") == "W#"
    clock.advance(6 * 60.0)
    assert ready.ask(":GAT#") == "1#"
    clock.advance(2 * 60.0)
    assert ready.ask(":GAT#") == "e8#"
    assert hour_angle(model) * 15.0 == pytest.approx(1.0, abs=0.01)  # stopped at +1° of hour angle
    assert truth(model) is PierSide.WEST  # still counterweight up on pierWest


@pytest.mark.parametrize(("setting", "ha", "side"), [("01+10", 0.3, PierSide.WEST), ("00+10", 0.3, PierSide.EAST),
                                                     ("00-10", -0.3, PierSide.EAST)])
def test_meridian_settings_choose_the_goto_side_by_hour_angle(
        ready: MountClient, model: MountModel, clock: ManualClock, site: Site, setting: str, ha: float,
        side: PierSide) -> None:
    assert ready.exact(f":STa{setting}#") == "1"
    goto_ha(ready, model, clock, ha, site.dec(40.0))
    assert truth(model) is side
    assert sky.angular_separation(*model.position(), *model.target()) < ARCSEC


def test_sync_across_the_meridian_is_refused(ready: MountClient, model: MountModel, clock: ManualClock,
                                             site: Site) -> None:
    goto_ha(ready, model, clock, -0.2, site.dec(30.0))
    assert ready.exact(protocol.set_target_ra(target_at(model, 0.3)).text) == "1"
    assert ready.ask(":CM#") == "e9#"
    assert ready.exact(protocol.set_target_ra(target_at(model, -0.3)).text) == "1"
    assert ready.ask(":CM#") == "N/A#"


# --------------------------------------------------------------------------------------------
# Moves and guide pulses
# --------------------------------------------------------------------------------------------


def _moved(client: MountClient, model: MountModel, clock: ManualClock, command: str) -> tuple[float, float]:
    """(RA arcsec, Dec arcsec) a 2 s move at 60x sidereal carries the pointing (tracking on)."""
    ra0, dec0 = model.position()
    client.send(":R7#")
    client.send(f":M{command}#")
    clock.advance(2.0)
    client.send(f":Q{command}#")
    clock.advance(2.0)
    ra1, dec1 = model.position()
    return sky.wrap_hours_12(ra1 - ra0) * 54000.0, (dec1 - dec0) * 3600.0


def _expected_move() -> float:
    return 2.0 * 60.0 * SIDEREAL_DEG_S * 3600.0


@pytest.mark.parametrize("ha", [-2.0, 2.0])
def test_moves_are_sky_directions_on_both_sides(ready: MountClient, model: MountModel, clock: ManualClock,
                                                site: Site, ha: float) -> None:
    goto_ha(ready, model, clock, ha, site.dec(30.0))
    assert _moved(ready, model, clock, "n")[1] == pytest.approx(_expected_move(), abs=1.0)
    assert _moved(ready, model, clock, "s")[1] == pytest.approx(-_expected_move(), abs=1.0)
    assert _moved(ready, model, clock, "e")[0] == pytest.approx(_expected_move(), abs=1.0)
    assert _moved(ready, model, clock, "w")[0] == pytest.approx(-_expected_move(), abs=1.0)


@pytest.mark.parametrize("ha", [-2.0, 2.0])
def test_guide_pulses_are_sky_directions_on_both_sides(ready: MountClient, model: MountModel, clock: ManualClock,
                                                       site: Site, ha: float) -> None:
    goto_ha(ready, model, clock, ha, site.dec(30.0))
    for direction, axis, sign in (("n", 1, 1.0), ("s", 1, -1.0), ("e", 0, 1.0), ("w", 0, -1.0)):
        before = model.position()
        ready.send(f":Mg{direction}1000#")
        clock.advance(2.0)
        after = model.position()
        moved = [sky.wrap_hours_12(after[0] - before[0]) * 54000.0, (after[1] - before[1]) * 3600.0]
        assert moved[axis] == pytest.approx(sign * 0.5 * SIDEREAL_DEG_S * 3600.0, abs=0.01), direction
        assert moved[1 - axis] == pytest.approx(0.0, abs=0.01), direction


@pytest.mark.parametrize("firmware", [FirmwareVariant(ns_moves="mechanical")], ids=["ns-mechanical"])
@pytest.mark.parametrize("ha", [-2.0, 2.0])
def test_mechanical_north_raises_dec_on_pier_east_and_lowers_it_on_pier_west(
        ready: MountClient, model: MountModel, clock: ManualClock, site: Site, ha: float) -> None:
    """The other reading (eq-satrack's AM3): :Mn#/:Mgn turn the Dec axis one way, whatever the side."""
    goto_ha(ready, model, clock, ha, site.dec(30.0))
    sign = 1.0 if truth(model) is PierSide.EAST else -1.0
    assert _moved(ready, model, clock, "n")[1] == pytest.approx(sign * _expected_move(), abs=1.0)
    before = model.position()[1]
    ready.send(":Mgn1000#")
    clock.advance(2.0)
    assert (model.position()[1] - before) * 3600.0 == pytest.approx(sign * 0.5 * SIDEREAL_DEG_S * 3600.0, abs=0.01)
    assert _moved(ready, model, clock, "e")[0] == pytest.approx(_expected_move(), abs=1.0)  # E/W stay sky


# --------------------------------------------------------------------------------------------
# The :Gm# letter variants
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("rule", ["pointing_state", "mechanical", "hour_angle"])
def test_pier_letter_variants(ready: MountClient, model: MountModel, clock: ManualClock, site: Site,
                              rule: str) -> None:
    """Far from the meridian only the mechanical names differ (reversed south of the equator); with the
    counterweight up (tracked past the meridian on pierWest) the hour-angle letter differs too."""
    model.firmware.pier_letter = rule
    reversed_south = rule == "mechanical" and site.pole < 0

    def letter(side: PierSide) -> str:
        west = (side is PierSide.WEST) != reversed_south
        return "W#" if west else "E#"

    goto_ha(ready, model, clock, -3.0, site.dec(40.0))
    assert ready.ask(":Gm#") == letter(PierSide.WEST)
    goto_ha(ready, model, clock, 3.0, site.dec(40.0))
    assert ready.ask(":Gm#") == letter(PierSide.EAST)
    assert ready.exact(":STa01+05#") == "1"
    goto_ha(ready, model, clock, -0.05, site.dec(40.0))
    clock.advance(8 * 60.0)  # to HA +0.08 h, still tracking on pierWest
    assert truth(model) is PierSide.WEST and hour_angle(model) > 0.05
    assert ready.ask(":Gm#") == ("E#" if rule == "hour_angle" else letter(PierSide.WEST))


# --------------------------------------------------------------------------------------------
# The latitude changed while powered, and a power cycle
# --------------------------------------------------------------------------------------------


def test_latitude_across_the_equator_keeps_the_axes_and_mirrors_the_sky(
        ready: MountClient, model: MountModel, clock: ManualClock, site: Site) -> None:
    """The mount keeps its motor positions; from the new latitude on they point at the mirrored sky:
    Dec and hour angle change sign, and the same axes are the other pointing state."""
    goto_ha(ready, model, clock, -2.0, site.dec(30.0))
    axes, side, ha = model.axes(), truth(model), hour_angle(model)
    dec = model.position()[1]
    ready.send(":Q#")
    assert ready.exact(":Td#") == "1"
    mirrored = Site("mirror", -site.latitude if site.latitude != 0.0 else -10.0, site.longitude)
    set_site(ready, mirrored)
    assert model.axes() == pytest.approx(axes)
    if (mirrored.pole > 0) != (site.pole > 0):
        assert model.position()[1] == pytest.approx(-dec, abs=1e-9)
        assert hour_angle(model) == pytest.approx(-ha, abs=1e-6)
        assert truth(model) is not side
    ready.send(":hC#")
    wait_slew(ready, clock)
    assert ready.ask(":GD#") == ("+90*00:00#" if mirrored.pole > 0 else "-90*00:00#")


@pytest.mark.parametrize("keeps", [False, True], ids=["site-forgotten", "site-in-flash"])
def test_a_power_cycle_returns_to_home_with_the_stored_site(
        ready: MountClient, model: MountModel, site: Site, keeps: bool) -> None:
    """At power-up the mount is at home and has the site flash holds: the factory's (the AM5N) or the
    last one set (the 1.8.8 NVS keys); home then reads the pole of that site's hemisphere."""
    model.firmware.site_in_flash = keeps
    set_site(ready, site)
    model.power_cycle()
    stored = site.latitude if keeps else FACTORY_LATITUDE
    assert model.clock_site.latitude() == pytest.approx(stored, abs=ARCSEC)
    assert model.clock_site.longitude() == pytest.approx(site.longitude if keeps else FACTORY_LONGITUDE, abs=ARCSEC)
    assert ready.ask(":Gm#") == "N#"
    assert ready.ask(":GD#") == ("-90*00:00#" if stored < 0.0 else "+90*00:00#")
    assert "N" in flags(ready)


# --------------------------------------------------------------------------------------------
# Alt-az mode
# --------------------------------------------------------------------------------------------


@pytest.fixture
def altaz_model(clock: ManualClock) -> MountModel:
    return MountModel(clock, mode=MountMode.ALTAZ)


def test_altaz_azimuth_is_from_north_and_tracking_holds(clock: ManualClock, site: Site,
                                                        altaz_model: MountModel) -> None:
    server = EmulatorServer(altaz_model, host="127.0.0.1", port=0, baud=0).start()
    client = MountClient(server.port)
    try:
        now = clock.now()
        assert client.exact(f":SL{now:%H:%M:%S}#") == "1"
        assert client.exact(f":SC{now:%m/%d/%y}#") == "1"
        set_site(client, site)
        dec = site.dec(20.0) if site.latitude != 0.0 else 20.0
        slew(client, clock, target_at(altaz_model, -2.0), dec)
        ra, dec_now = altaz_model.position()
        lst = altaz_model.clock_site.sidereal_time()
        expected = sky.equatorial_to_horizontal(sky.hour_angle(lst, ra), dec_now, altaz_model.clock_site.latitude())
        altitude, azimuth = altaz_model.horizontal()
        assert (altitude, azimuth) == pytest.approx(expected, abs=1e-6)
        primary, secondary = altaz_model.axes()
        assert sky.wrap_degrees_360(primary) == pytest.approx(azimuth, abs=1e-3)  # the axis is the azimuth
        assert secondary == pytest.approx(altitude, abs=1e-3)
        clock.advance(1800.0)
        assert sky.angular_separation(*altaz_model.position(), ra, dec_now) < ARCSEC
    finally:
        client.close()
        server.stop()
