"""The position estimator alone: full precision between the mount's coarse readings, never against them."""

from __future__ import annotations

import pytest

from alpaca_zwo.mount.estimator import PositionEstimator

ARCSEC = 1.0 / 3600.0
GUIDE = 7.5 * ARCSEC  # a pulse at the 0.5x guide rate, degrees per second


def test_estimator_refines_coarse_readings_but_never_contradicts_them() -> None:
    est = PositionEstimator()
    est.set_exact(10.123456, 20.5, now=0.0)
    assert est.observe(10.123333, 20.5, now=1.0) == (10.123456, 20.5)  # within the 1 s / 1" resolution
    far = est.observe(10.2, 20.5, now=2.0)  # the mount disagrees: believe the mount
    assert far == (10.2, 20.5)


def test_estimator_applies_pulses_and_drift() -> None:
    est = PositionEstimator()
    est.set_exact(1.0, 0.0, now=0.0)
    est.add_motion(1.0, 2.0, 0.0, 0.001)
    assert est.predict(1.5) == pytest.approx((1.0, 0.0005))
    assert est.predict(5.0) == pytest.approx((1.0, 0.001))
    est.set_ra_rate(1 / 3600, now=5.0)
    assert est.predict(8.0)[0] == pytest.approx(1.0 + 3 / 3600)


def test_estimator_keeps_only_running_pulses() -> None:
    est = PositionEstimator()
    est.set_exact(1.0, 0.0, now=0.0)
    for i in range(1000):  # a night of 1 s pulses every 2 s
        est.add_motion(2.0 * i, 2.0 * i + 1.0, 0.0, 1e-6)
    assert len(est.pending) <= 1
    assert est.predict(2001.0)[1] == pytest.approx(1000 * 1e-6)


def test_estimator_wraps_ra() -> None:
    est = PositionEstimator()
    est.set_exact(23.99999, 0.0, now=0.0)
    est.set_ra_rate(1 / 3600, now=0.0)
    ra, _ = est.predict(10.0)
    assert 0.0 <= ra < 0.01
    assert est.observe(0.0025, 0.0, now=10.0)[0] == pytest.approx(ra)


def _pulsing() -> PositionEstimator:
    """At Dec 10°, a north pulse at the guide rate running since t=0 (an alt-az timed move)."""
    est = PositionEstimator()
    est.set_exact(5.0, 10.0, now=0.0)
    est.set_dec_rate(GUIDE, now=0.0)
    return est


def test_a_late_reading_during_a_pulse_agrees_over_the_window_the_mount_took_it_in() -> None:
    """The mount read 10°00'07″ at t=1.0 (7.5″ truncated); the reply arrived at 1.3 (a WiFi stall).
    Judged at its arrival it is 2.75″ behind the estimate; over [asked, arrival] it agrees."""
    est = _pulsing()
    assert est.observe(5.0, 10.0 + 7 * ARCSEC, now=1.3, asked=0.98) == pytest.approx((5.0, 10.0 + 1.3 * GUIDE))
    est.set_dec_rate(0.0, now=3.0)
    assert est.predict(4.0)[1] == pytest.approx(10.0 + 3.0 * GUIDE, abs=1e-9)  # the whole 22.5″ pulse
    # Judged at its arrival alone (no window), the same reading pulls the estimate back where the mount was.
    alone = _pulsing()
    assert alone.observe(5.0, 10.0 + 7 * ARCSEC, now=1.3)[1] == pytest.approx(10.0 + 7 * ARCSEC)


def test_a_reading_that_disagrees_corrects_as_of_the_windows_middle() -> None:
    """A reading 10″ off at every instant of its window corrects the estimate by what it shows at the
    window's middle, and keeps the motion since: the rest of the pulse is not lost."""
    est = _pulsing()
    ra, dec = est.observe(5.0, 10.0 + 17 * ARCSEC, now=1.2, asked=1.0)  # 17″ read against 7.5-9″
    assert ra == pytest.approx(5.0)
    assert dec == pytest.approx(10.0 + 17 * ARCSEC + 0.1 * GUIDE)  # read at 1.1, plus 0.1 s of pulse since
    assert est.predict(2.2)[1] == pytest.approx(dec + GUIDE)
    # RA the same, across 0h: 3 s of time off, corrected as of the middle with sidereal drift kept.
    drifting = PositionEstimator()
    drifting.set_exact(23.999, 0.0, now=0.0)
    drifting.set_ra_rate(1 / 3600.0, now=0.0)  # not tracking: RA rises 1 s of time per second
    ra, _ = drifting.observe(0.002, 0.0, now=2.0, asked=1.0)
    assert ra == pytest.approx(0.002 + 0.5 / 3600.0)


def test_a_reading_taken_across_a_change_of_rate_waits_for_the_next() -> None:
    """The pulse stopped at t=2.0 while a reading was under way (asked 1.9, arrived 2.1): when within its
    window the mount took it cannot be told against the stop, so it changes nothing; the next does."""
    est = _pulsing()
    est.set_dec_rate(0.0, now=2.0)
    expected = 10.0 + 2.0 * GUIDE
    assert est.observe(5.0, 10.0, now=2.1, asked=1.9)[1] == pytest.approx(expected)
    assert est.observe(5.0, 10.0, now=2.3, asked=2.2)[1] == pytest.approx(10.0)  # the mount disagrees: believed


def test_an_anchor_set_at_the_readings_arrival_is_judged_there() -> None:
    """The poll that brought a reading first books what it learnt (the GOTO target it landed on, a tracking
    change) at the reading's arrival: that reading is judged at ``now``, against the new anchor, not skipped."""
    est = PositionEstimator()
    est.set_exact(5.0, 10.0, now=2.0)  # the target, booked by the poll whose reading arrived at 2.0
    assert est.observe(5.0, 10.0 + 5 * ARCSEC, now=2.0, asked=1.8)[1] == pytest.approx(10.0 + 5 * ARCSEC)
    near = PositionEstimator()
    near.set_exact(5.0, 10.0, now=2.0)
    assert near.observe(5.0, 10.0 + 1 * ARCSEC, now=2.0, asked=1.8)[1] == pytest.approx(10.0)  # agrees: kept

