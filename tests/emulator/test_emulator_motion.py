"""Physics over TCP: GOTO, tracking, guiding, manual moves, pier side, meridian, limits, home,
park, sync and heavy-duty mode. Emulated time moves only through the ManualClock."""

from __future__ import annotations

import pytest

from alpaca_zwo import sky
from alpaca_zwo.emulator import EmulatorServer, ManualClock, MountModel
from alpaca_zwo.emulator.state import TRACKING_HORIZON_SLACK_DEG
from alpaca_zwo.sky import SIDEREAL_DEG_S
from alpaca_zwo.zwo import protocol, wire_values
from tests.emulator.emuclient import MountClient, flags, initialize, slew, target_at, wait_slew

ARCSEC = 1.0 / 3600.0
SIDEREAL_ARCSEC_S = SIDEREAL_DEG_S * 3600.0


def ra_arcsec(delta_hours: float) -> float:
    """An RA difference in arcseconds of RA (the unit guide rates are quoted in)."""
    return sky.wrap_hours_12(delta_hours) * 15.0 * 3600.0


def goto_ha(client: MountClient, model: MountModel, clock: ManualClock, ha: float, dec: float) -> float:
    """GOTO the point at hour angle ``ha`` now; returns the slew's emulated duration."""
    return slew(client, clock, target_at(model, ha), dec)


# --------------------------------------------------------------------------------------------
# GOTO and tracking
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("ha", "dec"), [(-3.0, 20.0), (3.0, 45.0), (-0.5, 60.0), (1.0, -10.0), (-8.0, 75.0)])
def test_goto_lands_within_one_arcsecond_with_tracking_on(
    ready: MountClient, model: MountModel, clock: ManualClock, ha: float, dec: float
) -> None:
    duration = goto_ha(ready, model, clock, ha, dec)
    assert duration > 3.0  # a real slew, not a jump
    ra, dec_now = model.position()
    target_ra, target_dec = model.target()
    assert sky.angular_separation(ra, dec_now, target_ra, target_dec) < ARCSEC
    assert ready.ask(":GR#") == ready.ask(":Gr#")
    assert ready.ask(":GD#") == ready.ask(":Gd#")
    assert ready.ask(":GAT#") == "1#"
    assert "n" not in flags(ready)


def test_slew_reports_busy_until_it_really_ends(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    assert ready.exact(protocol.set_target_ra(target_at(model, -2.0)).text) == "1"
    assert ready.exact(":Sd+10*00:00#") == "1"
    assert ready.exact(":MS#") == "0"
    clock.advance(5.0)
    assert "N" not in flags(ready)
    ra, dec = model.position()
    assert sky.angular_separation(ra, dec, *model.target()) > 10.0  # still far away
    wait_slew(ready, clock, step=0.1)
    assert sky.angular_separation(*model.position(), *model.target()) < ARCSEC


def test_tracking_holds_ra_and_dec_for_an_hour(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    goto_ha(ready, model, clock, -2.0, 35.0)
    ra_text, dec_text = ready.ask(":Gr#"), ready.ask(":Gd#")
    start = model.position()
    for _ in range(60):
        clock.advance(60.0)
        assert ready.ask(":GR#") == ra_text
        assert ready.ask(":GD#") == dec_text
    assert sky.angular_separation(*model.position(), *start) < 0.1 * ARCSEC


def test_ra_drifts_with_sidereal_time_when_not_tracking(
    ready: MountClient, model: MountModel, clock: ManualClock
) -> None:
    goto_ha(ready, model, clock, -2.0, 35.0)
    assert ready.exact(":Td#") == "1"
    assert ready.ask(":GAT#") == "0#"
    ra0, dec0 = model.position()
    clock.advance(600.0)
    ra1, dec1 = model.position()
    assert ra_arcsec(ra1 - ra0) == pytest.approx(600.0 * SIDEREAL_ARCSEC_S, abs=0.1)
    assert dec1 == pytest.approx(dec0, abs=1e-9)


@pytest.mark.parametrize(("request_text", "rate"), [(":TQ#", 15.041), (":TS#", 15.0), (":TL#", 14.685)])
def test_tracking_rates_move_the_ra_axis_at_their_speed(
    ready: MountClient, model: MountModel, clock: ManualClock, request_text: str, rate: float
) -> None:
    goto_ha(ready, model, clock, -2.0, 35.0)
    ready.send(request_text)
    primary0, _ = model.axes()
    clock.advance(100.0)
    primary1, _ = model.axes()
    assert (primary1 - primary0) * 3600.0 / 100.0 == pytest.approx(rate, abs=0.002)


def test_goto_during_goto_is_refused_with_e3(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    ready.exact(protocol.set_target_ra(target_at(model, -2.0)).text)
    ready.exact(":Sd+20*00:00#")
    assert ready.exact(":MS#") == "0"
    clock.advance(1.0)
    assert ready.exact(":MS#") == "e3#"
    assert ready.exact(":Td#") == "0"  # tracking cannot be switched off mid-GOTO (ZWO v2.1)
    ready.send(":Q#")  # INDI: abort, then re-target (once the axes have braked, see the next test)
    clock.advance(3.0)  # 1440x brakes in 2 s at 3 deg/s^2
    assert "N" in flags(ready)
    assert ready.exact(":MS#") == "0"
    wait_slew(ready, clock)
    assert sky.angular_separation(*model.position(), *model.target()) < ARCSEC


def test_goto_while_a_stopped_slew_brakes_is_refused_with_e3(
    ready: MountClient, model: MountModel, clock: ManualClock
) -> None:
    """After :Q# the firmware stays in its GOTO state until both motors have stopped (README,
    "GOTO during braking"): no N in :GU# and e3# for a GOTO until then, a GOTO accepted after."""
    ready.exact(protocol.set_target_ra(target_at(model, 3.0)).text)
    ready.exact(":Sd+20*00:00#")
    assert ready.exact(":MS#") == "0"
    clock.advance(4.0)  # at full speed on at least one axis
    speed = max(abs(v) for v in model.snapshot()["velocity_deg_s"])
    assert speed > 5.0
    ready.send(":Q#")
    clock.advance(0.1)  # INDI re-targets 100 ms after its abort
    assert "N" not in flags(ready)
    assert ready.exact(":MS#") == "e3#"
    assert model.snapshot()["braking"]
    clock.advance(speed / 3.0)  # the rest of the braking at 3 deg/s^2
    assert not model.snapshot()["braking"]
    assert "N" in flags(ready)
    assert ready.exact(":MS#") == "0"
    wait_slew(ready, clock)
    assert sky.angular_separation(*model.position(), *model.target()) < ARCSEC


def test_abort_stops_the_slew_and_keeps_the_tracking_setting(
    ready: MountClient, model: MountModel, clock: ManualClock
) -> None:
    assert ready.exact(":Te#") == "1"
    ready.exact(protocol.set_target_ra(target_at(model, 3.0)).text)
    ready.exact(":Sd+20*00:00#")
    assert ready.exact(":MS#") == "0"
    clock.advance(4.0)
    ready.send(":Q#")
    clock.advance(5.0)  # time to brake
    assert ready.ask(":GAT#") == "1#"
    assert sky.angular_separation(*model.position(), *model.target()) > 10.0
    assert model.snapshot()["velocity_deg_s"][1] == 0.0


# --------------------------------------------------------------------------------------------
# Guiding and manual moves
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("ha", [-2.0, 2.0])  # both pier sides
def test_north_pulse_of_one_second_at_half_sidereal_moves_dec_7_5_arcsec(
    ready: MountClient, model: MountModel, clock: ManualClock, ha: float
) -> None:
    goto_ha(ready, model, clock, ha, 30.0)
    ready.send(":Rg0.50#")
    ra0, dec0 = model.position()
    ready.send(":Mgn1000#")
    assert model.pulsing() == (False, True)
    clock.advance(0.5)
    assert model.pulsing() == (False, True)
    clock.advance(1.5)
    assert model.pulsing() == (False, False)
    ra1, dec1 = model.position()
    assert (dec1 - dec0) * 3600.0 == pytest.approx(7.52, abs=0.5)
    assert (dec1 - dec0) * 3600.0 == pytest.approx(0.5 * SIDEREAL_ARCSEC_S, abs=0.01)
    assert abs(ra_arcsec(ra1 - ra0)) < 0.01  # no cross-axis motion


def test_simultaneous_ra_and_dec_pulses(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    goto_ha(ready, model, clock, -2.0, 30.0)
    ra0, dec0 = model.position()
    ready.send(":Mge1000#:Mgs0500#")
    assert model.pulsing() == (True, True)
    clock.advance(3.0)
    ra1, dec1 = model.position()
    assert ra_arcsec(ra1 - ra0) == pytest.approx(0.5 * SIDEREAL_ARCSEC_S, abs=0.01)  # east: RA up
    assert (dec1 - dec0) * 3600.0 == pytest.approx(-0.25 * SIDEREAL_ARCSEC_S, abs=0.01)
    ready.send(":Mgw2000#")
    clock.advance(3.0)
    assert ra_arcsec(model.position()[0] - ra1) == pytest.approx(-SIDEREAL_ARCSEC_S, abs=0.01)


def test_new_pulse_replaces_old_and_long_pulses_are_clamped(
    ready: MountClient, model: MountModel, clock: ManualClock
) -> None:
    goto_ha(ready, model, clock, -2.0, 30.0)
    _, dec0 = model.position()
    ready.send(":Mgn3000#")
    clock.advance(0.5)
    ready.send(":Mgn0500#")
    clock.advance(4.0)
    _, dec1 = model.position()
    assert (dec1 - dec0) * 3600.0 == pytest.approx(1.0 * 0.5 * SIDEREAL_ARCSEC_S, abs=0.01)
    ready.send(":Rg0.90#")
    ready.send(":Mgs05000#")  # INDI sends five digits for long pulses: 3000 ms at most
    clock.advance(6.0)
    _, dec2 = model.position()
    assert (dec2 - dec1) * 3600.0 == pytest.approx(-3.0 * 0.9 * SIDEREAL_ARCSEC_S, abs=0.01)


def test_guide_rate_from_the_v11_times_15_form(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    goto_ha(ready, model, clock, -2.0, 30.0)
    ready.send(":Rg1.5#")  # 0.1 x sidereal
    assert ready.ask(":Ggr#") == "0.10#"
    _, dec0 = model.position()
    ready.send(":Mgn2000#")
    clock.advance(3.0)
    assert (model.position()[1] - dec0) * 3600.0 == pytest.approx(0.2 * SIDEREAL_ARCSEC_S, abs=0.01)


def test_stop_cancels_pulses(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    goto_ha(ready, model, clock, -2.0, 30.0)
    _, dec0 = model.position()
    ready.send(":Mgn3000#")
    clock.advance(1.0)
    ready.send(":Q#")
    clock.advance(3.0)
    assert (model.position()[1] - dec0) * 3600.0 == pytest.approx(0.5 * SIDEREAL_ARCSEC_S, abs=0.05)
    assert ready.ask(":GAT#") == "1#"  # :Q# leaves tracking alone


@pytest.mark.parametrize("tracking", [True, False])
def test_manual_move_at_720x_for_one_second_moves_about_three_degrees(
    ready: MountClient, model: MountModel, clock: ManualClock, tracking: bool
) -> None:
    goto_ha(ready, model, clock, -3.0, 20.0)
    if not tracking:
        assert ready.exact(":Td#") == "1"
    ra0, dec0 = model.position()
    ready.send(":R8#")
    ready.send(":Me#")
    assert "N" in flags(ready)  # manual moves do not clear N
    clock.advance(1.0)
    ready.send(":Qe#")
    clock.advance(3.0)
    ra1, dec1 = model.position()
    drift = 0.0 if tracking else 4.0 * SIDEREAL_DEG_S  # RA also drifts with LST when not tracking
    assert sky.wrap_hours_12(ra1 - ra0) * 15.0 - drift == pytest.approx(3.0, abs=0.1)
    assert dec1 == pytest.approx(dec0, abs=1e-9)


@pytest.mark.parametrize("ha", [-2.0, 2.0])
def test_north_and_south_are_sky_relative_on_both_pier_sides(
    ready: MountClient, model: MountModel, clock: ManualClock, ha: float
) -> None:
    goto_ha(ready, model, clock, ha, 30.0)
    _, dec0 = model.position()
    ready.send(":R7#")  # 60x = 0.25 deg/s
    ready.send(":Mn#")
    clock.advance(2.0)
    ready.send(":Qn#")
    clock.advance(1.0)
    _, dec1 = model.position()
    assert dec1 - dec0 == pytest.approx(2.0 * 60.0 * SIDEREAL_DEG_S, abs=0.01)
    ready.send(":Ms#")
    clock.advance(2.0)
    ready.send(":Qs#")
    clock.advance(1.0)
    assert model.position()[1] == pytest.approx(dec0, abs=0.001)


def test_axes_stop_independently(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    goto_ha(ready, model, clock, -3.0, 30.0)
    ready.send(":R6#")  # 20x
    ready.send(":Mw#:Mn#")
    clock.advance(2.0)
    ready.send(":Qw#")
    clock.advance(1.0)
    ra1, dec1 = model.position()
    clock.advance(1.0)
    ra2, dec2 = model.position()
    assert abs(ra_arcsec(ra2 - ra1)) < 0.01  # RA stopped (and tracking again)
    assert (dec2 - dec1) == pytest.approx(20.0 * SIDEREAL_DEG_S, rel=1e-6)  # Dec still moving
    ready.send(":Qn#")
    clock.advance(1.0)
    _, dec3 = model.position()
    clock.advance(1.0)
    assert model.position()[1] == pytest.approx(dec3, abs=1e-9)


def test_variable_rate_is_latched_when_the_move_starts(
    ready: MountClient, model: MountModel, clock: ManualClock
) -> None:
    goto_ha(ready, model, clock, -3.0, 30.0)
    ready.send(":Rv100#")
    ready.send(":Mn#")
    ready.send(":Rv10#")  # no effect on the running move...
    clock.advance(2.0)
    _, dec1 = model.position()
    clock.advance(1.0)
    _, dec2 = model.position()
    assert dec2 - dec1 == pytest.approx(100.0 * SIDEREAL_DEG_S, rel=1e-6)
    ready.send(":Mn#")  # ...until the move is sent again
    clock.advance(2.0)
    _, dec3 = model.position()
    clock.advance(1.0)
    assert model.position()[1] - dec3 == pytest.approx(10.0 * SIDEREAL_DEG_S, rel=1e-6)
    ready.send(":Rvd5#")  # per-axis rate for Dec only (fw 1.8.8)
    ready.send(":Mn#")
    clock.advance(2.0)
    _, dec4 = model.position()
    clock.advance(1.0)
    assert model.position()[1] - dec4 == pytest.approx(5.0 * SIDEREAL_DEG_S, rel=1e-6)


# --------------------------------------------------------------------------------------------
# Pier side and meridian
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("ha", "letter"), [(-3.0, "W"), (-9.0, "W"), (-0.02, "W"), (0.02, "E"), (3.0, "E"), (9.0, "E")]
)
def test_pier_side_after_goto_follows_the_hour_angle(
    ready: MountClient, model: MountModel, clock: ManualClock, ha: float, letter: str
) -> None:
    goto_ha(ready, model, clock, ha, 70.0)
    assert ready.ask(":Gm#") == letter + "#"
    ra, _ = model.position()
    expected = sky.pointing_state(sky.hour_angle(model.clock_site.sidereal_time(), ra))
    assert (letter == "W") == (expected is sky.PierSide.WEST)


def test_flip_swings_through_the_pole_and_takes_longer(
    ready: MountClient, model: MountModel, clock: ManualClock
) -> None:
    goto_ha(ready, model, clock, -0.5, 30.0)
    assert ready.ask(":Gm#") == "W#"
    ready.exact(protocol.set_target_ra(target_at(model, 0.5)).text)
    assert ready.exact(":MS#") == "0"
    highest = 0.0
    elapsed = 0.0
    while "N" not in flags(ready):
        clock.advance(0.25)
        elapsed += 0.25
        highest = max(highest, model.axes()[1])
    assert highest > 90.0  # the Dec axis went through the pole
    assert elapsed > 25.0  # ~180 deg of primary axis at 6 deg/s
    assert ready.ask(":Gm#") == "E#"
    assert sky.angular_separation(*model.position(), *model.target()) < ARCSEC


@pytest.mark.parametrize(
    ("setting", "limit", "ha", "letter"),
    [("01+10", 10.0, 0.3, "W"), ("00+10", 0.0, 0.3, "E"), ("00-10", -10.0, -0.3, "E"), ("00-10", -10.0, -0.9, "W")],
)
def test_meridian_limit_decides_the_goto_side(
    ready: MountClient, model: MountModel, clock: ManualClock, setting: str, limit: float, ha: float, letter: str
) -> None:
    """Tracking past the meridian (t=1) lets the west side reach past it; a negative limit makes
    targets just before the meridian go to the flipped side (``sky.goto_pier_side``)."""
    assert ready.exact(f":STa{setting}#") == "1"
    goto_ha(ready, model, clock, ha, 40.0)
    assert ready.ask(":Gm#") == letter + "#"
    ra, _ = model.position()
    expected = sky.goto_pier_side(sky.hour_angle(model.clock_site.sidereal_time(), ra), sky.PierSide.UNKNOWN, limit)
    assert (letter == "W") == (expected is sky.PierSide.WEST)


def test_factory_setting_stops_tracking_one_degree_past_the_meridian(
    ready: MountClient, model: MountModel, clock: ManualClock
) -> None:
    goto_ha(ready, model, clock, -0.05, 20.0)  # 3 minutes before the meridian, west side
    assert ready.ask(":Gm#") == "W#"
    clock.advance(6 * 60.0)  # 3 minutes past: still tracking
    assert ready.ask(":GAT#") == "1#"
    clock.advance(2 * 60.0)  # 5 minutes past (1.25 deg): stopped
    assert ready.ask(":GAT#") == "e8#"
    assert "n" in flags(ready)
    primary, _ = model.axes()
    assert primary == pytest.approx(1.0, abs=0.01)  # stopped right at +1 deg
    assert ready.exact(":Te#") == "0"
    assert ready.ask(":GAT#") == "e8#"
    ra0, _ = model.position()
    clock.advance(60.0)
    assert ra_arcsec(model.position()[0] - ra0) == pytest.approx(60.0 * SIDEREAL_ARCSEC_S, abs=0.1)
    # A GOTO away (here: the same target, now across the meridian) clears it.
    assert ready.exact(":MS#") == "0"
    wait_slew(ready, clock)
    assert ready.ask(":Gm#") == "E#"
    assert ready.ask(":GAT#") == "1#"


@pytest.mark.parametrize(("setting", "stop_deg"), [("01+05", 5.0), ("00+05", 1.0), ("01-05", -5.0)])
def test_meridian_settings_move_the_tracking_stop(
    ready: MountClient, model: MountModel, clock: ManualClock, setting: str, stop_deg: float
) -> None:
    assert ready.exact(f":STa{setting}#") == "1"
    goto_ha(ready, model, clock, -0.7, 20.0)  # 10.5 deg before the meridian
    assert ready.ask(":Gm#") == "W#"
    minutes_to_stop = (stop_deg + 10.5) * 4.0 / 1.0027
    clock.advance((minutes_to_stop - 1.0) * 60.0)
    assert ready.ask(":GAT#") == "1#"
    clock.advance(2.0 * 60.0)
    assert ready.ask(":GAT#") == "e8#"
    assert model.axes()[0] == pytest.approx(stop_deg, abs=0.01)


def test_tracking_stops_at_the_horizon(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    goto_ha(ready, model, clock, 5.0, -5.0)  # low in the west, setting within the hour
    assert ready.ask(":GAT#") == "1#"
    for _ in range(120):
        clock.advance(60.0)
        if ready.ask(":GAT#") != "1#":
            break
    assert ready.ask(":GAT#") == "e5#"
    # at the horizon, less the firmware's slack (docs/southern.md, assumption 13)
    assert model.horizontal()[0] == pytest.approx(-TRACKING_HORIZON_SLACK_DEG, abs=0.05)
    assert ready.exact(":Te#") == "0"


# --------------------------------------------------------------------------------------------
# Limits
# --------------------------------------------------------------------------------------------


def test_goto_below_the_horizon_is_refused_with_e5(ready: MountClient, model: MountModel) -> None:
    ready.exact(protocol.set_target_ra(target_at(model, 0.0)).text)
    assert ready.exact(":Sd-70*00:00#") == "1"  # never rises at +31 deg
    assert ready.exact(":MS#") == "e5#"
    assert "N" in flags(ready)


def test_altitude_limits_refuse_with_e6_only_when_enabled(
    ready: MountClient, model: MountModel, clock: ManualClock
) -> None:
    ra = target_at(model, 0.0)
    ready.exact(protocol.set_target_ra(ra).text)
    ready.exact(":Sd-48*00:00#")  # on the meridian at about 10.7 deg altitude
    assert ready.exact(":SLL20#") == "1"
    assert ready.exact(":MS#") == "0"  # limits are off
    ready.send(":Q#")
    assert ready.exact(":SLE#") == "1"
    assert ready.exact(":MS#") == "e6#"
    ready.exact(":Sd+60*00:00#")  # about 61 deg: fine
    assert ready.exact(":MS#") == "0"
    ready.send(":Q#")
    assert ready.exact(":SLH60#") == "1"
    ready.exact(":Sd+30*00:00#")  # about 89 deg: above the upper limit
    assert ready.exact(":MS#") == "e6#"
    assert ready.exact(":SLD#") == "1"
    assert ready.exact(":MS#") == "0"


# --------------------------------------------------------------------------------------------
# Home, park
# --------------------------------------------------------------------------------------------


def test_home_slew_ends_at_the_pole_with_tracking_off_and_h(
    ready: MountClient, model: MountModel, clock: ManualClock
) -> None:
    goto_ha(ready, model, clock, 2.0, 20.0)
    assert "H" not in flags(ready)
    ready.send(":hC#")
    assert "N" not in flags(ready)
    wait_slew(ready, clock)
    assert flags(ready) == "nNHG"
    assert ready.ask(":Gm#") == "N#"
    assert ready.ask(":GD#") == "+90*00:00#"
    assert ready.ask(":GAT#") == "0#"
    lst = wire_values.parse_hms(ready.ask(":GS#")[:-1])
    ra = wire_values.parse_hms(ready.ask(":GR#")[:-1])
    assert sky.wrap_hours_12(ra - lst - 6.0) == pytest.approx(0.0, abs=1.5 / 3600)
    assert ready.exact(":Te#") == "1"  # tracking leaves home...
    clock.advance(10.0)
    assert "H" not in flags(ready)  # ...and H goes
    assert ready.ask(":Gm#") != "N#"


def test_park_latch_survives_a_reboot_until_unpark(
    emu: EmulatorServer, ready: MountClient, model: MountModel, clock: ManualClock, connect: object
) -> None:
    goto_ha(ready, model, clock, -2.0, 40.0)
    ready.send(":hP#")
    assert ready.ask(":Gps#") == "1#"
    wait_slew(ready, clock)
    assert ready.ask(":Gps#") == "2#"
    assert ready.ask(":GD#") == "+00*00:00#"  # factory park: OTA horizontal, counterweight down
    assert ready.ask(":GAT#") == "0#"
    assert model.horizontal()[0] == pytest.approx(0.0, abs=0.01)
    emu.faults.reboot(0.0)
    client = connect()  # type: ignore[operator]
    assert client.ask(":GC#") == "01/01/00#"  # a real power cycle...
    assert client.ask(":Gps#") == "2#"  # ...but the latch is in flash
    initialize(client, clock)
    client.exact(protocol.set_target_ra(target_at(model, -2.0)).text)
    client.exact(":Sd+40*00:00#")
    assert client.exact(":MS#") == "e4#"  # parked: refused
    assert client.exact(":Te#") == "0"
    assert client.exact(":Spu#") == "1"
    assert client.ask(":Gps#") == "0#"
    assert client.exact(":Spu#") == "0"
    assert client.exact(":MS#") == "0"


def test_custom_park_position_needs_a_home_first(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    assert ready.exact(":Sp01#") == "5"
    ready.send(":hC#")
    assert ready.exact(":Sp01#") == "9"  # moving
    assert ready.exact(":MS#") == "e3#"  # no GOTO while homing
    wait_slew(ready, clock)
    goto_ha(ready, model, clock, -1.0, 50.0)
    assert ready.exact(":Sp01#") == "1"
    stored = model.axes()
    goto_ha(ready, model, clock, 2.0, 10.0)
    ready.send(":hP#")
    wait_slew(ready, clock)
    assert model.axes() == pytest.approx(stored, abs=1e-6)
    assert ready.ask(":Gps#") == "2#"


def test_set_current_position_as_home(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    goto_ha(ready, model, clock, -2.0, 40.0)
    ready.send(":R6#:Mn#")
    assert ready.exact(":SOa#") == "0"  # not while moving
    ready.send(":Q#")
    clock.advance(2.0)
    assert ready.exact(":Td#") == "1"
    assert ready.exact(":SOa#") == "1"
    assert ready.ask(":Gm#") == "N#"
    assert ready.ask(":GD#") == "+90*00:00#"


def test_persistent_settings_survive_a_reboot_and_volatile_ones_do_not(
    emu: EmulatorServer, ready: MountClient, connect: object, clock: ManualClock
) -> None:
    for request in (":SLL05#", ":SLH80#", ":SLE#", ":SRl720#", ":STa01+05#"):
        assert ready.exact(request) == "1"
    ready.send(":Rg0.30#:SBu2#:AA#:TL#")
    assert ready.exact(":SBlNEW001#") == "1"
    emu.faults.reboot(0.0)
    client = connect()  # type: ignore[operator]
    kept = {
        ":GLL#": "5#",
        ":GLH#": "80#",
        ":GLC#": "1#",
        ":GRl#": "720#",
        ":GTa#": "01+05#",
        ":Ggr#": "0.30#",
        ":GBu#": "2#",
        ":GU#": "nNZ000000000#",
        ":GBl#": "AM5_NEW001#",
    }
    for request, reply in kept.items():
        assert client.ask(request) == reply, request
    lost = {":GC#": "01/01/00#", ":GG#": "+00:00#", ":Gt#": "+31*15:41#", ":GT#": "0#", ":Gm#": "N#"}
    for request, reply in lost.items():
        assert client.ask(request) == reply, request
    assert client.exact(":Sp01#") == "4"  # alt-az mode now


# --------------------------------------------------------------------------------------------
# Sync
# --------------------------------------------------------------------------------------------


def test_sync_offsets_the_reported_position_until_cleared(
    ready: MountClient, model: MountModel, clock: ManualClock
) -> None:
    goto_ha(ready, model, clock, -2.0, 30.0)
    ra, dec = model.target()
    ready.exact(protocol.set_target_ra(ra + 2.0 / 60.0).text)
    ready.exact(protocol.set_target_dec(dec + 0.3).text)
    assert ready.exact(":CM#") == "N/A#"
    assert ready.ask(":GR#") == ready.ask(":Gr#")
    assert ready.ask(":GD#") == ready.ask(":Gd#")
    clock.advance(600.0)  # the offset holds while tracking
    assert ready.ask(":GR#") == ready.ask(":Gr#")
    # a GOTO after the sync lands on the synced frame
    goto_ha(ready, model, clock, -1.0, 45.0)
    assert sky.angular_separation(*model.position(), *model.target()) < ARCSEC
    assert ready.exact(":NSC#") == "1"
    assert model.snapshot()["alignment_points"] == 0
    ra_raw, dec_raw = model.position()
    assert sky.angular_separation(ra_raw, dec_raw, *model.target()) > 0.25


def test_sync_refusals(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    ready.exact(":Sr10:00:00#")
    ready.exact(":Sd+30*00:00#")
    assert ready.exact(":CM#") == "e11#"  # at home
    goto_ha(ready, model, clock, -2.0, 87.0)
    assert ready.exact(":CM#") == "e11#"  # near the pole
    goto_ha(ready, model, clock, -0.3, 30.0)
    ready.exact(protocol.set_target_ra(target_at(model, 0.3)).text)
    assert ready.exact(":CM#") == "e9#"  # other side of the meridian
    ready.exact(protocol.set_target_ra(target_at(model, -2.0)).text)
    assert ready.exact(":CM#") == "e12#"  # 25 deg away
    assert ready.exact(":MS#") == "0"
    assert ready.exact(":CM#") == "e4#"  # during a GOTO


# --------------------------------------------------------------------------------------------
# Heavy duty
# --------------------------------------------------------------------------------------------


def test_heavy_duty_caps_slews_and_moves_at_720x(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    fast = goto_ha(ready, model, clock, -4.0, 0.0)
    ready.send(":hC#")
    wait_slew(ready, clock)
    assert ready.exact(":SRl720#") == "1"
    slow = goto_ha(ready, model, clock, -4.0, 0.0)
    assert slow > fast * 1.6
    ready.send(":R9#:Mn#")
    clock.advance(3.0)
    assert abs(model.snapshot()["velocity_deg_s"][1]) == pytest.approx(720 * SIDEREAL_DEG_S, rel=1e-9)
    ready.send(":Q#")
    assert ready.exact(":SRl1440#") == "1"
    ready.send(":Ms#")
    clock.advance(5.0)  # brake from +720x, then accelerate to -1440x
    assert abs(model.snapshot()["velocity_deg_s"][1]) == pytest.approx(1440 * SIDEREAL_DEG_S, rel=1e-9)


def test_physics_is_deterministic_for_the_same_clock_readings(clock: ManualClock) -> None:
    def run() -> tuple[float, float]:
        local = ManualClock(clock.now())
        model = MountModel(local, initialized=True)
        model.set_target_ra(sky.ra_from_hour_angle(model.clock_site.sidereal_time(), 2.0))
        model.set_target_dec(25.0)
        assert model.goto() == 0
        for step in (0.3, 1.7, 0.05, 4.0, 12.5, 0.01, 30.0):
            local.advance(step)
            model.position()
        return model.axes()

    assert run() == run()


def test_initialize_helper_reads_back(ready: MountClient, clock: ManualClock) -> None:
    assert ready.ask(":GC#") == f"{clock.now():%m/%d/%y}#"
    initialize(ready, clock, utc_offset_hours=-5.0)
    assert ready.ask(":GG#") == "+05:00#"
