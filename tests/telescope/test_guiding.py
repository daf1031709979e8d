"""Pulse guiding and guide rates, judged by where the emulated mount really moved."""

from __future__ import annotations

import time
from collections.abc import Sequence

import pytest

from alpaca_zwo.emulator import MountModel
from alpaca_zwo.server import AlpacaZwoServer
from alpaca_zwo.sky import SIDEREAL_DEG_S
from tests.support import wait_until
from tests.telescope.harness import ARCSEC, MOTION_TIMEOUT_S, Api, mount_seconds, slew_to_ha, wrap12


def guide_rate_fraction(api: Api) -> float:
    return float(api.value("GuideRateDeclination")) / SIDEREAL_DEG_S


def pulse_and_watch(api: Api, server: AlpacaZwoServer, pulses: Sequence[tuple[int, int]]) -> float:
    """Send pulses back to back; watch IsPulseGuiding (true until all end) and Slewing (always false).

    Returns the mount seconds from the first PUT until IsPulseGuiding read false.
    """
    started = mount_seconds(server)
    for direction, duration in pulses:
        returned = time.monotonic()
        api.ok("PulseGuide", Direction=direction, Duration=duration)
        assert time.monotonic() - returned < 1.0  # asynchronous (ConformU IV4: < 1 s)
    assert api.value("IsPulseGuiding") is True
    deadline = time.monotonic() + MOTION_TIMEOUT_S
    while True:
        state = api.state()
        assert state["Slewing"] is False, "PulseGuide must never set Slewing"
        if not state["IsPulseGuiding"]:
            break
        assert time.monotonic() < deadline, "IsPulseGuiding never went false"
    ended = mount_seconds(server) - started
    assert api.value("IsPulseGuiding") is False and api.value("Slewing") is False
    return ended


def sky_offset_deg(before: tuple[float, float], after: tuple[float, float]) -> tuple[float, float]:
    """(RA change as degrees of hour angle, Dec change in degrees) between two (RA h, Dec deg) readings."""
    return wrap12(after[0] - before[0]) * 15.0, after[1] - before[1]


#: Degrees each guide direction moves (RA, Dec) per degree of guiding: North +Dec, East +RA.
GUIDE_SIGNS = {0: (0, 1), 1: (0, -1), 2: (1, 0), 3: (-1, 0)}


@pytest.mark.parametrize("direction,duration", [(0, 2000), (1, 5000), (2, 2000), (3, 7500)])
def test_pulse_guide_moves_by_rate_times_duration(server: AlpacaZwoServer, api: Api, model: MountModel,
                                                  direction: int, duration: int) -> None:
    """Asynchronous pulses; those over 3000 ms (the mount's limit) are continued to their full length.

    The distance is measured on the emulator: this is about what the mount did. What a client reads
    back afterwards is the next test.
    """
    slew_to_ha(api, -2.0, 30.0)
    rate_deg_s = guide_rate_fraction(api) * SIDEREAL_DEG_S
    before = model.position()
    elapsed = pulse_and_watch(api, server, [(direction, duration)])
    assert elapsed >= duration / 1000.0 - 0.05, "IsPulseGuiding went false before the pulse ended"
    assert elapsed <= duration / 1000.0 + 3.0
    moved = sky_offset_deg(before, model.position())
    distance = rate_deg_s * duration / 1000.0
    signs = GUIDE_SIGNS[direction]
    assert moved[0] == pytest.approx(signs[0] * distance, abs=0.2 * ARCSEC)
    assert moved[1] == pytest.approx(signs[1] * distance, abs=0.2 * ARCSEC)


@pytest.mark.parametrize("direction", [0, 3])
def test_position_is_current_when_is_pulse_guiding_turns_false(api: Api, model: MountModel,
                                                               direction: int) -> None:
    """ConformU's extended pulse test: poll IsPulseGuiding until false, then read RA/Dec (1" tolerance).

    Once IsPulseGuiding is false, the position a client reads must include the whole pulse.
    """
    slew_to_ha(api, -2.0, 30.0)
    wait_until(lambda: api.value("Slewing") is False and api.value("IsPulseGuiding") is False, 10, "rest")
    before = (api.value("RightAscension"), api.value("Declination"))
    truth_before = model.position()
    api.ok("PulseGuide", Direction=direction, Duration=3000)
    wait_until(lambda: api.value("IsPulseGuiding") is False, MOTION_TIMEOUT_S, "the pulse to end")
    after = (api.value("RightAscension"), api.value("Declination"))
    truth = sky_offset_deg(truth_before, model.position())
    seen = sky_offset_deg(before, after)
    assert seen[0] == pytest.approx(truth[0], abs=ARCSEC) and seen[1] == pytest.approx(truth[1], abs=ARCSEC), (
        f"read {seen[0] * 3600:.1f}\"/{seen[1] * 3600:.1f}\" of movement, the mount moved "
        f"{truth[0] * 3600:.1f}\"/{truth[1] * 3600:.1f}\"")


def test_ra_and_dec_pulses_run_at_once(server: AlpacaZwoServer, api: Api, model: MountModel) -> None:
    """R24: NINA sends both pulses back to back; both are accepted and IsPulseGuiding waits for both."""
    slew_to_ha(api, 2.0, 40.0)
    rate_deg_s = guide_rate_fraction(api) * SIDEREAL_DEG_S
    before = model.position()
    elapsed = pulse_and_watch(api, server, [(0, 2000), (2, 4000)])
    assert elapsed >= 4.0 - 0.05
    moved = sky_offset_deg(before, model.position())
    assert moved[0] == pytest.approx(rate_deg_s * 4.0, abs=0.2 * ARCSEC)
    assert moved[1] == pytest.approx(rate_deg_s * 2.0, abs=0.2 * ARCSEC)


def test_zero_length_pulse_is_accepted(api: Api) -> None:
    api.ok("PulseGuide", Direction=2, Duration=0)
    assert api.value("IsPulseGuiding") is False


def test_guide_rates_are_one_shared_rate(api: Api, model: MountModel) -> None:
    """R18: writing either guide rate sets both (the mount has one), and the mount gets it."""
    assert api.value("GuideRateRightAscension") == api.value("GuideRateDeclination")
    assert guide_rate_fraction(api) == pytest.approx(0.5, abs=0.005)
    api.ok("GuideRateRightAscension", GuideRateRightAscension=0.3 * SIDEREAL_DEG_S)
    assert api.value("GuideRateDeclination") == pytest.approx(0.3 * SIDEREAL_DEG_S, rel=1e-6)
    assert api.value("GuideRateRightAscension") == pytest.approx(0.3 * SIDEREAL_DEG_S, rel=1e-6)
    assert model.guide_rate() == pytest.approx(0.3)
    api.ok("GuideRateDeclination", GuideRateDeclination=0.8 * SIDEREAL_DEG_S)
    assert api.value("GuideRateRightAscension") == pytest.approx(0.8 * SIDEREAL_DEG_S, rel=1e-6)
    assert model.guide_rate() == pytest.approx(0.8)
    value = api.value("GuideRateRightAscension")
    api.ok("GuideRateRightAscension", GuideRateRightAscension=value)  # ConformU writes the read value back
    assert api.value("GuideRateRightAscension") == value
