"""The supervisor's parts alone, each built with its collaborators passed in as the supervisor builds it:
the rate-offset ledger (pure), the rest detector, the limit rules, the guide pulses and the pier flips on
a real Mount (and supervisor) on the emulator (tests/telescope/parts.py), the stop generation.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from alpaca_zwo import sky
from alpaca_zwo._exceptions import InvalidOperation, MotionCancelled
from alpaca_zwo.motion.balance import CYCLE_S, MIN_PULSE_MS, RateOffsets
from alpaca_zwo.motion.flip import PierFlips, side_setting
from alpaca_zwo.motion.guiding import Guiding
from alpaca_zwo.motion.kinds import MAX_AXIS_DEG_S, Generation, Motion, MotionKind
from alpaca_zwo.motion.limits import Limits
from alpaca_zwo.motion.rest import REST_READINGS, RestDetector
from alpaca_zwo.mount.operations import PULSE_CHUNK_MS
from alpaca_zwo.mount.state import MountState
from alpaca_zwo.zwo.protocol import TrackingState
from alpaca_zwo.zwo.wire_values import Direction, MeridianSettings
from tests.conftest import make_settings
from tests.support import wait_until
from tests.telescope.parts import parts_rig

GUIDE_ARCSEC_S = 7.5  # 0.5x sidereal


# -- RateOffsets: the ledger -------------------------------------------------------------------------


def test_an_offset_accrues_and_one_pulse_pays_it_ahead() -> None:
    ledger = RateOffsets()
    assert not ledger.active and ledger.due(0.0) is False
    ledger.set_rate(0, 3.0)  # 3″/s east
    assert ledger.active and ledger.due(0.0)
    ledger.accrue(10.0)
    ledger.accrue(10.0 + CYCLE_S)
    assert ledger.axes[0].owed == pytest.approx(3.0 * CYCLE_S)
    assert not ledger.due(10.0 + CYCLE_S + 0.1)
    pulse = ledger.next_pulse(0, GUIDE_ARCSEC_S)
    assert pulse is not None
    direction, ms = pulse
    assert direction is Direction.EAST
    # What was owed plus what accrues until the middle of the next cycle, booked as paid: slightly negative.
    assert ms / 1000.0 * GUIDE_ARCSEC_S > 3.0 * CYCLE_S
    assert ledger.axes[0].owed < 0.0
    assert ledger.next_pulse(1, GUIDE_ARCSEC_S) is None  # nothing owed on Dec


def test_a_negative_rate_pays_the_other_way_and_tiny_debts_wait() -> None:
    ledger = RateOffsets()
    ledger.set_rate(1, -0.01)
    ledger.accrue(0.0)
    ledger.accrue(0.1)
    assert ledger.next_pulse(1, GUIDE_ARCSEC_S) is None  # under MIN_PULSE_MS: waits for the next cycle
    ledger.axes[1].owed = -GUIDE_ARCSEC_S  # one second of guiding owed southwards
    direction, ms = ledger.next_pulse(1, GUIDE_ARCSEC_S) or (None, 0)
    assert direction is Direction.SOUTH and ms >= 1000 > MIN_PULSE_MS


def test_a_client_pulse_refunds_the_unfinished_offset_pulse_and_zero_rates_forget() -> None:
    ledger = RateOffsets()
    ledger.set_rate(0, 3.0)
    ledger.sent(0, decided=0.0, end=2.0, ms=2000, direction=Direction.WEST, guide_arcsec_s=GUIDE_ARCSEC_S)
    ledger.refund(0, now=1.5)  # half a second of a westward pulse never ran: owed again
    assert ledger.axes[0].owed == pytest.approx(-0.5 * GUIDE_ARCSEC_S)
    ledger.set_rate(0, 0.0)  # no offset left on any axis: nothing is owed any more
    assert ledger.axes[0].owed == 0.0 and ledger.accrued_at is None


# -- Generation: the stop counter every motion command carries -----------------------------------------


def test_a_guard_fails_once_a_stop_bumped_the_generation() -> None:
    stops = Generation()
    guard = stops.guard()
    assert guard()
    assert stops.bump() == stops.value
    assert not guard()
    assert stops.guard()()


# -- RestDetector: at rest, judged from readings, on a real mount ---------------------------------------


def _reading(t: float, ra: float, dec: float, tracking: bool = True) -> MountState:
    return MountState(time=t, raw_ra=ra, raw_dec=dec, position_time=t, tracking=TrackingState(tracking))


@contextmanager
def _rest_after_stop(tmp_path: Path, rest_from: float, brake_s: float) -> Iterator[tuple[RestDetector, Motion]]:
    """A RestDetector on a connected mount, and a stop whose readings count from ``rest_from``."""
    with parts_rig(tmp_path) as rig:
        rig.mount.connect()
        motion = Motion(MotionKind.STOP, generation=0, started=0.0, rest_from=rest_from, brake_s=brake_s)
        yield RestDetector(mount=rig.mount), motion


def test_rest_needs_agreeing_readings_after_the_braking_time(tmp_path: Path) -> None:
    with _rest_after_stop(tmp_path, rest_from=100.0, brake_s=2.0) as (rest, motion):
        for t in (101.0, 102.0, 103.0, 104.0):
            rest.record(_reading(t, 5.0, 20.0))
        assert not rest.at_rest(motion, now=101.5), "still inside the braking time"
        assert rest.at_rest(motion, now=104.5)
        rest.record(_reading(104.0, 6.0, 20.0))  # not newer than the last: ignored
        assert rest.readings[-1].ra == 5.0
        rest.record(_reading(105.0, 5.1, 20.0))  # 6 minutes of RA in a second: moving
        assert not rest.at_rest(motion, now=105.5)
        assert len([r for r in rest.readings if r.t > motion.rest_from]) >= REST_READINGS


def test_an_idle_mount_rests_in_hour_angle_and_a_pole_crossing_is_no_speed(tmp_path: Path) -> None:
    with _rest_after_stop(tmp_path, rest_from=0.0, brake_s=0.0) as (rest, motion):
        for t in (1.0, 2.0, 3.0):  # tracking off: RA grows with the sidereal time, HA stays
            rest.record(_reading(t, 5.0 + sky.SIDEREAL_HOURS_PER_S * t, 20.0, tracking=False))
        assert rest.at_rest(motion, now=3.5)
        rest.record(_reading(4.0, 17.0, 89.9, tracking=False))  # through the pole: RA jumps 12 h
        assert rest.speed_estimate([]) == MAX_AXIS_DEG_S
        assert rest.speed_estimate([0.5]) == MAX_AXIS_DEG_S


# -- Limits: braking-aware limits of a manual move, on a real mount -------------------------------------


def test_a_mount_under_the_minimum_altitude_may_only_climb(tmp_path: Path) -> None:
    """At home the north pole sits at the latitude's altitude (51.5°): with a 60° floor the mount is under
    the limit, so a Dec move (down either side of the pole) is refused and an RA turn (on the pole) is not."""
    base = make_settings()
    settings = dataclasses.replace(base, limits=dataclasses.replace(base.limits, min_altitude_deg=60.0))
    with parts_rig(tmp_path, settings=settings) as rig:
        rig.mount.connect()
        wait_until(lambda: rig.mount.position() is not None and rig.mount.state.position_time is not None, 5.0,
                   "a first position")
        limits = Limits(mount=rig.mount, settings=lambda: rig.settings,
                        lst=lambda: sky.local_sidereal_time(rig.mount.time.now(), rig.settings.site.longitude))
        with pytest.raises(InvalidOperation, match="horizon limit"):
            limits.check_move(1, 2.0)
        with pytest.raises(InvalidOperation, match="horizon limit"):
            limits.check_move(1, -2.0)
        limits.check_move(0, 2.0)  # turning about the pole lowers nothing
        assert limits.reached({0: 2.0}, rig.mount.state, running=False) == ""


# -- PierFlips: a GOTO under a temporary meridian limit, on a real mount and supervisor -----------------


def test_a_flip_goto_runs_under_its_limit_and_the_mounts_own_comes_back(tmp_path: Path) -> None:
    own = MeridianSettings(False, False, -3)
    with parts_rig(tmp_path) as rig:
        rig.mount.connect()
        assert rig.model.flash.set_meridian(own)
        flips = PierFlips(mount=rig.mount, motion=rig.motion, configured=lambda: own)
        lst = sky.local_sidereal_time(rig.mount.time.now(), rig.settings.site.longitude)
        temporary = side_setting(5)
        assert temporary == MeridianSettings(False, True, 5)  # "track past" only for a limit past the meridian
        motion = flips.goto((lst + 1.0) % 24.0, 80.0, temporary)  # near home: a short slew
        assert flips.in_force and rig.model.flash.meridian() == temporary
        assert motion.done.wait(60.0), "the GOTO ended"
        wait_until(lambda: not flips.in_force and rig.model.flash.meridian() == own, 10.0,
                   "the mount's own meridian setting back once the GOTO ended")
        # A GOTO without a temporary setting runs under the mount's own.
        plain = flips.goto((lst + 1.5) % 24.0, 80.0, None)
        assert not flips.in_force and rig.model.flash.meridian() == own
        assert plain.done.wait(60.0)


# -- Guiding: a client pulse longer than one :Mg, on a real mount ------------------------------------


def test_a_long_pulse_goes_out_in_chunks_until_its_length_is_sent(tmp_path: Path) -> None:
    with parts_rig(tmp_path) as rig:
        rig.mount.connect()
        stops, stopped = Generation(), list[str]()
        guiding = Guiding(mount=rig.mount, ledger=RateOffsets(), stops=stops, notify=lambda: None,
                          safety_stop=stopped.append)
        chunk = guiding.first_chunk_ms(5000)
        assert chunk == PULSE_CHUNK_MS < 5000  # equatorial: at most one :Mg at a time
        guiding.start(Direction.NORTH, 5000, chunk)
        assert guiding.busy and guiding.pulses[1].remaining_ms == 5000 - chunk
        wait_until(lambda: rig.model.pulsing()[1], 5.0, "the mount guiding in Dec")
        first = guiding.pulses[1]
        guiding.tick(first.chunk_end)  # the first chunk's end: the rest goes out
        assert guiding.pulses[1].remaining_ms == 0
        guiding.tick(guiding.pulses[1].chunk_end)  # nothing left to send: the pulse is done here
        assert not guiding.busy and not stopped
        # A stop's new generation withdraws a pulse being started: nothing reaches the mount.
        guard = stops.guard()
        stops.bump()
        with pytest.raises(MotionCancelled):
            guiding.guide_pulse(Direction.SOUTH, 100, guard=guard)
