"""Each firmware-variant switch changes exactly the replies it is meant to (field notes §5.6, §6).

The ``firmware`` fixture is overridden by direct parametrisation, so each test runs a server
whose mount has that variant from power-up.
"""

from __future__ import annotations

import pytest

from alpaca_zwo.emulator import PRESETS, FirmwareVariant, ManualClock, MountModel, preset
from alpaca_zwo.sky import SIDEREAL_DEG_S
from alpaca_zwo.zwo import wire_values
from alpaca_zwo.zwo.firmware import has_feature
from tests.emulator.emuclient import MountClient, flags, slew, target_at, wait_slew


@pytest.mark.parametrize("firmware", [FirmwareVariant(home_flag="always_at_home")])
def test_home_flag_always_at_home_shows_h_from_power_up(
    mount: MountClient, ready: MountClient, model: MountModel, clock: ManualClock
) -> None:
    assert flags(mount) == "nNHG"
    slew(ready, clock, target_at(model, -2.0), 30.0)
    assert "H" not in flags(ready)
    ready.send(":hC#")
    wait_slew(ready, clock)
    assert flags(ready) == "nNHG"


@pytest.mark.parametrize("firmware", [FirmwareVariant(home_flag="never")])
def test_home_flag_never_hides_h_even_after_a_home(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    slew(ready, clock, target_at(model, -2.0), 30.0)
    ready.send(":hC#")
    wait_slew(ready, clock)
    assert flags(ready) == "nNG"
    assert ready.ask(":Gm#") == "N#"  # it is at home all the same


def test_home_flag_after_home_is_the_default(mount: MountClient, clock: ManualClock) -> None:
    assert flags(mount) == "nNG"  # at home since power-up, but no home slew yet (AM5N fw 1.6.3)
    mount.send(":hC#")
    wait_slew(mount, clock)
    assert flags(mount) == "nNHG"


@pytest.mark.parametrize(
    ("firmware", "expected"),
    [
        (FirmwareVariant(gt_mapping="english"), {":TQ#": "0#", ":TS#": "1#", ":TL#": "2#"}),
        (FirmwareVariant(gt_mapping="chinese"), {":TQ#": "0#", ":TS#": "2#", ":TL#": "1#"}),
    ],
)
def test_gt_mapping(mount: MountClient, expected: dict[str, str]) -> None:
    for request, reply in expected.items():
        mount.send(request)
        assert mount.ask(":GT#") == reply


@pytest.mark.parametrize("firmware", [FirmwareVariant(gps_reply="empty")])
def test_gps_empty_reply(mount: MountClient, clock: ManualClock) -> None:
    assert mount.exact(":Gps#") == "#"
    mount.send(":hP#")
    assert mount.exact(":Gps#") == "#"
    wait_slew(mount, clock)
    assert mount.exact(":Gps#") == "#"
    assert mount.exact(":Spu#") == "1"  # the latch is there even though :Gps# does not say so


@pytest.mark.parametrize("firmware", [FirmwareVariant(hp_reply="1#")])
def test_hp_reply_variant_answers_1_or_0(mount: MountClient, model: MountModel) -> None:
    assert mount.exact(":hP#") == "1#"
    mount.send(":AA#")
    model.power_cycle()
    assert mount.exact(":hP#") == "0#"  # alt-az mode: EQ only


@pytest.mark.parametrize(
    ("firmware", "before", "after"),
    [
        (FirmwareVariant(gh_reply="empty"), "#", "#"),
        (FirmwareVariant(gh_reply="zero"), "0#", "0#"),
        (FirmwareVariant(gh_reply="homed"), "0#", "1#"),
    ],
)
def test_gh_variants(mount: MountClient, clock: ManualClock, before: str, after: str) -> None:
    assert mount.exact(":Gh#") == before
    mount.send(":hC#")
    wait_slew(mount, clock)
    assert mount.exact(":Gh#") == after


@pytest.mark.parametrize("firmware", [FirmwareVariant(compound_goto_sync=True)])
def test_compound_goto_and_sync_work_as_documented(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    ra = wire_values.format_hms(target_at(model, -2.0))
    assert ready.exact(f":SMeq{ra}&+30*00:00#") == "0"
    assert ready.ask(":GMeq#") == f"{ra}&+30*00:00#"
    wait_slew(ready, clock)
    assert ready.ask(":GMEQ#") == f"{ra}&+30*00:00#"
    synced = wire_values.format_hms(wire_values.parse_hms(ra) + 1 / 60)
    assert ready.exact(f":SMMC{synced}&+30*10:00#") == f"{synced}&+30*10:00#"
    assert ready.ask(":GMEQ#") == f"{synced}&+30*10:00#"
    assert ready.exact(":SMeq12:00:00&+95*00:00#") == "e2#"  # still checks its arguments


def test_compound_goto_and_sync_answer_e2_on_real_firmware(ready: MountClient, model: MountModel) -> None:
    ra = wire_values.format_hms(target_at(model, -2.0))
    assert ready.exact(f":SMeq{ra}&+30*00:00#") == "e2#"
    assert "N" in flags(ready)
    assert ready.exact(f":SMMC{ra}&+30*00:00#") == "e2#"


@pytest.mark.parametrize("firmware", [FirmwareVariant(custom_tracking=True)])
def test_custom_tracking_variant(ready: MountClient, model: MountModel, clock: ManualClock) -> None:
    slew(ready, clock, target_at(model, -2.0), 30.0)
    assert ready.exact(":STR05#") == "1"
    assert ready.ask(":GT#") == "3#"
    primary0, _ = model.axes()
    clock.advance(100.0)
    assert model.axes()[0] - primary0 == pytest.approx(100.0 * 0.5 * SIDEREAL_DEG_S, rel=1e-5)
    assert ready.exact(":STR25#") == "0"
    assert ready.exact(":STR5#") == "0"


@pytest.mark.parametrize("firmware", [FirmwareVariant(gmza_south_azimuth=True)])
def test_gmza_south_azimuth(mount: MountClient) -> None:
    """AM5N at home at +31°15'41": 180*00:00&+31*15:41 (field notes §2.2)."""
    assert mount.ask(":GMZA#") == "180*00:00&+31*15:41#"
    assert mount.ask(":GZ#") == "000*00:00#"


@pytest.mark.parametrize("firmware", [preset("am3-1.6.3"), preset("am7-2.0.0")])
def test_model_and_version(mount: MountClient, firmware: FirmwareVariant) -> None:
    assert mount.ask(":GVP#") == f"{firmware.model}#"
    assert mount.ask(":GV#") == f"{firmware.version}#"
    assert mount.ask(":GBl#") == f"{firmware.model}_123456#"


def test_a_switch_flipped_on_a_running_mount_applies_at_once(mount: MountClient, model: MountModel) -> None:
    mount.send(":TL#")
    assert mount.ask(":GT#") == "2#"
    model.firmware.gt_mapping = "chinese"
    assert mount.ask(":GT#") == "1#"


@pytest.mark.parametrize(
    "kwargs",
    [
        {"home_flag": "sometimes"},
        {"gt_mapping": "french"},
        {"gps_reply": "x"},
        {"hp_reply": "1"},
        {"gh_reply": "2#"},
        {"model": "EQ6"},  # any AM<digit> with a suffix is a ZWO model (AM5N, AM9); nothing else is
        {"model": "AM5-N"},
        {"park_refusal": "e15"},
        {"hp_while_tracking": "sometimes"},
        {"status_word": "1.9"},
        {"unknown_query": "hash"},
        {"home_reading": "N"},
        {"jog_rates": "fast"},
    ],
)
def test_invalid_variant_values_are_rejected(kwargs: dict[str, str]) -> None:
    with pytest.raises(ValueError):
        FirmwareVariant(**kwargs)  # type: ignore[arg-type]


@pytest.mark.parametrize("name", list(PRESETS))
def test_every_preset_describes_itself(name: str) -> None:
    variant = preset(name)
    assert variant.name == name and variant.description
    assert variant.describe().startswith(f"{name}: {variant.model} firmware {variant.version} (")
    assert variant is not PRESETS[name]  # a copy: flipping a switch never changes the preset


def test_the_default_variant_is_the_default_preset() -> None:
    assert {k: v for k, v in FirmwareVariant().as_dict().items() if k not in ("name", "description")} == {
        k: v for k, v in preset().as_dict().items() if k not in ("name", "description")}
    assert preset().quirks() == {}


def test_a_preset_with_a_changed_switch_says_so() -> None:
    variant = preset("am5-x2", gt_mapping="chinese", version="1.9.9")
    assert variant.name == "am5-x2+custom" and variant.version == "1.9.9"
    assert variant.quirks()["gt_mapping"] == "chinese" and variant.quirks()["gps_reply"] == "empty"
    with pytest.raises(ValueError, match="unknown firmware preset"):
        preset("am9-0.0.1")


@pytest.mark.parametrize("firmware", [preset("am5n-1.6.3")])
def test_the_am5n_preset_answers_as_that_mount(mount: MountClient, firmware: FirmwareVariant) -> None:
    assert mount.ask(":GVP#") == "AM5N#" and mount.ask(":GV#") == "1.6.3#"
    assert mount.ask(":GMZA#").startswith("180*00:00&")


@pytest.mark.parametrize(("version", "has"), [("1.2.3", False), ("1.2.4", True), ("1.2.4b", True), ("1.10.0", True)])
def test_feature_versions_compare_as_numbers(version: str, has: bool) -> None:
    assert has_feature(version, "meridian_settings") is has
