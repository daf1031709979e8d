"""The Telescope's capabilities that vary, the members a ZWO mount lacks, its rates and its site.

The Can* flags that never change are constants in the member table (``alpaca/members.py``); the
ones here depend on the mount (CanSetPierSide: its mode and firmware) or take an argument (CanMoveAxis).
The rates: the drive rate (TrackingRate, TrackingRates), its offsets (RightAscensionRate, DeclinationRate),
the guide rate and the axis rates.

No lock here: the rate offsets are plain floats written by one member and read back, and the
settings store serialises its own saves.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable, Mapping

from .._exceptions import (
    InvalidOperation,
    InvalidValue,
    MemberNotImplemented,
    mount_errors,
)
from ..config.settings import Settings
from ..config.store import SettingsStore
from ..motion import MotionSupervisor
from ..motion.offsets import MAX_OFFSET_ARCSEC, ra_rate_to_arcsec
from ..mount.operations import Mount
from ..sky import SIDEREAL_DEG_S
from ..zwo.wire_values import SLEW_SPEEDS, TrackRate

log = logging.getLogger(__name__)

AXIS_MIN_DEG_S = SLEW_SPEEDS[0] * SIDEREAL_DEG_S  # 0.25x sidereal
#: TrackingRate codes (ASCOM DriveRates) and the mount's rates; King (3) the mount does not have.
DRIVE_RATES = {0: TrackRate.SIDEREAL, 1: TrackRate.LUNAR, 2: TrackRate.SOLAR}
RATE_CODES = {rate: code for code, rate in DRIVE_RATES.items()}


class Capabilities:
    """CanSetPierSide, CanMoveAxis, AxisRates, the drive, guide and offset rates and the site of
    :class:`~alpaca_zwo.telescope.device.Telescope`.

    ``require_connected`` is the owner's connection check (raises NotConnected), called where a
    member needs the mount.
    """

    def __init__(self, *, mount: Mount, store: SettingsStore, motion: MotionSupervisor,
                 require_connected: Callable[[], None]) -> None:
        self.mount = mount
        self.store = store
        self.motion = motion  # pays the rate offsets
        self._require_connected = require_connected
        self._ra_rate = 0.0  # RightAscensionRate as written (RA seconds per sidereal second)
        self._dec_rate = 0.0  # DeclinationRate as written (arcseconds per second)

    @property
    def settings(self) -> Settings:
        return self.store.settings

    # -- capabilities ------------------------------------------------------------------------

    def can_set_pier_side(self) -> bool:
        """A German mount flips on a SideOfPier write (motion/flip.py) by a temporary meridian limit, so
        only with firmware that has meridian settings (1.2.4+); an alt-az mount has no pier side."""
        return self.flips_by_limit()

    def flips_by_limit(self) -> bool:
        """Whether the server may choose a GOTO's pier side by a temporary :STa limit: equatorial mode and
        firmware with meridian settings (unknown firmware: not yet read, assume the current kind)."""
        state = self.mount.state
        return not state.altaz and (state.info is None or state.info.has_meridian_settings)

    def can_move_axis(self, axis: int) -> bool:
        if axis not in (0, 1, 2):
            raise InvalidValue(f"axis {axis} does not exist; axes are 0 (RA), 1 (Dec) and 2 (none on this mount)")
        return axis in (0, 1)

    def axis_rates(self, axis: int) -> list[tuple[float, float]]:
        if not self.can_move_axis(axis):
            return []
        return [(AXIS_MIN_DEG_S, self.max_rate())]

    def max_rate(self) -> float:
        return SLEW_SPEEDS[-1] * SIDEREAL_DEG_S

    # -- properties the mount does not have ----------------------------------------------------

    def aperture_area(self) -> float:
        raise MemberNotImplemented("a mount does not know the telescope's aperture")

    def aperture_diameter(self) -> float:
        raise MemberNotImplemented("a mount does not know the telescope's aperture")

    def focal_length(self) -> float:
        raise MemberNotImplemented("a mount does not know the telescope's focal length")

    def set_does_refraction(self, value: bool) -> None:
        if value:
            raise MemberNotImplemented("the mount does not correct for refraction")

    # -- the drive rate -------------------------------------------------------------------------

    def tracking_rates(self) -> list[int]:
        return sorted(DRIVE_RATES)

    def tracking_rate(self) -> int:
        self._require_connected()
        return RATE_CODES[self.mount.state.tracking_rate]

    def set_tracking_rate(self, value: int) -> None:
        if value not in DRIVE_RATES:
            raise InvalidValue(f"TrackingRate {value} is not supported; use 0 (sidereal), 1 (lunar) or 2 (solar)")
        self._require_connected()
        with mount_errors("setting the tracking rate"):
            self.mount.set_tracking_rate(DRIVE_RATES[value])
        if DRIVE_RATES[value] is not TrackRate.SIDEREAL:  # offsets exist only on sidereal (Platform 7)
            self.zero_offsets()

    # -- rate offsets ----------------------------------------------------------------------------
    # Rate offsets are paid as guide pulses by the motion supervisor (motion/offsets.py); the values
    # clients wrote are kept exactly, for read-back.

    def declination_rate(self) -> float:
        self._require_connected()
        return self._dec_rate if self._sidereal() else 0.0

    def set_declination_rate(self, value: float) -> None:
        self._set_rate_offset(1, value, value, "DeclinationRate", "arcseconds per second")
        self._dec_rate = value

    def right_ascension_rate(self) -> float:
        self._require_connected()
        return self._ra_rate if self._sidereal() else 0.0

    def set_right_ascension_rate(self, value: float) -> None:
        self._set_rate_offset(0, value, ra_rate_to_arcsec(value), "RightAscensionRate",
                              "seconds of RA per sidereal second")
        self._ra_rate = value

    def zero_offsets(self) -> None:
        """Off sidereal no rate offset exists (Platform 7): forget those written and stop paying them."""
        self._ra_rate = self._dec_rate = 0.0
        self.motion.set_rate_offset(0, 0.0)
        self.motion.set_rate_offset(1, 0.0)

    def _sidereal(self) -> bool:
        return self.mount.state.tracking_rate is TrackRate.SIDEREAL

    def _set_rate_offset(self, axis: int, value: float, arcsec_s: float, name: str, unit: str) -> None:
        self._require_connected()
        if not self._sidereal():
            raise InvalidOperation(f"{name} can only be set while TrackingRate is sidereal (Platform 7)")
        if not math.isfinite(arcsec_s) or abs(arcsec_s) > MAX_OFFSET_ARCSEC:
            limit = MAX_OFFSET_ARCSEC if axis == 1 else MAX_OFFSET_ARCSEC / ra_rate_to_arcsec(1.0)
            raise InvalidValue(f"{name} {value} is beyond ±{limit:.4f} {unit}, the largest offset this server "
                               "tracks (a slew is the way to go faster)")
        self.motion.set_rate_offset(axis, arcsec_s)

    # -- guide rates (one mount rate shared by both axes) --------------------------------------

    def guide_rate_right_ascension(self) -> float:
        self._require_connected()
        return self.mount.state.guide_rate * SIDEREAL_DEG_S

    def guide_rate_declination(self) -> float:
        return self.guide_rate_right_ascension()

    def set_guide_rate_right_ascension(self, value: float) -> None:
        fraction = value / SIDEREAL_DEG_S
        if not 0.095 <= fraction <= 0.905:
            raise InvalidValue(
                f"guide rate {value:.6f} deg/s is {fraction:.2f}x sidereal; the mount accepts 0.1x to 0.9x "
                f"({0.1 * SIDEREAL_DEG_S:.6f} to {0.9 * SIDEREAL_DEG_S:.6f} deg/s)"
            )
        self._require_connected()
        with mount_errors("setting the guide rate"):
            self.mount.set_guide_rate(min(0.9, max(0.1, round(fraction, 2))))

    def set_guide_rate_declination(self, value: float) -> None:
        self.set_guide_rate_right_ascension(value)

    # -- site ----------------------------------------------------------------------------------

    def site_latitude(self) -> float:
        return self.settings.site.latitude

    def site_longitude(self) -> float:
        return self.settings.site.longitude

    def site_elevation(self) -> float:
        return self.settings.site.elevation

    def set_site_latitude(self, value: float) -> None:
        if not -90.0 <= value <= 90.0:
            raise InvalidValue(f"SiteLatitude {value} is outside -90..90 degrees")
        self._update_site(latitude=value)

    def set_site_longitude(self, value: float) -> None:
        if not -180.0 <= value <= 180.0:
            raise InvalidValue(f"SiteLongitude {value} is outside -180..180 degrees")
        self._update_site(longitude=value)

    def set_site_elevation(self, value: float) -> None:
        if not -300.0 <= value <= 10000.0:
            raise InvalidValue(f"SiteElevation {value} is outside -300..10000 m")
        self._update_site(elevation=value)

    def set_site(self, values: Mapping[str, float]) -> None:
        """Several site values (latitude, longitude, elevation) in one save: all applied or none (setup page)."""
        unknown = set(values) - {"latitude", "longitude", "elevation"}
        if unknown:
            raise InvalidValue(f"unknown site value(s): {', '.join(sorted(unknown))}")
        self._check_site(**values)
        self._update_site(**values)

    @staticmethod
    def _check_site(latitude: float = 0.0, longitude: float = 0.0, elevation: float = 0.0) -> None:
        for name, value, low, high in (("SiteLatitude", latitude, -90.0, 90.0),
                                       ("SiteLongitude", longitude, -180.0, 180.0),
                                       ("SiteElevation", elevation, -300.0, 10000.0)):
            if not low <= value <= high:
                raise InvalidValue(f"{name} {value} is outside {low:g}..{high:g}")

    def _update_site(self, **changes: float) -> None:
        """Keep the exact values clients wrote (they read back with ==); the mount gets arcseconds.

        Saved first, pushed to the mount after: a failed save (SettingsNotSaved) changes nothing; a
        mount that then fails to take it keeps the old site until the next connect pushes the saved one.
        """
        now = self.settings.site
        site = dataclasses.replace(now, latitude=changes.get("latitude", now.latitude),
                                   longitude=changes.get("longitude", now.longitude),
                                   elevation=changes.get("elevation", now.elevation))
        self.store.update(lambda s: dataclasses.replace(s, site=site))
        if self.mount.running and ("latitude" in changes or "longitude" in changes):
            with mount_errors("setting the site"):
                self.mount.push_site(site.latitude, site.longitude)
