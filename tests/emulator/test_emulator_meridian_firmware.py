"""Meridian settings exist only from firmware 1.2.4 (field notes §5.6: INDIGO asks for :GTa# only then).

Older builds treat :STa/:GTa like any command they do not know: no reply at all (field notes §2.9),
and the stored setting is untouched. From 1.2.4 on both answer as documented (§2.8).
"""

from __future__ import annotations

import pytest

from alpaca_zwo.emulator import FirmwareVariant, MountModel
from alpaca_zwo.zwo.wire_values import MeridianSettings
from tests.emulator.emuclient import MountClient

OLD = ["0.9.9", "1.1.2", "1.2.3"]
NEW = ["1.2.4", "1.9.2"]


@pytest.fixture(params=OLD + NEW)
def firmware(request: pytest.FixtureRequest) -> FirmwareVariant:
    return FirmwareVariant(version=request.param)


def test_meridian_commands_follow_the_firmware(mount: MountClient, model: MountModel,
                                               firmware: FirmwareVariant) -> None:
    if firmware.version in OLD:
        mount.assert_silent(":GTa#")
        mount.assert_silent(":STa01+05#")
        assert model.flash.meridian() == MeridianSettings()
        assert mount.ask(":GVP#") == "AM5#"  # still in step: the silence left nothing behind
        return
    assert mount.ask(":GTa#") == "00+00#"  # factory setting
    assert mount.ask(":STa01+05#") == "1"
    assert mount.ask(":GTa#") == "01+05#"
    assert model.flash.meridian() == MeridianSettings(flip=False, track_after=True, limit_degrees=5)
