"""The emulator's parts alone, with their collaborators passed in as ``MountModel`` passes them: the flash
settings (a lent lock, the physics' ``advance``), the hemisphere mapping of the axes to the sky.
"""

from __future__ import annotations

import threading

import pytest

from alpaca_zwo import sky
from alpaca_zwo.emulator.flash import FlashSettings
from alpaca_zwo.emulator.state import NORTH, SOUTH, Hemisphere, Persistent
from alpaca_zwo.zwo.firmware import preset
from alpaca_zwo.zwo.wire_values import MeridianSettings, MountMode


class Advances:
    """The model's ``advance`` as the flash sees it: counts the calls and checks the lent lock is held."""

    def __init__(self, lock: threading.RLock) -> None:
        self.lock = lock
        self.calls = 0

    def __call__(self) -> float:
        assert self.lock._is_owned(), "advance runs under the model's lock"
        self.calls += 1
        return 0.0


def _flash(**firmware: object) -> tuple[FlashSettings, Persistent, Advances]:
    lock = threading.RLock()
    advances = Advances(lock)
    persist = Persistent()
    return FlashSettings(persist=persist, firmware=preset(**firmware), lock=lock, advance=advances), persist, advances


def test_settings_that_change_motion_bring_the_physics_up_to_now_first() -> None:
    """A new meridian limit or top speed applies from now on, not retroactively: advance() runs first."""
    flash, persist, advances = _flash()
    assert flash.set_meridian(MeridianSettings(False, True, 5))
    assert advances.calls == 1 and persist.meridian == MeridianSettings(False, True, 5)
    assert flash.set_max_speed(720)
    assert advances.calls == 2 and flash.max_speed() == 720
    flash.set_buzzer(2)  # changes no motion: no advance
    assert advances.calls == 2 and flash.buzzer() == 2


@pytest.mark.parametrize(("setter", "value"), [
    ("set_upper_limit", 59), ("set_upper_limit", 91), ("set_lower_limit", -1), ("set_lower_limit", 31),
    ("set_max_speed", 1000),
])
def test_out_of_range_values_are_refused_and_change_nothing(setter: str, value: int) -> None:
    flash, persist, _ = _flash()
    before = (persist.upper_limit, persist.lower_limit, persist.max_speed)
    assert getattr(flash, setter)(value) is False
    assert (persist.upper_limit, persist.lower_limit, persist.max_speed) == before


def test_a_meridian_limit_outside_15_degrees_is_refused() -> None:
    flash, persist, advances = _flash()
    assert not flash.set_meridian(MeridianSettings(False, True, 16))
    assert persist.meridian == MeridianSettings() and advances.calls == 0


def test_a_mode_switch_and_a_bluetooth_name_take_effect_at_power_up() -> None:
    flash, persist, _ = _flash()
    before = flash.mode()
    other = MountMode.ALTAZ if before is MountMode.EQUATORIAL else MountMode.EQUATORIAL
    flash.request_mode(other)
    assert flash.mode() is before and persist.mode is other
    assert flash.set_ble_suffix("Dome1")
    assert not flash.ble_name().endswith("_Dome1")
    with flash._lock:  # power_up is for a caller holding the model's lock
        flash.power_up()
    assert flash.mode() is other and flash.ble_name().endswith("_Dome1")
    assert not flash.set_ble_suffix("no spaces")


@pytest.mark.parametrize("hemisphere", [NORTH, SOUTH])
@pytest.mark.parametrize("side", [sky.PierSide.EAST, sky.PierSide.WEST])
@pytest.mark.parametrize(("ha", "dec"), [(-3.0, 20.0), (2.5, -40.0), (0.0, 60.0), (-11.0, 0.0)])
def test_the_axes_for_a_place_point_back_at_it_on_the_asked_side(hemisphere: Hemisphere, side: sky.PierSide,
                                                                ha: float, dec: float) -> None:
    p, s = hemisphere.axes(ha, dec, side)
    back_ha, back_dec = hemisphere.ha_dec(p, s)
    assert sky.wrap_hours_12(back_ha - ha) == pytest.approx(0.0, abs=1e-9)
    assert back_dec == pytest.approx(dec, abs=1e-9)
    assert hemisphere.side(hemisphere.outer(side)) is side


def test_the_south_tracks_the_other_way_and_the_equator_counts_as_north() -> None:
    assert Hemisphere.of(0.0) is NORTH and Hemisphere.of(-0.1) is SOUTH
    assert NORTH.primary_rate(1.0) == 1.0 and SOUTH.primary_rate(1.0) == -1.0
    # pierEast has the Dec axis through the pole in the north, pierWest in the south.
    assert NORTH.outer(sky.PierSide.EAST) and SOUTH.outer(sky.PierSide.WEST)
