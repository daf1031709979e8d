"""The time reference (mount/timekeeping.py) and the host clock's status (mount/host_clock.py).

Against the real emulator in-process: its universe runs 5000.4 s ahead of this machine's clock, so a
mount whose clock is set there disagrees with the host by 1 h 23 min. Whether the host clock is
synchronised is injected through HostClockWatch's reader (the server reads the operating system).
"""

from __future__ import annotations

import re
import time
from collections.abc import Iterator
from datetime import datetime, timedelta, timezone

import pytest

from alpaca_zwo.emulator import EmulatorServer, MountModel, ScaledClock
from alpaca_zwo.mount.host_clock import (
    HostClockStatus,
    HostClockWatch,
    interpret_timex,
    interpret_w32tm,
    linux_status,
    override_status,
)
from alpaca_zwo.mount.operations import Mount, utc_now
from alpaca_zwo.mount.timekeeping import TimeKeeper, TimeSource, describe_difference
from alpaca_zwo.zwo.link import Link
from tests.support import wait_until

AHEAD_S = 5000.4
SITE = (48.8566, 2.3522)


class Host:
    """The injected answer to "is the host clock synchronised?"."""

    def __init__(self, synchronised: bool | None) -> None:
        self.synchronised = synchronised

    def read(self) -> HostClockStatus:
        return HostClockStatus(self.synchronised, "test", f"injected: synchronised={self.synchronised}")


@pytest.fixture
def emulator() -> Iterator[EmulatorServer]:
    clock = ScaledClock(start_utc=datetime.now(timezone.utc) + timedelta(seconds=AHEAD_S))
    server = EmulatorServer(MountModel(clock, initialized=True), host="127.0.0.1", port=0, baud=0).start()
    yield server
    server.stop()


def _mount(emulator: EmulatorServer, host: Host, policy: str = "auto") -> Mount:
    link = Link(f"socket://127.0.0.1:{emulator.port}", timeout=1.0, reconnect_delays=(0.1, 0.2, 0.5))
    keeper = TimeKeeper(utc_now, time.monotonic, watch=HostClockWatch(host.read, max_age_s=0.0),
                        policy=lambda: policy)
    return Mount(link, lambda: SITE, time_keeper=keeper, poll_fast_s=0.05, poll_slow_s=0.1)


def mount_clock_minus_universe_s(emulator: EmulatorServer) -> float:
    model = emulator.model
    truth = model.snapshot()
    return (datetime.fromisoformat(truth["mount_utc"]) - datetime.fromisoformat(truth["true_utc"])).total_seconds()


def test_an_unsynchronised_host_adopts_the_mount_clock_to_the_millisecond(emulator: EmulatorServer) -> None:
    mount = _mount(emulator, Host(False))
    mount.connect()
    try:
        assert mount.time.source is TimeSource.MOUNT
        assert abs(mount_clock_minus_universe_s(emulator)) < 0.01, "the mount's clock was written"
        error = (mount.time.now() - emulator.model.clock.now()).total_seconds()
        assert abs(error) < 0.03, f"the mount's time was adopted {error * 1000:.0f} ms off (edge read)"
        assert "1 h 23 min ahead of the host's" in mount.time.view().reason
    finally:
        mount.disconnect()


def test_a_synchronised_host_sets_the_mount_and_one_that_becomes_so_takes_over(emulator: EmulatorServer) -> None:
    host = Host(False)
    mount = _mount(emulator, host)
    mount.connect()
    try:
        assert mount.time.source is TimeSource.MOUNT
        host.synchronised = True  # chrony got its GPS fix, or the network came back
        wait_until(lambda: mount.time.source is TimeSource.HOST, 10, "the host clock to take over")
        wait_until(lambda: abs(mount_clock_minus_universe_s(emulator) + AHEAD_S) < 1.0, 10,
                   "the mount's clock to be set from the host's")
        assert abs((mount.time.now() - datetime.now(timezone.utc)).total_seconds()) < 0.05
    finally:
        mount.disconnect()


def test_time_source_mount_keeps_a_clock_even_within_two_seconds(emulator: EmulatorServer) -> None:
    mount = _mount(emulator, Host(True), policy="mount")
    mount.connect()
    try:
        assert mount.time.source is TimeSource.MOUNT and 'time.source is "mount"' in mount.time.view().reason
        assert abs(mount_clock_minus_universe_s(emulator)) < 0.01
    finally:
        mount.disconnect()


def test_a_restarted_mount_gets_the_kept_time_back_not_the_hosts(emulator: EmulatorServer) -> None:
    mount = _mount(emulator, Host(False))
    mount.connect()
    try:
        ups = emulator.model.snapshot()["power_ups"]
        emulator.faults.reboot(0.5)
        wait_until(lambda: emulator.model.snapshot()["power_ups"] > ups and emulator.model.snapshot()["initialized"],
                   30, "the mount to restart and be given its time again")
        assert abs(mount_clock_minus_universe_s(emulator)) < 1.0, "the restarted mount got the host's time"
        assert mount.time.source is TimeSource.MOUNT and "restarted" in mount.time.view().reason
    finally:
        mount.disconnect()


def test_a_client_time_survives_a_host_clock_step() -> None:
    """A client's time is anchored on the monotonic clock: the host clock stepping (NTP) does not move it."""
    host_now = [datetime(2026, 11, 26, 20, 0, tzinfo=timezone.utc)]
    mono = [100.0]
    keeper = TimeKeeper(lambda: host_now[0], lambda: mono[0], watch=HostClockWatch(Host(False).read, max_age_s=0.0))
    keeper.set_by_client(datetime(2026, 11, 26, 23, 0, tzinfo=timezone.utc), "a test")
    host_now[0] += timedelta(hours=3)  # stepped by NTP
    mono[0] += 10.0
    assert keeper.now() == datetime(2026, 11, 26, 23, 0, 10, tzinfo=timezone.utc)
    assert keeper.source is TimeSource.CLIENT and not keeper.wants_mount_clock()
    assert keeper.at_connect(None, mono[0]) is False  # pushed to the mount at connect


def test_the_kernels_answer_in_words() -> None:
    stamp = datetime(2026, 11, 25, 22, 10, tzinfo=timezone.utc)
    synced = interpret_timex(0, 12_000, 0x2001, stamp)
    assert synced.synchronised is True and "12 ms" in synced.detail and synced.last_synchronised == stamp
    chrony = interpret_timex(5, 40_000, 0x40, None)  # chrony without rtcsync leaves STA_UNSYNC set
    assert chrony.synchronised is True and "STA_UNSYNC" in chrony.kernel
    lost = interpret_timex(5, 16_000_000, 0x40, None)
    assert lost.synchronised is False and not lost.trusted and "TIME_ERROR" in lost.kernel
    # The page shows the detail: a person's words, the kernel's own for the log only (issue 43 point 6).
    assert lost.detail == "this computer's clock is not synchronised to a time server (it may be up to 16 s off)"
    assert not re.search(r"TIME_ERROR|STA_|adjtimex|kernel", lost.detail + chrony.detail + synced.detail)
    assert interpret_timex(-1, 0, 0, None).synchronised is None
    real = linux_status()  # this machine's kernel, read without root: an answer, whichever
    assert real.method == "adjtimex" and real.synchronised in (True, False)


def test_windows_time_status_in_any_language() -> None:
    assert interpret_w32tm("Leap Indicator: 0(no warning)\nStratum: 4 (secondary reference)\n").synchronised is True
    assert interpret_w32tm("Leap Indicator: 3(not synchronized)\nStratum: 0 (unspecified)\n").synchronised is False
    assert interpret_w32tm("Sprungindikator: 3(nicht synchronisiert)\r\nStratum: 0\r\n").synchronised is False
    unknown = interpret_w32tm("The following error occurred: The service has not been started. (0x80070426)")
    assert unknown.synchronised is None and unknown.trusted


def test_the_override_and_its_words() -> None:
    forced = override_status("unsynchronised")
    assert forced is not None and forced.synchronised is False
    on = override_status("synchronized")
    assert on is not None and on.synchronised is True
    assert override_status("") is None and override_status("perhaps") is None
    assert [describe_difference(s) for s in (4.2, -725, 10800, -3 * 86400 - 7200)] == [
        "4.2 s", "12 min 5 s", "3 h 0 min", "3 d 2 h"]


def test_a_difference_is_rounded_to_its_last_unit() -> None:
    """A clock 3 h behind measured over a round trip is 10,799.6 s: "3 h 0 min", never "2 h 59 min"."""
    assert [describe_difference(s) for s in (10799.6, -3599.7, 59.97, 2 * 86400 - 20)] == [
        "3 h 0 min", "1 h 0 min", "1 min 0 s", "2 d 0 h"]
