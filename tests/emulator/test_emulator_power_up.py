"""The mount's power-up state, its own clock, and the e7# gate until date, time and site are set."""

from __future__ import annotations

from datetime import datetime, timedelta, timezone

import pytest

from alpaca_zwo import sky
from alpaca_zwo.emulator import ManualClock, MountModel
from alpaca_zwo.emulator.model import FACTORY_LATITUDE, FACTORY_LONGITUDE
from alpaca_zwo.zwo import wire_values
from tests.emulator.emuclient import MountClient, flags, initialize


def test_power_up_state_matches_a_real_am5(mount: MountClient) -> None:
    expected = {
        ":GC#": "01/01/00#",
        ":GL#": "00:00:00#",
        ":GG#": "+00:00#",
        ":Gt#": "+31*15:41#",
        ":Gg#": "-120*43:11#",
        ":Gm#": "N#",
        ":GD#": "+90*00:00#",
        ":GU#": "nNG000000000#",
        ":GAT#": "0#",
        ":GTa#": "00+00#",
        ":GLC#": "0#",
        ":GLH#": "90#",
        ":GLL#": "0#",
        ":GRl#": "1440#",
        ":Ggr#": "0.50#",
        ":GT#": "0#",
        ":Gps#": "0#",
        ":Gh#": "#",
    }
    for request, reply in expected.items():
        assert mount.ask(request) == reply, request


def test_home_reads_ra_lst_plus_six_hours(mount: MountClient) -> None:
    """AM5N at home: :GR# 09:31:44 while :GS# 03:31:44 (field notes §5.2)."""
    lst = wire_values.parse_hms(mount.ask(":GS#")[:-1])
    ra = wire_values.parse_hms(mount.ask(":GR#")[:-1])
    assert sky.wrap_hours_12(ra - lst - 6.0) == pytest.approx(0.0, abs=1.5 / 3600)


def test_mount_clock_counts_from_power_on_not_true_time(mount: MountClient, clock: ManualClock) -> None:
    clock.advance(3725.0)
    assert mount.ask(":GL#") == "01:02:05#"
    assert mount.ask(":GC#") == "01/01/00#"
    clock.advance(23 * 3600.0)  # past the mount's midnight
    assert mount.ask(":GC#") == "01/02/00#"


def test_sidereal_time_follows_the_mounts_clock_and_site(mount: MountClient, clock: ManualClock) -> None:
    """LST is computed from what the mount was told, wrong until set, as on a real mount."""
    initialize(mount, clock, utc_offset_hours=8.0)
    assert mount.ask(":GG#") == "-08:00#"  # the negated offset
    expected = sky.local_sidereal_time(clock.now(), FACTORY_LONGITUDE)
    got = wire_values.parse_hms(mount.ask(":GS#")[:-1])
    assert sky.wrap_hours_12(got - expected) == pytest.approx(0.0, abs=1.5 / 3600)
    local = clock.now() + timedelta(hours=8)
    assert mount.ask(":GL#") == f"{local:%H:%M:%S}#"


def test_dst_moves_utc_by_an_hour(mount: MountClient, clock: ManualClock) -> None:
    initialize(mount, clock)
    before = wire_values.parse_hms(mount.ask(":GS#")[:-1])
    assert mount.exact(":SH1#") == "1"
    after = wire_values.parse_hms(mount.ask(":GS#")[:-1])
    assert sky.wrap_hours_12(before - after) == pytest.approx(1.00273790935, abs=2 / 3600)


GOTO_TARGET = (":Sr10:00:00#", ":Sd+45*00:00#")


@pytest.mark.parametrize(
    ("setters", "allowed"),
    [
        ((), False),
        ((":SC03/20/25#", ":SL14:00:00#"), False),
        ((":St+31*15:41#", ":Sg-120*43:11#"), False),
        ((":SC03/20/25#", ":SL14:00:00#", ":St+31*15:41#"), False),
        ((":SC03/20/25#", ":St+31*15:41#", ":Sg-120*43:11#"), False),
        ((":SG-08#", ":St+31*15:41#", ":Sg-120*43:11#"), False),
        ((":SC03/20/25#", ":SL14:00:00#", ":St+31*15:41#", ":Sg-120*43:11#"), True),
        ((":SMTI03/20/25&14:00:00&+00:00#", ":SMGE+31*15:41&-120*43:11#"), True),
        ((":SMTI03/20/25&14:00:00&+00:00#", ":St+31*15:41#", ":Sg-120*43:11#"), True),
    ],
)
def test_goto_answers_e7_until_date_time_and_site_are_set(
    mount: MountClient, setters: tuple[str, ...], allowed: bool
) -> None:
    for setter in setters:
        assert mount.exact(setter) == "1"
    for request in GOTO_TARGET:
        assert mount.exact(request) == "1"
    reply = mount.exact(":MS#")
    assert reply == ("0" if allowed else "e7#")
    assert ("N" not in flags(mount)) is allowed


def test_site_and_time_are_lost_and_restored_to_factory_on_reboot(
    mount: MountClient, model: MountModel, clock: ManualClock
) -> None:
    initialize(mount, clock)
    assert mount.exact(":St+48*07:30#") == "1"
    model.power_cycle()
    assert mount.ask(":Gt#") == "+31*15:41#"
    assert mount.ask(":GC#") == "01/01/00#"
    for request in GOTO_TARGET:
        mount.exact(request)
    assert mount.exact(":MS#") == "e7#"


def test_model_site_and_initialized_options() -> None:
    clock = ManualClock(datetime(2025, 6, 1, 21, 30, tzinfo=timezone.utc))
    model = MountModel(clock, site=(52.5, 13.4), initialized=True)
    assert model.clock_site.latitude() == 52.5 and model.clock_site.longitude() == 13.4
    assert model.clock_site.local_datetime() == datetime(2025, 6, 1, 21, 30)
    snapshot = model.snapshot()
    assert snapshot["initialized"] is True
    # and the factory default when no site is given
    plain = MountModel(clock)
    assert (plain.clock_site.latitude(), plain.clock_site.longitude()) == (FACTORY_LATITUDE, FACTORY_LONGITUDE)
