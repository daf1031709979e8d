"""The physics and state of an emulated ZWO AM mount.

A German equatorial mount is two mechanical axes, not a pair of sky coordinates: the primary
(RA) axis angle ``p`` and the secondary (Dec) axis angle ``s``, both in degrees here.

- North of the equator: the Dec axis inside ±90° is pointing side WEST (ASCOM pierWest, looking
  east): HA = p, Dec = s; through the pole it is EAST (looking west): HA = p + 12 h, Dec = 180 - s.
- South of it the same axes point at the mirrored sky (HA and Dec change sign; ``state.Hemisphere``,
  docs/southern.md): the RA axis turns the other way to track, and through the pole is WEST.
- Home: p = -90, s = 90 (the pole of the site's hemisphere: HA -6 h and Dec +90 in the north, HA +6 h
  and Dec -90 in the south); ``:Gm#`` says ``N`` there.

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

``MountModel`` owns four parts, one module each, and has the commands that use them:
``model.flash`` (``flash.FlashSettings``: what the mount keeps in flash), ``model.clock_site``
(``clocksite.ClockAndSite``: the mount's clock and site), ``model.mechanics`` (``physics.Mechanics``:
the axes and what drives them) and ``model.altaz_rules`` (``altaz.AltAzRules``: the alt-az GOTO and
tracking rules).
Clients reach the flash settings and the clock and site through their parts
(``model.flash.set_meridian(...)``, ``model.clock_site.set_date(...)``).

Lock: one, ``MountModel._lock`` (an RLock), owned by the model. ``flash`` and ``clock_site`` are lent
it, because their public methods are called directly (by the responder, the tests); the mechanics
and the alt-az rules have no lock of their own and are called only with it held. The parts never
call back into the model: ``flash`` and ``clock_site`` get ``advance`` (the mechanics' integration,
returning the emulated seconds) as a callable, the others get the parts they read.

In alt-az mode (``:AA#``, in effect after a power cycle) the same axes are azimuth and altitude;
``altaz`` says what moves how. Not modelled (see the README): refraction, encoder/periodic errors,
ST-4 guiding and the meaning of the ``:GU#`` digits.
"""

from __future__ import annotations

import threading
from datetime import datetime, timezone
from typing import Any

from .. import sky
from ..sky import SIDEREAL_DEG_S
from ..zwo.firmware import MEASURED_JOG_SPEEDS, FirmwareVariant
from ..zwo.wire_values import SLEW_SPEEDS, MountMode, MountStatus
from .altaz import AltAzRules
from .clock import Clock
from .clocksite import ClockAndSite
from .faults import FaultEvent, Faults
from .flash import FlashSettings
from .imperfection import Imperfection
from .physics import Mechanics
from .state import (
    ACCEL_DEG_S2,
    DEC,
    FACTORY_LATITUDE,
    FACTORY_LONGITUDE,
    HOME_P,
    HOME_S,
    HORIZON_TOLERANCE_DEG,
    PARK_P,
    PARK_S,
    PULSE_MAX_MS,
    RA,
    SYNC_MAX_DEG,
    SYNC_POLE_DEG,
    TRACK_RATES,
    AxisPulse,
    Persistent,
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


class MountModel:
    """One emulated mount: thread-safe (one lock), advanced lazily to the clock on every call.

    Methods return plain values (bools, error codes, floats); the ``Responder`` turns them into
    the mount's exact reply text. Owns ``_lock`` (RLock: every command holds it; lent to ``flash``
    and ``clock_site``), ``firmware``, ``faults``, ``power_ups`` and the four parts.
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
        imperfection: Imperfection | None = None,
    ) -> None:
        """``site`` is the (latitude, east longitude) stored in the mount, returned after every
        power-up; ``initialized`` starts as if a client had already set date, time and site;
        ``mode`` is the mount mode in flash (as if ``:AA#``/``:AP#`` and a restart had happened);
        ``imperfection`` its mechanical errors (``imperfection.py``; default: a perfect mount)."""
        self._lock = threading.RLock()
        self._clock = clock
        self.firmware = firmware if firmware is not None else FirmwareVariant()
        persist = Persistent(mode=mode)
        if site is not None:
            persist.latitude, persist.longitude = float(site[0]), float(site[1])
        self.faults = faults if faults is not None else Faults()
        # The parts start powered up; ``_advance`` reaches the mechanics only once they exist.
        self.power_ups = 1
        start = clock.seconds()
        self.flash = FlashSettings(persist=persist, firmware=self.firmware, lock=self._lock, advance=self._advance)
        self.clock_site = ClockAndSite(flash=self.flash, lock=self._lock, advance=self._advance, t=start)
        self.mechanics = Mechanics(clock=clock, accel=accel, flash=self.flash, site=self.clock_site, t=start,
                                   imperfection=imperfection if imperfection is not None else Imperfection())
        self.altaz_rules = AltAzRules(mechanics=self.mechanics, site=self.clock_site, flash=self.flash)
        self.faults.add_listener(self._on_fault)
        if initialized:
            self.initialize()

    # ---------------------------------------------------------------- lifecycle

    @property
    def clock(self) -> Clock:
        return self._clock

    def _advance(self) -> float:
        """Bring the physics up to the clock's present (callers hold the lock); the emulated seconds."""
        return self.mechanics.advance()

    def _on_fault(self, event: FaultEvent) -> None:
        if event.kind == "reboot":
            self.power_cycle()

    def power_cycle(self) -> None:
        """Switch the mount off and on: volatile state is lost, flash settings are kept."""
        with self._lock:
            t = self._advance()
            self.power_ups += 1
            self.flash.power_up()
            self.clock_site.power_up(t)
            self.mechanics.power_up()

    def initialize(self, utc: datetime | None = None) -> None:
        """Set date, time (zone +00:00) and mark the stored site as set, as a client would."""
        with self._lock:
            t = self._advance()
            now = utc if utc is not None else self._clock.now()
            if now.tzinfo is not None:
                now = now.astimezone(timezone.utc).replace(tzinfo=None)
            self.clock_site.initialize(now, t)

    # ---------------------------------------------------------------- position, target

    def position(self) -> tuple[float, float]:
        """(RA hours, Dec degrees) the mount reports, alignment offsets included; at home, on firmware
        that counts home as the through-the-pole side, the hour angle of that side (+6 h in the north)."""
        mech = self.mechanics
        with self._lock:
            mech.advance()
            ra, dec = mech.reported()
            if self._home_through_pole():
                ra = sky.wrap_hours_24(ra + 12.0)
            return ra, dec

    def _home_through_pole(self) -> bool:
        """At the home position on firmware that reads it as the through-the-pole side (``home_reading``,
        AM5N 1.8.8: ``E`` and hour angle +6 h). Callers hold the lock and have advanced the mechanics."""
        mech = self.mechanics
        return self.firmware.home_reading == "through_pole" and not mech.altaz() and mech.at_home_position()

    def horizontal(self) -> tuple[float, float]:
        """(altitude, azimuth from north) of the reported position, at the mount's site and LST."""
        mech, site = self.mechanics, self.clock_site
        with self._lock:
            mech.advance()
            ra, dec = mech.reported()
            return sky.equatorial_to_horizontal(sky.hour_angle(site.lst(mech.t), ra), dec, site.latitude_deg)

    @property
    def imperfection(self) -> Imperfection:
        """The mount's mechanical errors (``imperfection.py``): where the tube truly points, relative to its axes."""
        return self.mechanics.imperfection

    def set_imperfection(self, imperfection: Imperfection) -> None:
        """Change the mount's mechanical errors (the control port's ``pointing-errors``/``pointing-noise``)."""
        with self._lock:
            self.mechanics.imperfection = imperfection

    def sky(self) -> tuple[float, float, float, float]:
        """Where the tube truly points: (RA hours, Dec degrees, altitude, azimuth), in the frame of
        ``position()`` (the mount's LST and site) but without its sync offset, which is only the mount's
        belief. A perfect mount points where its axes say (``raw_ha_dec``)."""
        with self._lock:
            self.mechanics.advance()
            return self._sky()

    def _sky(self) -> tuple[float, float, float, float]:
        """``sky()`` for callers holding the lock, the physics advanced."""
        mech, site = self.mechanics, self.clock_site
        ha, dec = mech.true_ha_dec()
        alt, az = sky.equatorial_to_horizontal(ha, dec, site.latitude_deg)
        return sky.ra_from_hour_angle(site.lst(mech.t), ha), dec, alt, az

    def axes(self) -> tuple[float, float]:
        """Mechanical (primary, secondary) axis angles in degrees, for tests and inspection."""
        mech = self.mechanics
        with self._lock:
            mech.advance()
            return mech.pos[RA], mech.pos[DEC]

    def pier_letter(self) -> str:
        """``:Gm#``: N at home, else W or E as the firmware variant names the side (``pier_letter``):
        the pointing state of the axes (W looking east, counterweight down: pierWest), the axes'
        mechanical state named as in the north (W with the Dec axis inside ±90°), or the side of the
        pointing's hour angle (W east of the meridian) whatever the axes."""
        mech = self.mechanics
        with self._lock:
            mech.advance()
            if self._home_through_pole():
                return "W" if mech.hemisphere().side(True) is sky.PierSide.WEST else "E"
            if mech.at_home_position():
                return "N"
            rule = self.firmware.pier_letter
            if rule == "mechanical" and not mech.altaz():
                return "E" if mech.outer else "W"
            if rule == "hour_angle" and not mech.altaz():
                return "W" if sky.pointing_state(mech.raw_ha_dec()[0]) is sky.PierSide.WEST else "E"
            return "W" if mech.side() is sky.PierSide.WEST else "E"

    def set_target_ra(self, hours: float) -> bool:
        with self._lock:
            self.mechanics.target_ra = hours
            return True

    def set_target_dec(self, degrees: float) -> bool:
        if not -90.0 <= degrees <= 90.0:
            return False
        with self._lock:
            self.mechanics.target_dec = degrees
            return True

    def target(self) -> tuple[float, float]:
        with self._lock:
            return self.mechanics.target_ra, self.mechanics.target_dec

    # ---------------------------------------------------------------- GOTO, home, park, stop

    def goto(self) -> int:
        """Start a GOTO to the target; 0 on success, else the mount's error code."""
        mech, site = self.mechanics, self.clock_site
        with self._lock:
            mech.advance()
            if self.flash.persist.parked:
                return 4  # a guess: no ZWO code for "parked" is published (OnStep uses 4)
            if not site.initialized():
                return 7
            if mech.slew is not None or mech.braking():
                return 3  # also while a stopped slew still brakes (README: "GOTO during braking")
            lst = site.lst(mech.t)
            ha = sky.hour_angle(lst, mech.target_ra)
            alt, _ = sky.equatorial_to_horizontal(ha, mech.target_dec, site.latitude_deg)
            if alt < -HORIZON_TOLERANCE_DEG:
                return 5
            persist = self.flash.persist
            if persist.limits_enabled and not persist.lower_limit <= alt <= persist.upper_limit:
                return 6
            raw_ra = sky.wrap_hours_24(mech.target_ra - mech.offset_ra)
            raw_dec = max(-90.0, min(90.0, mech.target_dec - mech.offset_dec))
            raw_ha = sky.hour_angle(lst, raw_ra)
            if mech.altaz():
                mech.start_slew(self.altaz_rules.goto(raw_ha, raw_dec))
                return 0
            hemisphere = mech.hemisphere()
            current = hemisphere.side(True) if self._home_through_pole() else mech.side()  # the side :Gm# names
            side = sky.goto_pier_side(raw_ha, current, self._goto_limit_deg())
            p, s = hemisphere.axes(raw_ha, raw_dec, side)
            mech.start_slew(Slew("goto", mech.t, p, hemisphere.primary_rate(SIDEREAL_DEG_S), s,
                                 hemisphere.outer(side)))
            return 0

    def _goto_limit_deg(self) -> float:
        """The limit handed to ``sky.goto_pier_side``: how far past the meridian the west side may go."""
        settings = self.flash.persist.meridian
        limit = float(settings.limit_degrees)
        if self.firmware.goto_flip_at_meridian:
            return min(limit, 0.0)
        return sky.flip_line_deg(limit, settings.track_after)

    def home(self) -> bool:
        """``:hC#``: slew to the mechanical home; tracking goes off on arrival."""
        mech = self.mechanics
        with self._lock:
            mech.advance()
            if self.flash.persist.parked:
                return False
            mech.start_slew(Slew("home", mech.t, HOME_P, 0.0, HOME_S))
            return True

    def park(self) -> bool:
        """``:hP#``: slew to the (custom or factory) park position and latch the parked state."""
        mech = self.mechanics
        with self._lock:
            mech.advance()
            if self.flash.mode_in_effect is not MountMode.EQUATORIAL:
                return False
            if mech.tracking and self.firmware.hp_while_tracking == "ignored":
                return False  # AM5N 1.8.8: never moves, never parks (docs/firmware-evidence.md)
            factory = (HOME_P, HOME_S) if self.firmware.park_at_home else (PARK_P, PARK_S)
            p, s = self.flash.persist.custom_park or factory
            self.flash.persist.parked = True
            mech.start_slew(Slew("park", mech.t, p, 0.0, s, abs(s) > 90.0))
            return True

    def unpark(self) -> bool:
        """``:Spu#``: clear the latch; False when there was none."""
        with self._lock:
            self.mechanics.advance()
            was = self.flash.persist.parked
            self.flash.persist.parked = False
            return was

    def parked(self) -> bool:
        """Whether the park latch is set (parking or parked): it survives power cycles, it is in flash."""
        with self._lock:
            return self.flash.persist.parked

    def park_status(self) -> int:
        """0 not parked, 1 parking, 2 parked."""
        mech = self.mechanics
        with self._lock:
            mech.advance()
            if not self.flash.persist.parked:
                return 0
            return 1 if mech.slew is not None and mech.slew.kind == "park" else 2

    def set_park_position(self) -> str:
        """``:Sp01#``: the one-character result code (field notes §4.2)."""
        mech = self.mechanics
        with self._lock:
            mech.advance()
            if self.flash.mode_in_effect is not MountMode.EQUATORIAL:
                return "4"
            if mech.moving():
                return "9"
            if not mech.homed:
                return "5"
            self.flash.persist.custom_park = (mech.pos[RA], mech.pos[DEC])
            return "1"

    def set_current_as_home(self) -> bool:
        """``:SOa#``: redefine the current position as the mechanical home."""
        mech = self.mechanics
        with self._lock:
            mech.advance()
            if mech.moving():
                return False
            mech.pos = [HOME_P, HOME_S]
            mech.vel = [mech.vel[RA], 0.0]
            return True

    def homed(self) -> bool:
        with self._lock:
            return self.mechanics.homed

    def stop(self) -> None:
        """``:Q#``: end GOTO/home/park slews, moves and pulses; tracking stays as it was.

        The axes brake at the normal deceleration. A stopped slew keeps the mount in its GOTO
        state until both axes have braked (no ``N`` in ``:GU#``, ``:MS#`` answers ``e3#``), as the
        firmware's state machine does (README: "GOTO during braking").
        """
        mech = self.mechanics
        with self._lock:
            mech.advance()
            was_slewing = mech.slew is not None
            mech.slew = None
            mech.moves = [None, None]
            mech.pulses = [None, None]
            if was_slewing:
                mech.begin_braking()

    # ---------------------------------------------------------------- manual moves, guiding

    def select_speed(self, index: int) -> None:
        """``:Rn#`` (and ``:RG/:RC/:RM/:RS``): fixed speed for both axes, latched by ``:M?#``."""
        speeds = MEASURED_JOG_SPEEDS if self.firmware.jog_rates == "measured" else SLEW_SPEEDS
        with self._lock:
            self.mechanics.speed = speeds[index]
            self.mechanics.axis_speed = [None, None]

    def set_variable_speed(self, multiple: float, axis: int | None = None) -> None:
        """``:Rv#`` (both axes) or ``:Rvr#``/``:Rvd#`` (one axis), in multiples of sidereal."""
        mech = self.mechanics
        multiple = max(0.0, min(1440.0, multiple))
        with self._lock:
            if axis is None:
                mech.speed = multiple
                mech.axis_speed = [None, None]
            else:
                mech.axis_speed[axis] = multiple

    def move(self, direction: str) -> bool:
        """``:Me/:Mw/:Mn/:Ms#``: move at the latched speed until stopped; E/W relative to the sky, N/S
        as the firmware variant has it (``ns_moves``, ``_dec_velocity``)."""
        mech = self.mechanics
        with self._lock:
            mech.advance()
            if self.flash.persist.parked or mech.slew is not None:
                return False
            axis = RA if direction in "ew" else DEC
            multiple = mech.axis_speed[axis]
            if multiple is None:
                multiple = mech.speed
            rate = min(multiple, float(self.flash.persist.max_speed)) * SIDEREAL_DEG_S
            if direction in "ew":  # east: RA up, the hour angle down
                mech.moves[RA] = rate * mech.ra_sign() * (-1.0 if direction == "e" else 1.0)
            else:
                mech.moves[DEC] = self._dec_velocity(direction, rate)
            return True

    def _dec_velocity(self, direction: str, rate: float) -> float:
        """The secondary axis' speed for ``:Mn/:Ms#`` or ``:Mgn/:Mgs``: toward the sky's north or
        south on either side (``ns_moves = "sky"``), or one way of the Dec axis whatever the side
        (``"mechanical"``: north raises Dec on pierEast and lowers it on pierWest, as eq-satrack saw
        on an AM3). Alt-az moves are sky motions. Callers hold the lock."""
        mech = self.mechanics
        sign = 1.0 if direction == "n" else -1.0
        if self.firmware.ns_moves == "mechanical" and not mech.altaz():
            return -rate * sign  # the way that raises Dec on pierEast in either hemisphere
        return rate * mech.dec_sign() * sign

    def stop_axis(self, direction: str) -> None:
        """``:Qe/:Qw#`` stop the RA axis, ``:Qn/:Qs#`` the Dec axis (moves and pulses)."""
        mech = self.mechanics
        with self._lock:
            mech.advance()
            axis = RA if direction in "ew" else DEC
            mech.moves[axis] = None
            mech.pulses[axis] = None

    def pulse(self, direction: str, milliseconds: int) -> bool:
        """``:Mgdnnnn#``: guide at the guide rate for ``milliseconds`` (clamped to 3000)."""
        mech = self.mechanics
        with self._lock:
            mech.advance()
            if self.flash.persist.parked or mech.slew is not None:
                return False
            axis = RA if direction in "ew" else DEC
            milliseconds = min(max(0, milliseconds), PULSE_MAX_MS)
            if milliseconds == 0:
                mech.pulses[axis] = None
                return True
            rate = self.flash.persist.guide_rate * SIDEREAL_DEG_S
            if mech.altaz():
                # Accepted and timed, but no measurable movement in alt-az (field notes §2.5, PT).
                mech.pulses[axis] = AxisPulse(0.0, mech.t + milliseconds / 1000.0)
                return True
            if direction in "ew":
                velocity = rate * mech.ra_sign() * (-1.0 if direction == "e" else 1.0)
            else:
                velocity = self._dec_velocity(direction, rate)
            mech.pulses[axis] = AxisPulse(velocity, mech.t + milliseconds / 1000.0)
            return True

    def pulsing(self) -> tuple[bool, bool]:
        """Whether an RA / Dec pulse is still running."""
        mech = self.mechanics
        with self._lock:
            mech.advance()
            return mech.pulses[RA] is not None, mech.pulses[DEC] is not None

    def set_guide_rate(self, fraction: float) -> bool:
        if not 0.1 - 1e-9 <= fraction <= 0.9 + 1e-9:
            return False
        with self._lock:
            self.flash.persist.guide_rate = round(fraction, 2)
            return True

    def guide_rate(self) -> float:
        with self._lock:
            return self.flash.persist.guide_rate

    # ---------------------------------------------------------------- tracking

    def set_tracking_rate(self, rate: str) -> None:
        if rate not in TRACK_RATES:
            raise ValueError(f"unknown tracking rate {rate!r}")
        with self._lock:
            self.mechanics.advance()
            self.mechanics.track_rate = rate

    def set_custom_rate(self, multiple: float) -> bool:
        """``:STRnn#``: n.n x sidereal, 0.1-1.9 (only on firmware variants that have it)."""
        if not 0.1 - 1e-9 <= multiple <= 1.9 + 1e-9:
            return False
        mech = self.mechanics
        with self._lock:
            mech.advance()
            mech.custom_multiple = multiple
            mech.track_rate = "custom"
            return True

    def tracking_rate(self) -> str:
        with self._lock:
            return self.mechanics.track_rate

    def tracking_on(self) -> bool:
        """``:Te#``: refused while parked, past the meridian limit or below the horizon."""
        mech = self.mechanics
        with self._lock:
            mech.advance()
            if self.flash.persist.parked or mech.track_error == 8:
                return False
            refusal = self.altaz_rules.tracking_refusal()
            if refusal is not None:
                if refusal != 7:  # 7 is read from the clock and site themselves (tracking_state)
                    mech.track_error = refusal
                return False
            if mech.below_horizon():
                mech.track_error = 5
                return False
            mech.tracking = True
            mech.track_error = None
            mech.home_flag = False
            return True

    def tracking_off(self) -> bool:
        """``:Td#``: refused while a GOTO, home or park slew runs (ZWO v2.1)."""
        mech = self.mechanics
        with self._lock:
            mech.advance()
            if mech.slew is not None:
                return False
            mech.tracking = False
            if mech.track_error != 8:
                mech.track_error = None
            return True

    def tracking_state(self) -> tuple[bool, int | None]:
        """(on, reason code when it stopped by itself) for ``:GAT#``."""
        mech = self.mechanics
        with self._lock:
            mech.advance()
            if mech.tracking:
                return True, None
            if mech.track_error is None and mech.altaz() and not self.clock_site.initialized():
                return False, 7  # alt-az tracking needs time and site: e7# until they are set
            return False, mech.track_error

    # ---------------------------------------------------------------- sync

    def sync(self) -> int:
        """``:CM#`` to the target: 0 or an error code; a sync adds an alignment offset."""
        mech = self.mechanics
        with self._lock:
            mech.advance()
            if mech.slew is not None:
                return 4
            ra, dec = mech.reported()
            if mech.at_home_position() or (abs(dec) > SYNC_POLE_DEG and not mech.altaz()):
                return 11
            ha = sky.hour_angle(self.clock_site.lst(mech.t), mech.target_ra)
            if not mech.altaz() and sky.pointing_state(ha) is not mech.side():
                return 9  # an alt-az mount has no meridian side
            if sky.angular_separation(ra, dec, mech.target_ra, mech.target_dec) > SYNC_MAX_DEG:
                return 12
            mech.offset_ra = sky.wrap_hours_12(mech.offset_ra + mech.target_ra - ra)
            mech.offset_dec += mech.target_dec - dec
            mech.alignment_points += 1
            return 0

    def clear_alignment(self) -> None:
        mech = self.mechanics
        with self._lock:
            mech.advance()
            mech.offset_ra = mech.offset_dec = 0.0
            mech.alignment_points = 0

    # ---------------------------------------------------------------- status and inspection

    def status(self) -> MountStatus:
        """The ``:GU#`` flags, firmware variant applied (``status_word``: the documents' letters, or
        the 1.8.8 word, where parked or parking shows ``n`` alone, ``M`` is always there, ``P``
        never, and the last digit says the state)."""
        mech = self.mechanics
        with self._lock:
            mech.advance()
            idle_home = mech.at_home_position() and not mech.moving()
            flag = self.firmware.home_flag
            at_home = idle_home and (flag == "always_at_home" or (flag == "after_home" and mech.home_flag))
            slewing = mech.slew is not None or mech.braking()
            if self.firmware.status_word != "1.8.8":
                return MountStatus(tracking=mech.tracking, slewing=slewing, at_home=at_home,
                                   mode=self.flash.mode_in_effect)
            parked = self.flash.persist.parked
            return MountStatus(tracking=mech.tracking, slewing=slewing or parked, at_home=at_home,
                               mode=self.flash.mode_in_effect, other_flags="M",
                               digits="00000000" + self._state_digit(parked))

    def _state_digit(self, parked: bool) -> str:
        """The last digit of a 1.8.8 ``:GU#`` (eq-satrack am5/mock_mount.py L597-600, "real hardware
        confirmed live"): 5 parked, 3 a manual move running, 1 tracking, 0 otherwise. Callers hold the lock."""
        mech = self.mechanics
        if parked:
            return "5"
        if any(move is not None for move in mech.moves):
            return "3"
        return "1" if mech.tracking else "0"

    def slewing(self) -> bool:
        """In the GOTO state: a slew, or a stopped slew still braking (what ``:GU#`` shows)."""
        mech = self.mechanics
        with self._lock:
            mech.advance()
            return mech.slew is not None or mech.braking()

    def snapshot(self) -> dict[str, Any]:
        """Everything worth inspecting, JSON-friendly, for tests and the control port."""
        mech, site = self.mechanics, self.clock_site
        with self._lock:
            mech.advance()
            ra, dec = mech.reported()
            raw_ha, raw_dec = mech.raw_ha_dec()
            lst = site.lst(mech.t)
            alt, az = sky.equatorial_to_horizontal(sky.hour_angle(lst, ra), dec, site.latitude_deg)
            sky_ra, sky_dec, sky_alt, sky_az = self._sky()
            persist = self.flash.persist
            return {
                "emulated_seconds": mech.t,
                "true_utc": self._clock.now().isoformat(),
                "mount_local": site.local_now(mech.t).isoformat(),
                "mount_utc": site.mount_utc(mech.t).isoformat(),
                "utc_offset_h": site.utc_offset_h,
                "dst": site.dst_on,
                "initialized": site.initialized(),
                "latitude": site.latitude_deg,
                "longitude_east": site.longitude_deg,
                "lst_h": lst,
                "ra_h": ra,
                "dec_deg": dec,
                "alt_deg": alt,
                "az_deg": az,
                "raw_ha_h": raw_ha,
                "raw_dec_deg": raw_dec,
                "sky_ra_h": sky_ra,  # where the tube truly points (imperfection.py), the frame of ra_h
                "sky_dec_deg": sky_dec,
                "sky_alt_deg": sky_alt,
                "sky_az_deg": sky_az,
                "pointing_errors": self.imperfection.describe(),
                "primary_deg": mech.pos[RA],
                "secondary_deg": mech.pos[DEC],
                "velocity_deg_s": list(mech.vel),
                "pier": self.pier_letter(),
                "side": mech.side().name if not mech.altaz() else "UNKNOWN",  # the truth, whatever :Gm# says
                "through_pole": mech.outer,  # the Dec axis beyond ±90° (mechanically)
                "hemisphere": "south" if mech.hemisphere().sign < 0.0 else "north",
                "at_home": mech.at_home_position(),
                "homed": mech.homed,
                "slew": None if mech.slew is None else mech.slew.kind,
                "braking": mech.braking(),
                "moves_deg_s": list(mech.moves),
                "pulses": [None if p is None else {"deg_s": p.velocity, "end_s": p.end} for p in mech.pulses],
                "tracking": mech.tracking,
                "tracking_rate": mech.track_rate,
                "tracking_error": mech.track_error,
                "target_ra_h": mech.target_ra,
                "target_dec_deg": mech.target_dec,
                "offset_ra_h": mech.offset_ra,
                "offset_dec_deg": mech.offset_dec,
                "alignment_points": mech.alignment_points,
                "mode": self.flash.mode_in_effect.name,
                "parked": persist.parked,
                "park_status": 0 if not persist.parked else (1 if mech.slew and mech.slew.kind == "park" else 2),
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
