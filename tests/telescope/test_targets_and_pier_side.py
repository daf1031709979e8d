"""Targets and the pier side: targets read back exactly and answer 0x402 until set; DestinationSideOfPier
predicts the side a GOTO ends on, under the mount's meridian setting. And the ``Targets`` part alone.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from alpaca_zwo._exceptions import InvalidValue, ValueNotSet
from alpaca_zwo.config.settings import LimitSettings
from alpaca_zwo.emulator import MountModel
from alpaca_zwo.server import AlpacaZwoServer
from alpaca_zwo.telescope.targets import Targets
from alpaca_zwo.zwo.wire_values import MeridianSettings
from tests.conftest import ServerFactory
from tests.telescope.harness import OK, VALUE_NOT_SET, Api, case, fast_settings, make_transport, run_cases
from tests.telescope.parts import parts_rig


def test_targets_answer_0x402_until_set(server: AlpacaZwoServer, api: Api, transport_kind: str) -> None:
    run_cases(make_transport(transport_kind, server, api), [
        case("GET", "TargetRightAscension", VALUE_NOT_SET),
        case("GET", "TargetDeclination", VALUE_NOT_SET),
        case("PUT", "SlewToTarget", VALUE_NOT_SET),
        case("PUT", "SlewToTargetAsync", VALUE_NOT_SET),
        case("PUT", "SyncToTarget", VALUE_NOT_SET),
        case("PUT", "TargetRightAscension", OK, TargetRightAscension=5.0),
        case("GET", "TargetDeclination", VALUE_NOT_SET),  # one target alone is not enough
        case("PUT", "SlewToTargetAsync", VALUE_NOT_SET),
        case("GET", "Slewing", OK),
    ])
    assert api.value("Slewing") is False


def test_targets_read_back_exactly(api: Api) -> None:
    for ra, dec in [(0.0, -90.0), (23.999999, 90.0), (12.3456789012345, -12.3456789012345)]:
        api.ok("TargetRightAscension", TargetRightAscension=ra)
        api.ok("TargetDeclination", TargetDeclination=dec)
        assert api.value("TargetRightAscension") == ra and api.value("TargetDeclination") == dec


@pytest.mark.parametrize("ha,dec", [(-9.0, 60.0), (-3.0, 30.0), (3.0, 30.0), (9.0, 60.0), (-0.2, 20.0),
                                    (0.2, 20.0)])
def test_destination_side_of_pier_predicts_the_goto(api: Api, model: MountModel, ha: float, dec: float) -> None:
    """R21: DestinationSideOfPier equals SideOfPier after the GOTO; SideOfPier is the pointing state."""
    ra = api.ra_at_ha(ha)
    predicted = api.value("DestinationSideOfPier", RightAscension=ra, Declination=dec)
    api.ok("SlewToCoordinatesAsync", RightAscension=ra, Declination=dec)
    api.wait_idle()
    assert api.value("SideOfPier") == predicted
    pointing = 1 if ha < 0 else 0  # pierWest looking east (HA < 0), pierEast looking west
    assert predicted == pointing
    assert api.state()["SideOfPier"] == predicted


@pytest.mark.parametrize("track_past,limit,ha,expected", [
    (True, 10, 0.4, 1),  # 6° past the meridian: still reachable on the west side (tracks up to 10° past)
    (True, 10, 1.0, 0),  # 15° past: beyond the limit, so the GOTO takes the flipped side
    (False, -10, -0.4, 0),  # the west side must stop 10° before the meridian: 6° before is already flipped
    (False, -10, -1.0, 1),  # 15° before: still the ordinary west side
])
def test_destination_side_of_pier_follows_the_meridian_setting(
        server_factory: ServerFactory, track_past: bool, limit: int, ha: float, expected: int) -> None:
    """The configured meridian behaviour reaches the mount, and the prediction uses the same rule near the
    meridian (ZWO field notes §2.8: a negative limit stops tracking that far *before* the meridian)."""
    limits = LimitSettings(meridian_limit_deg=float(limit), meridian_track_past=track_past)
    server = server_factory(fast_settings(limits=limits))
    api = Api(f"http://127.0.0.1:{server.port}").connect()
    emulator = server.emulators[0]
    assert emulator is not None
    assert emulator.model.flash.meridian() == MeridianSettings(False, track_past, limit)
    ra, dec = api.ra_at_ha(ha), 20.0
    predicted = api.value("DestinationSideOfPier", RightAscension=ra, Declination=dec)
    api.ok("SlewToCoordinatesAsync", RightAscension=ra, Declination=dec)
    api.wait_idle()
    actual = api.value("SideOfPier")
    assert (predicted, actual) == (expected, expected), f"predicted {predicted}, GOTO ended on {actual}"


def test_side_of_pier_at_home_is_a_valid_pointing_state(api: Api) -> None:
    assert api.value("AtHome") is True
    assert api.value("SideOfPier") in (0, 1)  # the mount's N (home) still maps to a pointing state


# ================================================================================================
# The part alone: Targets, with the motion supervisor that keeps Slewing true for the settle time
# ================================================================================================


def test_targets_are_unset_until_both_are_written_and_read_back_exactly(tmp_path: Path) -> None:
    with parts_rig(tmp_path) as rig:
        targets = Targets(motion=rig.motion)
        for read in (targets.target_right_ascension, targets.target_declination, targets.target):
            with pytest.raises(ValueNotSet):
                read()
        targets.set_target_declination(-12.3456789012345)
        with pytest.raises(ValueNotSet, match="TargetRightAscension"):  # RA is asked first, as SlewToTarget does
            targets.target()
        targets.set_target_right_ascension(23.999999)
        assert targets.target() == (23.999999, -12.3456789012345)
        targets.remember(1.5, 45.0)  # a slew or sync to coordinates makes them the target
        assert (targets.target_right_ascension(), targets.target_declination()) == (1.5, 45.0)


@pytest.mark.parametrize(("member", "value"), [
    ("set_target_right_ascension", 24.0), ("set_target_right_ascension", -0.1),
    ("set_target_declination", 90.1), ("set_target_declination", -91.0),
    ("set_slew_settle_time", -1), ("set_slew_settle_time", 3601),
])
def test_out_of_range_values_are_refused_and_change_nothing(tmp_path: Path, member: str, value: float) -> None:
    with parts_rig(tmp_path) as rig:
        targets = Targets(motion=rig.motion)
        targets.remember(3.0, 20.0)
        targets.set_slew_settle_time(2)
        with pytest.raises(InvalidValue):
            getattr(targets, member)(value)
        assert targets.target() == (3.0, 20.0) and targets.slew_settle_time() == 2 and rig.motion.settle_s == 2.0


def test_the_settle_time_is_the_supervisors(tmp_path: Path) -> None:
    with parts_rig(tmp_path) as rig:
        targets = Targets(motion=rig.motion)
        assert targets.slew_settle_time() == 0 and rig.motion.settle_s == 0.0
        targets.set_slew_settle_time(3600)
        assert targets.slew_settle_time() == 3600 and rig.motion.settle_s == 3600.0
