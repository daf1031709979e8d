"""The physics and state of an emulated ZWO AM mount.

A German equatorial mount is two mechanical axes, not a pair of sky coordinates: the primary
(RA) axis angle ``p`` and the secondary (Dec) axis angle ``s``, both in degrees here.

- Pointing side WEST (ASCOM pierWest, looking east, the normal side): HA = p, Dec = s.
- Pointing side EAST (through the pole, looking west): HA = p + 12 h, Dec = 180 - s.
- Home: p = -90 (HA -6 h), s = 90 (the pole); ``:Gm#`` says ``N`` there.

Everything a client sees is derived from (p, s), the mount's own clock and its stored site,
exactly as on the real mount: RA drifts with sidereal time when tracking is off, LST and Alt/Az
are wrong until the client sets time and site, a meridian flip swings the Dec axis through the
pole and takes as long as it would on the real thing.

Motion is integrated lazily: every public call first advances the physics to ``clock.seconds()``
in bounded steps, so the result depends only on the sequence of clock readings (a
``ManualClock`` makes tests exact). Each step integrates a trapezoidal velocity profile exactly
(accelerate at ``accel`` toward the commanded velocity, then hold it), so a 1000 ms guide pulse
moves exactly rate x 1 s however the steps fall. GOTOs use a sampled braking-curve controller
that chases the target's moving hour angle and snaps onto it once within a fraction of an
arcsecond.

The class is assembled from parts, one module each, sharing the state ``state.ModelBase``
declares: ``physics.Mechanics`` (axis integration), ``clocksite.ClockAndSite`` (the mount's clock
and site) and ``flash.FlashSettings`` (settings kept in flash); this module has the commands.

In alt-az mode (``:AA#``, in effect after a power cycle) the same axes are azimuth and altitude;
``altaz`` says what moves how. Not modelled (see the README): southern-hemisphere homes (home
is always the north celestial pole), refraction, encoder/periodic errors, ST-4 guiding and the
meaning of the ``:GU#`` digits.
"""

from __future__ import annotations

import threading
from datetime import datetime, timezone
from typing import Any

from .. import sky
from ..sky import SIDEREAL_DEG_S
from ..zwo.firmware import FirmwareVariant
from ..zwo.wire_values import SLEW_SPEEDS, MountMode, MountStatus
from .altaz import AltAzRules
from .clock import Clock
from .clocksite import ClockAndSite
from .faults import FaultEvent, Faults
from .flash import FlashSettings
from .physics import Mechanics
from .state import (
    ACCEL_DEG_S2,
    DEC,
    EPOCH_LOCAL,
    FACTORY_LATITUDE,
    FACTORY_LONGITUDE,
    HOME_P,
    HOME_S,
    PARK_P,
    PARK_S,
    PULSE_MAX_MS,
    RA,
    SYNC_MAX_DEG,
    SYNC_POLE_DEG,
    TRACK_RATES,
    Persistent,
    Pulse,
    Slew,
)

__all__ = [
    "FACTORY_LATITUDE",
    "FACTORY_LONGITUDE",
    "FirmwareVariant",
    "MountModel",
]

# --------------------------------------------------------------------------------------------
# The model
# --------------------------------------------------------------------------------------------


class MountModel(Mechanics, ClockAndSite, FlashSettings, AltAzRules):
    """One emulated mount: thread-safe (one lock), advanced lazily to the clock on every call.

    Methods return plain values (bools, error codes, floats); the ``Responder`` turns them into
    the mount's exact reply text.
    """

    def __init__(
        self,
        clock: Clock,
        firmware: FirmwareVariant | None = None,
        site: tuple[float, float] | None = None,
        *,
        initialized: bool = False,
        faults: Faults | None = None,
        accel: float = ACCEL_DEG_S2,
        mode: MountMode = MountMode.EQUATORIAL,
    ) -> None:
        """``site`` is the (latitude, east longitude) stored in the mount, returned after every
        power-up; ``initialized`` starts as if a client had already set date, time and site;
        ``mode`` is the mount mode in flash (as if ``:AA#``/``:AP#`` and a restart had happened)."""
        self._lock = threading.RLock()
        self._clock = clock
        self.firmware = firmware if firmware is not None else FirmwareVariant()
        self._accel = accel
        self._persist = Persistent(mode=mode)
        if site is not None:
            self._persist.latitude, self._persist.longitude = float(site[0]), float(site[1])
        self.faults = faults if faults is not None else Faults()
        self.faults.add_listener(self._on_fault)
        self.power_ups = 0
        self._t = clock.seconds()
        self._power_up()
        if initialized:
            self.initialize()

    # ---------------------------------------------------------------- lifecycle

    @property
    def clock(self) -> Clock:
        return self._clock

    def _on_fault(self, event: FaultEvent) -> None:
        if event.kind == "reboot":
            self.power_cycle()

    def power_cycle(self) -> None:
        """Switch the mount off and on: volatile state is lost, flash settings are kept."""
        with self._lock:
            self._advance()
            self._power_up()

    def _power_up(self) -> None:
        persist = self._persist
        self.power_ups += 1
        # The mount's own clock: no RTC, so 01/01/00 00:00:00 at power-on, zone +00:00.
        self._local_ref = EPOCH_LOCAL
        self._local_ref_t = self._t
        self._utc_offset = 0.0  # true UTC offset in hours (the mount shows it negated)
        self._dst = False
        self._lst_offset = 0.0  # hours, from :SS#
        self._date_set = self._time_set = False
        self._lat_set = self._lon_set = False
        self._latitude = persist.latitude
        self._longitude = persist.longitude
        self._mode = persist.mode
        self._ble_suffix = persist.ble_suffix
        # Mechanics
        self._pos = [HOME_P, HOME_S]
        self._vel = [0.0, 0.0]
        self._last_side = sky.PierSide.WEST
        self._slew: Slew | None = None
        self._braking_until = self._t
        self._moves: list[float | None] = [None, None]
        self._pulses: list[Pulse | None] = [None, None]
        self._speed = SLEW_SPEEDS[9]
        self._disturbed_t = self._t
        self._axis_speed: list[float | None] = [None, None]
        # Tracking
        self._tracking = False
        self._track_rate = "sidereal"
        self._custom_multiple = 1.0
        self._track_error: int | None = None
        # Targets and alignment
        self._target_ra = 0.0
        self._target_dec = 0.0
        self._offset_ra = 0.0  # hours
        self._offset_dec = 0.0  # degrees
        self._alignment_points = 0
        # Home bookkeeping
        self._homed = False  # a home slew completed since power-up
        self._home_flag = False  # 'H' latch of the after_home variant

    def initialize(self, utc: datetime | None = None) -> None:
        """Set date, time (zone +00:00) and mark the stored site as set, as a client would."""
        with self._lock:
            self._advance()
            now = utc if utc is not None else self._clock.now()
            if now.tzinfo is not None:
                now = now.astimezone(timezone.utc).replace(tzinfo=None)
            self._set_local(now)
            self._utc_offset = 0.0
            self._date_set = self._time_set = self._lat_set = self._lon_set = True

    # ---------------------------------------------------------------- position, target

    def position(self) -> tuple[float, float]:
        """(RA hours, Dec degrees) the mount reports, alignment offsets included."""
        with self._lock:
            self._advance()
            return self._reported()

    def horizontal(self) -> tuple[float, float]:
        """(altitude, azimuth from north) of the reported position, at the mount's site and LST."""
        with self._lock:
            self._advance()
            ra, dec = self._reported()
            return sky.equatorial_to_horizontal(sky.hour_angle(self._lst(), ra), dec, self._latitude)

    def axes(self) -> tuple[float, float]:
        """Mechanical (primary, secondary) axis angles in degrees, for tests and inspection."""
        with self._lock:
            self._advance()
            return self._pos[RA], self._pos[DEC]

    def pier_letter(self) -> str:
        """``:Gm#``: N at home, else W (pierWest, looking east) or E (through the pole)."""
        with self._lock:
            self._advance()
            if self._at_home_position():
                return "N"
            return "W" if self._side() is sky.PierSide.WEST else "E"

    def set_target_ra(self, hours: float) -> bool:
        with self._lock:
            self._target_ra = hours
            return True

    def set_target_dec(self, degrees: float) -> bool:
        if not -90.0 <= degrees <= 90.0:
            return False
        with self._lock:
            self._target_dec = degrees
            return True

    def target(self) -> tuple[float, float]:
        with self._lock:
            return self._target_ra, self._target_dec

    # ---------------------------------------------------------------- GOTO, home, park, stop

    def goto(self) -> int:
        """Start a GOTO to the target; 0 on success, else the mount's error code."""
        with self._lock:
            self._advance()
            if self._persist.parked:
                return 4  # a guess: no ZWO code for "parked" is published (OnStep uses 4)
            if not self._initialized():
                return 7
            if self._slew is not None or self._braking():
                return 3  # also while a stopped slew still brakes (README: "GOTO during braking")
            lst = self._lst()
            ha = sky.hour_angle(lst, self._target_ra)
            alt, _ = sky.equatorial_to_horizontal(ha, self._target_dec, self._latitude)
            if alt < 0.0:
                return 5
            persist = self._persist
            if persist.limits_enabled and not persist.lower_limit <= alt <= persist.upper_limit:
                return 6
            raw_ra = sky.wrap_hours_24(self._target_ra - self._offset_ra)
            raw_dec = max(-90.0, min(90.0, self._target_dec - self._offset_dec))
            raw_ha = sky.hour_angle(lst, raw_ra)
            if self._altaz():
                self._start_slew(self._altaz_goto(raw_ha, raw_dec))
                return 0
            side = sky.goto_pier_side(raw_ha, self._side(), self._goto_limit_deg())
            if side is sky.PierSide.EAST:
                p, s = (raw_ha - 12.0) * 15.0, 180.0 - raw_dec
            else:
                p, s = raw_ha * 15.0, raw_dec
            self._start_slew(Slew("goto", self._t, p, SIDEREAL_DEG_S, s, side))
            return 0

    def _start_slew(self, slew: Slew) -> None:
        self._slew = slew
        self._braking_until = self._t  # the new slew takes over the braking axes
        self._moves = [None, None]
        self._pulses = [None, None]
        self._track_error = None  # a slew moves away from whatever stopped tracking

    def home(self) -> bool:
        """``:hC#``: slew to the mechanical home; tracking goes off on arrival."""
        with self._lock:
            self._advance()
            if self._persist.parked:
                return False
            self._start_slew(Slew("home", self._t, HOME_P, 0.0, HOME_S))
            return True

    def park(self) -> bool:
        """``:hP#``: slew to the (custom or factory) park position and latch the parked state."""
        with self._lock:
            self._advance()
            if self._mode is not MountMode.EQUATORIAL:
                return False
            p, s = self._persist.custom_park or (PARK_P, PARK_S)
            self._persist.parked = True
            side = sky.PierSide.EAST if s > 90.0 else sky.PierSide.WEST
            self._start_slew(Slew("park", self._t, p, 0.0, s, side))
            return True

    def unpark(self) -> bool:
        """``:Spu#``: clear the latch; False when there was none."""
        with self._lock:
            self._advance()
            was = self._persist.parked
            self._persist.parked = False
            return was

    def park_status(self) -> int:
        """0 not parked, 1 parking, 2 parked."""
        with self._lock:
            self._advance()
            if not self._persist.parked:
                return 0
            return 1 if self._slew is not None and self._slew.kind == "park" else 2

    def set_park_position(self) -> str:
        """``:Sp01#``: the one-character result code (field notes §4.2)."""
        with self._lock:
            self._advance()
            if self._mode is not MountMode.EQUATORIAL:
                return "4"
            if self._moving():
                return "9"
            if not self._homed:
                return "5"
            self._persist.custom_park = (self._pos[RA], self._pos[DEC])
            return "1"

    def set_current_as_home(self) -> bool:
        """``:SOa#``: redefine the current position as the mechanical home."""
        with self._lock:
            self._advance()
            if self._moving():
                return False
            self._pos = [HOME_P, HOME_S]
            self._vel = [self._vel[RA], 0.0]
            return True

    def homed(self) -> bool:
        with self._lock:
            return self._homed

    def stop(self) -> None:
        """``:Q#``: end GOTO/home/park slews, moves and pulses; tracking stays as it was.

        The axes brake at the normal deceleration. A stopped slew keeps the mount in its GOTO
        state until both axes have braked (no ``N`` in ``:GU#``, ``:MS#`` answers ``e3#``), as the
        firmware's state machine does (README: "GOTO during braking").
        """
        with self._lock:
            self._advance()
            was_slewing = self._slew is not None
            self._slew = None
            self._moves = [None, None]
            self._pulses = [None, None]
            if was_slewing:
                self._begin_braking()

    # ---------------------------------------------------------------- manual moves, guiding

    def select_speed(self, index: int) -> None:
        """``:Rn#`` (and ``:RG/:RC/:RM/:RS``): fixed speed for both axes, latched by ``:M?#``."""
        with self._lock:
            self._speed = SLEW_SPEEDS[index]
            self._axis_speed = [None, None]

    def set_variable_speed(self, multiple: float, axis: int | None = None) -> None:
        """``:Rv#`` (both axes) or ``:Rvr#``/``:Rvd#`` (one axis), in multiples of sidereal."""
        multiple = max(0.0, min(1440.0, multiple))
        with self._lock:
            if axis is None:
                self._speed = multiple
                self._axis_speed = [None, None]
            else:
                self._axis_speed[axis] = multiple

    def _dec_sign(self) -> float:
        """+1 when raising the secondary angle raises Dec (west side), -1 through the pole; in alt-az
        mode moves are sky motions (the alt-az controller turns them into axis motions), so +1."""
        if self._altaz():
            return 1.0
        return 1.0 if self._side() is sky.PierSide.WEST else -1.0

    def move(self, direction: str) -> bool:
        """``:Me/:Mw/:Mn/:Ms#``: move relative to the sky at the latched speed until stopped."""
        with self._lock:
            self._advance()
            if self._persist.parked or self._slew is not None:
                return False
            axis = RA if direction in "ew" else DEC
            multiple = self._axis_speed[axis]
            if multiple is None:
                multiple = self._speed
            rate = min(multiple, float(self._persist.max_speed)) * SIDEREAL_DEG_S
            if direction == "e":  # RA up = HA down = primary angle down
                self._moves[RA] = -rate
            elif direction == "w":
                self._moves[RA] = rate
            else:
                self._moves[DEC] = rate * self._dec_sign() * (1.0 if direction == "n" else -1.0)
            return True

    def stop_axis(self, direction: str) -> None:
        """``:Qe/:Qw#`` stop the RA axis, ``:Qn/:Qs#`` the Dec axis (moves and pulses)."""
        with self._lock:
            self._advance()
            axis = RA if direction in "ew" else DEC
            self._moves[axis] = None
            self._pulses[axis] = None

    def pulse(self, direction: str, milliseconds: int) -> bool:
        """``:Mgdnnnn#``: guide at the guide rate for ``milliseconds`` (clamped to 3000)."""
        with self._lock:
            self._advance()
            if self._persist.parked or self._slew is not None:
                return False
            axis = RA if direction in "ew" else DEC
            milliseconds = min(max(0, milliseconds), PULSE_MAX_MS)
            if milliseconds == 0:
                self._pulses[axis] = None
                return True
            rate = self._persist.guide_rate * SIDEREAL_DEG_S
            if self._altaz():
                # Accepted and timed, but no measurable movement in alt-az (field notes §2.5, PT).
                self._pulses[axis] = Pulse(0.0, self._t + milliseconds / 1000.0)
                return True
            if direction == "e":
                velocity = -rate
            elif direction == "w":
                velocity = rate
            else:
                velocity = rate * self._dec_sign() * (1.0 if direction == "n" else -1.0)
            self._pulses[axis] = Pulse(velocity, self._t + milliseconds / 1000.0)
            return True

    def pulsing(self) -> tuple[bool, bool]:
        """Whether an RA / Dec pulse is still running."""
        with self._lock:
            self._advance()
            return self._pulses[RA] is not None, self._pulses[DEC] is not None

    def set_guide_rate(self, fraction: float) -> bool:
        if not 0.1 - 1e-9 <= fraction <= 0.9 + 1e-9:
            return False
        with self._lock:
            self._persist.guide_rate = round(fraction, 2)
            return True

    def guide_rate(self) -> float:
        with self._lock:
            return self._persist.guide_rate

    # ---------------------------------------------------------------- tracking

    def set_tracking_rate(self, rate: str) -> None:
        if rate not in TRACK_RATES:
            raise ValueError(f"unknown tracking rate {rate!r}")
        with self._lock:
            self._advance()
            self._track_rate = rate

    def set_custom_rate(self, multiple: float) -> bool:
        """``:STRnn#``: n.n x sidereal, 0.1-1.9 (only on firmware variants that have it)."""
        if not 0.1 - 1e-9 <= multiple <= 1.9 + 1e-9:
            return False
        with self._lock:
            self._advance()
            self._custom_multiple = multiple
            self._track_rate = "custom"
            return True

    def tracking_rate(self) -> str:
        with self._lock:
            return self._track_rate

    def tracking_on(self) -> bool:
        """``:Te#``: refused while parked, past the meridian limit or below the horizon."""
        with self._lock:
            self._advance()
            if self._persist.parked or self._track_error == 8:
                return False
            refusal = self._altaz_tracking_refusal()
            if refusal is not None:
                if refusal != 7:  # 7 is read from the clock and site themselves (tracking_state)
                    self._track_error = refusal
                return False
            if self._raw_altitude() < 0.0:
                self._track_error = 5
                return False
            self._tracking = True
            self._track_error = None
            self._home_flag = False
            return True

    def tracking_off(self) -> bool:
        """``:Td#``: refused while a GOTO, home or park slew runs (ZWO v2.1)."""
        with self._lock:
            self._advance()
            if self._slew is not None:
                return False
            self._tracking = False
            if self._track_error != 8:
                self._track_error = None
            return True

    def tracking_state(self) -> tuple[bool, int | None]:
        """(on, reason code when it stopped by itself) for ``:GAT#``."""
        with self._lock:
            self._advance()
            if self._tracking:
                return True, None
            if self._track_error is None and self._altaz() and not self._initialized():
                return False, 7  # alt-az tracking needs time and site: e7# until they are set
            return False, self._track_error

    # ---------------------------------------------------------------- sync

    def sync(self) -> int:
        """``:CM#`` to the target: 0 or an error code; a sync adds an alignment offset."""
        with self._lock:
            self._advance()
            if self._slew is not None:
                return 4
            ra, dec = self._reported()
            if self._at_home_position() or (abs(dec) > SYNC_POLE_DEG and not self._altaz()):
                return 11
            ha = sky.hour_angle(self._lst(), self._target_ra)
            if not self._altaz() and sky.pointing_state(ha) is not self._side():
                return 9  # an alt-az mount has no meridian side
            if sky.angular_separation(ra, dec, self._target_ra, self._target_dec) > SYNC_MAX_DEG:
                return 12
            self._offset_ra = sky.wrap_hours_12(self._offset_ra + self._target_ra - ra)
            self._offset_dec += self._target_dec - dec
            self._alignment_points += 1
            return 0

    def clear_alignment(self) -> None:
        with self._lock:
            self._advance()
            self._offset_ra = self._offset_dec = 0.0
            self._alignment_points = 0

    # ---------------------------------------------------------------- status and inspection

    def status(self) -> MountStatus:
        """The ``:GU#`` flags, firmware variant applied."""
        with self._lock:
            self._advance()
            idle_home = self._at_home_position() and not self._moving()
            flag = self.firmware.home_flag
            at_home = idle_home and (flag == "always_at_home" or (flag == "after_home" and self._home_flag))
            return MountStatus(
                tracking=self._tracking,
                slewing=self._slew is not None or self._braking(),
                at_home=at_home,
                mode=self._mode,
            )

    def slewing(self) -> bool:
        """In the GOTO state: a slew, or a stopped slew still braking (what ``:GU#`` shows)."""
        with self._lock:
            self._advance()
            return self._slew is not None or self._braking()

    def snapshot(self) -> dict[str, Any]:
        """Everything worth inspecting, JSON-friendly, for tests and the control port."""
        with self._lock:
            self._advance()
            ra, dec = self._reported()
            raw_ha, raw_dec = self._raw_ha_dec()
            lst = self._lst()
            alt, az = sky.equatorial_to_horizontal(sky.hour_angle(lst, ra), dec, self._latitude)
            persist = self._persist
            return {
                "emulated_seconds": self._t,
                "true_utc": self._clock.now().isoformat(),
                "mount_local": self._local_now().isoformat(),
                "mount_utc": self._mount_utc().isoformat(),
                "utc_offset_h": self._utc_offset,
                "dst": self._dst,
                "initialized": self._initialized(),
                "latitude": self._latitude,
                "longitude_east": self._longitude,
                "lst_h": lst,
                "ra_h": ra,
                "dec_deg": dec,
                "alt_deg": alt,
                "az_deg": az,
                "raw_ha_h": raw_ha,
                "raw_dec_deg": raw_dec,
                "primary_deg": self._pos[RA],
                "secondary_deg": self._pos[DEC],
                "velocity_deg_s": list(self._vel),
                "pier": self.pier_letter(),
                "at_home": self._at_home_position(),
                "homed": self._homed,
                "slew": None if self._slew is None else self._slew.kind,
                "braking": self._braking(),
                "moves_deg_s": list(self._moves),
                "pulses": [None if p is None else {"deg_s": p.velocity, "end_s": p.end} for p in self._pulses],
                "tracking": self._tracking,
                "tracking_rate": self._track_rate,
                "tracking_error": self._track_error,
                "target_ra_h": self._target_ra,
                "target_dec_deg": self._target_dec,
                "offset_ra_h": self._offset_ra,
                "offset_dec_deg": self._offset_dec,
                "alignment_points": self._alignment_points,
                "mode": self._mode.name,
                "parked": persist.parked,
                "park_status": 0 if not persist.parked else (1 if self._slew and self._slew.kind == "park" else 2),
                "limits_enabled": persist.limits_enabled,
                "limits": [persist.lower_limit, persist.upper_limit],
                "max_speed": persist.max_speed,
                "guide_rate": persist.guide_rate,
                "meridian": {
                    "flip": persist.meridian.flip,
                    "track_after": persist.meridian.track_after,
                    "limit_degrees": persist.meridian.limit_degrees,
                },
                "pending_mode": persist.mode.name,
                "power_ups": self.power_ups,
                "firmware": self.firmware.as_dict(),
            }
