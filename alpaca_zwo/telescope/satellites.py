"""The satellites the server keeps and follows (issue 41): TLE sets, their passes, and the follow of one.

``Satellites`` is a part of the Telescope. It keeps the TLE sets users give it (pasted on the page,
uploaded as a file, or through ``zwo:TrackSatellite``), one per catalogue number (a newer set replaces
an older one), in ``satellites.tle`` beside the configuration file, so they survive a restart with no
network: nothing is ever fetched. It plans passes over the site with the one limit check of a GoTo
(``passes.py``, ``orbits.py``) and starts a follow of the next one through the motion supervisor
(``motion/follow.py``), which owns the motion: a stop from any door ends it.
"""

from __future__ import annotations

import logging
import os
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path

from .. import sky
from .._exceptions import InvalidOperation, InvalidValue
from ..config.settings import Settings
from ..motion import MotionSupervisor
from ..motion.kinds import Follow, MotionKind
from ..mount.operations import Mount
from .orbits import Tle, parse_tles
from .passes import AllowedSky, Pass, passes
from .pointing import MountAltitudeLimits, goto_blocked

log = logging.getLogger(__name__)

#: The file of kept sets, beside ``config.toml``.
FILE_NAME = "satellites.tle"
#: At most this many sets are kept (a page paste of a whole CelesTrak group would plan for minutes).
MAX_SETS = 50
#: A follow starts only for a pass that enters the allowed sky within this time: Slewing stays true
#: from the start, and a mount held for an hour would keep every other client waiting.
MAX_WAIT_S = 900.0
#: A set further than this from now is not followed: the ISS's along-track error grows to minutes of
#: time within weeks (drag), so the mount would wait where the satellite never passes.
FOLLOW_MAX_AGE_DAYS = 14.0
#: The point the mount waits at lies this far above where the pass enters the allowed sky, so the GOTO
#: there is inside every limit when it is sent, a slew's time before the mount lands.
AIM_ABOVE_DEG = 0.5


@dataclass(frozen=True)
class Progress:
    """What ``zwo:TrackSatellite`` and the page read back of the follow running or last run."""

    name: str
    phase: str
    ended: str
    enters: datetime
    leaves: datetime
    error_arcmin: float | None
    rms_arcmin: float | None
    worst_arcmin: float | None
    acquired: datetime | None
    lead_s: float
    flip_at: datetime | None  # a planned meridian flip: the first leg ends (None: one leg)
    resumes: datetime | None  # ... and the second leg's follow starts
    reacquired: datetime | None  # the second leg's acquisition (its figures count from here)


def _arcmin(degrees: float | None) -> float | None:
    return None if degrees is None else round(degrees * 60.0, 3)


class Satellites:
    """The kept TLE sets, their passes and the follow (module docstring). Owns ``_sets`` (replaced whole,
    never changed in place, so a reader needs no lock; writes come from one request at a time per set)."""

    def __init__(self, *, mount: Mount, motion: MotionSupervisor, settings: Callable[[], Settings],
                 mount_limits: Callable[[], MountAltitudeLimits | None], flip_line_deg: Callable[[], float],
                 folder: Path | None) -> None:
        self._mount = mount
        self._motion = motion
        self._settings = settings
        self._mount_limits = mount_limits
        self._flip_line_deg = flip_line_deg
        self._path = None if folder is None else folder / FILE_NAME
        self._sets: dict[int, Tle] = {}
        self._follow: Follow | None = None
        self._load()

    # -- the kept sets -------------------------------------------------------------------------

    def _load(self) -> None:
        if self._path is None or not self._path.exists():
            return
        try:
            self._sets = {tle.number: tle for tle in parse_tles(self._path.read_text(encoding="utf-8"))}
        except (OSError, UnicodeDecodeError, InvalidValue) as exc:
            log.error("%s: kept satellites not read: %s", self._path, getattr(exc, "message", exc))

    def _save(self, sets: dict[int, Tle]) -> None:
        """Write the sets atomically (a temporary file, then a rename), as the configuration is."""
        if self._path is None:
            return
        text = "".join(tle.text + "\n" for tle in sets.values())
        try:
            self._path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=self._path.parent, prefix=f".{FILE_NAME}.", suffix=".tmp")
            with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as f:
                f.write(text)
            os.replace(tmp, self._path)
        except OSError as exc:
            raise InvalidOperation(f"the satellites could not be saved: {exc.strerror or exc}") from None

    def sets(self) -> list[Tle]:
        return list(self._sets.values())

    def add(self, text: str) -> list[Tle]:
        """Keep every set in ``text`` (checked first: a bad one keeps nothing); the sets it added."""
        found = parse_tles(text)
        sets = dict(self._sets)
        sets.update((tle.number, tle) for tle in found)
        if len(sets) > MAX_SETS:
            raise InvalidValue(f"at most {MAX_SETS} satellites are kept; remove some first")
        self._save(sets)
        self._sets = sets
        return found

    def remove(self, number: int) -> None:
        sets = {n: tle for n, tle in self._sets.items() if n != number}
        if len(sets) == len(self._sets):
            raise InvalidValue(f"no satellite {number} is kept")
        self._save(sets)
        self._sets = sets

    def find(self, key: str | int) -> Tle:
        """A kept set by catalogue number or name (case-insensitive)."""
        for tle in self._sets.values():
            if str(key).strip().lower() in (str(tle.number), tle.name.lower()):
                return tle
        raise InvalidValue(f"no satellite {key!r} is kept; give its TLE")

    def warnings(self, now: datetime | None = None) -> list[str]:
        """The sets too old to trust (``orbits.STALE_DAYS``)."""
        now = now or self._mount.time.now()
        return [w for w in (tle.stale(now) for tle in self._sets.values()) if w]

    # -- passes ------------------------------------------------------------------------------

    def sky(self) -> AllowedSky:
        """The site, the limits and the meridian rule the plans are made under, as they are now."""
        return AllowedSky(self._settings(), self._mount_limits(), self._flip_line_deg(),
                          self._motion.follower.top_speed())

    def passes(self, tle: Tle, hours: float = 24.0, start: datetime | None = None) -> list[Pass]:
        return passes(tle, self.sky(), start or self._mount.time.now(), hours)

    # -- the follow ----------------------------------------------------------------------------

    def follow(self, tle: Tle) -> Pass:
        """Start following the next pass of ``tle`` that can be followed: under way now, or entering the
        allowed sky within ``MAX_WAIT_S``. The pass it follows."""
        now = self._mount.time.now()
        if abs(tle.age_days(now)) > FOLLOW_MAX_AGE_DAYS:
            raise InvalidOperation(f"{tle.name}: its elements are {abs(tle.age_days(now)):.0f} days from now "
                                   f"(epoch {tle.epoch:%Y-%m-%d}); after {FOLLOW_MAX_AGE_DAYS:g} days a pass comes "
                                   "minutes off its prediction: load a fresh set")
        where = self.sky()
        found = passes(tle, where, now, hours=MAX_WAIT_S / 3600.0, limit=1)
        if not found:
            raise InvalidOperation(f"{tle.name} enters no allowed part of the sky within "
                                   f"{MAX_WAIT_S / 60.0:.0f} minutes; see its passes")
        chosen = found[0]
        leaves = chosen.leaves
        altaz = self._mount.state.altaz
        # A pass under way is planned from now (``passes``): its first leg starts here.
        flip = None if altaz else chosen.side.flip
        if not altaz:
            leaves = chosen.side.follow_until or leaves
        aim = self._aim(tle, where, chosen, max(now, chosen.enters), leaves)
        if aim >= leaves or (flip is not None and aim >= flip.flip_at):
            raise InvalidOperation(f"{tle.name}: what is left of the pass is too short to follow")
        site = self._settings().site

        def target(when: datetime) -> tuple[float, float]:
            spot = where.place(tle, when)
            return spot.ra_hours, spot.dec_deg

        def blocked(ra: float, dec: float, slew_s: float) -> str | None:
            """The one limit check of a GoTo (``pointing.goto_blocked``), for the flip's GOTO."""
            lst = sky.local_sidereal_time(self._mount.time.now(), self._settings().site.longitude)
            verdict = goto_blocked(self._settings(), self._mount_limits(), lst, ra, dec, slew_s)
            return None if verdict is None else verdict.detail

        follow = Follow(tle.name, target, chosen.enters, aim, leaves, blocked=blocked)
        if flip is not None:
            follow.flip_at, follow.resumes, follow.flip_side = flip.flip_at, flip.resumes, side_name(flip.side)
        self._motion.follow(follow)
        self._follow = follow
        log.info("following %s from %s to %s (site %.3f, %.3f)", tle.name, aim, leaves, site.latitude,
                 site.longitude)
        return chosen

    @staticmethod
    def _aim(tle: Tle, where: AllowedSky, chosen: Pass, start: datetime, leaves: datetime) -> datetime:
        """The first instant from ``start`` the satellite stands ``AIM_ABOVE_DEG`` above where it entered
        (or its highest point, if lower): the mount waits there."""
        floor = where.place(tle, start).altitude + AIM_ABOVE_DEG
        when = start
        while when < min(leaves, chosen.culmination) and where.place(tle, when).altitude < floor:
            when += timedelta(seconds=0.5)
        return when

    def stop(self) -> None:
        """End the follow running now (an abort, as STOP is); nothing when none runs."""
        running = self._motion.running()
        if running is not None and running.kind is MotionKind.FOLLOW:
            self._motion.abort("satellite follow stopped")

    def progress(self) -> Progress | None:
        """The follow running, or the last one and how it ended."""
        follow = self._follow
        if follow is None:
            return None
        return Progress(follow.name, follow.shown_phase, follow.ended, follow.enters, follow.leaves,
                        _arcmin(follow.error_deg), _arcmin(follow.rms_deg),
                        _arcmin(follow.worst_deg if follow.samples else None), follow.acquired,
                        round(follow.lead_s, 3), follow.flip_at, follow.resumes, follow.reacquired)


def side_name(side: sky.PierSide) -> str:
    return {sky.PierSide.EAST: "pierEast", sky.PierSide.WEST: "pierWest"}.get(side, "unknown")
