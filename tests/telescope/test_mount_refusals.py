"""Every ``eN#`` the mount answers becomes the right ASCOM error in plain words (``_exceptions.MOUNT_REFUSALS``).

The codes come from the emulator over a real link, as the mount sends them (real-transcripts-1.8.8.md
§2 item 10); the e11 and e14 cases also go end to end through the Alpaca API.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from alpaca_zwo._exceptions import (
    AlpacaError,
    DriverError,
    InvalidOperation,
    InvalidValue,
    MountReplyError,
    Parked,
    refusal_error,
)
from alpaca_zwo.emulator import EmulatorServer, MountModel, ScaledClock
from alpaca_zwo.zwo import protocol as p
from alpaca_zwo.zwo.firmware import preset
from alpaca_zwo.zwo.link import Link
from tests.support import wait_until
from tests.telescope.harness import Api

INVALID_OPERATION = 0x40B


def _linked(model: MountModel) -> Iterator[Link]:
    emulator = EmulatorServer(model, host="127.0.0.1", port=0, baud=0).start()
    link = Link(f"socket://127.0.0.1:{emulator.port}", timeout=1.0)
    link.open()
    yield link
    link.close()
    emulator.stop()


@pytest.fixture
def fresh_mount() -> Iterator[Link]:
    """A mount just powered up: time and site never set."""
    yield from _linked(MountModel(ScaledClock(), initialized=False))


@pytest.fixture
def parked_1_8_8() -> Iterator[Link]:
    model = MountModel(ScaledClock(speed=50.0), firmware=preset("am5-1.8.8"), initialized=True)
    assert model.park()
    wait_until(lambda: model.park_status() == 2, 30, "the emulated mount to park")
    yield from _linked(model)


def _refused(link: Link, req: p.Request) -> MountReplyError:
    with pytest.raises(MountReplyError) as info:
        link.execute(req)
    return info.value


def test_e7_says_time_and_site_are_not_set_and_what_to_do(fresh_mount: Link) -> None:
    fresh_mount.execute(p.set_target_ra(3.0))
    fresh_mount.execute(p.set_target_dec(20.0))
    error = refusal_error("SlewToCoordinatesAsync", _refused(fresh_mount, p.query("MS")))
    assert isinstance(error, InvalidOperation)
    assert "time and site are not set (e7)" in error.message and "connect again" in error.message


def test_e2_is_an_invalid_value_that_names_the_command(fresh_mount: Link) -> None:
    request = p.Request(p.BY_CODE["Sd"], ":Sd+10*00:60#")  # S2's rounding bug: 60 seconds
    error = refusal_error("SlewToCoordinatesAsync", _refused(fresh_mount, request))
    assert isinstance(error, InvalidValue) and ":Sd+10*00:60#" in error.message and "(e2)" in error.message


def test_e14_is_invalid_while_parked(parked_1_8_8: Link) -> None:
    for req in (p.query("MS"), p.query("Te")):
        error = refusal_error("Tracking=true", _refused(parked_1_8_8, req))
        assert isinstance(error, Parked) and error.number == 0x408 and "Unpark" in error.message


def test_busy_says_moving_only_when_the_mount_moves() -> None:
    busy = MountReplyError(":MS#", "e4#", 4, p.ERROR_CODES[4])
    assert "is moving" in refusal_error("GOTO", busy, moving=True).message
    for moving in (False, None):
        error = refusal_error("GOTO", busy, moving=moving)
        assert isinstance(error, InvalidOperation) and "is moving" not in error.message


def test_other_codes_stay_driver_errors_with_the_mounts_meaning() -> None:
    error: AlpacaError = refusal_error("GOTO", MountReplyError(":MS#", "e10#", 10, p.ERROR_CODES[10]))
    assert isinstance(error, DriverError) and p.ERROR_CODES[10] in error.message


def test_a_sync_far_from_where_the_mount_points_says_goto_and_centre_first(api: Api) -> None:
    """The mount takes a sync only near where it points (e12 beyond 20°): the words say what a sync is for."""
    api.ok("Tracking", Tracking=True)
    api.ok("SlewToCoordinatesAsync", RightAscension=(api.value("SiderealTime") + 1.0) % 24.0, Declination=30.0)
    wait_until(lambda: not api.value("Slewing"), timeout=60.0, what="the slew's end")
    before = api.value("RightAscension")
    reply = api.put("SyncToCoordinates", RightAscension=(before + 2.5) % 24.0, Declination=30.0)
    assert reply.error == INVALID_OPERATION, reply.body
    message = reply.body["ErrorMessage"]
    assert "(e12)" in message and "GoTo the star, centre it, then sync" in message, message
    assert abs(api.value("RightAscension") - before) < 0.01  # nothing was synced: the position stands


def test_a_sync_at_home_is_an_invalid_operation_that_says_move_away(api: Api) -> None:
    """The emulator starts at home (the pole): the mount refuses a sync there with e11."""
    api.ok("Tracking", Tracking=True)
    ra = (api.value("RightAscension") + 0.5) % 24.0
    reply = api.put("SyncToCoordinates", RightAscension=ra, Declination=89.0)
    assert reply.error == INVALID_OPERATION, reply.body
    assert "home position (e11)" in reply.body["ErrorMessage"]
