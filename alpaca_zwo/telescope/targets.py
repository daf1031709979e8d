"""The Telescope's targets: TargetRightAscension, TargetDeclination and SlewSettleTime.

Values a client writes and reads back exactly; the slews and syncs read the target and set it
(``remember``). No lock: each is a single value written by one member and read by others.
"""

from __future__ import annotations

from .._exceptions import InvalidValue, ValueNotSet
from ..motion import MotionSupervisor


class Targets:
    """The target a SlewToTarget/SyncToTarget uses, and the settle time every slew ends with (on ``motion``)."""

    def __init__(self, *, motion: MotionSupervisor) -> None:
        self.motion = motion  # keeps Slewing true for the settle time after each slew
        self._ra: float | None = None
        self._dec: float | None = None
        self._settle_s = 0

    def target(self) -> tuple[float, float]:
        """(RA hours, Dec degrees); ValueNotSet (RA asked first) until both have been set."""
        return self.target_right_ascension(), self.target_declination()

    def remember(self, ra: float, dec: float) -> None:
        """A slew or sync to coordinates makes them the target (ASCOM: "the target is set to them")."""
        self._ra, self._dec = ra, dec

    # -- members -------------------------------------------------------------------------------

    def target_right_ascension(self) -> float:
        if self._ra is None:
            raise ValueNotSet("TargetRightAscension has not been set")
        return self._ra

    def target_declination(self) -> float:
        if self._dec is None:
            raise ValueNotSet("TargetDeclination has not been set")
        return self._dec

    def set_target_right_ascension(self, value: float) -> None:
        if not 0.0 <= value < 24.0:
            raise InvalidValue(f"TargetRightAscension {value} is outside 0..24 hours")
        self._ra = value

    def set_target_declination(self, value: float) -> None:
        if not -90.0 <= value <= 90.0:
            raise InvalidValue(f"TargetDeclination {value} is outside -90..90 degrees")
        self._dec = value

    def slew_settle_time(self) -> int:
        return self._settle_s

    def set_slew_settle_time(self, value: int) -> None:
        if not 0 <= value <= 3600:
            raise InvalidValue(f"SlewSettleTime {value} is outside 0..3600 s")
        self._settle_s = value
        self.motion.settle_s = float(value)
