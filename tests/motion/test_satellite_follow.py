"""Following a satellite's pass end to end on the emulator (issue 41): the ISS of the shipped TLE, with the
emulated universe started a little before its pass, in real time.

Judged by the emulator's truth (where the tube points, ``MountModel.position``) against SGP4's place every
0.1 s once the follower says it has acquired the satellite; and the motion rules: Slewing true throughout,
other motions and guiding refused with words that say why, a stop ends it at once and the mount comes to
rest.
"""

from __future__ import annotations

import math
import time
from datetime import timedelta
from pathlib import Path

import pytest

from alpaca_zwo import sky
from alpaca_zwo._exceptions import InvalidOperation
from alpaca_zwo.emulator import ScaledClock
from alpaca_zwo.motion.kinds import MotionKind
from alpaca_zwo.telescope.orbits import parse_tles
from alpaca_zwo.telescope.passes import AllowedSky, Pass, passes
from alpaca_zwo.telescope.satellites import Satellites
from alpaca_zwo.zwo.wire_values import Direction, MountMode
from tests.conftest import make_settings
from tests.support.wait import wait_until
from tests.telescope.parts import Rig, parts_rig

ISS = parse_tles((Path(__file__).parents[1] / "support" / "tle" / "iss-2018-05-15.tle").read_text(encoding="utf-8"))[0]
#: Seconds of the pass judged after acquisition (real time: the emulator runs at 1x).
JUDGED_S = 25.0


def _pass(low: float, high: float) -> Pass:
    found = passes(ISS, AllowedSky(make_settings(), None), ISS.epoch, hours=24.0, limit=50)
    return next(p for p in found if low < p.max_altitude < high and p.side.until is None)


def _satellites(rig: Rig, tmp_path: Path) -> Satellites:
    return Satellites(mount=rig.mount, motion=rig.motion, settings=lambda: rig.store.settings,
                      mount_limits=lambda: None, flip_line_deg=lambda: 0.0, folder=tmp_path)


@pytest.mark.parametrize("mode", [MountMode.EQUATORIAL, MountMode.ALTAZ], ids=["equatorial", "altaz"])
def test_a_low_pass_is_followed_within_an_arcminute_and_a_stop_ends_it(tmp_path: Path, mode: MountMode) -> None:
    chosen = _pass(5.0, 15.0)
    # The emulated universe starts 40 s before the pass enters the sky.
    clock = ScaledClock(1.0, start_utc=chosen.enters - timedelta(seconds=40))
    with parts_rig(tmp_path, clock=clock, mode=mode) as rig:
        rig.mount.connect()
        satellites = _satellites(rig, tmp_path)
        satellites.add(ISS.text)
        assert (tmp_path / "satellites.tle").read_text(encoding="utf-8").startswith("ISS (ZARYA)\n1 25544U")
        followed = satellites.follow(ISS)
        assert abs((followed.rise - chosen.rise).total_seconds()) < 1.0
        motion = rig.motion.running()
        assert motion is not None and motion.kind is MotionKind.FOLLOW
        assert rig.motion.slewing()
        # Nothing else may move the mount meanwhile, and the refusal says why.
        with pytest.raises(InvalidOperation, match="following ISS"):
            rig.motion.pulse(Direction.NORTH, 500)
        with pytest.raises(InvalidOperation, match="following ISS"):
            rig.motion.move_axis(0, 1.0, None)
        with pytest.raises(InvalidOperation, match="following ISS"):
            rig.motion.goto(1.0, 10.0)
        progress = wait_until(lambda: (p := satellites.progress()) is not None and p.acquired is not None and p,
                              timeout=60.0)
        acquired_after = (progress.acquired - followed.enters).total_seconds()
        assert acquired_after < 20.0
        errors = _judge(rig, JUDGED_S)
        rms = math.sqrt(sum(e * e for e in errors) / len(errors))
        assert rms < 1.0, (rms, max(errors))
        assert max(errors) < 3.0, errors
        satellites.stop()
        assert satellites.progress() is not None and satellites.progress().ended == "stopped"  # type: ignore[union-attr]
        wait_until(lambda: not rig.motion.slewing(), timeout=15.0)
        still = rig.model.snapshot()
        assert still["moves_deg_s"] == [None, None] and still["slew"] is None


def _judge(rig: Rig, seconds: float) -> list[float]:
    """The pointing error (arcmin) of the tube against SGP4 every 0.1 s for ``seconds``, Slewing true
    throughout."""
    errors = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        ra, dec = rig.model.position()
        spot = AllowedSky(rig.settings, None).place(ISS, rig.model.clock.now())
        errors.append(sky.angular_separation(ra, dec, spot.ra_hours, spot.dec_deg) * 60.0)
        assert rig.motion.slewing()
        time.sleep(0.1)
    return errors


def _before_the_flip(seconds: float) -> ScaledClock:
    """A universe that starts ``seconds`` before the planned flip of the ISS's first high pass that has one."""
    planned = passes(ISS, AllowedSky(make_settings(), None), ISS.epoch, hours=24.0, limit=50)
    high = next(p for p in planned if p.max_altitude > 80.0 and p.side.flip is not None)
    assert high.side.flip is not None
    return ScaledClock(1.0, start_utc=high.side.flip.flip_at - timedelta(seconds=seconds))


def test_a_high_pass_flips_mid_pass_and_follows_its_second_leg(tmp_path: Path) -> None:
    """A high pass: pierEast cannot follow past 15° before the meridian, so the plan flips to pierWest; the
    mount follows the first leg, says it flips, GOTOs to where the satellite will be, waits, and follows
    the second leg within the goals once re-acquired."""
    # The universe starts 75 s before the planned flip: the pass is under way, planned from there.
    clock = _before_the_flip(75.0)
    with parts_rig(tmp_path, clock=clock) as rig:
        rig.mount.connect()
        satellites = _satellites(rig, tmp_path)
        followed = satellites.follow(ISS)
        flip = followed.side.flip
        assert flip is not None and followed.side.side is sky.PierSide.EAST and flip.side is sky.PierSide.WEST
        wait_until(lambda: satellites.progress().acquired is not None, timeout=60.0)  # type: ignore[union-attr]
        assert rig.mount.state.side is sky.PierSide.EAST
        flipping = wait_until(lambda: (p := satellites.progress()) and p.phase.startswith("flipping") and p,
                              timeout=60.0, interval=0.1)
        assert flipping.phase == "flipping to pierWest" and rig.motion.slewing()
        assert abs((rig.model.clock.now() - flip.flip_at).total_seconds()) < 3.0
        wait_until(lambda: satellites.progress().phase == "waiting", timeout=flip.gap_s,  # type: ignore[union-attr]
                   interval=0.1)
        assert rig.mount.state.side is sky.PierSide.WEST and rig.motion.slewing()
        assert rig.model.clock.now() < flip.resumes  # the flip was done before the satellite got there
        second = wait_until(lambda: (p := satellites.progress()) and p.reacquired and p, timeout=30.0)
        assert (second.reacquired - flip.resumes).total_seconds() < 20.0
        assert satellites.progress().phase == "following"  # type: ignore[union-attr]
        errors = _judge(rig, JUDGED_S)
        rms = math.sqrt(sum(e * e for e in errors) / len(errors))
        assert rms < 1.0, (rms, max(errors))
        assert max(errors) < 3.0, errors
        progress = satellites.progress()
        assert progress is not None and progress.rms_arcmin is not None and progress.rms_arcmin < 1.0
        rig.motion.abort()
        assert satellites.progress().ended == "stopped"  # type: ignore[union-attr]
        wait_until(lambda: not rig.motion.slewing(), timeout=15.0)


def test_a_stop_during_the_flip_ends_the_follow_and_the_mount_comes_to_rest(tmp_path: Path) -> None:
    """AbortSlew while the flip's GOTO runs: the follow ends, no second leg starts, the mount is at rest."""
    clock = _before_the_flip(45.0)
    with parts_rig(tmp_path, clock=clock) as rig:
        rig.mount.connect()
        satellites = _satellites(rig, tmp_path)
        satellites.follow(ISS)
        wait_until(lambda: satellites.progress().phase.startswith("flipping")  # type: ignore[union-attr]
                   and rig.model.snapshot()["slew"] is not None, timeout=90.0, interval=0.1)
        assert rig.motion.slewing()
        rig.motion.abort()
        progress = satellites.progress()
        assert progress is not None and progress.phase == "ended" and progress.ended == "stopped"
        wait_until(lambda: not rig.motion.slewing(), timeout=30.0)
        still = rig.model.snapshot()
        assert still["moves_deg_s"] == [None, None] and still["slew"] is None
        assert satellites.progress().phase == "ended"  # type: ignore[union-attr]
