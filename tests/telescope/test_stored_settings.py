"""The mount's stored settings' one owner (``telescope/stored_settings.py``) alone, on the real emulator:
one check, one write path with the configuration's meridian mirror, its restore, the setting in force.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from alpaca_zwo._exceptions import AlpacaZwoError, InvalidValue
from alpaca_zwo.config.file import load_settings
from alpaca_zwo.telescope.stored_settings import CHECKS, NAMES
from alpaca_zwo.zwo.wire_values import MeridianSettings
from tests.support import wait_until
from tests.telescope.parts import closed_port, parts_rig, with_limits


def test_apply_writes_every_setting_to_the_mount_and_mirrors_the_meridian(tmp_path: Path) -> None:
    with parts_rig(tmp_path) as rig:
        rig.mount.connect()
        stored = rig.stored_settings()
        meridian = MeridianSettings(False, True, 7)
        stored.apply({"buzzer": 2, "heavy_duty": True, "meridian": meridian, "upper_limit": 80, "lower_limit": 12,
                      "limits_enabled": True})
        flash = rig.model.flash
        wait_until(lambda: flash.buzzer() == 2, 5.0, "the buzzer level (:SBu has no reply: it may land a moment later)")
        assert (flash.max_speed(), flash.meridian()) == (720, meridian)
        assert flash.limits_enabled() and flash.altitude_limits() == (12, 80)  # (lower, upper)
        # The configuration holds it (pushed on every connect), in memory and in the file.
        limits = rig.settings.limits
        assert (limits.meridian_track_past, limits.meridian_limit_deg) == (True, 7)
        assert load_settings(tmp_path / "config.toml").limits.meridian_limit_deg == 7
        # The setting in force, which DestinationSideOfPier and the GOTO side use.
        assert stored.meridian == meridian and stored.flip_line_deg() == 7.0
        assert stored.read().meridian == meridian


@pytest.mark.parametrize("changes", [
    {"buzzer": 1, "upper_limit": 50},  # one bad value: nothing at all is sent
    {"buzzer": 1, "meridian": MeridianSettings(False, True, 20)},
    {"buzzer": True},
    {"heavy_duty": 1},
    {"meridian": "00+05"},
    {"buzzer": 1, "mode": "altaz"},  # not a stored setting this owner writes
])
def test_a_bad_value_changes_nothing(tmp_path: Path, changes: dict[str, object]) -> None:
    with parts_rig(tmp_path) as rig:
        rig.mount.connect()
        stored = rig.stored_settings()
        before = (rig.model.flash.buzzer(), rig.model.flash.meridian(), rig.settings.limits)
        with pytest.raises(InvalidValue):
            stored.apply(changes)
        assert (rig.model.flash.buzzer(), rig.model.flash.meridian(), rig.settings.limits) == before
        assert stored.meridian == MeridianSettings()


def test_a_mount_that_cannot_take_it_gets_the_mirror_put_back(tmp_path: Path) -> None:
    """The configuration is saved first (a failed save changes nothing), so when the mount then fails
    the mirror goes back: file, memory and mount agree."""
    with parts_rig(tmp_path, url=f"socket://127.0.0.1:{closed_port()}",
                   settings=with_limits(meridian_track_past=False, meridian_limit_deg=-3.0)) as rig:
        stored = rig.stored_settings()
        before = rig.settings.limits
        with pytest.raises(AlpacaZwoError):
            stored.apply({"meridian": MeridianSettings(False, True, 9)})
        assert rig.settings.limits == before
        assert stored.meridian == MeridianSettings()  # not remembered: the mount never took it


def test_push_configured_reads_the_mount_then_writes_the_configured_setting(tmp_path: Path) -> None:
    with parts_rig(tmp_path, settings=with_limits(meridian_track_past=False, meridian_limit_deg=-10.0)) as rig:
        assert rig.model.flash.set_meridian(MeridianSettings(False, True, 5))
        rig.mount.connect()
        stored = rig.stored_settings()
        assert stored.configured_meridian() == MeridianSettings(False, False, -10)
        stored.push_configured()
        assert rig.model.flash.meridian() == MeridianSettings(False, False, -10)
        assert stored.meridian == MeridianSettings(False, False, -10)
        # A negative limit is the flip line whatever "track past" says (sky.flip_line_deg).
        assert stored.flip_line_deg() == -10.0


def test_every_written_setting_has_its_check() -> None:
    """The Actions and the page take their range checks from CHECKS: one rule per value."""
    assert set(NAMES) - {"meridian"} <= set(CHECKS)
    assert {"meridian.track_after", "meridian.limit_degrees"} <= set(CHECKS)
    with pytest.raises(ValueError, match="from 60 to 90"):
        CHECKS["upper_limit"](91)
    assert CHECKS["lower_limit"](0) == 0
