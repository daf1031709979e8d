"""What the server knows about the mount: the immutable snapshot one poller swaps, and its parts.

Value types only, so readers (telescope, motion, web, bridges) can hold and pass a snapshot without
touching :class:`~alpaca_zwo.mount.operations.Mount` or the serial line.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from ..sky import PierSide
from ..zwo.firmware import has_feature
from ..zwo.link import LinkStatus
from ..zwo.protocol import TrackingState
from ..zwo.wire_values import MeridianSettings, MountMode, MountStatus, TrackRate

#: ``:Gps#``'s "parking" and "parked" (0 not parked, 1 parking, 2 parked, 3 park error).
PARKING, PARKED = 1, 2


@dataclass(frozen=True)
class MountInfo:
    """Identity read at connect; the firmware version gates features (field notes §5.6)."""

    model: str
    firmware: str

    @property
    def has_meridian_settings(self) -> bool:
        return has_feature(self.firmware, "meridian_settings")

    @property
    def has_park(self) -> bool:
        """The firmware's own park (``:hP#``, ``:Gps#``, ``:Spu#``) exists: from 1.1.9 (INDI)."""
        return has_feature(self.firmware, "park")


@dataclass(frozen=True)
class MountSettings:
    """Settings stored in the mount itself, read on demand (not polled)."""

    meridian: MeridianSettings | None
    limits_enabled: bool | None
    upper_limit: int | None
    lower_limit: int | None
    heavy_duty: bool | None
    buzzer: int | None
    guide_rate: float | None
    daylight_saving: bool | None = None


@dataclass(frozen=True)
class MountState:
    """One coherent picture of the mount. Each group of values carries the time it was read."""

    time: float  # monotonic time this snapshot was published
    ra: float | None = None  # hours, best estimate (sub-arcsecond)
    dec: float | None = None  # degrees
    raw_ra: float | None = None  # as the mount printed them
    raw_dec: float | None = None
    position_time: float | None = None  # monotonic time of the reading
    status: MountStatus | None = None
    status_time: float | None = None
    tracking: TrackingState | None = None
    pier: str | None = None  # 'E', 'W' or 'N' (home): the mount's letter as it printed it
    side: PierSide = PierSide.UNKNOWN  # the pointing state that letter means (mount/pier.py); UNKNOWN at home
    tracking_rate: TrackRate = TrackRate.SIDEREAL
    guide_rate: float = 0.5
    moving_axes: frozenset[int] = frozenset()
    link: LinkStatus | None = None
    info: MountInfo | None = None
    initialised: bool = False  # time and site pushed since the link last (re)connected
    poll_error: str = ""
    #: The firmware's own park as ``:Gps#`` last said: 0 none, 1 parking, 2 parked, 3 park error; None
    #: when not read (a tracking mount is never parked) or the firmware answers an empty ``#``.
    park: int | None = None

    def age(self, now: float | None = None) -> float | None:
        """Seconds since the position was read (None: never)."""
        if self.position_time is None:
            return None
        return (time.monotonic() if now is None else now) - self.position_time

    @property
    def parked_by_mount(self) -> bool:
        """The mount holds its own (firmware) park: ``:hP#`` from the ZWO app, ASIAIR, the hand
        controller or another program, kept across power cycles, released only by ``:Spu#``. Real
        1.8.8 firmware shows it as ``:Gps#`` ``2#`` and a status word ending in 5, never a ``P``
        (real-transcripts-1.8.8.md §1 "Park, home, unpark", §2 items 4 and 6)."""
        if self.park is not None:
            return self.park == PARKED
        return bool(self.status and self.status.parked)

    @property
    def park_latched(self) -> bool:
        """The mount's own park is latched, parked or still on its way (``:Gps#`` 1): what Unpark releases."""
        return self.parked_by_mount or self.park == PARKING

    @property
    def goto_running(self) -> bool:
        """A GOTO, home or park slew runs. A parked mount's status word lacks ``N`` too (``nGM000000005#``):
        that is the park, not a slew, once ``:Gps#`` says parked."""
        return bool(self.status and self.status.slewing) and self.park != PARKED

    @property
    def altaz(self) -> bool:
        """Alt-az mode as the last ``:GU#`` said (``Z``); the mount reads its mode only at power-up."""
        return self.status is not None and self.status.mode is MountMode.ALTAZ
