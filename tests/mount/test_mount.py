"""The mount layer against the real emulator: connect sequence, poller, reboot recovery, estimator."""

from __future__ import annotations

from collections.abc import Iterator
from datetime import datetime, timedelta, timezone

import pytest

from alpaca_zwo.emulator import EmulatorServer, MountModel, ScaledClock
from alpaca_zwo.mount.operations import Mount
from alpaca_zwo.mount.state import MountState
from alpaca_zwo.sky import SIDEREAL_DEG_S
from alpaca_zwo.zwo.firmware import preset
from alpaca_zwo.zwo.link import Link
from alpaca_zwo.zwo.wire_values import Direction, TrackRate

SITE = (48.8566, 2.3522)  # Paris: east-positive longitude


@pytest.fixture
def model() -> MountModel:
    return MountModel(ScaledClock())  # power-up state: date 01/01/00, factory site


@pytest.fixture
def emulator(model: MountModel) -> Iterator[EmulatorServer]:
    server = EmulatorServer(model, host="127.0.0.1", port=0, baud=0).start()
    yield server
    server.stop()


@pytest.fixture
def mount(emulator: EmulatorServer, model: MountModel) -> Iterator[Mount]:
    link = Link(f"socket://127.0.0.1:{emulator.port}", timeout=1.0, reconnect_delays=(0.1, 0.2, 0.5))
    mount = Mount(link, lambda: SITE, clock=model.clock.now, utc_offset=lambda: timedelta(hours=2),
                  poll_fast_s=0.05, poll_slow_s=0.1)
    mount.connect()
    yield mount
    mount.disconnect()


def _fresh(mount: Mount, after: float, timeout: float = 5.0) -> MountState:
    state = mount.wait_for(lambda s: s.position_time is not None and s.position_time > after, timeout)
    assert state is not None, "the poller published nothing new"
    return state


def test_connect_pushes_site_and_time_with_the_mount_conventions(mount: Mount, model: MountModel) -> None:
    assert model.clock_site.latitude() == pytest.approx(SITE[0], abs=1 / 3600)
    # sent east-negative, read back east-positive
    assert model.clock_site.longitude() == pytest.approx(SITE[1], abs=1 / 3600)
    assert model.clock_site.utc_offset() == pytest.approx(2.0)  # sent as :SG-02:00#
    local = model.clock_site.local_datetime()
    expected = model.clock.now().replace(tzinfo=None) + timedelta(hours=2)
    assert abs((local - expected).total_seconds()) < 2.0
    state = mount.state
    assert state.initialised and state.info is not None and state.info.model == "AM5"


def test_poller_publishes_fresh_state_at_home(mount: Mount) -> None:
    state = _fresh(mount, mount.state.position_time or 0.0)
    assert state.dec == 90.0 and state.pier == "N"
    assert state.status is not None and not state.status.slewing
    assert state.tracking is not None and not state.tracking.on
    assert state.age() is not None and state.age() < 1.0


def test_goto_lands_and_tracks(mount: Mount, model: MountModel) -> None:
    lst = model.clock_site.sidereal_time()
    target = ((lst - 1.0) % 24.0, 30.0)
    mount.goto(*target)
    busy = mount.wait_for(lambda s: bool(s.status and s.status.slewing), 5.0)
    assert busy is not None
    done = mount.wait_for(lambda s: bool(s.status and not s.status.slewing) and s.position_time is not None, 60.0)
    assert done is not None
    state = _fresh(mount, done.time)
    assert state.tracking is not None and state.tracking.on  # GOTO arrival switches tracking on
    assert state.ra == pytest.approx(target[0], abs=0.5 / 3600)
    assert state.dec == pytest.approx(target[1], abs=1 / 3600)
    assert state.pier == "E"  # HA = LST - RA = +1 h: west of the meridian, pointing state pierEast


def test_after_a_reboot_time_and_site_are_pushed_before_the_next_goto(mount: Mount, model: MountModel) -> None:
    generation = mount.link.generation
    model.faults.reboot(0.5)
    assert mount.link.wait_connected(0.1) is False or mount.link.generation >= generation
    reconnected = mount.wait_for(lambda s: s.link is not None and s.link.generation > generation
                                 and s.link.connected and s.initialised, 10.0)
    assert reconnected is not None, "the link did not come back and re-initialise"
    assert model.clock_site.latitude() == pytest.approx(SITE[0], abs=1 / 3600)
    lst = model.clock_site.sidereal_time()
    mount.goto((lst - 2.0) % 24.0, 20.0)  # would be e7# if time and site had not been pushed again
    assert mount.wait_for(lambda s: bool(s.status and s.status.slewing), 5.0) is not None
    mount.stop()


def test_pulse_moves_the_estimate_by_exactly_the_commanded_amount(mount: Mount, model: MountModel) -> None:
    lst = model.clock_site.sidereal_time()
    mount.goto((lst - 2.0) % 24.0, 20.0)
    mount.wait_for(lambda s: bool(s.status and s.status.slewing), 5.0)
    mount.wait_for(lambda s: bool(s.status and not s.status.slewing and s.tracking and s.tracking.on), 60.0)
    before = _fresh(mount, mount.state.time)
    end = mount.pulse_guide(Direction.NORTH, 1000)
    after = mount.wait_for(lambda s: s.position_time is not None and s.position_time > end + 0.2, 5.0)
    assert after is not None
    moved = (after.dec - before.dec) * 3600
    assert moved == pytest.approx(0.5 * SIDEREAL_DEG_S * 3600, abs=0.1)  # 7.52"
    assert abs(after.ra - before.ra) * 15 * 3600 < 0.1


def test_move_axis_and_stop_update_the_state(mount: Mount) -> None:
    mount.move_axis(1, 1.0)
    assert mount.state.moving_axes == frozenset({1})
    mount.move_axis(1, 0.0)
    assert mount.state.moving_axes == frozenset()
    mount.move_axis(0, -0.5)
    mount.stop()
    assert mount.state.moving_axes == frozenset()


def test_tracking_and_guide_rate_round_trip(mount: Mount) -> None:
    mount.set_tracking(True)
    assert mount.state.tracking is not None and mount.state.tracking.on
    mount.set_tracking_rate(TrackRate.LUNAR)
    assert mount.state.tracking_rate is TrackRate.LUNAR
    assert mount.set_guide_rate(0.3) == pytest.approx(0.3)
    settings = mount.read_settings()
    assert settings.guide_rate == pytest.approx(0.3) and settings.upper_limit == 90 and settings.heavy_duty is False


def test_a_poll_cycle_costs_under_sixty_bytes(mount: Mount, emulator: EmulatorServer) -> None:
    state = _fresh(mount, mount.state.time)
    before = emulator.stats()["total"]
    for _ in range(10):
        state = _fresh(mount, state.position_time or 0.0)
    after = emulator.stats()["total"]
    exchanges = after["exchanges"] - before["exchanges"]
    octets = (after["bytes_in"] - before["bytes_in"]) + (after["bytes_out"] - before["bytes_out"])
    assert exchanges >= 40
    assert octets / (exchanges / 4) < 60


# --- the estimator, pure -----------------------------------------------------------------


def test_host_clock_is_used_when_no_clock_given() -> None:
    link = Link("loop://")
    mount = Mount(link, lambda: SITE)
    assert abs((mount.clock() - datetime.now(timezone.utc)).total_seconds()) < 1


# --- the mount's own park -------------------------------------------------------------------


def _asked_park(mount: Mount) -> int:
    return sum(1 for entry in mount.link.trace() if entry.request == ":Gps#")


@pytest.mark.parametrize(("switches", "times"), [
    ({}, range(3, 1000)),  # not tracking at power-up: :Gps# is read every poll, a park would be seen
    ({"version": "1.1.0"}, range(0, 1)),  # no firmware park before 1.1.9: never asked
    ({"gps_reply": "empty"}, range(1, 2)),  # asked once, answered '#': not asked again on this link
])
def test_the_park_state_is_read_only_where_the_firmware_has_it(switches: dict[str, str], times: range) -> None:
    model = MountModel(ScaledClock(), firmware=preset(**switches))
    with EmulatorServer(model, host="127.0.0.1", port=0, baud=0) as emulator:
        link = Link(f"socket://127.0.0.1:{emulator.port}", timeout=1.0)
        mount = Mount(link, lambda: SITE, clock=model.clock.now, poll_fast_s=0.05, poll_slow_s=0.05)
        mount.connect()
        try:
            state = mount.state
            for _ in range(3):
                state = _fresh(mount, state.position_time or 0.0)
            assert _asked_park(mount) in times
            assert state.park == (0 if not switches else None) and not state.parked_by_mount
        finally:
            mount.disconnect()
