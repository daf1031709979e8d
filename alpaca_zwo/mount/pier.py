"""Which pointing state the mount is in, and which way its N/S commands move: learned, not assumed.

No public source says what a ZWO mount's ``:Gm#`` letter names south of the equator, or whether its
``:Mn#``/``:Mgn`` move toward the sky's north on both pier sides (docs/southern.md lists the
readings; the emulator offers each as a firmware variant). The server must be right under all of
them, so it reads the mount's letters and moves through two small learners that watch what the mount
does with what the server sent:

- ``PierSides``: the letter may name ASCOM's pointing state, or the axes' mechanical state as a
  northern mount names it (then every letter is reversed south of the equator), or the side of the
  pointing's hour angle whatever the axes (then it is wrong wherever the counterweight is up, within
  the mount's ±15° meridian limits). A mount that a GOTO left far from the meridian has its
  counterweight down, so its letter there can only mean one side: that teaches whether letters are
  reversed. Near the meridian the server remembers the side from how the mount got there (the GOTO
  rule, which it predicts, then tracking, which never changes the side) and learns from the first
  disagreement whether the letters follow the hour angle; once they do, its memory answers there.
- ``DecSense``: a Dec move or pulse on pierWest shows whether ``:Mn#`` raised or lowered Dec there
  (on pierEast both readings agree): from then on the server sends the letter that moves the sky the
  way a client asked, on either side. A Dec move found going the wrong way is turned round at once.

Both are plain state, owned and locked by ``operations.Mount`` (its ``_pier_lock``).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

from .. import sky
from ..sky import PierSide
from ..zwo.wire_values import Direction

log = logging.getLogger(__name__)

#: Within this many degrees of the meridian (or the lower meridian) a mount may have its counterweight
#: up: the mount's limits reach 15° past it, and a GOTO or flip lands there; a margin for the landing.
ZONE_DEG = 20.0
#: An hour-angle jump this big between two readings is the pointing carried through the pole.
POLE_JUMP_H = 6.0
#: A Dec change this big (arcseconds) shows which way a Dec command moved; the mount prints whole ones.
SENSE_ARCSEC = 3.0
#: Mount seconds after a command within which the mount's flags may still show the state before it.
LAG_S = 1.5


def _letter_side(letter: str | None) -> PierSide:
    return PierSide.WEST if letter == "W" else PierSide.EAST if letter == "E" else PierSide.UNKNOWN


def _other(side: PierSide) -> PierSide:
    return PierSide.EAST if side is PierSide.WEST else PierSide.WEST if side is PierSide.EAST else side


def in_zone(ha_hours: float) -> bool:
    """Whether a pointing at ``ha_hours`` may have the counterweight up (near either meridian)."""
    ha_deg = abs(sky.wrap_hours_12(ha_hours)) * 15.0
    return ha_deg < ZONE_DEG or ha_deg > 180.0 - ZONE_DEG


@dataclass
class _Memory:
    side: PierSide = PierSide.UNKNOWN
    certain: bool = False  # from a GOTO whose side every reading of the evidence agrees on, or a letter known true
    confirmed: bool = False  # the letter agreed with it since the GOTO that set it


class PierSides:
    """The pointing state from ``:Gm#``, whatever the firmware names (see the module docstring)."""

    def __init__(self) -> None:
        #: The letters name the axes as a northern mount does (reversed south of the equator).
        self.mechanical_names: bool | None = None
        #: The letters follow the pointing's hour angle, not the axes.
        self.follows_hour_angle: bool | None = None
        self._memory = _Memory()
        self._expected: tuple[PierSide, bool] | None = None  # a GOTO's predicted side, until it lands
        self._sent_at = 0.0  # when that GOTO was sent (mount seconds)
        self._seen_busy = False  # and whether a reading has shown it under way since
        #: No GOTO since the server met the mount, or a manual RA move since the last one: the
        #: counterweight may be anywhere.
        self._moved_ra = True
        self._last: tuple[str, float] | None = None  # the last (letter, hour angle) seen

    def forget(self) -> None:
        """A mount restart or another mount: what it was doing is gone (the conventions stay)."""
        self._memory = _Memory()
        self._expected = None
        self._moved_ra = True
        self._last = None

    def goto_sent(self, predicted: PierSide, certain: bool, now: float) -> None:
        """A GOTO the mount took at ``now``: it lands on ``predicted`` (``certain``: under every reading
        of the GOTO side rule, docs/meridian.md)."""
        self._expected = (predicted, certain)
        self._sent_at, self._seen_busy = now, False
        self._moved_ra = False

    def ra_moved(self) -> None:
        self._moved_ra = True

    def observe(self, letter: str | None, ha_hours: float, south: bool, busy: bool, now: float) -> PierSide:
        """One reading at ``now``: the letter, the pointing's hour angle in the mount's own frame, the
        site's hemisphere, and whether a slew or move runs. Returns the pointing state."""
        if busy:
            self._seen_busy = True
        if letter == "N" or letter is None:
            self._memory = _Memory()
            self._last = None
            return PierSide.UNKNOWN
        self._note_pole_passage(letter, ha_hours)
        if not busy:
            self._learn(letter, ha_hours, south, now)
        named = self._named(letter, south)
        zone = in_zone(ha_hours)
        memory = self._memory
        if self.follows_hour_angle and zone and memory.side is not PierSide.UNKNOWN:
            return memory.side
        return named

    def trusted(self, ha_hours: float, south: bool) -> bool:
        """Whether the side ``observe`` gives here is known, not merely read: the letters' names are
        learned (south of the equator), and near the meridian whether they follow the hour angle.
        Only a known side may teach ``DecSense``: on the side mistaken for pierWest both N/S readings
        agree, and it would learn the wrong one."""
        if south and self.mechanical_names is None:
            return False
        return not in_zone(ha_hours) or self.follows_hour_angle is not None

    def _note_pole_passage(self, letter: str, ha_hours: float) -> None:
        """A Dec move through the pole changes the side: the letter changes and the hour angle jumps."""
        last = self._last
        self._last = (letter, ha_hours)
        if last is not None and last[0] != letter and abs(sky.wrap_hours_12(ha_hours - last[1])) > POLE_JUMP_H:
            self._memory.side = _other(self._memory.side)

    def _named(self, letter: str, south: bool) -> PierSide:
        """The side the letter names, reversed where the letters are known to be mechanical names."""
        named = _letter_side(letter)
        return _other(named) if south and self.mechanical_names else named

    def _learn(self, letter: str, ha_hours: float, south: bool, now: float) -> None:
        heading = sky.pointing_state(ha_hours)
        if south and self.mechanical_names is None and not in_zone(ha_hours) and not self._moved_ra \
                and self._expected is None:
            # A GOTO left the mount here, counterweight down: only one side can point here.
            self.mechanical_names = _letter_side(letter) is not heading
            if self.mechanical_names:
                log.info("the mount names its pier side mechanically: E/W are reversed south of the equator")
        named = self._named(letter, south)
        if self._expected is not None:
            if not (self._seen_busy or now - self._sent_at > LAG_S):
                return  # the flags may not show the GOTO yet
            self._land(named)
        if not in_zone(ha_hours):
            if not self._moved_ra:  # counterweight down: the side is the hour angle's
                self._memory = _Memory(heading, True, True)
            return
        self._learn_near_meridian(named, heading)

    def _land(self, named: PierSide) -> None:
        """A GOTO has landed: its side as predicted, unless the letter says otherwise and is not known
        to follow the hour angle (then the letter, and nothing is learned from it)."""
        assert self._expected is not None
        side, certain = self._expected
        self._expected = None
        if named is not side and not (certain and self.follows_hour_angle):
            side, certain = named, False
        self._memory = _Memory(side, certain, named is side)

    def _learn_near_meridian(self, named: PierSide, heading: PierSide) -> None:
        """Where the counterweight may be up: a letter that disagrees with a side the server knows for
        certain (and saw confirmed) shows the letters follow the hour angle; one that agrees while the
        hour angle says otherwise shows they name the axes."""
        memory = self._memory
        if memory.side is PierSide.UNKNOWN or not memory.certain:
            return
        if named is memory.side:
            memory.confirmed = True
            if self.follows_hour_angle is None and named is not heading:
                self.follows_hour_angle = False
        elif memory.confirmed and self.follows_hour_angle is None and named is heading:
            self.follows_hour_angle = True
            log.info("the mount's pier letter follows the hour angle: near the meridian the server keeps the "
                     "side from how the mount got there")
        elif self.follows_hour_angle is False:
            self._memory = _Memory(named, True, True)


@dataclass
class _Probe:
    sent: Direction  # the letter sent (NORTH: :Mn#)
    dec0: float
    until: float | None  # when the motion ends (mount seconds); None: a move, until it is stopped


class DecSense:
    """Which way ``:Mn#``/``:Mgn`` move Dec on pierWest (module docstring); pierEast agrees either way."""

    def __init__(self) -> None:
        #: ``:Mn#`` lowers Dec on pierWest (one way of the Dec axis, eq-satrack's AM3); None: not yet seen.
        self.mechanical: bool | None = None
        self._probe: _Probe | None = None

    def letter(self, wanted: Direction, side: PierSide) -> Direction:
        """The N/S command that moves the sky toward ``wanted`` on ``side`` (E/W pass through)."""
        if wanted in (Direction.EAST, Direction.WEST) or not self.mechanical or side is not PierSide.WEST:
            return wanted
        return Direction.SOUTH if wanted is Direction.NORTH else Direction.NORTH

    def started(self, sent: Direction, side: PierSide, dec: float | None, until: float | None) -> None:
        """A Dec motion began (``sent`` is the letter on the wire, the mount-frame Dec ``dec`` before
        it): watch it while it can teach. Any other motion ends the watch (``cancel``)."""
        self._probe = None
        if sent in (Direction.NORTH, Direction.SOUTH) and side is PierSide.WEST and dec is not None \
                and self.mechanical is None:
            self._probe = _Probe(sent, dec, until)

    def cancel(self) -> None:
        self._probe = None

    def ended(self, now: float) -> None:
        """The move being watched stopped at ``now``: its last readings may still teach."""
        if self._probe is not None and self._probe.until is None:
            self._probe.until = now

    def observe(self, dec: float, side: PierSide, now: float) -> bool:
        """A reading; True when it just showed ``:Mn#`` lowers Dec on pierWest (the caller turns a
        running move round). A side change, the pole or the motion's end (plus the readings' lag)
        ends the watch."""
        probe = self._probe
        if probe is None:
            return False
        if side is not PierSide.WEST or abs(dec) > 89.0 or (probe.until is not None and now > probe.until + LAG_S):
            self._probe = None
            return False
        moved = (dec - probe.dec0) * 3600.0
        if abs(moved) < SENSE_ARCSEC:
            return False
        self._probe = None
        self.mechanical = (moved > 0.0) != (probe.sent is Direction.NORTH)
        if self.mechanical:
            log.warning("the mount's :Mn#/:Mgn lower Dec on pierWest (N/S are mechanical): the server now sends "
                        "the opposite letter there")
        else:
            log.info("the mount's :Mn#/:Mgn move toward the sky's north on pierWest too")
        return self.mechanical
