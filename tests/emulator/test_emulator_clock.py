"""Clocks: a scaled real-time clock and a manual one for exact tests."""

from __future__ import annotations

import time
from datetime import datetime, timedelta, timezone

import pytest

from alpaca_zwo.emulator import ManualClock, MountModel, ScaledClock
from alpaca_zwo.sky import SIDEREAL_DEG_S


def test_manual_clock_moves_only_when_advanced() -> None:
    start = datetime(2025, 1, 2, 3, 4, 5, tzinfo=timezone.utc)
    clock = ManualClock(start)
    assert clock.now() == start and clock.seconds() == 0.0
    clock.advance(90.5)
    assert clock.seconds() == 90.5
    assert clock.now() == start + timedelta(seconds=90.5)
    with pytest.raises(ValueError):
        clock.advance(-1.0)


def test_naive_start_times_are_utc() -> None:
    assert ManualClock(datetime(2025, 1, 1, 12)).now().tzinfo is timezone.utc
    assert ScaledClock(start_utc=datetime(2025, 1, 1, 12)).now().utcoffset() == timedelta(0)


def test_scaled_clock_runs_speed_times_faster_than_real_time() -> None:
    start = datetime(2025, 1, 1, tzinfo=timezone.utc)
    clock = ScaledClock(speed=50.0, start_utc=start)
    real0, emu0 = time.monotonic(), clock.seconds()
    while time.monotonic() - real0 < 0.1:  # measuring elapsed time, not waiting for a result
        time.sleep(0.01)
    real1, emu1 = time.monotonic(), clock.seconds()
    assert (emu1 - emu0) / (real1 - real0) == pytest.approx(50.0, rel=0.1)
    assert clock.now() - start >= timedelta(seconds=emu1)
    with pytest.raises(ValueError):
        ScaledClock(speed=0.0)


def test_model_physics_runs_on_the_clock_it_is_given() -> None:
    """With --speed 100 one real second of tracking moves the axis 100 s worth."""
    clock = ScaledClock(speed=100.0)
    model = MountModel(clock, initialized=True)
    assert model.tracking_on()
    p0, _ = model.axes()
    real0 = time.monotonic()
    while time.monotonic() - real0 < 0.1:
        time.sleep(0.01)
    p1, _ = model.axes()
    elapsed = time.monotonic() - real0
    assert (p1 - p0) / SIDEREAL_DEG_S == pytest.approx(100.0 * elapsed, rel=0.15)
