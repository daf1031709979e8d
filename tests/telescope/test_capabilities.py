"""Capabilities: over HTTP, what the mount can do reads true, what it lacks reads false and answers 0x400;
and the ``Capabilities`` part alone on the real emulator: the flags that vary, the drive, offset and guide
rates, the site (saved, then pushed), and which members ask the connection first.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from alpaca_zwo._exceptions import InvalidOperation, InvalidValue, MemberNotImplemented, NotConnected
from alpaca_zwo.clients import ClientKey
from alpaca_zwo.config.file import load_settings
from alpaca_zwo.server import AlpacaZwoServer
from alpaca_zwo.sky import SIDEREAL_DEG_S
from alpaca_zwo.telescope.actions import supported_actions
from alpaca_zwo.telescope.capabilities import AXIS_MIN_DEG_S, Capabilities
from alpaca_zwo.zwo.firmware import preset
from alpaca_zwo.zwo.wire_values import MountMode
from tests.support import wait_until
from tests.telescope.expectations import not_implemented_cases
from tests.telescope.harness import Api, make_transport, run_cases
from tests.telescope.parts import Rig, parts_rig


def test_lacking_capabilities_report_false_and_answer_0x400(server: AlpacaZwoServer, api: Api,
                                                            transport_kind: str) -> None:
    assert api.value("CanMoveAxis", Axis=2) is False
    assert api.value("AxisRates", Axis=2) == []
    assert api.value("DeclinationRate") == 0.0
    assert api.value("RightAscensionRate") == 0.0
    assert api.value("DoesRefraction") is False
    assert api.value("SupportedActions") == supported_actions()  # the ZWO actions (tests/alpaca/test_actions.py)
    run_cases(make_transport(transport_kind, server, api), not_implemented_cases())


def test_implemented_capabilities_report_true(api: Api) -> None:
    for name in ("CanFindHome", "CanPark", "CanPulseGuide", "CanSetGuideRates", "CanSetPark", "CanSetTracking",
                 "CanSlew", "CanSlewAltAz", "CanSlewAltAzAsync", "CanSlewAsync", "CanSync", "CanSyncAltAz",
                 "CanUnpark", "CanSetRightAscensionRate", "CanSetDeclinationRate", "CanSetPierSide"):
        assert api.value(name) is True, name
    assert api.value("CanMoveAxis", Axis=0) is True
    assert api.value("CanMoveAxis", Axis=1) is True


# ================================================================================================
# The part alone: Capabilities on a real Mount, settings store, MotionSupervisor and emulator
# ================================================================================================

CLIENT = ClientKey("192.0.2.20", 1)
ARCSEC = 1.0 / 3600.0


@contextmanager
def capabilities_on(tmp_path: Path, *, connect: bool = True,
                    **model_options: object) -> Iterator[tuple[Capabilities, Rig]]:
    """Capabilities as the Telescope builds them: its connection check is a real Connection's."""
    with parts_rig(tmp_path, **model_options) as rig:
        connection = rig.connection()
        if connect:
            connection.attach(CLIENT)
        yield Capabilities(mount=rig.mount, store=rig.store, motion=rig.motion,
                           require_connected=connection.require_connected), rig
        connection.close()


def test_axes_and_their_rates(tmp_path: Path) -> None:
    with capabilities_on(tmp_path, connect=False) as (caps, _):
        for axis in (0, 1):
            assert caps.can_move_axis(axis) is True
            assert caps.axis_rates(axis) == [(AXIS_MIN_DEG_S, caps.max_rate())]
        assert caps.can_move_axis(2) is False and caps.axis_rates(2) == []
        for axis in (3, -1):
            with pytest.raises(InvalidValue):
                caps.can_move_axis(axis)
            with pytest.raises(InvalidValue):
                caps.axis_rates(axis)
        assert caps.tracking_rates() == [0, 1, 2]  # no King rate on a ZWO mount


@pytest.mark.parametrize(("options", "expected"), [
    ({}, True),
    ({"firmware": preset(version="1.2.3")}, False),  # no :STa before 1.2.4: no flip by a temporary limit
    ({"mode": MountMode.ALTAZ}, False),  # no pier side in alt-az
])
def test_can_set_pier_side_needs_equatorial_mode_and_meridian_settings(tmp_path: Path, options: dict[str, object],
                                                                       expected: bool) -> None:
    with capabilities_on(tmp_path, connect=False, **options) as (caps, rig):
        assert caps.can_set_pier_side() is True  # not read yet: a German mount with current firmware assumed
        rig.connection().attach(CLIENT)
        assert caps.can_set_pier_side() is expected
        assert caps.flips_by_limit() is expected


def test_members_that_need_the_mount_ask_the_connection_first(tmp_path: Path) -> None:
    with capabilities_on(tmp_path, connect=False) as (caps, _):
        for member in (caps.tracking_rate, caps.guide_rate_right_ascension, caps.guide_rate_declination,
                       caps.declination_rate, caps.right_ascension_rate):
            with pytest.raises(NotConnected):
                member()
        with pytest.raises(NotConnected):
            caps.set_tracking_rate(1)
        with pytest.raises(NotConnected):
            caps.set_guide_rate_right_ascension(0.5 * SIDEREAL_DEG_S)
        # What describes the server, not the mount, answers without one.
        assert caps.site_latitude() == 51.4769 and caps.tracking_rates() == [0, 1, 2]
        # And a value out of range is refused before the connection is asked.
        with pytest.raises(InvalidValue):
            caps.set_tracking_rate(3)
        with pytest.raises(InvalidValue):
            caps.set_guide_rate_declination(0.05 * SIDEREAL_DEG_S)


def test_the_drive_rate_reaches_the_mount_and_off_sidereal_the_offsets_are_forgotten(tmp_path: Path) -> None:
    with capabilities_on(tmp_path) as (caps, rig):
        assert caps.tracking_rate() == 0
        caps.set_right_ascension_rate(0.01)
        caps.set_declination_rate(0.5)
        assert (caps.right_ascension_rate(), caps.declination_rate()) == (0.01, 0.5)
        caps.set_tracking_rate(1)
        assert caps.tracking_rate() == 1
        wait_until(lambda: rig.model.tracking_rate() == "lunar", 5.0, "the mount to track at the lunar rate")
        assert (caps.right_ascension_rate(), caps.declination_rate()) == (0.0, 0.0)  # none off sidereal
        assert not rig.motion.offsets.active  # and none paid
        with pytest.raises(InvalidOperation):
            caps.set_declination_rate(0.5)
        caps.set_tracking_rate(0)
        wait_until(lambda: rig.model.tracking_rate() == "sidereal", 5.0, "the sidereal rate again")
        assert (caps.right_ascension_rate(), caps.declination_rate()) == (0.0, 0.0)  # forgotten, not resumed


def test_the_guide_rate_is_one_mount_rate(tmp_path: Path) -> None:
    with capabilities_on(tmp_path) as (caps, rig):
        caps.set_guide_rate_declination(0.3 * SIDEREAL_DEG_S)
        assert rig.model.guide_rate() == pytest.approx(0.3)
        assert caps.guide_rate_right_ascension() == pytest.approx(0.3 * SIDEREAL_DEG_S, rel=1e-6)
        assert caps.guide_rate_declination() == caps.guide_rate_right_ascension()
        with pytest.raises(InvalidValue):
            caps.set_guide_rate_right_ascension(0.95 * SIDEREAL_DEG_S)
        assert rig.model.guide_rate() == pytest.approx(0.3)  # the refusal sent nothing


def test_the_site_is_saved_then_pushed_and_reads_back_exactly(tmp_path: Path) -> None:
    with capabilities_on(tmp_path) as (caps, rig):
        caps.set_site_latitude(47.123456789012)
        caps.set_site_longitude(-122.98765432101)
        caps.set_site_elevation(1234.5678)
        assert (caps.site_latitude(), caps.site_longitude(), caps.site_elevation()) == (
            47.123456789012, -122.98765432101, 1234.5678)
        saved = load_settings(rig.store.path).site
        assert (saved.latitude, saved.longitude, saved.elevation) == (47.123456789012, -122.98765432101, 1234.5678)
        assert rig.model.clock_site.latitude() == pytest.approx(47.123456789012, abs=ARCSEC)
        assert rig.model.clock_site.longitude() == pytest.approx(-122.98765432101, abs=ARCSEC)
        # Several values in one save: all or none.
        for bad in ({"latitude": 10.0, "longitude": 200.0}, {"latitude": 10.0, "altitude": 5.0}):
            with pytest.raises(InvalidValue):
                caps.set_site(bad)
        assert caps.site_latitude() == load_settings(rig.store.path).site.latitude == 47.123456789012
        caps.set_site({"latitude": -33.8688, "longitude": 151.2093})
        assert (caps.site_latitude(), caps.site_longitude()) == (-33.8688, 151.2093)
        assert rig.model.clock_site.latitude() == pytest.approx(-33.8688, abs=ARCSEC)
        with pytest.raises(InvalidValue):
            caps.set_site_elevation(10000.5)


def test_what_a_mount_does_not_have(tmp_path: Path) -> None:
    with capabilities_on(tmp_path, connect=False) as (caps, _):
        for member in (caps.aperture_area, caps.aperture_diameter, caps.focal_length):
            with pytest.raises(MemberNotImplemented):
                member()
        caps.set_does_refraction(False)  # the answer the constant DoesRefraction gives: accepted
        with pytest.raises(MemberNotImplemented):
            caps.set_does_refraction(True)
