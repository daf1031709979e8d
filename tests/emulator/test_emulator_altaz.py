"""Alt-az mode over TCP: the mode switch and its restart, ``Z``, tracking that needs time and site,
GOTO/tracking/moves on the azimuth and altitude axes, guide pulses that move nothing, no pier flip,
``e10`` for an altitude carried over the zenith.

Facts from shared/zwo/field-notes.md: ``:AP#``/``:AA#`` switch the mode and the mount must be
restarted (§2.8; the mode is kept in flash across power cycles, §5.3); ``:GU#`` shows ``G``/``Z``
(§3); ``:GAT#`` answers ``e7#`` in alt-az until time and site are set (§2.4, §4.1); ``e10#`` is
"alt-az: altitude inverted" (§4.1); PT's 200-2000 ms guide pulses gave no measurable movement in
alt-az (§2.5); manual moves are relative to the sky (§5.1, PYAM5). Where the notes stop, the
emulator README says what is assumed. Emulated time moves only through the ManualClock.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

from alpaca_zwo import sky
from alpaca_zwo.emulator import EmulatorServer, FirmwareVariant, ManualClock, ModelResponder, MountModel
from alpaca_zwo.sky import SIDEREAL_DEG_S
from alpaca_zwo.zwo import protocol
from alpaca_zwo.zwo.wire_values import MountMode
from tests.emulator.emuclient import MountClient, flags, initialize, slew, target_at
from tests.emulator.test_emulator_faults import _connect_is_refused, _connection_is_dropped
from tests.support import wait_until

ARCSEC = 1.0 / 3600.0
#: The factory site's latitude, which ``initialize`` sets: the zenith is at this declination.
LATITUDE = 31.0 + 15.0 / 60.0 + 41.0 / 3600.0


@pytest.fixture
def model(clock: ManualClock, firmware: FirmwareVariant) -> MountModel:
    """A mount whose flash says alt-az, as after ``:AA#`` and a restart."""
    return MountModel(clock, firmware, mode=MountMode.ALTAZ)


def _goto_ha(client: MountClient, model: MountModel, clock: ManualClock, ha: float, dec: float) -> float:
    return slew(client, clock, target_at(model, ha), dec)


def _axes_match_pointing(model: MountModel) -> None:
    """In alt-az mode the primary axis is the azimuth and the secondary the altitude."""
    altitude, azimuth = model.horizontal()
    primary, secondary = model.axes()
    assert secondary == pytest.approx(altitude, abs=1e-6)
    assert sky.wrap_degrees_360(primary) == pytest.approx(azimuth, abs=1e-6)


# --------------------------------------------------------------------------------------------
# The mode and its restart
# --------------------------------------------------------------------------------------------


def test_mode_switch_takes_effect_only_after_a_power_cycle(clock: ManualClock) -> None:
    """§2.8: ``:AA#``/``:AP#`` answer nothing and need a restart; §5.3: the mode survives power cycles."""
    model = MountModel(clock)
    mount = ModelResponder(model)
    assert mount.handle("AA") is None
    assert mount.handle("GU").rstrip("#").rstrip("0123456789") == "nNG"  # not yet
    model.power_cycle()
    assert mount.handle("GU").rstrip("#").rstrip("0123456789") == "nNZ"
    model.power_cycle()
    assert "Z" in mount.handle("GU")  # kept in flash
    assert mount.handle("AP") is None
    assert "Z" in mount.handle("GU")
    model.power_cycle()
    assert "G" in mount.handle("GU")


def test_reboot_fault_brings_the_requested_mode_up(
    emu: EmulatorServer, model: MountModel, connect: Callable[[], MountClient]
) -> None:
    """The ``reboot`` fault is a power cycle: a mode sent before it is the mode after it (§2.8)."""
    client = connect()
    assert flags(client) == "nNZ"
    client.send(":AP#")
    assert flags(client) == "nNZ"
    emu.faults.reboot(0.5)
    assert _connection_is_dropped(client)
    assert _connect_is_refused(emu.port)
    wait_until(lambda: not emu.faults.refusing(), 5.0, "the reboot to end", interval=0.02)
    assert flags(connect()) == "nNG"
    assert model.power_ups == 2


# --------------------------------------------------------------------------------------------
# Tracking needs time and site
# --------------------------------------------------------------------------------------------


def test_tracking_answers_e7_until_time_and_site_are_set(mount: MountClient, clock: ManualClock) -> None:
    """§2.4/§4.1: in alt-az ``:GAT#`` is ``e7#`` (time and site not set) and ``:Te#`` fails until they are."""
    assert mount.ask(":GAT#") == "e7#"
    assert mount.exact(":Te#") == "0"
    assert mount.ask(":GAT#") == "e7#"
    initialize(mount, clock)
    assert mount.ask(":GAT#") == "0#"
    assert mount.exact(":Te#") == "1"
    assert mount.ask(":GAT#") == "1#"


def test_equatorial_mode_tracks_without_time_and_site(clock: ManualClock) -> None:
    """The e7 rule is alt-az only (§2.4): an EQ mount at power-up reads ``0#`` and can track."""
    mount = ModelResponder(MountModel(clock))
    assert mount.handle("GAT") == "0#"
    assert mount.handle("Te") == "1"


# --------------------------------------------------------------------------------------------
# GOTO, tracking, moves on the azimuth/altitude axes
# --------------------------------------------------------------------------------------------


def test_home_points_at_the_zenith(ready: MountClient, model: MountModel) -> None:
    """The mechanical zero is unchanged (§5.2); with the primary axis vertical it looks straight up."""
    assert ready.ask(":Gm#") == "N#"
    assert model.horizontal()[0] == pytest.approx(90.0, abs=1e-6)
    ra, dec = model.position()
    assert dec == pytest.approx(LATITUDE, abs=1e-4)
    assert sky.hour_angle(model.clock_site.sidereal_time(), ra) == pytest.approx(0.0, abs=1e-4)


@pytest.mark.parametrize(("ha", "dec"), [(-3.0, 20.0), (2.5, 45.0), (-6.0, 70.0), (1.0, -20.0)])
def test_goto_lands_on_target_with_both_axes_and_tracks(
    ready: MountClient, model: MountModel, clock: ManualClock, ha: float, dec: float
) -> None:
    """A GOTO moves the azimuth and altitude axes and ends tracking, as in EQ (§5.1)."""
    duration = _goto_ha(ready, model, clock, ha, dec)
    assert duration > 3.0
    assert sky.angular_separation(*model.position(), *model.target()) < ARCSEC
    assert ready.ask(":GR#") == ready.ask(":Gr#")
    assert ready.ask(":GD#") == ready.ask(":Gd#")
    assert ready.ask(":GAT#") == "1#"
    _axes_match_pointing(model)


def test_goto_uses_the_equatorial_speed_model(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    """Both axes accelerate at 3 °/s² up to 1440x sidereal, as in EQ: a long azimuth swing takes about
    its length / top speed + the time to reach top speed."""
    _goto_ha(ready, model, clock, -3.0, 10.0)
    first = model.axes()
    assert ready.exact(protocol.set_target_ra(target_at(model, 3.0)).text) == "1"
    assert ready.exact(":Sd+10*00:00#") == "1"
    assert ready.exact(":MS#") == "0"
    elapsed = fastest = 0.0
    while "N" not in flags(ready):
        clock.advance(0.25)
        elapsed += 0.25
        fastest = max(fastest, *(abs(v) for v in model.snapshot()["velocity_deg_s"]))
    vmax = 1440 * SIDEREAL_DEG_S
    assert 0.9 * vmax < fastest <= vmax + 1e-9
    swing = abs(model.axes()[0] - first[0])
    assert swing > 30.0
    assert elapsed == pytest.approx(swing / vmax + vmax / 3.0, abs=3.0)
    assert sky.angular_separation(*model.position(), *model.target()) < ARCSEC


def test_tracking_holds_ra_and_dec_while_both_axes_turn(
    ready: MountClient, model: MountModel, clock: ManualClock
) -> None:
    """Alt-az tracking turns both axes so that RA/Dec stay put (the mount tracks in alt-az, §2.4)."""
    _goto_ha(ready, model, clock, -2.0, 10.0)
    ra0, dec0 = model.position()
    axes0 = model.axes()
    for _ in range(6):
        clock.advance(600.0)
        ra, dec = model.position()
        assert sky.angular_separation(ra0, dec0, ra, dec) < 0.01 * ARCSEC
    axes1 = model.axes()
    assert abs(axes1[0] - axes0[0]) > 5.0 and abs(axes1[1] - axes0[1]) > 5.0
    assert ready.ask(":GAT#") == "1#"
    _axes_match_pointing(model)


def test_tracking_off_holds_altitude_and_azimuth(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    _goto_ha(ready, model, clock, 2.0, 30.0)
    assert ready.exact(":Td#") == "1"
    clock.advance(5.0)  # let the axes come to rest
    axes = model.axes()
    clock.advance(900.0)
    assert model.axes() == pytest.approx(axes, abs=1e-9)


def test_manual_moves_are_relative_to_the_sky(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    """``:Mn#`` raises Dec (§5.1: moves are relative to the sky), which turns both alt-az axes."""
    _goto_ha(ready, model, clock, -3.0, 10.0)
    ra0, dec0 = model.position()
    axes0 = model.axes()
    ready.send(":R7#")  # 60x sidereal
    ready.send(":Mn#")
    clock.advance(20.0)
    ready.send(":Qn#")
    clock.advance(5.0)
    ra, dec = model.position()
    assert dec - dec0 == pytest.approx(60 * SIDEREAL_DEG_S * 20.0, rel=0.02)
    assert abs(sky.wrap_hours_12(ra - ra0)) * 15.0 * 3600.0 < 5.0  # RA held within a few arcseconds
    axes = model.axes()
    assert abs(axes[0] - axes0[0]) > 0.01 and abs(axes[1] - axes0[1]) > 0.01
    assert ready.ask(":GAT#") == "1#"


@pytest.mark.parametrize("direction", ["n", "s", "e", "w"])
def test_guide_pulses_move_nothing(
    ready: MountClient, model: MountModel, clock: ManualClock, direction: str
) -> None:
    """§2.5 (PT): 200-2000 ms pulses gave no measurable movement in alt-az mode."""
    _goto_ha(ready, model, clock, -2.0, 20.0)
    before = model.position()
    ready.send(f":Mg{direction}2000#")
    clock.advance(1.0)
    assert any(model.pulsing())  # accepted and timed
    clock.advance(2.0)
    assert not any(model.pulsing())
    assert sky.angular_separation(*before, *model.position()) < 0.01 * ARCSEC


# --------------------------------------------------------------------------------------------
# No pier side, no meridian; e10
# --------------------------------------------------------------------------------------------


def test_no_pier_flip_either_side_of_the_meridian(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    """An alt-az mount never swings through the pole: ``:Gm#`` stays ``W`` east and west of the meridian."""
    for ha in (-3.0, 3.0, -1.0, 4.0):
        _goto_ha(ready, model, clock, ha, 30.0)
        assert ready.ask(":Gm#") == "W#"
        assert model.axes()[1] <= 90.0


def test_tracking_runs_past_the_meridian(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    """The factory meridian setting stops EQ tracking 1° past the meridian (§5.3); alt-az has no meridian."""
    _goto_ha(ready, model, clock, -0.1, 0.0)
    clock.advance(1800.0)
    assert ready.ask(":GAT#") == "1#"
    assert sky.hour_angle(model.clock_site.sidereal_time(), model.position()[0]) > 0.3


def test_altitude_over_the_zenith_stops_tracking_with_e10(
    ready: MountClient, model: MountModel, clock: ManualClock
) -> None:
    """§4.1 ``e10``, "alt-az: altitude inverted": a star crossing the zenith needs the azimuth to turn 180°
    at once; the axes take the altitude over the top instead, and tracking stops with ``e10#``."""
    _goto_ha(ready, model, clock, -0.05, LATITUDE)  # the zenith's declination, 3 minutes before transit
    assert ready.ask(":GAT#") == "1#"
    for _ in range(60):
        if ready.ask(":GAT#") != "1#":
            break
        clock.advance(5.0)
    assert ready.ask(":GAT#") == "e10#"
    assert model.axes()[1] > 90.0
    assert ready.exact(":Te#") == "0"
    assert ready.ask(":GAT#") == "e10#"
    _goto_ha(ready, model, clock, 2.0, 20.0)  # a GOTO brings the altitude back upright
    assert model.axes()[1] <= 90.0
    assert ready.ask(":GAT#") == "1#"


def test_sync_knows_no_meridian_side(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    """EQ refuses a sync target across the meridian with ``e9#`` (§4.1); alt-az has no sides."""
    _goto_ha(ready, model, clock, -0.05, 20.0)
    assert ready.exact(protocol.set_target_ra(target_at(model, 0.05)).text) == "1"
    assert ready.ask(":CM#") == "N/A#"


def test_factory_park_is_equatorial_only(ready: MountClient) -> None:
    """§2.7: ``:hP#`` and ``:Sp01#`` are EQ-mode only (``:Sp01#`` code 4 "not in EQ mode", §4.2)."""
    assert ready.exact(":Sp01#") == "4"


def test_moves_through_the_zenith_keep_the_altitude_upright(
    ready: MountClient, model: MountModel, clock: ManualClock
) -> None:
    """From home (the zenith) a fast move cannot turn the azimuth at once; the altitude stays upright
    (the pointing lags in the keyhole), so tracking can start afterwards. Only settled tracking of a
    star through the zenith takes the altitude over the top (the e10 test above)."""
    for direction in ("w", "e", "w", "e", "n", "s", "n"):
        ready.send(":R9#")
        ready.send(f":M{direction}#")
        clock.advance(2.0)
        ready.send(f":Q{direction}#")
        clock.advance(3.0)
        assert model.axes()[1] <= 90.0
    assert ready.exact(":Te#") == "1"
    assert ready.ask(":GAT#") == "1#"
