"""MoveAxis and AxisRates."""

from __future__ import annotations

import pytest

from alpaca_zwo.emulator import MountModel
from alpaca_zwo.server import AlpacaZwoServer
from tests.support import wait_until
from tests.telescope.harness import INVALID_VALUE, Api, slew_to_ha


def test_axis_rates_are_non_overlapping_ranges(api: Api) -> None:
    for axis in (0, 1):
        rates = api.value("AxisRates", Axis=axis)
        assert rates, f"axis {axis} has no rates"
        pairs = [(r["Minimum"], r["Maximum"]) for r in rates]
        assert all(set(r) == {"Minimum", "Maximum"} for r in rates)
        assert all(0 < lo <= hi for lo, hi in pairs)
        for i, (lo_i, _) in enumerate(pairs):  # ConformU's overlap rule, touching ranges included
            for j, (lo_j, hi_j) in enumerate(pairs):
                assert i == j or not lo_j <= lo_i <= hi_j, f"axis {axis}: {pairs[i]} overlaps {pairs[j]}"
        assert any(lo <= 0.5 <= hi for lo, hi in pairs), "INDI and TPPA move at 0.5 deg/s (R17)"
        assert max(hi for _, hi in pairs) >= 3.0  # up to slewing speed
    assert api.value("AxisRates", Axis=2) == []


@pytest.mark.parametrize("axis,sign", [(0, 1), (0, -1), (1, 1), (1, -1)])
def test_move_axis_moves_and_stops(server: AlpacaZwoServer, api: Api, model: MountModel, axis: int,
                                   sign: int) -> None:
    slew_to_ha(api, -2.0, 30.0)
    tracking = api.value("Tracking")
    before = model.axes()
    api.ok("MoveAxis", Axis=axis, Rate=sign * 0.5)
    assert api.value("Slewing") is True  # true immediately, while the rate is not zero
    wait_until(lambda: abs(model.axes()[axis] - before[axis]) > 1.0, 30.0, "the axis to move a degree")
    assert api.value("Slewing") is True
    api.ok("MoveAxis", Axis=axis, Rate=0.0)
    wait_until(lambda: api.value("Slewing") is False, 30.0, "Slewing false after MoveAxis(0)")
    assert api.value("Tracking") == tracking  # MoveAxis never changes Tracking


def test_move_axis_rate_limits(api: Api) -> None:
    rates = api.value("AxisRates", Axis=0)
    low = min(r["Minimum"] for r in rates)
    high = max(r["Maximum"] for r in rates)
    assert api.put("MoveAxis", Axis=0, Rate=low / 2).error == INVALID_VALUE
    assert api.put("MoveAxis", Axis=1, Rate=-(high + 1)).error == INVALID_VALUE
    assert api.put("MoveAxis", Axis=0, Rate=high + 1).error == INVALID_VALUE
    assert api.value("Slewing") is False
    api.ok("MoveAxis", Axis=1, Rate=-low)
    assert api.value("Slewing") is True
    api.ok("AbortSlew")  # also stops MoveAxis
    wait_until(lambda: api.value("Slewing") is False, 30.0, "AbortSlew to stop MoveAxis")
