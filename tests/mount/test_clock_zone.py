"""The zone the mount's clock is set in (issue 43 point 3): the site's, whatever the host's, against the emulator.

The emulator keeps the mount's wall clock and its zone as a real mount does (``emulator/clocksite.py``):
UTC = local - (zone + the daylight-saving flag). Each test judges the mount's own clock (``mount_utc``)
against the emulated universe's true UTC, and its wall clock against the site's local time.
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Iterator
from datetime import datetime, timedelta, timezone

import pytest

from alpaca_zwo.emulator import EmulatorServer, MountModel, ScaledClock
from alpaca_zwo.mount.operations import Mount
from alpaca_zwo.sky import zone_at
from alpaca_zwo.zwo.link import Link

SYDNEY = (-33.8688, 151.2093)
BERLIN = (52.52, 13.405)
DECEMBER = datetime(2026, 12, 15, 9, 0, tzinfo=timezone.utc)  # AEDT (UTC+11) in Sydney, CET (UTC+1) in Berlin


class Rig:
    """An emulated mount just powered up (no time: the server sets it) at true UTC ``start``, and a Mount
    whose site is ``site`` (a list, so a test can move it as a client or the page does)."""

    def __init__(self, start: datetime, site: tuple[float, float]) -> None:
        self.model = MountModel(ScaledClock(start_utc=start))
        self.emulator = EmulatorServer(self.model, host="127.0.0.1", port=0, baud=0).start()
        self.site = list(site)
        link = Link(f"socket://127.0.0.1:{self.emulator.port}", timeout=1.0)
        self.mount = Mount(link, lambda: (self.site[0], self.site[1]), clock=self.model.clock.now,
                           poll_fast_s=0.05, poll_slow_s=0.1)

    def mount_error_s(self) -> float:
        """The mount's own UTC minus the true one."""
        snapshot = self.model.snapshot()
        return (datetime.fromisoformat(snapshot["mount_utc"])
                - datetime.fromisoformat(snapshot["true_utc"])).total_seconds()

    def local_minus_true_h(self) -> float:
        """The mount's wall clock minus true UTC, hours: the local time's offset as the mount shows it."""
        snapshot = self.model.snapshot()
        local = datetime.fromisoformat(snapshot["mount_local"])
        true = datetime.fromisoformat(snapshot["true_utc"]).replace(tzinfo=None)
        return round((local - true).total_seconds() / 60.0) / 60.0

    def close(self) -> None:
        self.mount.disconnect()
        self.emulator.stop()


@pytest.fixture
def rigs() -> Iterator[list[Rig]]:
    made: list[Rig] = []
    yield made
    for rig in made:
        rig.close()


def test_a_new_site_is_used_at_the_next_setting(rigs: list[Rig]) -> None:
    rig = Rig(DECEMBER, SYDNEY)
    rigs.append(rig)
    rig.mount.connect()
    assert rig.model.clock_site.utc_offset() == 11.0 and rig.local_minus_true_h() == 11.0
    rig.site[:] = BERLIN  # a client's SiteLatitude/SiteLongitude, the page or GPS: the server's site
    rig.mount.push_site(*BERLIN)
    rig.mount.push_time()
    assert rig.model.clock_site.utc_offset() == 1.0 and rig.local_minus_true_h() == 1.0
    assert abs(rig.mount_error_s()) < 1.5
    utc, _ = rig.mount.read_clock()
    assert abs((utc - rig.model.clock.now()).total_seconds()) < 1.5


def test_a_mount_with_daylight_saving_on_gets_its_zone_an_hour_less(rigs: list[Rig]) -> None:
    """The flag is the user's (ZWO's app, the hand controller) and is left on: the zone sent is an hour
    less, so zone + flag is the site's offset and the mount's UTC exact."""
    rig = Rig(DECEMBER + timedelta(days=180), BERLIN)  # June: CEST, UTC+2
    rigs.append(rig)
    assert rig.model.clock_site.set_dst(True)
    rig.mount.connect()
    assert rig.model.clock_site.dst() and rig.model.clock_site.utc_offset() == 1.0
    assert rig.local_minus_true_h() == 2.0
    assert abs(rig.mount_error_s()) < 1.5


def test_without_the_sites_zone_the_hosts_is_used_and_said(
        rigs: list[Rig], monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    """tzfpy has no wheel for 32-bit ARM: there the site's zone cannot be known, and the mount's clock is
    set as before this change, in the host's zone; the log says so."""
    zone_at.cache_clear()
    monkeypatch.setitem(sys.modules, "tzfpy", None)
    try:
        rig = Rig(DECEMBER, SYDNEY)
        rigs.append(rig)
        with caplog.at_level(logging.INFO, logger="alpaca_zwo.mount.operations"):
            rig.mount.connect()
    finally:
        zone_at.cache_clear()
    host = (DECEMBER.astimezone().utcoffset() or timedelta(0)).total_seconds() / 3600.0
    assert rig.model.clock_site.utc_offset() == host and rig.local_minus_true_h() == host
    assert abs(rig.mount_error_s()) < 1.5
    assert "the site's time zone is not known at -33.8688, 151.2093" in caplog.text
    assert "set in the host's zone" in caplog.text
