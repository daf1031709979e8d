"""The learners of mount/pier.py on their own: what a reading teaches and what it must not.

The end-to-end proof is tests/motion/test_sites.py (the server against every emulated firmware
reading); these pin down the rules, one reading at a time.
"""

from __future__ import annotations

from alpaca_zwo.mount.pier import DecSense, PierSides
from alpaca_zwo.sky import PierSide
from alpaca_zwo.zwo.wire_values import Direction

EAST, WEST = PierSide.EAST, PierSide.WEST


def _landed(pier: PierSides, letter: str, ha: float, south: bool, predicted: PierSide, certain: bool = True,
            now: float = 10.0) -> PierSide:
    """A GOTO sent, seen under way, then two readings at rest (the second is what a client reads)."""
    pier.goto_sent(predicted, certain, now)
    pier.observe(letter, ha, south, True, now + 1.0)
    pier.observe(letter, ha, south, False, now + 2.0)
    return pier.observe(letter, ha, south, False, now + 3.0)


def test_reversed_letters_are_learned_south_of_the_equator_far_from_the_meridian() -> None:
    pier = PierSides()
    assert _landed(pier, "E", -3.0, True, WEST) is WEST  # counterweight down at HA -3 h: pierWest
    assert pier.mechanical_names is True
    assert pier.observe("W", 3.0, True, False, 20.0) is EAST


def test_nothing_is_learned_in_the_north_or_after_a_manual_ra_move() -> None:
    north = PierSides()
    _landed(north, "W", -3.0, False, WEST)
    assert north.mechanical_names is None
    moved = PierSides()
    moved.ra_moved()
    assert moved.observe("E", -3.0, True, False, 1.0) is EAST  # the letter, unlearned
    assert moved.mechanical_names is None


def test_letters_that_follow_the_hour_angle_are_learned_and_memory_answers_near_the_meridian() -> None:
    pier = PierSides()
    assert _landed(pier, "W", -0.02, False, WEST) is WEST  # certain: every GOTO rule agrees west of it
    assert pier.observe("E", 0.05, False, False, 30.0) is WEST  # tracked past the meridian: still pierWest
    assert pier.follows_hour_angle is True
    assert pier.observe("E", 2.0, False, False, 40.0) is EAST  # far from it the letter is the side


def test_mechanical_letters_near_the_meridian_are_learned_as_such() -> None:
    pier = PierSides()
    _landed(pier, "W", -0.02, False, WEST)
    assert pier.observe("W", 0.05, False, False, 30.0) is WEST
    assert pier.follows_hour_angle is False


def test_a_goto_whose_side_the_rules_disagree_on_believes_the_letter() -> None:
    pier = PierSides()
    # Past the meridian inside "track past": A1 says pierWest, A2 pierEast; the letter says E.
    assert _landed(pier, "E", 0.05, False, WEST, certain=False) is EAST
    assert pier.follows_hour_angle is None


def test_a_dec_move_through_the_pole_changes_the_remembered_side() -> None:
    pier = PierSides()
    _landed(pier, "W", -0.02, False, WEST)
    pier.observe("E", 0.05, False, False, 30.0)  # learns: the letters follow the hour angle
    assert pier.observe("W", 0.05 - 12.0, False, True, 31.0) is EAST  # through the pole: 12 h jump
    assert pier.observe("E", 0.06, False, True, 32.0) is WEST  # and back


def test_home_forgets_the_side() -> None:
    pier = PierSides()
    _landed(pier, "W", -3.0, False, WEST)
    assert pier.observe("N", -6.0, False, False, 50.0) is PierSide.UNKNOWN


def test_dec_sense_learns_mechanical_north_on_pier_west_only() -> None:
    sense = DecSense()
    sense.started(Direction.NORTH, EAST, 30.0, None)  # pierEast teaches nothing
    assert not sense.observe(30.0 - 10 / 3600, EAST, 1.0) and sense.mechanical is None
    sense.started(Direction.NORTH, WEST, 30.0, None)
    assert not sense.observe(30.0 - 2 / 3600, WEST, 1.0)  # 2″: not yet
    assert sense.observe(30.0 - 4 / 3600, WEST, 1.5) and sense.mechanical is True
    assert sense.letter(Direction.NORTH, WEST) is Direction.SOUTH
    assert sense.letter(Direction.NORTH, EAST) is Direction.NORTH
    assert sense.letter(Direction.EAST, WEST) is Direction.EAST


def test_dec_sense_learns_sky_north_and_forgets_a_finished_pulse() -> None:
    sense = DecSense()
    sense.started(Direction.SOUTH, WEST, -20.0, until=5.0)
    assert not sense.observe(-20.0, WEST, 7.0)  # the pulse ended unmeasured: the watch is over
    sense.observe(-21.0, WEST, 8.0)  # a later, unrelated Dec change teaches nothing
    assert sense.mechanical is None
    sense.started(Direction.SOUTH, WEST, -20.0, None)
    assert not sense.observe(-20.0 - 5 / 3600, WEST, 9.0)  # south lowered Dec: sky directions
    assert sense.mechanical is False


def test_a_side_merely_read_is_not_trusted_to_teach_north_and_south() -> None:
    pier = PierSides()
    pier.ra_moved()
    pier.observe("W", -3.0, True, False, 1.0)
    assert not pier.trusted(-3.0, True)  # south of the equator, the letters' names not yet learned
    assert pier.trusted(-3.0, False)
    _landed(pier, "W", -3.0, True, WEST)
    assert pier.trusted(-3.0, True)
    assert not pier.trusted(0.05, True)  # near the meridian: whether the letters follow the hour angle
