"""ConformU's Telescope conformance run (checklist §3-§7), in ConformU's order, with its grading.

This is a transcription of ``TelescopeTester`` (TT) plus the parts of ``DeviceTesterBaseClass``
and ``ConformanceTestManager`` a Telescope run uses, in CLI full-test mode (every telescope test,
the extended site / rate-offset / pulse-guide tests, first-use tests and both SideOfPier model
tests enabled). Method and variable names follow ConformU's so a reader can hold the two side by
side; where the checklist (ConformU 4.4.0, commit 5c6591c) describes behaviour newer than the
source text quoted in it, the checklist wins.

Two clients carry the requests: ``self.t`` is the transcription of ConformU's own ASCOM client,
``self.a`` is the official alpyca client with the same reply rules (see ``ascom.py``). alpyca
carries the common members, the Can* flags, the plain property reads, the site properties and
CanMoveAxis/AxisRates; everything else goes through ``self.t``.

ConformU quirks that are reproduced on purpose (checklist §E) are marked ``QUIRK``.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable
from dataclasses import dataclass
from datetime import timedelta

from tests.conformance.ascom import (
    AlpacaTelescope,
    AlpycaTelescope,
    ConformTimeout,
    EmulatedClock,
    InvalidOperationException,
    InvalidValueException,
    NotImplementedException,
    Stopwatch,
    julian_date,
)
from tests.conformance.conformu_base import (
    SLEEP_TIME_MS,
    DeviceTesterBase,
    MemberType,
    Required,
    TargetTime,
    condition_ra,
    ra_difference_arcsec,
    round_away,
    to_dms,
    to_hms,
)
from tests.conformance.report import Report

PROPERTY, METHOD = MemberType.PROPERTY, MemberType.METHOD
OPTIONAL, MANDATORY = Required.OPTIONAL, Required.MANDATORY
MUST_BE, MUST_NOT_BE = Required.MUST_BE_IMPLEMENTED, Required.MUST_NOT_BE_IMPLEMENTED
FAST, STANDARD, EXTENDED = TargetTime.FAST, TargetTime.STANDARD, TargetTime.EXTENDED

# TT constants (L44-L69)
TRACKING_COMMAND_DELAY = 1000
MOVE_AXIS_TIME = 2000
WAIT_FOR_SLEW_MINIMUM_DURATION = 5
SIDEOFPIER_MERIDIAN_TRACKING_PERIOD = 7 * 60 * 1000
PULSEGUIDE_MOVEMENT_TIME = 2
PULSEGUIDE_TIMEOUT_TIME = 6
BAD_RA_LOW, BAD_RA_HIGH = -1.0, 25.0
BAD_DEC_LOW, BAD_DEC_HIGH = -100.0, 100.0
BAD_AZIMUTH_LOW, BAD_AZIMUTH_HIGH = -10.0, 370.0
BAD_ALTITUDE_LOW, BAD_ALTITUDE_HIGH = -100.0, 100.0
SIDE_OF_PIER_INVALID_LATITUDE = 10.0
SLEW_SYNC_OK_TOLERANCE = 10.0
SYNC_SIMULATED_ERROR = 60.0
SIDEREAL_SECONDS_TO_SI_SECONDS = 0.99726956631945
SITE_ELEVATION_TEST_VALUE = 2385.0
ARC_SECONDS_TO_RA_SECONDS = 1.0 / 15.0
STANDARD_TARGET_RESPONSE_TIME = 1.0

# Enumerations on the wire
PIER_EAST, PIER_WEST, PIER_UNKNOWN = 0, 1, -1
GERMAN_POLAR = 2
SIDEREAL = 0
DRIVE_RATES = {0: "driveSidereal", 1: "driveLunar", 2: "driveSolar", 3: "driveKing"}
NORTH, SOUTH, EAST, WEST = 0, 1, 2, 3
DIRECTION_NAMES = {NORTH: "North", SOUTH: "South", EAST: "East", WEST: "West"}
PRIMARY, SECONDARY, TERTIARY = 0, 1, 2
AXIS_NAMES = {PRIMARY: "Primary", SECONDARY: "Secondary", TERTIARY: "Tertiary"}
PIER_NAMES = {PIER_EAST: "pierEast", PIER_WEST: "pierWest", PIER_UNKNOWN: "pierUnknown"}


@dataclass(frozen=True)
class Settings:
    """ConformU's defaults (SET L143-L197) as the CLI full-test mode applies them."""

    telescope_maximum_slew_time: int = 300
    telescope_time_for_slewing_to_become_false: int = 30
    telescope_slew_tolerance: float = 10.0
    dome_slew_tolerance: float = 1.0
    telescope_pulse_guide_tolerance: float = 1.0
    telescope_rate_offset_test_duration: float = 10.0
    telescope_rate_offset_test_low_value: float = 0.05
    telescope_rate_offset_test_high_value: float = 40.0
    connect_disconnect_timeout: int = 5
    telescope_first_use_tests: bool = True
    test_side_of_pier_read: bool = True
    test_side_of_pier_write: bool = True
    telescope_extended_rate_offset_tests: bool = True
    telescope_extended_pulse_guide_tests: bool = True
    telescope_extended_site_tests: bool = True


@dataclass
class SideOfPierResults:
    side_of_pier: int = PIER_UNKNOWN
    destination_side_of_pier: int = PIER_UNKNOWN


class AbandonRun(Exception):
    """ConformU stops the whole run (connection failure or invalid interface version)."""


def conform_lst(utc_jd: float, longitude: float) -> float:
    """ConformU's own sidereal time formula (TT L2116)."""
    return (18.697374558 + 24.065709824419081 * (utc_jd - 2451545.0) + longitude / 15.0) % 24.0


class TelescopeTester(DeviceTesterBase):
    """One ConformU conformance run against one Alpaca telescope."""

    def __init__(self, client: AlpacaTelescope, alpyca: AlpycaTelescope, clock: EmulatedClock, report: Report,
                 settings: Settings | None = None) -> None:
        super().__init__(report, clock)
        self.t = client
        self.a = alpyca
        self.settings = settings or Settings()
        self.interface_version: int | None = None
        self.is_platform7 = False
        # Can flags and values read along the way (TT fields)
        self.can_find_home = self.can_park = self.can_pulse_guide = False
        self.can_set_declination_rate = self.can_set_guide_rates = self.can_set_park = False
        self.can_set_pierside = self.can_set_right_ascension_rate = self.can_set_tracking = False
        self.can_slew = self.can_slew_alt_az = self.can_slew_alt_az_async = self.can_slew_async = False
        self.can_sync = self.can_sync_alt_az = self.can_unpark = False
        self.can_move_axis = {PRIMARY: False, SECONDARY: False, TERTIARY: False}
        self.alignment_mode = 0
        self.guide_rate_declination = 0.0
        self.guide_rate_right_ascension = 0.0
        self.declination_rate = 0.0
        self.site_latitude = 0.0
        self.site_longitude = 0.0
        self.site_elevation = 0.0
        self.target_right_ascension = 0.0
        self.target_declination = 0.0
        self.target_altitude = 0.0
        self.target_azimuth = 0.0
        self.tracking = False
        self.can_read_altitude = self.can_read_azimuth = self.can_read_sidereal_time = False
        self.can_read_side_of_pier: bool | None = None
        self.abandoned = False

    # =================================================================================================
    # Run order (CTM L153-L557)
    # =================================================================================================
    def run(self) -> None:
        report = self.report
        report.section("ConformU-style conformance run: ITelescopeV4, CLI full-test mode")
        try:
            self.create_device()
            self.connect()
        except AbandonRun:
            return
        except Exception as ex:
            self.log_issue("Connected", f"Connection exception - further testing abandoned: {ex!r}")
            return
        try:
            report.section("Common Driver Methods")
            self.check_common_methods()
            report.section("Can Properties")
            self.read_can_properties()
            report.section("Pre-run Checks")
            self.pre_run_check()
            report.section("Properties")
            self.check_properties()
            report.section("Methods")
            self.check_methods()
        except Exception as ex:
            self.abandoned = True
            self.log_issue("ConformanceCheck", f"Exception when testing device - testing abandoned: {ex!r}")
            return
        report.section("Post-run Checks")
        self.post_run_check()
        report.section("Disconnect")
        try:
            self.disconnect()
        except Exception as ex:
            self.log_issue("Disconnect", f"Exception when setting Connected to false: {ex!r}")
        report.section("Conform configuration")
        self.log_ok("CheckConfiguration", "Every telescope test ran (CLI full-test mode): no configuration alerts")

    # -- creation and connection ------------------------------------------------------------------------
    def get_interface_version(self) -> int:
        if self.interface_version is None:
            self.interface_version = self.t.InterfaceVersion
        return self.interface_version

    def create_device(self) -> None:
        """TT CreateDevice: wait 1 s, then ValidateInterfaceVersion before any connect (§4.1)."""
        self.log_info("CreateDevice", f"Creating Alpaca device: {self.t.base_url}")
        self.wait_for(1000, 100)
        try:
            version = self.get_interface_version()
        except Exception as ex:
            self.log_issue("CreateDevice", f"InterfaceVersion could not be read before connecting: {ex!r}")
            raise AbandonRun from ex
        if 1 <= version <= 4:  # DeviceCapabilities.IsValidAscomInterface(Telescope)
            self.log_ok("CreateDevice", f"Found a valid interface version: {version}")
        else:
            self.log_issue("CreateDevice", f"The returned interface version is invalid: {version}")
            raise AbandonRun

    def connect(self) -> None:
        """BASE Connect (§4.2), Platform 7 form."""
        self.is_platform7 = self.get_interface_version() >= 4
        t = self.t
        if not self.is_platform7:
            t.Connected = True
        else:
            _ = t.Connecting  # must exist
            if not t.Connecting:
                t.Connected = True
                if t.Connected is not True:
                    raise InvalidOperationException(
                        "Set Connected True - The device connected without error but Connected Get returned False.")
                self.log_ok("Connected", "Connected to device successfully using Connected = True")
                self.wait_for(500, 100)
                t.Connected = False
                if t.Connected is not False:
                    raise InvalidOperationException(
                        "Set Connected False - The device disconnected without error but Connected Get returned True.")
                self.log_ok("Connected", "Disconnected from device successfully using Connected = False")
                self.time_method("Connect", t.Connect, STANDARD)
                self.wait_while("Connecting to device", lambda: t.Connecting, SLEEP_TIME_MS,
                                self.settings.connect_disconnect_timeout)
            else:
                self.log_info("Connect", "Ignoring this request because a Connect() or Disconnect() operation is "
                                         "already in progress.")
        if t.Connected is not True:
            raise InvalidOperationException("The device connected without error but Connected Get returned False.")
        self.log_ok("Connect", "Connected to device successfully using Connect()")

    def disconnect(self) -> None:
        """BASE Disconnect (§7.20)."""
        t = self.t
        if self.is_platform7:
            if not t.Connecting:
                self.time_method("Disconnect", t.Disconnect, STANDARD)
                self.wait_while("Disconnecting from device", lambda: t.Connecting, SLEEP_TIME_MS,
                                self.settings.connect_disconnect_timeout)
            else:
                self.log_info("Disconnect", "Ignoring this request because a Connect() or Disconnect() operation is "
                                            "already in progress.")
        else:
            t.Connected = False
        if t.Connected is not False:
            raise InvalidOperationException("The device disconnected without error but Connected Get returned True.")
        self.log_ok("Disconnect", "Disconnected from device successfully using Disconnect()")

    # =================================================================================================
    # Common members (BASE CheckCommonMethods, §4.3) - through alpyca
    # =================================================================================================
    def check_common_methods(self) -> None:
        a = self.a
        try:
            version = self.time_func("InterfaceVersion", lambda: a.InterfaceVersion, FAST)
            if version < 1:
                self.log_issue("InterfaceVersion", f"InterfaceVersion must be 1 or greater but driver returned: "
                                                   f"{version}")
            else:
                self.log_ok("InterfaceVersion", str(version))
        except Exception as ex:
            self.handle_exception("InterfaceVersion", PROPERTY, MANDATORY, ex, "")
        try:
            connected = self.time_func("Connected", lambda: a.Connected, FAST)
            self.log_ok("Connected", str(connected))
        except Exception as ex:
            self.log_issue("Connected", str(ex))
        for member, empty in (("Description", "No description string"), ("DriverInfo", "No DriverInfo string"),
                              ("DriverVersion", "No DriverVersion string"), ("Name", "Name is empty")):
            try:
                text = self.time_func(member, lambda m=member: getattr(a, m), FAST)
                if not text:
                    self.log_info(member, empty)
                else:
                    self.log_ok(member, str(text))
            except Exception as ex:
                if member == "DriverVersion":
                    self.log_issue(member, str(ex))
                else:
                    self.handle_exception(member, PROPERTY, MANDATORY, ex, "")
        try:
            actions = self.time_func("SupportedActions", lambda: a.SupportedActions, FAST)
            if not isinstance(actions, list):
                raise TypeError(f"SupportedActions returned {actions!r}, not a list")
            if not actions:
                self.log_ok("SupportedActions", "Driver returned an empty action list")
            for i, action in enumerate(actions, 1):
                if not isinstance(action, str):
                    self.log_issue("SupportedActions", f"Actions must be strings. The type of action {i} {action} "
                                                       f"is: {type(action).__name__}")
                elif action == "":
                    self.log_issue("SupportedActions", f"Supported action {i} Is an empty string")
                else:
                    self.log_ok("SupportedActions", f"Found action: {action}")
        except Exception as ex:
            self.handle_exception("SupportedActions", PROPERTY, OPTIONAL, ex, "")
            self.log_issue("SupportedActions", str(ex))
        self.log_info("Action", "Conform cannot test the Action method")
        if self.is_platform7:
            self.check_device_state()
        else:
            self.log_info("DeviceState", "DeviceState tests omitted - DeviceState is not a member of this interface "
                                         "version.")

    def check_device_state(self) -> None:
        expected = ["Altitude", "AtHome", "AtPark", "Azimuth", "Declination", "IsPulseGuiding", "RightAscension",
                    "SideOfPier", "SiderealTime", "Slewing", "Tracking", "UTCDate"]
        try:
            state = self.time_func("DeviceState", lambda: self.a.DeviceState, FAST)
            if not isinstance(state, list):
                raise TypeError(f"DeviceState returned {state!r}, not a list")
            self.log_ok("DeviceState", f"Received {len(state)} operational state propert"
                                       f"{'y' if len(state) == 1 else 'ies'}.")
            found = dict.fromkeys(expected, False)
            lowered = {name.lower(): name for name in expected}
            for item in state:
                name, value = item["Name"], item["Value"]
                if name in found or name == "TimeStamp":
                    found[name] = True
                    self.log_ok("DeviceState", f"  {name} = {value}")
                elif isinstance(name, str) and name.lower() in lowered:
                    key = lowered[name.lower()]
                    self.log_issue("DeviceState", f"The {key} property name is mis-cased: {name}. The correct casing "
                                                  f"is: {key}")
                else:
                    self.log_issue("DeviceState", f"A non-operational property was included in the DeviceState "
                                                  f"response: {name} = {value}")
            missing = [name for name in expected if not found[name]]
            for name in missing:
                self.log_info("DeviceState", f"Operational property {name} was not included in the DeviceState "
                                             "response.")
            if not missing:
                self.log_ok("DeviceState", "Found all expected operational properties")
        except Exception as ex:
            self.handle_exception("DeviceState", PROPERTY, MANDATORY, ex, "")

    # =================================================================================================
    # Can properties (§5.1) - through alpyca
    # =================================================================================================
    def read_can_properties(self) -> None:
        def can(member: str, test_name: str | None = None) -> bool:
            name = test_name or member
            try:
                value = self.time_func(name, lambda: getattr(self.a, member), FAST)
                if not isinstance(value, bool):
                    raise TypeError(f"{member} returned {value!r}, not a boolean")
                self.log_ok(name, str(value))
                return value
            except Exception as ex:
                self.handle_exception(name, PROPERTY, MANDATORY, ex, "")
                return False

        self.can_find_home = can("CanFindHome")
        self.can_park = can("CanPark")
        self.can_pulse_guide = can("CanPulseGuide")
        self.can_set_declination_rate = can("CanSetDeclinationRate")
        self.can_set_guide_rates = can("CanSetGuideRates")
        self.can_set_park = can("CanSetPark")
        self.can_set_pierside = can("CanSetPierSide")
        try:
            if self.a.AlignmentMode != GERMAN_POLAR and self.can_set_pierside:
                self.log_issue("CanSetPierSide", "AlignmentMode is not GermanPolar but CanSetPierSide is true - "
                                                 "contrary to ASCOM specification")
        except Exception:  # ConformU ignores errors here (they are graded under AlignmentMode)
            pass
        self.can_set_right_ascension_rate = can("CanSetRightAscensionRate")
        self.can_set_tracking = can("CanSetTracking")
        self.can_slew = can("CanSlew")
        self.can_slew_alt_az = can("CanSlewAltAz", "CanSlewltAz")  # QUIRK: ConformU's typo in the test name
        self.can_slew_alt_az_async = can("CanSlewAltAzAsync")
        self.can_slew_async = can("CanSlewAsync")
        self.can_sync = can("CanSync")
        self.can_sync_alt_az = can("CanSyncAltAz")
        self.can_unpark = can("CanUnpark", "CanUnPark")
        if self.can_unpark and not self.can_park:
            self.log_issue("CanUnPark", "CanUnPark is true but CanPark is false - this does not comply with ASCOM "
                                        "specification")
        # The Platform 7 "CanSlew == CanSlewAsync" rule applies to COM drivers only (TT L599-L623).

    # =================================================================================================
    # PreRunCheck (§5.2)
    # =================================================================================================
    def pre_run_check(self) -> None:
        t = self.t
        try:
            if t.AtPark:
                if self.can_unpark:
                    try:
                        t.Unpark()
                        self.wait_while("Waiting for scope to unpark", lambda: t.AtPark, SLEEP_TIME_MS,
                                        self.settings.telescope_maximum_slew_time)
                        self.log_info("Mount Safety", "Scope was parked, so it has been unparked for testing")
                    except Exception as ex:
                        self.handle_exception("Mount Safety - Unpark", METHOD, MUST_BE, ex, "CanUnpark is true")
                else:
                    self.log_issue("Mount Safety", "Scope reports that it is parked but CanUnPark is false - please "
                                                   "manually unpark the scope")
            else:
                self.log_info("Mount Safety", "Scope is not parked, continuing testing")
        except Exception as ex:
            self.handle_exception("Mount Safety - AtPark", PROPERTY, MANDATORY, ex, "")
        if self.can_set_tracking:
            try:
                t.Tracking = True
                self.log_info("Mount Safety", "Scope tracking has been enabled")
            except Exception as ex:
                self.log_info("Mount Safety", f"Exception while trying to set Tracking to true: {ex}")
        self.log_info("TimeCheck", "PC Time Zone:  UTC (the emulated clock)")
        self.log_info("TimeCheck", f"PC UTCDate:    {self.clock.utcnow():%d-%b-%Y %H:%M:%S.%f}")
        try:
            mount_time = t.UTCDate
            self.log_info("TimeCheck", f"Mount UTCDate: {mount_time:%d-%b-%Y %H:%M:%S.%f}")
        except Exception as ex:
            self.handle_exception("UTCDate", PROPERTY, MANDATORY, ex, "")

    # =================================================================================================
    # Properties (§6, TT L626-L2811)
    # =================================================================================================
    def check_properties(self) -> None:
        t, a = self.t, self.a
        # 6.0: first-use reads, graded later
        target_dec_exception: BaseException | None = None
        target_ra_exception: BaseException | None = None
        try:
            self.target_declination = self.time_func("TargetDeclination Read", lambda: t.TargetDeclination, FAST)
        except Exception as ex:
            target_dec_exception = ex
        try:
            self.target_right_ascension = self.time_func("TargetRightAscension Read",
                                                         lambda: t.TargetRightAscension, FAST)
        except Exception as ex:
            target_ra_exception = ex

        # 6.1 AlignmentMode
        try:
            self.alignment_mode = self.time_func("AlignmentMode", lambda: a.AlignmentMode, FAST)
            self.log_ok("AlignmentMode", {0: "algAltAz", 1: "algPolar", 2: "algGermanPolar"}.get(
                self.alignment_mode, str(self.alignment_mode)))
        except Exception as ex:
            self.handle_exception("AlignmentMode", PROPERTY, OPTIONAL, ex, "")
        # 6.2 Altitude
        try:
            self.can_read_altitude = False
            altitude = self.time_func("Altitude", lambda: a.Altitude, FAST)
            self.can_read_altitude = True
            if altitude < 0.0:
                self.log_issue("Altitude", f"Altitude is <0.0 degrees: {to_dms(altitude)}")
            elif altitude > 90.0000001:
                self.log_issue("Altitude", f"Altitude is >90.0 degrees: {to_dms(altitude)}")
            else:
                self.log_ok("Altitude", to_dms(altitude))
        except Exception as ex:
            self.handle_exception("Altitude", PROPERTY, OPTIONAL, ex, "")
        # 6.3 / 6.4 aperture
        for member in ("ApertureArea", "ApertureDiameter"):
            try:
                value = self.time_func(member, lambda m=member: getattr(a, m), FAST)
                if value < 0:
                    self.log_issue(member, f"{member} is < 0.0 : {value}")
                elif value == 0.0:
                    self.log_info(member, f"{member} is 0.0")
                else:
                    self.log_ok(member, str(value))
            except Exception as ex:
                self.handle_exception(member, PROPERTY, OPTIONAL, ex, "")
        # 6.5 / 6.6 AtHome, AtPark
        for member in ("AtHome", "AtPark"):
            try:
                value = self.time_func(member, lambda m=member: getattr(a, m), FAST)
                self.log_ok(member, str(value))
            except Exception as ex:
                self.handle_exception(member, PROPERTY, MANDATORY, ex, "")
        # 6.7 Azimuth
        try:
            self.can_read_azimuth = False
            azimuth = self.time_func("Azimuth", lambda: a.Azimuth, FAST)
            self.can_read_azimuth = True
            if azimuth < 0.0:
                self.log_issue("Azimuth", f"Azimuth is <0.0 degrees: {to_dms(azimuth)}")
            elif azimuth > 360.0000000001:
                self.log_issue("Azimuth", f"Azimuth is >360.0 degrees: {to_dms(azimuth)}")
            else:
                self.log_ok("Azimuth", to_dms(azimuth))
        except Exception as ex:
            self.handle_exception("Azimuth", PROPERTY, OPTIONAL, ex, "")
        # 6.8 Declination
        try:
            declination = self.time_func("Declination", lambda: a.Declination, FAST)
            if declination < -90.0 or declination > 90.0:
                self.log_issue("Declination", f"Declination is <-90 or >90 degrees: {to_dms(declination)}")
            else:
                self.log_ok("Declination", to_dms(declination))
        except Exception as ex:
            self.handle_exception("Declination", PROPERTY, MANDATORY, ex, "")
        # 6.9 DeclinationRate read
        try:
            self.declination_rate = self.time_func("DeclinationRate Read", lambda: t.DeclinationRate, FAST)
            if self.can_set_declination_rate:
                if self.declination_rate >= 0.0:
                    self.log_ok("DeclinationRate Read", f"{self.declination_rate:.2f}")
                else:
                    self.log_issue("DeclinationRate Read", f"Negative DeclinatioRate: {self.declination_rate:.2f}")
            elif self.declination_rate == 0.0:
                self.log_ok("DeclinationRate Read", f"{self.declination_rate:.2f}")
            else:
                self.log_issue("DeclinationRate Read", "DeclinationRate is non zero when CanSetDeclinationRate is "
                                                       f"False {self.declination_rate:.2f}")
        except Exception as ex:
            if not self.can_set_declination_rate:
                self.log_issue("DeclinationRate Read", "DeclinationRate must return 0 even when "
                                                       "CanSetDeclinationRate is false.")
            self.handle_exception("DeclinationRate Read", PROPERTY, MANDATORY, ex, "")
        # 6.10 DeclinationRate write
        self.rate_offset_write_tests("DeclinationRate Write", "Dec")
        # 6.11 DoesRefraction
        does_refraction = False
        try:
            does_refraction = self.time_func("DoesRefraction Read", lambda: t.DoesRefraction, FAST)
            self.log_ok("DoesRefraction Read", str(does_refraction))
        except Exception as ex:
            self.handle_exception("DoesRefraction Read", PROPERTY, OPTIONAL, ex, "")
        try:
            self.time_method("DoesRefraction Write", lambda: setattr(t, "DoesRefraction", not does_refraction),
                             STANDARD)
            self.log_ok("DoesRefraction Write", f"Can set DoesRefraction to {not does_refraction}")
        except Exception as ex:
            self.handle_exception("DoesRefraction Write", PROPERTY, OPTIONAL, ex, "")
        try:
            t.DoesRefraction = does_refraction
            self.log_ok("DoesRefraction Write", f"Restored original DoesRefraction state: {does_refraction}")
        except Exception as ex:
            self.log_info("DoesRefraction Write", f"Exception while restoring the telescope's original "
                                                  f"DoesRefraction state: {ex}")
            self.handle_exception("DoesRefraction Write", PROPERTY, OPTIONAL, ex, "")
        # 6.12 EquatorialSystem
        try:
            system = self.time_func("EquatorialSystem", lambda: a.EquatorialSystem, FAST)
            self.log_ok("EquatorialSystem", str(system))
        except Exception as ex:
            self.handle_exception("EquatorialSystem", PROPERTY, MANDATORY, ex, "")
        # 6.13 FocalLength
        try:
            focal = self.time_func("FocalLength", lambda: a.FocalLength, FAST)
            if focal < 0.0:
                self.log_issue("FocalLength", f"FocalLength is <0.0 : {focal}")
            elif focal == 0.0:
                self.log_info("FocalLength", "FocalLength is 0.0")
            else:
                self.log_ok("FocalLength", str(focal))
        except Exception as ex:
            self.handle_exception("FocalLength", PROPERTY, OPTIONAL, ex, "")
        # 6.14 / 6.15 guide rates
        self.guide_rate_declination = self.guide_rate_test("GuideRateDeclination", check_value_of="self")
        # QUIRK (§E): with CanSetGuideRates false ConformU range-checks GuideRateDeclination here.
        self.guide_rate_right_ascension = self.guide_rate_test("GuideRateRightAscension", check_value_of="dec")
        # 6.16 IsPulseGuiding
        if self.can_pulse_guide:
            try:
                value = self.time_func("IsPulseGuiding", lambda: t.IsPulseGuiding, FAST)
                self.log_ok("IsPulseGuiding", str(value))
            except Exception as ex:
                self.handle_exception("IsPulseGuiding", PROPERTY, MUST_BE, ex, "CanPulseGuide is True")
        else:
            try:
                _ = t.IsPulseGuiding
                self.log_issue("IsPulseGuiding", "CanPulseGuide is False but no error was raised on calling "
                                                 "IsPulseGuiding")
            except Exception as ex:
                self.handle_exception("IsPulseGuiding", PROPERTY, MUST_NOT_BE, ex, "CanPulseGuide is False")
        # 6.17 RightAscension
        try:
            ra = self.time_func("RightAscension", lambda: a.RightAscension, FAST)
            if ra < 0.0 or ra >= 24.0:
                self.log_issue("RightAscension", f"RightAscension is <0 or >=24 hours: {ra} {to_hms(ra)}")
            else:
                self.log_ok("RightAscension", to_hms(ra))
        except Exception as ex:
            self.handle_exception("RightAscension", PROPERTY, MANDATORY, ex, "")
        # 6.18 RightAscensionRate read
        try:
            ra_rate = self.time_func("RightAscensionRate Read", lambda: t.RightAscensionRate, FAST)
            if self.can_set_right_ascension_rate:
                # QUIRK (§E): the sign check uses the DeclinationRate value read earlier.
                if self.declination_rate >= 0.0:
                    self.log_ok("RightAscensionRate Read", f"{ra_rate:.2f}")
                else:
                    self.log_issue("RightAscensionRate Read", f"Negative RightAscensionRate: {ra_rate:.2f}")
            elif ra_rate == 0.0:
                self.log_ok("RightAscensionRate Read", f"{ra_rate:.2f}")
            else:
                # QUIRK (§E): the message prints the DeclinationRate value.
                self.log_issue("RightAscensionRate Read", "RightAscensionRate is non zero when "
                                                          "CanSetRightAscensionRate is False "
                                                          f"{self.declination_rate:.2f}")
        except Exception as ex:
            if not self.can_set_right_ascension_rate:
                self.log_info("RightAscensionRate Read", "RightAscensionRate must return 0 if "
                                                         "CanSetRightAscensionRate is false.")
            self.handle_exception("RightAscensionRate Read", PROPERTY, MANDATORY, ex, "")
        # 6.19 RightAscensionRate write
        self.rate_offset_write_tests("RightAscensionRate Write", "RA")
        # 6.20-6.22 site
        self.site_elevation_tests()
        self.site_latitude_tests()
        self.site_longitude_tests()
        # 6.23 Slewing
        try:
            slewing = self.time_func("Slewing", lambda: t.Slewing, FAST)
            if slewing:
                self.log_issue("Slewing", f"Slewing should be false and it reads as {slewing}")
            else:
                self.log_ok("Slewing", str(slewing))
        except Exception as ex:
            self.handle_exception("Slewing", PROPERTY, OPTIONAL, ex, "")
        # 6.24 SlewSettleTime
        settle = 0
        try:
            settle = self.time_func("SlewSettleTime Read", lambda: t.SlewSettleTime, FAST)
            if settle < 0:
                self.log_issue("SlewSettleTime Read", "SlewSettleTime is < 0 seconds")
            elif settle > 30:
                self.log_info("SlewSettleTime Read", "SlewSettleTime is > 30 seconds")
            else:
                self.log_ok("SlewSettleTime Read", str(settle))
        except Exception as ex:
            self.handle_exception("SlewSettleTime Read", PROPERTY, OPTIONAL, ex, "")
        try:
            t.SlewSettleTime = -1
            self.log_issue("SlewSettleTime Write", "No error generated on set SlewSettleTime < 0 seconds")
        except Exception as ex:
            self.handle_invalid_value_exception_as_ok("SlewSettleTime Write", PROPERTY, OPTIONAL, ex, "",
                                                      "Invalid Value exception generated as expected on set slew "
                                                      "settle time < 0")
        try:
            settle = max(settle, 0)
            self.time_method("SlewSettleTime Write", lambda: setattr(t, "SlewSettleTime", settle), STANDARD)
            self.log_ok("SlewSettleTime Write", f"Legal value {settle} seconds written successfully")
        except Exception as ex:
            self.handle_exception("SlewSettleTime Write", PROPERTY, OPTIONAL, ex, "")
        # 6.25 SideOfPier read
        try:
            side = self.time_func("SideOfPier Read", lambda: t.SideOfPier, FAST)
            self.log_ok("SideOfPier Read", PIER_NAMES.get(side, str(side)))
            self.can_read_side_of_pier = True
        except Exception as ex:
            self.handle_exception("SideOfPier Read", PROPERTY, OPTIONAL, ex, "")
        # 6.26 SiderealTime
        if not self.sidereal_time_test():
            return  # > 1 h off: ConformU skips the remaining property tests (L2195-L2198)
        # 6.27 / 6.29 first-use target reads
        self.grade_first_target_read("TargetDeclination Read", target_dec_exception, self.target_declination,
                                     lambda v: -90.0 <= v <= 90.0, to_dms)
        self.log_info("TargetDeclination Write", "Tests moved after the SlewToCoordinates tests so that Conform can "
                                                 "confirm that target coordinates are set as expected.")
        self.grade_first_target_read("TargetRightAscension Read", target_ra_exception, self.target_right_ascension,
                                     lambda v: 0.0 <= v < 24.0, to_hms)
        self.log_info("TargetRightAscension Write", "Tests moved after the SlewToCoordinates tests so that Conform "
                                                    "can confirm that target coordinates are set as expected.")
        # 6.31 / 6.32 Tracking
        self.tracking_tests()
        # 6.33 TrackingRates, 6.34 TrackingRate
        self.tracking_rates_tests()
        self.tracking_rate_tests()
        # 6.35 UTCDate
        try:
            utc_date = self.time_func("UTCDate Read", lambda: t.UTCDate, FAST)
            self.log_ok("UTCDate Read", f"{utc_date:%d-%b-%Y %H:%M:%S.%f}")
            try:
                ahead = utc_date + timedelta(hours=1)
                self.time_method("UTCDate Write", lambda: setattr(t, "UTCDate", ahead), STANDARD)
                self.log_ok("UTCDate Write", f"New UTCDate written successfully: {ahead}")
                t.UTCDate = utc_date
                self.log_ok("UTCDate Write", f"Original UTCDate restored successfully: {utc_date}")
            except Exception as ex:
                self.handle_exception("UTCDate Write", PROPERTY, OPTIONAL, ex, "")
        except Exception as ex:
            self.handle_exception("UTCDate Read", PROPERTY, MANDATORY, ex, "")

    def grade_first_target_read(self, test: str, exception: BaseException | None, value: float,
                                in_range: Callable[[float], bool], fmt: Callable[[float], str]) -> None:
        """§6.27/§6.29: the read made before any target was set must fail with 0x402 (or 0x40B / 0x400)."""
        if exception is None:
            if self.settings.telescope_first_use_tests:
                self.log_issue(test, "Read before write should generate an error and didn't")
                self.log_info(test, "This issue can be suppressed by unchecking Conform's \"Enable first time use "
                                    "tests\" setting in the telescope test section.")
            elif in_range(value):
                self.log_ok(test, fmt(value))
            else:
                self.log_issue(test, f"{test.split()[0]} is out of range: {fmt(value)}")
        elif self.is_not_set_exception(exception):
            self.log_ok(test, "Not Set exception generated on read before write")
        else:
            self.handle_invalid_operation_exception_as_ok(test, PROPERTY, OPTIONAL, exception,
                                                          "Incorrect exception received",
                                                          "InvalidOperationException generated as expected on target "
                                                          "read before read")

    def guide_rate_test(self, member: str, check_value_of: str) -> float:
        t = self.t
        value = 0.0
        if self.can_set_guide_rates:
            try:
                value = self.time_func(f"{member} Read", lambda: getattr(t, member), FAST)
                if value >= 0.0:
                    self.log_ok(f"{member} Read", f"{value:.6f} ({to_dms(value)})")
                else:
                    self.log_issue(f"{member} Read", f"{member} is < 0.0: {value:.6f} ({to_dms(value)})")
            except Exception as ex:
                self.handle_exception(f"{member} Read", PROPERTY, MUST_BE, ex, "CanSetGuideRates is True")
            try:
                self.time_method(f"{member} Write", lambda: setattr(t, member, value), STANDARD)
                self.log_ok(f"{member} Write", f"Can write {member} OK")
            except Exception as ex:
                self.handle_exception(f"{member} Write", PROPERTY, MUST_BE, ex, "CanSetGuideRates is True")
        else:
            try:
                value = getattr(t, member)
                checked = value if check_value_of == "self" else self.guide_rate_declination
                if checked < 0.0:
                    self.log_issue(f"{member} Read", f"{member} is < 0.0 {value:.2f}")
                else:
                    self.log_ok(f"{member} Read", f"{value:.2f}")
            except Exception as ex:
                self.handle_exception(f"{member} Read", PROPERTY, OPTIONAL, ex, "")
            try:
                setattr(t, member, value)
                self.log_issue(f"{member} Write", f"CanSetGuideRates is false but no exception generated; value "
                                                  f"returned: {value:.2f}")
            except Exception as ex:
                self.handle_exception(f"{member} Write", PROPERTY, MUST_NOT_BE, ex, "CanSetGuideRates is False")
        return value

    # -- rate offsets (§6.10, §6.19) ----------------------------------------------------------------------
    def rate_offset_write_tests(self, test: str, axis: str) -> None:
        t = self.t
        member = "DeclinationRate" if axis == "Dec" else "RightAscensionRate"
        can_set = self.can_set_declination_rate if axis == "Dec" else self.can_set_right_ascension_rate
        if not can_set:
            try:
                setattr(t, member, 0.0)
                self.log_issue(test, f"CanSet{member} is False but setting {member} did not generate an error")
            except Exception as ex:
                self.handle_exception(test, PROPERTY, MUST_NOT_BE, ex, f"CanSet{member} is False")
            return
        with contextlib.suppress(Exception):  # best endeavours
            t.TrackingRate = SIDEREAL
        low = self.settings.telescope_rate_offset_test_low_value
        high = self.settings.telescope_rate_offset_test_high_value
        if axis == "RA":
            low, high = low * ARC_SECONDS_TO_RA_SECONDS, high * ARC_SECONDS_TO_RA_SECONDS
        if self.test_ra_dec_rate(test, "Set rate to   0.000", axis, 0.0, True):
            for rate in (low, -low, high, -high):
                self.test_ra_dec_rate(test, f"Set rate to {rate:+7.3f}", axis, rate, True)
            self.test_ra_dec_rate(test, "Set rate to   0.000", axis, 0.0, True)
            if self.settings.telescope_extended_rate_offset_tests:
                for ha in (-9.0, 3.0, 9.0, -3.0):  # no try/catch: exceptions abandon the run (§3)
                    low_v = self.settings.telescope_rate_offset_test_low_value
                    high_v = self.settings.telescope_rate_offset_test_high_value
                    scale = 1.0 if axis == "Dec" else ARC_SECONDS_TO_RA_SECONDS
                    for rate in (low_v, -low_v, high_v, -high_v):
                        self.test_offset_rate(test, ha, axis, rate * scale)
            self.test_ra_dec_rate(test, "Reset rate to 0.0", axis, 0.0, False)

    def test_ra_dec_rate(self, test: str, description: str, axis: str, rate: float, include_slewing: bool) -> bool:
        """TT TestRaDecRate (L8032-L8139)."""
        t = self.t
        member = "DeclinationRate" if axis == "Dec" else "RightAscensionRate"
        try:
            if not t.Tracking and not self.can_set_tracking:
                self.log_issue(test, f"{description} - Test abandoned because {member} is true but Tracking is "
                                     "false and CanSetTracking is also false.")
                return False
            if include_slewing and t.Slewing:
                self.log_issue(test, f"{description} - Telescope.Slewing should be False at the start of this test "
                                     "but is returning True, test abandoned")
                return False
            try:
                self.time_method(f"{test} {rate:.3f}", lambda: setattr(t, member, rate), STANDARD)
                self.wait_for(1000)
                actual = getattr(t, member)
                slewing = t.Slewing
                matches = (abs(actual - rate) <= 0.00001) if rate == 0.0 else abs((actual - rate) / rate) <= 0.00001
                if matches and not slewing:
                    self.log_ok(test, f"{description} - successfully set rate to {actual:+.3f}")
                    return True
                if slewing and matches:
                    self.log_issue(test, f"{member} was successfully set to {rate} but Slewing is returning True, it "
                                         "should return False.")
                elif slewing:
                    self.log_issue(test, f"{member} Read does not return {rate} as set, instead it returns {actual}. "
                                         "Slewing is also returning True, it should return False.")
                else:
                    self.log_issue(test, f"{member} Read does not return {rate} as set, instead it returns {actual}.")
            except Exception as ex:
                # QUIRK (§E): ConformU treats InvalidOperation here as "rejected as an invalid value".
                if self.is_invalid_operation_exception(test, ex):
                    self.log_info(test, f"Unable to set test rate {rate}, it was rejected as an invalid value.")
                else:
                    self.handle_exception(test, PROPERTY, MUST_BE, ex, f"CanSet{member} is True")
        except Exception as ex:
            self.handle_exception(test, PROPERTY, MUST_BE, ex, "Tried to read Slewing property")
        return False

    def test_offset_rate(self, test: str, ha: float, axis: str, expected: float) -> None:
        """TT TestOffsetRate (L8350-L8445): 10 s of tracking with an offset, movement within 5 %."""
        t = self.t
        duration = self.settings.telescope_rate_offset_test_duration
        test = f"{test} {ha:+.1f}"
        expected_ra = expected if axis == "RA" else 0.0
        expected_dec = expected if axis == "Dec" else 0.0
        test_ra = condition_ra(t.SiderealTime - ha)
        try:
            test_dec = self.get_test_declination_halfway_to_horizon(test, test_ra)
        except InvalidOperationException:
            self.log_info(test, f"Test omitted because it was not possible to find a declination above the horizon "
                                f"at {to_hms(test_ra)}.")
            return
        self.slew_scope(test_ra, test_dec, f"Hour angle {ha:.2f}")
        pri_start, sec_start = t.RightAscension, t.Declination
        t.RightAscensionRate = expected_ra * SIDEREAL_SECONDS_TO_SI_SECONDS
        t.DeclinationRate = expected_dec
        self.wait_for(int(duration * 1000))
        pri_end, sec_end = t.RightAscension, t.Declination
        t.RightAscensionRate = 0.0
        t.DeclinationRate = 0.0
        actual_pri = (pri_end - pri_start) / duration * 3600.0
        actual_sec = (sec_end - sec_start) / duration * 3600.0
        self.test_double(test, f"Rate: {expected:+7.3f} - RightAscensionRate", actual_pri, expected_ra)
        self.test_double(test, f"Rate: {expected:+7.3f} - DeclinationRate   ", actual_sec, expected_dec)

    def test_double(self, test: str, name: str, actual: float, expected: float, tolerance: float = 0.0) -> None:
        tolerance = tolerance or 0.05
        if expected == 0.0:
            good = abs(actual - expected) <= tolerance
        else:
            good = abs(abs(actual - expected) / expected) <= tolerance
        message = f"{name} Expected: {expected:+.4f}, Actual: {actual:+.4f}"
        if good:
            self.log_ok(test, f"{name} is within expected tolerance. {message}")
        else:
            self.log_issue(test, f"{name} is outside the expected tolerance. {message}, "
                                 f"Tolerance:{tolerance * 100:.0f}%.")

    # -- site (§6.20-§6.22) - through alpyca -------------------------------------------------------------
    def site_elevation_tests(self) -> None:
        a = self.a
        readable, writable = True, True
        elevation = 0.0
        try:
            elevation = self.time_func("SiteElevation Read", lambda: a.SiteElevation, FAST)
            if elevation < -300.0:
                self.log_issue("SiteElevation Read", "SiteElevation is <-300m")
                readable = False
            elif elevation > 10000.0:
                self.log_issue("SiteElevation Read", "SiteElevation is >10,000m")
                readable = False
            else:
                self.log_ok("SiteElevation Read", str(elevation))
        except Exception as ex:
            readable = False
            self.handle_exception("SiteElevation Read", PROPERTY, OPTIONAL, ex, "")
        for bad, what in ((-301.0, "< -300m"), (10001.0, "> 10,000m")):
            try:
                a.SiteElevation = bad
                self.log_issue("SiteElevation Write", f"No error generated on set site elevation {what}")
            except Exception as ex:
                self.handle_invalid_value_exception_as_ok("SiteElevation Write", PROPERTY, OPTIONAL, ex, "",
                                                          "Invalid Value exception generated as expected on set site "
                                                          f"elevation {what}")
        try:
            if elevation < -300.0 or elevation > 10000.0:
                elevation = 1000.0
            self.time_method("SiteElevation Write", lambda: setattr(a, "SiteElevation", elevation), STANDARD)
            self.log_ok("SiteElevation Write", f"Current value {elevation}m written successfully")
        except Exception as ex:
            writable = False
            self.handle_exception("SiteElevation Write", PROPERTY, OPTIONAL, ex, "")
        self.site_elevation = elevation
        if readable and writable and self.settings.telescope_extended_site_tests:
            self.site_round_trip("SiteElevation", SITE_ELEVATION_TEST_VALUE, elevation, str)

    def site_latitude_tests(self) -> None:
        a = self.a
        readable, writable = True, True
        latitude = 0.0
        try:
            latitude = self.time_func("SiteLatitude Read", lambda: a.SiteLatitude, FAST)
            if latitude < -90.0:
                self.log_issue("SiteLatitude Read", "SiteLatitude is < -90 degrees")
                readable = False
            elif latitude > 90.0:
                self.log_issue("SiteLatitude Read", "SiteLatitude is > 90 degrees")
                readable = False
            else:
                self.log_ok("SiteLatitude Read", to_dms(latitude))
        except Exception as ex:
            readable = False
            self.handle_exception("SiteLatitude Read", PROPERTY, OPTIONAL, ex, "")
        for bad, what in ((-91.0, "< -90 degrees"), (91.0, "> 90 degrees")):
            try:
                a.SiteLatitude = bad
                self.log_issue("SiteLatitude Write", f"No error generated on set site latitude {what}")
            except Exception as ex:
                self.handle_invalid_value_exception_as_ok("SiteLatitude Write", PROPERTY, OPTIONAL, ex, "",
                                                          "Invalid Value exception generated as expected on set site "
                                                          f"latitude {what}")
        try:
            if latitude < -90.0 or latitude > 90.0:
                latitude = 45.0
            self.time_method("SiteLatitude Write", lambda: setattr(a, "SiteLatitude", latitude), STANDARD)
            self.log_ok("SiteLatitude Write", f"Current value: {to_dms(latitude)} degrees written successfully")
        except Exception as ex:
            writable = False
            self.handle_exception("SiteLatitude Write", PROPERTY, OPTIONAL, ex, "")
        self.site_latitude = latitude
        if readable and writable and self.settings.telescope_extended_site_tests:
            if latitude <= -70.0:
                test_value = latitude + 10.0
            elif latitude <= 0.0:
                test_value = latitude - 10.0
            elif latitude <= 70.0:
                test_value = latitude + 10.0
            else:
                test_value = latitude - 10.0
            self.site_round_trip("SiteLatitude", test_value, latitude, to_dms)

    def site_longitude_tests(self) -> None:
        a = self.a
        readable, writable = True, True
        longitude = 0.0
        try:
            longitude = self.time_func("SiteLongitude Read", lambda: a.SiteLongitude, FAST)
            if longitude < -180.0:
                readable = False
                self.log_issue("SiteLongitude Read", "SiteLongitude is < -180 degrees")
            elif longitude > 180.0:
                readable = False
                self.log_issue("SiteLongitude Read", "SiteLongitude is > 180 degrees")
            else:
                self.log_ok("SiteLongitude Read", to_dms(longitude))
        except Exception as ex:
            readable = False
            self.handle_exception("SiteLongitude Read", PROPERTY, OPTIONAL, ex, "")
        for bad, what in ((-181.0, "< -180 degrees"), (181.0, "> 180 degrees")):
            try:
                a.SiteLongitude = bad
                self.log_issue("SiteLongitude Write", f"No error generated on set site longitude {what}")
            except Exception as ex:
                self.handle_invalid_value_exception_as_ok("SiteLongitude Write", PROPERTY, OPTIONAL, ex, "",
                                                          "Invalid Value exception generated as expected on set site "
                                                          f"longitude {what}")
        try:
            if longitude < -180.0 or longitude > 180.0:
                longitude = 60.0
            # QUIRK (§E): ConformU times this write under the name "SiteLatitude Write".
            self.time_method("SiteLatitude Write", lambda: setattr(a, "SiteLongitude", longitude), STANDARD)
            self.log_ok("SiteLongitude Write", f"Current value {to_dms(longitude)} degrees written successfully")
        except Exception as ex:
            writable = False
            self.handle_exception("SiteLongitude Write", PROPERTY, OPTIONAL, ex, "")
        self.site_longitude = longitude
        if readable and writable and self.settings.telescope_extended_site_tests:
            if longitude <= -150.0:
                test_value = longitude + 10.0
            elif longitude <= 0.0:
                test_value = longitude - 10.0
            elif longitude <= 150.0:
                test_value = longitude + 10.0
            else:
                test_value = longitude - 10.0
            self.site_round_trip("SiteLongitude", test_value, longitude, to_dms)

    def site_round_trip(self, member: str, test_value: float, original: float, fmt: Callable[[float], str]) -> None:
        """Extended site test: write, read back with exact ``==``, restore."""
        a = self.a
        test = f"{member} Write"
        try:
            setattr(a, member, test_value)
            read_back = getattr(a, member)
            if read_back == test_value:
                self.log_ok(test, f"Test value {fmt(test_value)} set and read correctly")
            else:
                self.log_issue(test, f"Test value {fmt(test_value)} did not round trip correctly. GET {member} "
                                     f"returned: {read_back!r} instead of {test_value!r}")
        except Exception as ex:
            self.handle_exception(test, PROPERTY, MUST_BE, ex, "A valid value could not be set")
        try:
            setattr(a, member, original)
            self.log_ok(test, f"Successfully restored original {member}: {fmt(original)}.")
        except Exception as ex:
            self.handle_exception(test, PROPERTY, MUST_BE, ex, "The original value could not be restored")

    # -- SiderealTime (§6.26) ----------------------------------------------------------------------------
    def sidereal_time_test(self) -> bool:
        """Returns False when the rest of CheckProperties is skipped (more than 1 h off)."""
        try:
            self.can_read_sidereal_time = False
            scope = self.time_func("SiderealTime", lambda: self.t.SiderealTime, FAST)
            self.can_read_sidereal_time = True
            ascom = conform_lst(julian_date(self.clock.utcnow()), self.site_longitude)
            if scope < 0.0 or scope >= 24.0:
                self.log_issue("SiderealTime", f"SiderealTime is <0 or >=24 hours: {to_hms(scope)}")
                return True
            self.log_ok("SiderealTime", to_hms(scope))
            difference = abs(scope - ascom)
            if 23.0 < ascom < 23.999 and 0.0 < scope < 1.0:
                difference = abs(scope - ascom + 24.0)
            if 23.0 < scope < 23.999 and 0.0 < ascom < 1.0:
                difference = abs(scope - ascom - 24.0)
            bands = ((1 / 3600, "1 second"), (2 / 3600, "2 seconds"), (5 / 3600, "5 seconds"), (1 / 60, "1 minute"),
                     (5 / 60, "5 minutes"))
            for limit, text in bands:
                if difference <= limit:
                    self.log_ok("SiderealTime", f"Scope and ASCOM sidereal times agree to better than {text}, Scope: "
                                                f"{to_hms(scope)}, ASCOM: {to_hms(ascom)}")
                    return True
            if difference <= 1.0:
                self.log_info("SiderealTime", f"Scope and ASCOM sidereal times are up to "
                                              f"{'0.5' if difference <= 0.5 else '1.0'} hour different, Scope: "
                                              f"{to_hms(scope)}, ASCOM: {to_hms(ascom)}")
                return True
            self.log_issue("SiderealTime", f"Scope and ASCOM sidereal times are more than 1 hour apart, Scope: "
                                           f"{to_hms(scope)}, ASCOM: {to_hms(ascom)}")
            return False
        except Exception as ex:
            self.handle_exception("SiderealTime", PROPERTY, MANDATORY, ex, "")
            return True

    # -- Tracking (§6.31-§6.32) ----------------------------------------------------------------------------
    def tracking_tests(self) -> None:
        t = self.t
        try:
            self.tracking = self.time_func("Tracking Read", lambda: t.Tracking, FAST)
            self.log_ok("Tracking Read", str(self.tracking))
        except Exception as ex:
            self.handle_exception("Tracking Read", PROPERTY, MANDATORY, ex, "")
        original = self.tracking
        if self.can_set_tracking:
            try:
                self.time_method("Tracking Write", lambda: setattr(t, "Tracking", not original), STANDARD)
                self.wait_for(TRACKING_COMMAND_DELAY)
                self.tracking = t.Tracking
                if self.tracking != original:
                    self.log_ok("Tracking Write", str(self.tracking))
                else:
                    self.log_issue("Tracking Write", f"Tracking didn't change state on write: {self.tracking}")
                t.Tracking = original
                self.wait_for(TRACKING_COMMAND_DELAY)
            except Exception as ex:
                self.handle_exception("Tracking Write", PROPERTY, MUST_BE, ex, "CanSetTracking is True")
        else:
            try:
                t.Tracking = not original
                self.tracking = t.Tracking
                self.log_issue("Tracking Write", "CanSetTracking is false but no error generated when value is set")
            except Exception as ex:
                self.handle_exception("Tracking Write", PROPERTY, MUST_NOT_BE, ex, "CanSetTracking is False")

    def tracking_rates_tests(self) -> None:
        t = self.t
        count = 0
        try:
            # QUIRK (§E): ConformU times this GET under the name "Tracking Write".
            rates = self.time_func("Tracking Write", lambda: t.TrackingRates, FAST)
            count = len(rates or [])
            for rate in rates or []:
                if isinstance(rate, bool) or not isinstance(rate, int):
                    raise TypeError(f"TrackingRates element {rate!r} is not a DriveRate integer")
        except Exception as ex:
            self.handle_exception("TrackingRates", PROPERTY, MANDATORY, ex, "")
        try:
            rates = t.TrackingRates or []
            for rate in rates:
                self.log_info("TrackingRates", f"Found drive rate: {DRIVE_RATES.get(rate, rate)}")
            if rates:
                self.log_ok("TrackingRates", "Drive rates read OK")
            elif count > 0:
                self.log_issue("TrackingRates", "Multiple calls to TrackingRates returned different answers!")
            else:
                self.log_issue("TrackingRates", "No drive rates returned")
        except Exception as ex:
            self.handle_exception("TrackingRates", PROPERTY, MANDATORY, ex, "")
        # The TrackingRates.Dispose() test is client-side only; it re-reads the property once.
        try:
            _ = t.TrackingRates
            self.log_ok("TrackingRates", "Disposed tracking rates OK")
        except Exception as ex:
            self.log_issue("TrackingRates", f"TrackingRates could not be read for the Dispose test: {ex}")

    def tracking_rate_tests(self) -> None:
        t = self.t
        try:
            rates = t.TrackingRates
            if rates is None:
                self.log_issue("TrackingRate Write", "TrackingRates did not return an object after calling Disposed() "
                                                     "on a previous instance, TrackingRate.Write testing skipped")
                return
            self.log_ok("TrackingRates", "Successfully obtained a TrackingRates object after the previous "
                                         "TrackingRates object was disposed")
            original = t.TrackingRate
            self.log_ok("TrackingRate Read", DRIVE_RATES.get(original, str(original)))
            can_set_rate = False
            try:
                t.TrackingRate = SIDEREAL
                can_set_rate = True
            except InvalidValueException:
                can_set_rate = True
            except Exception as ex:
                self.handle_exception("TrackingRate Write", PROPERTY, OPTIONAL, ex, "")
            if not can_set_rate:
                return
            try:
                for rate in rates:
                    try:
                        t.TrackingRate = rate
                        if t.TrackingRate == rate:
                            self.log_ok("TrackingRate Write", f"Successfully set drive rate: {DRIVE_RATES.get(rate)}")
                        else:
                            self.log_issue("TrackingRate Write", f"Unable to set drive rate: {DRIVE_RATES.get(rate)}")
                        if self.is_platform7:
                            self.check_rate_offsets_rejected(rate, "DeclinationRate")
                            self.check_rate_offsets_rejected(rate, "RightAscensionRate")
                    except Exception as ex:
                        self.handle_exception("TrackingRate Write", PROPERTY, OPTIONAL, ex, "")
                for rate in DRIVE_RATES:
                    if rate in rates:
                        continue
                    try:
                        t.TrackingRate = rate
                        self.log_issue("TrackingRate Write", f"Tracking rate {DRIVE_RATES[rate]} is not supported but "
                                                             "did not throw an InvalidValueException exception.")
                    except Exception as ex:
                        # QUIRK (§E): the OK message reads "...did not throw an InvalidValueException as expected".
                        self.handle_invalid_value_exception_as_ok(
                            "TrackingRate Write", PROPERTY, OPTIONAL, ex, "",
                            f"Drive rate {DRIVE_RATES[rate]} is not supported but did not throw an "
                            "InvalidValueException as expected.")
            except Exception as ex:
                self.handle_exception("TrackingRate Write 1", PROPERTY, MANDATORY, ex, "")
            for bad in (5, -1):
                try:
                    t.TrackingRate = bad
                    self.log_issue("TrackingRate Write", f"No error generated when TrackingRate is set to an invalid "
                                                         f"value ({bad})")
                except Exception as ex:
                    self.handle_invalid_value_exception_as_ok(
                        "TrackingRate Write", PROPERTY, OPTIONAL, ex, "",
                        f"Invalid Value exception generated as expected when TrackingRate is set to an invalid "
                        f"value ({bad})")
            try:
                t.TrackingRate = original
            except Exception as ex:
                self.handle_exception("TrackingRate Write", PROPERTY, OPTIONAL, ex, "Unable to restore original "
                                                                                     "tracking rate")
        except Exception as ex:
            self.handle_exception("TrackingRate Read", PROPERTY, MANDATORY, ex, "")

    def check_rate_offsets_rejected(self, drive_rate: int, member: str) -> None:
        """TT CheckRateOffsetsRejectedForNonSiderealDriveRates (L4080-L4149)."""
        if drive_rate == SIDEREAL:
            return
        t = self.t
        name = DRIVE_RATES.get(drive_rate, str(drive_rate))
        current = getattr(t, member)
        if current == 0.0:
            self.log_ok("TrackingRate Write", f"{member} is zero for {name} drive rate.")
        else:
            self.log_issue("TrackingRate Write", f"{member} is not zero for drive rate: {name}, it is: {current}")
            self.log_info("TrackingRate Write", "In ITelescopeV4 and later, rate offsets are only valid when tracking "
                                                "at Sidereal rate.")
        can_set = self.can_set_declination_rate if member == "DeclinationRate" else self.can_set_right_ascension_rate
        if not can_set:
            return
        low = self.settings.telescope_rate_offset_test_low_value
        try:
            setattr(t, member, low if member == "DeclinationRate" else low / 15.0)
            self.log_issue("TrackingRate Write", f"Setting {member} in {name} drive rate did not result in an "
                                                 "InvalidOperation  error but should have.")
        except Exception as ex:
            if isinstance(ex, InvalidOperationException):
                self.log_ok("TrackingRate Write", f"Setting {member} in {name} drive rate resulted in an "
                                                  "InvalidOperationException.")
            else:
                self.log_issue("TrackingRate Write", f"Setting {member} in {name} drive rate did not result in an "
                                                     f"InvalidOperationException. Instead it resulted in an "
                                                     f"{type(ex).__name__} exception: {ex}")

    # =================================================================================================
    # Methods (§7, TT L2813-L3845)
    # =================================================================================================
    def check_methods(self) -> None:
        version = self.get_interface_version()
        if version > 1:
            for axis in (PRIMARY, SECONDARY, TERTIARY):
                self.can_move_axis_test(axis)
            self.park_tests()
        self.abort_slew_tests()
        if version > 1:
            for axis in (PRIMARY, SECONDARY, TERTIARY):
                self.axis_rate_test(f"AxisRate:{AXIS_NAMES[axis]}", axis)
        self.optional_method_test("FindHome", "FindHome", self.can_find_home)
        if version > 1:
            for axis in (PRIMARY, SECONDARY, TERTIARY):
                self.optional_method_test(f"MoveAxis{AXIS_NAMES[axis]}", f"MoveAxis {AXIS_NAMES[axis]}",
                                          self.can_move_axis[axis])
        self.optional_method_test("PulseGuide", "PulseGuide", self.can_pulse_guide)
        if self.settings.telescope_extended_pulse_guide_tests:
            if self.can_pulse_guide:
                if self.guide_rate_right_ascension >= 0.0 and self.guide_rate_declination >= 0.0:
                    for ha in (-9.0, 9.0, -3.0, 3.0):  # no try/catch: exceptions abandon the run (§7.7.2)
                        self.test_pulse_guide(ha)
                else:
                    self.log_issue("PulseGuide", "Extended pulse guide tests skipped because at least one of the "
                                                 "GuideRateRightAscension or GuideRateDeclination properties was not "
                                                 "implemented or returned a zero or negative value.")
            else:
                self.log_info("PulseGuide", "Extended pulse guide tests skipped because the CanPulseGuide property "
                                            "returned False.")
        self.slew_test("SlewToCoordinates", "SlewToCoordinates", self.can_slew, "CanSlew")
        if self.can_slew:
            self.bad_coordinate_test("SlewToCoordinates (Bad L)", "SlewToCoordinates", BAD_RA_LOW, BAD_DEC_LOW)
            self.bad_coordinate_test("SlewToCoordinates (Bad H)", "SlewToCoordinates", BAD_RA_HIGH, BAD_DEC_HIGH)
        self.slew_test("SlewToCoordinatesAsync", "SlewToCoordinatesAsync", self.can_slew_async, "CanSlewAsync")
        if self.can_slew_async:
            self.bad_coordinate_test("SlewToCoordinatesAsync (Bad L)", "SlewToCoordinatesAsync", BAD_RA_LOW,
                                     BAD_DEC_LOW)
            self.bad_coordinate_test("SlewToCoordinatesAsync (Bad H)", "SlewToCoordinatesAsync", BAD_RA_HIGH,
                                     BAD_DEC_HIGH)
        self.sync_test("SyncToCoordinates", "SyncToCoordinates", self.can_sync, "CanSync")
        if self.can_sync:
            self.bad_coordinate_test("SyncToCoordinates (Bad L)", "SyncToCoordinates", BAD_RA_LOW, BAD_DEC_LOW)
            self.bad_coordinate_test("SyncToCoordinates (Bad H)", "SyncToCoordinates", BAD_RA_HIGH, BAD_DEC_HIGH)
        self.target_write_tests()
        self.slew_test("SlewToTarget", "SlewToTarget", self.can_slew, "CanSlew")
        if self.can_slew:
            self.bad_coordinate_test("SlewToTarget (Bad L)", "SlewToTarget", BAD_RA_LOW, BAD_DEC_LOW)
            self.bad_coordinate_test("SlewToTarget (Bad H)", "SlewToTarget", BAD_RA_HIGH, BAD_DEC_HIGH)
        self.slew_test("SlewToTargetAsync", "SlewToTargetAsync", self.can_slew_async, "CanSlewAsync")
        if self.can_slew_async:
            self.bad_coordinate_test("SlewToTargetAsync (Bad L)", "SlewToTargetAsync", BAD_RA_LOW, BAD_DEC_LOW)
            self.bad_coordinate_test("SlewToTargetAsync (Bad H)", "SlewToTargetAsync", BAD_RA_HIGH, BAD_DEC_HIGH)
        if version > 1:
            if self.alignment_mode == GERMAN_POLAR:
                self.optional_method_test("DestinationSideOfPier", "DestinationSideOfPier", True)
            else:
                self.log_info("DestinationSideOfPier", "Test skipped as AligmentMode is not German Polar")
            self.slew_test("SlewToAltAz", "SlewToAltAz", self.can_slew_alt_az, "CanSlewAltAz")
            if self.can_slew_alt_az:
                self.bad_coordinate_test("SlewToAltAz (Bad L)", "SlewToAltAz", BAD_ALTITUDE_LOW, BAD_AZIMUTH_LOW)
                self.bad_coordinate_test("SlewToAltAz (Bad H)", "SlewToAltAz", BAD_ALTITUDE_HIGH, BAD_AZIMUTH_HIGH)
            self.slew_test("SlewToAltAzAsync", "SlewToAltAzAsync", self.can_slew_alt_az_async, "CanSlewAltAzAsync")
            if self.can_slew_alt_az_async:
                self.bad_coordinate_test("SlewToAltAzAsync (Bad L)", "SlewToAltAzAsync", BAD_ALTITUDE_LOW,
                                         BAD_AZIMUTH_LOW)
                self.bad_coordinate_test("SlewToAltAzAsync (Bad H)", "SlewToAltAzAsync", BAD_ALTITUDE_HIGH,
                                         BAD_AZIMUTH_HIGH)
        self.sync_test("SyncToTarget", "SyncToTarget", self.can_sync, "CanSync")
        if self.can_sync:
            self.bad_coordinate_test("SyncToTarget (Bad L)", "SyncToTarget", BAD_RA_LOW, BAD_DEC_LOW)
            self.bad_coordinate_test("SyncToTarget (Bad H)", "SyncToTarget", BAD_RA_HIGH, BAD_DEC_HIGH)
        if version > 1:
            self.sync_test("SyncToAltAz", "SyncToAltAz", self.can_sync_alt_az, "CanSyncAltAz")
            if self.can_sync_alt_az:
                self.bad_coordinate_test("SyncToAltAz (Bad L)", "SyncToAltAz", BAD_ALTITUDE_LOW, BAD_AZIMUTH_LOW)
                self.bad_coordinate_test("SyncToAltAz (Bad H)", "SyncToAltAz", BAD_ALTITUDE_HIGH, BAD_AZIMUTH_HIGH)
        if self.settings.test_side_of_pier_read:
            self.report.section("SideOfPier Model Tests")
            self.side_of_pier_model_tests()

    # -- CanMoveAxis (§7.1) - through alpyca -----------------------------------------------------------------
    def can_move_axis_test(self, axis: int) -> None:
        name = f"CanMoveAxis:{AXIS_NAMES[axis]}"
        try:
            value = self.time_func(name, lambda: self.a.CanMoveAxis(axis), FAST)
            if not isinstance(value, bool):
                raise TypeError(f"CanMoveAxis returned {value!r}, not a boolean")
            self.can_move_axis[axis] = value
            self.log_ok(name, f"{name} {value}")
        except Exception as ex:
            self.handle_exception(name, METHOD, MANDATORY, ex, "")

    # -- Park / Unpark (§7.2) -------------------------------------------------------------------------------
    def wait_for_park_state(self, action: str, parked: bool) -> None:
        t = self.t
        if self.is_platform7:
            self.wait_while(action, lambda: t.Slewing, SLEEP_TIME_MS, self.settings.telescope_maximum_slew_time)
        elif parked:
            self.wait_while(action, lambda: not t.AtPark, SLEEP_TIME_MS, self.settings.telescope_maximum_slew_time)
        else:
            self.wait_while(action, lambda: t.AtPark, SLEEP_TIME_MS, self.settings.telescope_maximum_slew_time)

    def park_tests(self) -> None:
        t = self.t
        if not self.can_park:
            self.park_not_supported_tests()
            return
        try:
            if t.AtPark:
                self.log_issue("Park", "AtPark still true despite an earlier successful unpark")
                return
            try:
                try:
                    self.slew_to_ha(-3.0)
                except Exception as ex:
                    self.log_debug("Park", f"Exception when attempting to slew to start position: {ex!r}")
                self.log_info("Park", "Parking scope...")
                self.time_method("Park", t.Park, STANDARD if self.is_platform7 else EXTENDED)
                self.wait_for_park_state("Waiting for scope to park", True)
                if t.AtPark:
                    self.log_ok("Park", "Parked successfully.")
                    try:
                        t.Park()
                        self.wait_for_park_state("Waiting for scope to park", True)
                        if t.AtPark:
                            self.log_ok("Park", "Calling Park twice is harmless and leaves the mount in the parked "
                                                "state.")
                        else:
                            self.log_issue("Park", f"Failed to park within {self.settings.telescope_maximum_slew_time} "
                                                   "seconds.")
                    except Exception as ex:
                        self.log_issue("Park", f"Exception when calling Park two times in succession: {ex}")
                    self.parked_exception_tests()
                else:
                    self.log_issue("Park", f"Failed to park within {self.settings.telescope_maximum_slew_time} "
                                           "seconds, skipping further Park tests.")
                if self.can_unpark:
                    self.unpark_after_park()
                else:
                    try:
                        t.Unpark()
                        self.wait_while("Waiting for scope to unpark", lambda: t.AtPark, SLEEP_TIME_MS,
                                        self.settings.telescope_maximum_slew_time)
                        self.log_issue("Unpark", "No exception thrown by Unpark when CanUnpark is false")
                    except Exception as ex:
                        self.handle_exception("Unpark", METHOD, MUST_NOT_BE, ex, "CanUnpark is false")
                    self.log_info("Unpark", "CanUnpark is false so you need to unpark manually")
            except Exception as ex:
                self.handle_exception("Park", METHOD, MUST_BE, ex, "CanPark is true")
        except Exception as ex:
            self.handle_exception("Park", METHOD, MUST_BE, ex, "CanPark is True")

    def unpark_after_park(self) -> None:
        t = self.t
        try:
            self.time_method("Unpark", t.Unpark, STANDARD if self.is_platform7 else EXTENDED)
            self.wait_for_park_state("Waiting for scope to unpark when parked", False)
            if not t.AtPark:
                self.log_ok("Unpark", "Unparked successfully.")
                with contextlib.suppress(Exception):  # ConformU ignores this
                    t.Tracking = True
                try:
                    t.Unpark()
                    self.wait_for_park_state("Waiting for scope to unpark when parked", False)
                    if not t.AtPark:
                        self.log_ok("Park", "Calling Unpark twice is harmless and leaves the mount in the un-parked "
                                            "state.")
                    else:
                        self.log_issue("Unpark", f"Failed to unpark after {self.settings.telescope_maximum_slew_time} "
                                                 "seconds when sending a second Unpark command.")
                except Exception as ex:
                    self.log_issue("Unpark", f"Exception when calling Unpark two times in succession: {ex}")
            else:
                self.log_issue("Unpark", "AtPark remains True - the scope failed to unpark.")
        except Exception as ex:
            self.handle_exception("Unpark", METHOD, MUST_BE, ex, "CanUnpark is true")

    def park_not_supported_tests(self) -> None:
        t = self.t
        try:
            t.Park()
            self.log_ok("Park", "Success if already parked")
            self.wait_while("Waiting for scope to park", lambda: not t.AtPark, SLEEP_TIME_MS,
                            self.settings.telescope_maximum_slew_time)
            self.log_issue("Park", "CanPark is false but no exception was generated on use")
        except Exception as ex:
            self.handle_exception("Park", METHOD, MUST_NOT_BE, ex, "CanPark is False")
        try:
            t.Unpark()
            self.wait_while("Waiting for scope to unpark", lambda: t.AtPark, SLEEP_TIME_MS,
                            self.settings.telescope_maximum_slew_time)
            if self.can_unpark:
                self.log_ok("UnPark", "CanPark is false and CanUnPark is true; no exception generated as expected")
            else:
                self.log_issue("UnPark", "CanPark and CanUnPark are false but no exception was generated on use")
        except Exception as ex:
            if self.can_unpark:
                self.handle_exception("UnPark", METHOD, MUST_BE, ex, "CanUnPark is True")
            else:
                self.handle_exception("UnPark", METHOD, MUST_NOT_BE, ex, "CanUnPark is False")

    def parked_exception_tests(self) -> None:
        t = self.t
        if self.can_slew or self.can_slew_async or self.can_slew_alt_az or self.can_slew_alt_az_async:
            self.parked_exception_test("AbortSlew", t.AbortSlew)
        if self.can_find_home:
            def find_home() -> None:
                t.FindHome()
                sw = Stopwatch(self.clock)
                self.wait_while("Waiting for mount to home...", lambda: not t.AtHome and sw.elapsed < 60, 200,
                                self.settings.telescope_maximum_slew_time)
            self.parked_exception_test("FindHome", find_home)
        for axis in (PRIMARY, SECONDARY, TERTIARY):
            if self.can_move_axis[axis]:
                self.parked_exception_test(f"MoveAxis {AXIS_NAMES[axis]}", lambda ax=axis: t.MoveAxis(ax, 0.0))
        if self.can_pulse_guide:
            self.parked_exception_test("PulseGuide", lambda: t.PulseGuide(EAST, 0))
        if self.can_slew:
            self.parked_exception_test("SlewToCoordinates",
                                       lambda: t.SlewToCoordinates(self.ra_from_sidereal_time(1.0), 0.0))
        if self.can_slew_async:
            def slew_async() -> None:
                t.SlewToCoordinatesAsync(self.ra_from_sidereal_time(1.0), 0.0)
                self.wait_for_slew("Parked:SlewToCoordinatesAsync", "Slewing to coordinates asynchronously")
            self.parked_exception_test("SlewToCoordinatesAsync", slew_async)

        def set_targets() -> None:
            t.TargetRightAscension = self.ra_from_sidereal_time(1.0)
            t.TargetDeclination = 0.0

        if self.can_slew:
            self.parked_exception_test("SlewToTarget", lambda: (set_targets(), t.SlewToTarget()))
        if self.can_slew_async:
            def slew_target_async() -> None:
                set_targets()
                t.SlewToTargetAsync()
                self.wait_for_slew("Parked:SlewToTargetAsync", "Slewing to target asynchronously")
            self.parked_exception_test("SlewToTargetAsync", slew_target_async)
        if self.can_sync:
            self.parked_exception_test("SyncToCoordinates",
                                       lambda: t.SyncToCoordinates(self.ra_from_sidereal_time(1.0), 0.0))
            self.parked_exception_test("SyncToTarget", lambda: (set_targets(), t.SyncToTarget()))
        if self.can_set_tracking and self.is_platform7:
            def tracking_true() -> None:
                original = t.Tracking
                t.Tracking = True
                if not original:
                    with contextlib.suppress(Exception):
                        t.Tracking = False
            self.parked_exception_test("Tracking = true", tracking_true)
            try:
                t.Tracking = False
                self.log_ok("Parked:Tracking = false", "Tracking = false was successful when parked.")
            except Exception as ex:
                self.handle_exception("Parked - Tracking=False", PROPERTY, MUST_BE, ex,
                                      "Setting Tracking false when parked must be successful for this interface "
                                      "version.")

    def parked_exception_test(self, method: str, action: Callable[[], object]) -> None:
        """TT TelescopeParkedExceptionTest (L5500-L5650)."""
        t = self.t
        test = f"Parked:{method}"
        if not t.AtPark:
            self.log_issue(test, f"Not parked after Telescope.Park command, {method} when parked test skipped")
            return
        try:
            action()
            self.log_issue(test, f"{method} didn't raise an error when Parked as required")
        except Exception as ex:
            if self.is_platform7:
                if self.is_parked_exception(ex):
                    self.log_ok(test, f"{method} threw a ParkedException when Parked, as required. "
                                      f"({type(ex).__name__} - {ex})")
                else:
                    self.log_issue(test, f"{method} threw a {type(ex).__name__} exception when a ParkedException was "
                                         f"expected. Exception message: {ex}")
            else:
                self.log_ok(test, f"{method} threw an exception when Parked, as required. The {type(ex).__name__} "
                                  f"exception message was: {ex}")
        if not t.AtPark:
            self.log_issue(test, f"Telescope was unparked by the {method} command. This should not happen!")

    # -- AbortSlew (§7.3) -------------------------------------------------------------------------------------
    def abort_slew_tests(self) -> None:
        try:
            self.t.AbortSlew()
            self.optional_method_test("AbortSlew", "AbortSlew", True)
        except Exception as ex:
            self.handle_exception("AbortSlew", METHOD, OPTIONAL, ex, "")

    # -- AxisRates (§7.4) - through alpyca ------------------------------------------------------------------
    def axis_rate_test(self, name: str, axis: int) -> None:
        try:
            rates = self.a.AxisRates(axis)
            for i, (minimum, maximum) in enumerate(rates, 1):
                self.log_debug(f"{name} Count", f"Rate {i} - Minimum: {minimum}, Maximum: {maximum}")
            if rates:
                for minimum, maximum in rates:
                    if minimum < 0.0 or maximum < 0.0:
                        self.log_issue(name, f"Minimum or maximum rate is negative: {minimum}, {maximum}")
                    elif minimum <= maximum:
                        self.log_ok(name, f"Axis rate minimum: {minimum} Axis rate maximum: {maximum}")
                    else:
                        self.log_issue(name, f"Maximum rate is less than minimum rate - minimum: {minimum} maximum: "
                                             f"{maximum}")
                    if minimum == 0.0 and maximum == 0.0:
                        self.log_issue(name, "Minimum and maximum are both 0.0: are the Minimum and Maximum fields of "
                                             "the AxisRates response correctly named and cased?")
                overlap = any(i != j and rates[j][0] <= rates[i][0] <= rates[j][1]
                              for i in range(len(rates)) for j in range(len(rates)))
                if overlap:
                    self.log_issue(name, "Overlapping axis rates found, suggest these be rationalised to remove "
                                         "overlaps")
                else:
                    self.log_ok(name, "No overlapping axis rates found")
                duplicate = any(i != j and rates[i] == rates[j] for i in range(len(rates)) for j in range(len(rates)))
                if duplicate:
                    self.log_issue(name, "Duplicate axis rates found, suggest these be removed")
                else:
                    self.log_ok(name, "No duplicate axis rates found")
            else:
                self.log_ok(name, "Empty axis rate returned")
        except Exception as ex:
            self.log_issue(name, f"Unable to get or unable to use an AxisRates object - Exception: {ex!r}")
            return
        try:  # the Rate/AxisRates Dispose tests are client side; ConformU re-reads the rates for them
            rates = self.a.AxisRates(axis)
            for minimum, maximum in rates:
                self.log_ok(name, f"Successfully disposed of rate {minimum} - {maximum}")
            self.log_ok(name, "Disposed axis rates OK")
        except Exception as ex:
            self.log_issue(name, f"AxisRate.Dispose() - Unable to get or unable to use an AxisRates object - "
                                 f"Exception: {ex!r}")

    # -- the optional-method dispatcher (TelescopeOptionalMethodsTest, L6596-L6758) --------------------------
    def optional_method_test(self, test_type: str, test_name: str, can_test: bool) -> None:
        t = self.t
        if can_test:
            try:
                if test_type == "AbortSlew":
                    self.abort_slew_during_slew(test_name)
                elif test_type == "DestinationSideOfPier":
                    self.destination_side_of_pier_test(test_name)
                elif test_type == "FindHome":
                    self.find_home_test(test_name)
                elif test_type.startswith("MoveAxis"):
                    axis = {"MoveAxisPrimary": PRIMARY, "MoveAxisSecondary": SECONDARY,
                            "MoveAxisTertiary": TERTIARY}[test_type]
                    rates = t.AxisRates(axis)
                    self.move_axis_test(test_name, axis, rates)
                    self.log_ok(test_name, "AxisRates object successfully disposed")
                elif test_type == "PulseGuide":
                    self.pulse_guide_test(test_name)
                elif test_type == "SideOfPierWrite":
                    self.side_of_pier_write_test(test_name)
            except Exception as ex:
                # QUIRK (§E): any exception, 0x400 included, is an ISSUE before HandleException grades it.
                self.log_issue(test_name, f"{test_type} Exception {ex!r}")
                self.handle_exception(test_name, METHOD, OPTIONAL, ex, "")
            return
        try:
            if test_type == "AbortSlew":
                t.AbortSlew()
            elif test_type == "DestinationSideOfPier":
                t.DestinationSideOfPier(self.ra_from_sidereal_time(-1.0), 0.0)
            elif test_type == "FindHome":
                t.FindHome()
                sw = Stopwatch(self.clock)
                self.wait_while("Waiting for mount to home...", lambda: not t.AtHome and sw.elapsed < 60, 200,
                                self.settings.telescope_maximum_slew_time)
            elif test_type.startswith("MoveAxis"):
                axis = {"MoveAxisPrimary": PRIMARY, "MoveAxisSecondary": SECONDARY,
                        "MoveAxisTertiary": TERTIARY}[test_type]
                t.MoveAxis(axis, 0.0)
            elif test_type == "PulseGuide":
                t.PulseGuide(EAST, 0)
            elif test_type == "SideOfPierWrite":
                t.SideOfPier = PIER_EAST
            self.log_issue(test_name, f"Can{test_name} is false but no exception was generated on use")
        except Exception as ex:
            if self.is_invalid_value_exception(test_name, ex):
                self.log_ok(test_name, "Received an invalid value exception")
            elif test_type == "SideOfPierWrite":
                self.handle_exception(test_name, PROPERTY, MUST_NOT_BE, ex, f"Can{test_name} is False")
            else:
                self.handle_exception(test_name, METHOD, MUST_NOT_BE, ex, f"Can{test_name} is False")

    def abort_slew_during_slew(self, test_name: str) -> None:
        """§7.3: AbortSlew while idle, then during an async slew to HA -3."""
        t = self.t
        t.AbortSlew()
        self.log_ok(test_name, "AbortSlew OK when not slewing")
        if not self.can_slew_async:
            self.log_info(test_name, f"Skipping the abort SlewToCoordinatesAsync test because CanSlewAsync is "
                                     f"{self.can_slew_async}.")
            return
        if self.can_set_tracking:
            t.Tracking = True
        target_ra = condition_ra(t.SiderealTime + 3.0)
        self.target_declination = self.get_test_declination_less_than_65(test_name, target_ra)
        t.SlewToCoordinatesAsync(target_ra, self.target_declination)
        self.wait_for(1500, 100)
        self.validate_slewing(test_name, True)
        sw = Stopwatch(self.clock)
        self.time_method(test_name, t.AbortSlew, STANDARD)
        try:
            self.wait_while("Waiting for slew to stop", lambda: t.Slewing, 500,
                            self.settings.telescope_time_for_slewing_to_become_false)
            self.log_ok(test_name, f"AbortSlew stopped the mount from slewing in {sw.elapsed:.1f} seconds.")
        except ConformTimeout:
            self.log_issue(test_name, f"The mount still reports Slewing as TRUE "
                                      f"{self.settings.telescope_time_for_slewing_to_become_false} seconds after "
                                      "AbortSlew returned.")
        except Exception as ex:
            self.log_issue(test_name, f"The mount reported an exception while waiting for Slewing to become false "
                                      f"after AbortSlew: {ex}")

    def destination_side_of_pier_test(self, test_name: str) -> None:
        """§7.13: DSOP at HA +2 and HA -2 must differ and be known."""
        t = self.t
        self.target_declination = 45.0 if self.site_latitude > 0.0 else -45.0
        if self.can_slew_async:
            self.slew_to_ha(3.0)
        if self.can_read_sop(test_name):
            _ = t.SideOfPier
        ra_west = self.ra_from_hour_angle(2.0)
        west = self.time_func(test_name, lambda: t.DestinationSideOfPier(ra_west, self.target_declination), FAST)
        ra_east = self.ra_from_hour_angle(-2.0)
        east = self.time_func(test_name, lambda: t.DestinationSideOfPier(ra_east, self.target_declination), FAST)
        if east == PIER_UNKNOWN or west == PIER_UNKNOWN:
            self.log_issue(test_name, f"Unexpected SideOfPier value received (Unknown), Target in East: "
                                      f"{PIER_NAMES.get(east)}, Target in West: {PIER_NAMES.get(west)}")
        elif east == west:
            self.log_issue(test_name, f"Same value for DestinationSideOfPier received on both sides of the meridian - "
                                      f"East: {PIER_NAMES.get(east)}, West: {PIER_NAMES.get(west)}")
        else:
            self.log_ok(test_name, f"DestinationSideOfPier is different on either side of the meridian - East: "
                                   f"{PIER_NAMES.get(east)}, West: {PIER_NAMES.get(west)}")

    def find_home_test(self, test_name: str) -> None:
        """§7.5 (CanFindHome true, IV > 1)."""
        t = self.t
        _ = t.Tracking
        if self.can_set_tracking:
            t.Tracking = False
        self.time_method(test_name, t.FindHome, STANDARD if self.is_platform7 else EXTENDED)
        if self.is_platform7:
            self.wait_while("Waiting for scope to home...", lambda: t.Slewing, SLEEP_TIME_MS,
                            self.settings.telescope_maximum_slew_time)
        else:
            self.wait_while("Waiting for scope to home...", lambda: not t.AtHome, SLEEP_TIME_MS,
                            self.settings.telescope_maximum_slew_time)
        if t.Tracking:
            t.Tracking = False
        if t.AtHome:
            self.log_ok(test_name, "Found home OK.")
        else:
            self.log_issue(test_name, "AtHome reports false after FindHome")
            self.log_info(test_name, "Possible causes: the mount did not reach home within "
                                     f"{self.settings.telescope_maximum_slew_time} seconds, Slewing became false "
                                     "before AtHome became true, or Tracking has been automatically enabled, moving "
                                     "the mount away from home.")
        if t.AtPark:
            self.log_issue(test_name, "FindHome has parked the scope as well as finding home")
            t.Unpark()
            self.wait_while("Waiting for scope to unpark", lambda: t.AtPark, SLEEP_TIME_MS,
                            self.settings.telescope_maximum_slew_time)
        if self.can_set_tracking:
            t.Tracking = True

    # -- MoveAxis (§7.6, TelescopeMoveAxisTest L6915-L7408) -------------------------------------------------
    def wait_for_slewing_to_become_false(self, test_name: str) -> bool:
        try:
            self.wait_while("Waiting for slew to stop", lambda: self.t.Slewing, 500,
                            self.settings.telescope_time_for_slewing_to_become_false)
            return True
        except ConformTimeout:
            self.log_issue(test_name, f"Timed out after {self.settings.telescope_time_for_slewing_to_become_false} "
                                      "seconds while waiting for Slewing to become FALSE.")
        except Exception as ex:
            self.log_issue(test_name, f"The mount reported an exception while waiting for Slewing to become false: "
                                      f"{ex}")
        return False

    def validate_slewing(self, test: str, expected: bool) -> bool:
        try:
            slewing = self.t.Slewing
            if slewing == expected:
                return True
            self.log_issue(test, f"Slewing did not have the expected state: {expected}, it was: {slewing}.")
        except Exception as ex:
            self.log_issue(test, f"Unexpected exception from Slewing: {ex}")
        return False

    def move_axis_test(self, test_name: str, axis: int, rates: list[tuple[float, float]]) -> None:
        t = self.t
        if not rates:
            self.log_issue(test_name, "MoveAxis tests skipped because there are no AxisRate values")
            return
        rate_min = min(r[0] for r in rates)
        rate_max = max(r[1] for r in rates)
        can_set_zero = False
        try:
            self.time_method(f"{test_name} {AXIS_NAMES[axis]} 0", lambda: t.MoveAxis(axis, 0.0), STANDARD)
            if self.wait_for_slewing_to_become_false(test_name):
                self.log_ok(test_name, "Can successfully set a movement rate of zero")
                can_set_zero = True
            else:
                self.log_issue(test_name, "Slewing was not false after setting a rate of 0..")
        except Exception as ex:
            self.log_issue(test_name, f"Unable to set a movement rate of zero - {ex}")
        move_rate = rate_min / 2.0 if rate_min > 0.0 else -rate_max - 1.0
        try:
            t.MoveAxis(axis, move_rate)
            self.log_issue(test_name, f"No exception raised when move axis value < minimum rate: {move_rate}")
        except Exception as ex:
            self.handle_invalid_value_exception_as_ok(
                test_name, METHOD, MUST_BE, ex, f"when move axis is set below lowest rate ({move_rate})",
                f"Exception correctly generated when move axis is set below lowest rate ({move_rate})")
        move_rate = rate_max + 1.0
        try:
            t.MoveAxis(axis, move_rate)
            self.log_issue(test_name, f"No exception raised when move axis value > maximum rate: {move_rate}")
        except Exception as ex:
            self.handle_invalid_value_exception_as_ok(
                test_name, METHOD, MUST_BE, ex, f"when move axis is set above highest rate ({move_rate})",
                f"Exception correctly generated when move axis is set above highest rate ({move_rate})")
        if not can_set_zero:
            self.log_info(test_name, "Remaining MoveAxis tests skipped because unable to set a movement rate of zero")
            return
        for magnitude in (rate_min, rate_max):
            try:
                for rate in (magnitude, -magnitude):
                    self.time_method(f"{test_name} {AXIS_NAMES[axis]} {rate}", lambda r=rate: t.MoveAxis(axis, r),
                                     STANDARD)
                    if self.validate_slewing(test_name, magnitude != 0.0):
                        self.log_ok(test_name, f"Can successfully set a movement rate of {rate}")
                    else:
                        self.log_issue(test_name, f"Slewing was not false after setting a rate of {rate}")
                    self.wait_for(MOVE_AXIS_TIME)
                    t.MoveAxis(axis, 0.0)
                    if self.wait_for_slewing_to_become_false(test_name):
                        self.log_ok(test_name, "Successfully stopped movement.")
                    else:
                        self.log_issue(test_name, "Slewing was not false after setting a rate of 0.0")
            except Exception as ex:
                self.handle_exception(test_name, METHOD, MUST_BE, ex, f"when setting rate: {magnitude}")
        try:
            if self.can_set_tracking:
                tracking_start = t.Tracking
                t.MoveAxis(axis, rate_max)
                self.wait_for(MOVE_AXIS_TIME)
                t.MoveAxis(axis, 0.0)
                self.wait_for_slewing_to_become_false(test_name)
                tracking_end = t.Tracking
                if tracking_start == tracking_end:
                    t.Tracking = not tracking_start
                    t.MoveAxis(axis, -rate_max)
                    self.wait_for(MOVE_AXIS_TIME)
                    t.MoveAxis(axis, 0.0)
                    self.wait_for_slewing_to_become_false(test_name)
                    if t.Tracking == (not tracking_start):
                        self.log_ok(test_name, "Tracking state correctly retained for both tracking states")
                    else:
                        self.log_issue(test_name, f"Tracking state correctly retained when tracking is "
                                                  f"{tracking_start}, but not when tracking is {not tracking_start}")
                else:
                    t.MoveAxis(axis, -rate_max)
                    self.wait_for(MOVE_AXIS_TIME)
                    t.MoveAxis(axis, 0.0)
                    self.wait_for_slewing_to_become_false(test_name)
                    t.Tracking = tracking_start
                    self.log_issue(test_name, "Tracking state not correctly restored after MoveAxis when "
                                              "CanSetTracking is true")
            else:
                tracking_start = t.Tracking
                t.MoveAxis(axis, rate_max)
                self.wait_for(MOVE_AXIS_TIME)
                t.MoveAxis(axis, 0.0)
                self.wait_for_slewing_to_become_false(test_name)
                tracking_end = t.Tracking
                t.MoveAxis(axis, -rate_max)
                self.wait_for(MOVE_AXIS_TIME)
                t.MoveAxis(axis, 0.0)
                self.wait_for_slewing_to_become_false(test_name)
                if tracking_start == tracking_end:
                    self.log_ok(test_name, "Tracking state correctly restored after MoveAxis when CanSetTracking is "
                                           "false")
                else:
                    t.Tracking = tracking_start
                    self.log_issue(test_name, "Tracking state not correctly restored after MoveAxis when "
                                              "CanSetTracking is false")
        except Exception as ex:
            self.handle_exception(test_name, METHOD, MUST_BE, ex, "")

    # -- PulseGuide (§7.7) --------------------------------------------------------------------------------------
    def pulse_guide_test(self, test_name: str) -> None:
        """§7.7.1: asynchronous 2 s pulses East and North, then a concurrent East+North pair."""
        t = self.t
        if self.can_set_tracking:
            t.Tracking = True
        if t.IsPulseGuiding:
            self.log_issue(test_name, "IsPulseGuiding is True when not pulse guiding - PulseGuide test omitted")
            return
        for direction in (EAST, NORTH):
            name = DIRECTION_NAMES[direction]
            start = Stopwatch(self.clock)
            self.time_method(f"{test_name} {name} {PULSEGUIDE_MOVEMENT_TIME}s",
                             lambda d=direction: t.PulseGuide(d, PULSEGUIDE_MOVEMENT_TIME * 1000), STANDARD)
            call_time = start.elapsed
            limit = STANDARD_TARGET_RESPONSE_TIME if self.is_platform7 else PULSEGUIDE_MOVEMENT_TIME * 0.75
            if call_time < limit:
                if t.IsPulseGuiding:
                    self.wait_while(f"Pulse guiding {name}wards", lambda: t.IsPulseGuiding, SLEEP_TIME_MS,
                                    PULSEGUIDE_TIMEOUT_TIME)
                    if not t.IsPulseGuiding:
                        self.log_ok(test_name, f"Asynchronous pulse guide found OK ({name})")
                    else:
                        self.log_issue(test_name, f"Asynchronous pulse guide expected but IsPulseGuiding is still TRUE "
                                                  f"{PULSEGUIDE_TIMEOUT_TIME} seconds beyond expected time")
                else:
                    self.log_issue(test_name, "Asynchronous pulse guide expected but IsPulseGuiding has returned FALSE")
            elif self.is_platform7:
                self.log_issue(test_name, f"Synchronous pulse guide found. The guide took {call_time:.2f} seconds to "
                                          f"complete, the expected maximum time is {STANDARD_TARGET_RESPONSE_TIME} "
                                          "seconds.")
            elif not t.IsPulseGuiding:
                self.log_ok(test_name, "Synchronous pulse guide found OK")
            else:
                self.log_issue(test_name, "Synchronous pulse guide expected but IsPulseGuiding has returned TRUE")
        # Concurrent guiding on both axes
        t.PulseGuide(EAST, PULSEGUIDE_MOVEMENT_TIME * 1000)
        try:
            t.PulseGuide(NORTH, PULSEGUIDE_MOVEMENT_TIME * 1000)
            self.log_ok(test_name, "Concurrent East and North pulse guides accepted: the mount can guide both axes at "
                                   "once")
        except Exception as ex:
            if isinstance(ex, InvalidOperationException):
                self.log_ok(test_name, "The mount is not capable of concurrent guiding and rejected the second pulse "
                                       "with an InvalidOperationException as expected")
            else:
                self.handle_exception(test_name, METHOD, MUST_BE, ex, "Second concurrent PulseGuide")
        self.wait_while("Concurrent pulse guiding", lambda: t.IsPulseGuiding, SLEEP_TIME_MS, PULSEGUIDE_TIMEOUT_TIME)
        if not t.IsPulseGuiding:
            self.log_ok(test_name, "IsPulseGuiding became false after the concurrent pulses")
        else:
            self.log_issue(test_name, "IsPulseGuiding is still TRUE after the concurrent pulses")

    def test_pulse_guide(self, ha: float) -> None:
        """§7.7.2: slew to ``ha``, then 5 s pulses N, S, E, W each moving by rate*5 s within 1"."""
        self.slew_to_ha(ha)
        for direction in (NORTH, SOUTH, EAST, WEST):
            self.test_pulse_guide_direction(ha, direction)

    def test_pulse_guide_direction(self, ha: float, direction: int) -> None:
        t = self.t
        duration = 5
        expected_dec = self.guide_rate_declination * duration
        expected_ra = self.guide_rate_right_ascension * duration / (15.0 * SIDEREAL_SECONDS_TO_SI_SECONDS)
        if direction == SOUTH:
            expected_dec = -expected_dec
        if direction == WEST:
            expected_ra = -expected_ra
        tol_dec = self.settings.telescope_pulse_guide_tolerance / 3600.0
        tol_ra = tol_dec / (15.0 * SIDEREAL_SECONDS_TO_SI_SECONDS)
        name = DIRECTION_NAMES[direction]
        log = f"PulseGuide {ha:+.1f} {name}"
        ra0, dec0 = t.RightAscension, t.Declination
        self.time_method(f"PulseGuide {name} {duration}s", lambda: t.PulseGuide(direction, duration * 1000), STANDARD)
        self.wait_while(f"Pulse guiding {name} at HA {ha:+.1f}", lambda: t.IsPulseGuiding, SLEEP_TIME_MS,
                        duration + 5)
        ra1, dec1 = t.RightAscension, t.Declination
        ra_change, dec_change = ra1 - ra0, dec1 - dec0
        ra_diff, dec_diff = abs(ra_change - expected_ra), abs(dec_change - expected_dec)
        detail_dec = (f"Declination change (DMS): {to_dms(dec_change)}, Expected: {to_dms(expected_dec)}, Difference: "
                      f"{to_dms(dec_diff)}, Test tolerance: {to_dms(tol_dec)}.")
        detail_ra = (f"RA change (HMS): {to_hms(ra_change)}, Expected: {to_hms(expected_ra)}, Difference: "
                     f"{to_hms(ra_diff)}, Test tolerance: {to_hms(tol_ra)}.")
        if direction in (NORTH, SOUTH):
            sign = 1.0 if direction == NORTH else -1.0
            if dec_change * sign > 0.0 and dec_diff <= tol_dec and abs(ra_change) <= tol_ra:
                self.log_ok(log, f"Moved {name.lower()} with no east-west movement  - {detail_dec}")
                return
            if dec_change * sign < 0.0:
                wrong = "south" if sign > 0 else "north"
                self.log_issue(log, f"Moved {wrong} instead of {name.lower()} - {detail_dec}")
            elif dec_change == 0.0:
                self.log_issue(log, "The declination axis did not move.")
            elif dec_diff <= tol_dec:
                self.log_ok(log, f"Moved {name.lower()} - {detail_dec}")
            else:
                self.log_issue(log, f"Moved {name.lower()} but outside test tolerance - {detail_dec}")
            if abs(ra_change) <= tol_ra:
                self.log_ok(log, f"No significant east-west movement as expected. RA change (HMS): "
                                 f"{to_hms(ra_change)}, Test tolerance: {to_hms(tol_ra)}.")
            else:
                self.log_issue(log, f"East-West movement was outside test tolerance: RA change (HMS): "
                                    f"{to_hms(ra_change)}, Expected: {to_hms(0.0)}, Tolerance: {to_hms(tol_ra)}.")
        else:
            sign = 1.0 if direction == EAST else -1.0
            if ra_change * sign > 0.0 and ra_diff <= tol_ra and abs(dec_change) <= tol_dec:
                self.log_ok(log, f"Moved {name.lower()} with no north-south movement - {detail_ra}")
                return
            if ra_change * sign < 0.0:
                wrong = "west" if sign > 0 else "east"
                self.log_issue(log, f"Moved {wrong} instead of {name.lower()} - {detail_ra}")
            elif ra_change == 0.0:
                self.log_issue(log, "The RA axis did not move.")
            elif ra_diff <= tol_ra:
                self.log_ok(log, f"Moved {name.lower()} - {detail_ra}")
            else:
                self.log_issue(log, f"Moved {name.lower()} but outside test tolerance - {detail_ra}")
            if abs(dec_change) <= tol_dec:
                self.log_ok(log, f"No significant north-south movement as expected. Declination change (DMS): "
                                 f"{to_dms(dec_change)}, Test tolerance: {to_dms(tol_dec)}.")
            else:
                self.log_issue(log, f"North-south movement was outside test tolerance: Declination change (DMS): "
                                    f"{to_dms(dec_change)}, Expected: {to_dms(0.0)}, Tolerance: {to_dms(tol_dec)}.")

    # -- SideOfPier write (§7.17.1) ----------------------------------------------------------------------------
    def side_of_pier_write_test(self, test_name: str) -> None:
        t = self.t
        if self.can_set_pierside:
            self.slew_scope(self.ra_from_hour_angle(-3.0), 0.0, "far start point")
            self.slew_scope(self.ra_from_hour_angle(-0.03), 0.0, "near start point")
            self.log_info(test_name, "This test will now wait for 7 minutes while the mount tracks through the "
                                     "Meridian")
            self.wait_for(SIDEOFPIER_MERIDIAN_TRACKING_PERIOD, 1000)
            side = t.SideOfPier
            if side in (PIER_EAST, PIER_WEST):
                new_side = PIER_WEST if side == PIER_EAST else PIER_EAST
                try:
                    self.time_method(f"{test_name} {PIER_NAMES[new_side]}", lambda: setattr(t, "SideOfPier", new_side),
                                     STANDARD)
                    self.wait_for_slew(test_name, "Moving to the other pointing state asynchronously")
                    side = t.SideOfPier
                    if side == new_side:
                        self.log_ok(test_name, f"Successfully flipped {PIER_NAMES[1 - new_side]} to "
                                               f"{PIER_NAMES[new_side]}")
                    else:
                        self.log_issue(test_name, f"Failed to set SideOfPier to {PIER_NAMES[new_side]}, got: "
                                                  f"{PIER_NAMES.get(side, side)}")
                except Exception as ex:
                    self.handle_exception(f"SideOfPier Write {PIER_NAMES[new_side]}", METHOD, MUST_BE, ex,
                                          "CanSetPierSide is True")
            else:
                self.log_issue(test_name, f"Unknown PierSide: {side}")
        else:
            try:
                t.SideOfPier = PIER_EAST
                self.wait_for_slew(test_name, "Moving to the pierWest pointing state asynchronously")
                self.log_issue(test_name, "CanSetPierSide is false but no exception was generated when set was "
                                          "attempted")
            except Exception as ex:
                self.handle_exception(test_name, METHOD, MUST_NOT_BE, ex, "CanSetPierSide is False")
            finally:
                self.wait_for_slew(test_name, "Moving to the pierWest pointing state asynchronously")
        t.Tracking = False

    # -- Slews (§7.8, §7.9, §7.12, §7.14; TelescopeSlewTest L4511-L4863) ----------------------------------------
    def slew_test(self, test_type: str, test_name: str, can: bool, can_name: str) -> None:
        t = self.t
        if self.can_set_tracking:
            t.Tracking = True
        try:
            if test_type in ("SlewToCoordinates", "SlewToCoordinatesAsync", "SlewToTarget", "SlewToTargetAsync"):
                if self.can_set_tracking and not t.Tracking:
                    t.Tracking = True
                offset = {"SlewToCoordinates": 1.0, "SlewToCoordinatesAsync": 2.0, "SlewToTarget": 3.0,
                          "SlewToTargetAsync": 4.0}[test_type]
                self.target_right_ascension = self.ra_from_sidereal_time(-offset)
                self.target_declination = offset
                ra, dec = self.target_right_ascension, self.target_declination
                if test_type == "SlewToCoordinates":
                    self.time_method("SlewToCoordinates", lambda: t.SlewToCoordinates(ra, dec), EXTENDED)
                elif test_type == "SlewToCoordinatesAsync":
                    self.time_method("SlewToCoordinatesAsync", lambda: t.SlewToCoordinatesAsync(ra, dec), STANDARD)
                    self.check_slewing_after_async(test_name, "SlewToCoordinatesAsync", can)
                    self.wait_for_slew(test_name, "Slewing to coordinates asynchronously")
                else:
                    for member, value in (("TargetRightAscension", ra), ("TargetDeclination", dec)):
                        try:
                            setattr(t, member, value)
                        except Exception as ex:
                            if can:
                                self.handle_exception(test_name, PROPERTY, MUST_BE, ex,
                                                      f"{can_name} is True but can't set {member}")
                    if test_type == "SlewToTarget":
                        self.time_method("SlewToTarget", t.SlewToTarget, EXTENDED)
                    else:
                        self.time_method("SlewToTargetAsync", t.SlewToTargetAsync, STANDARD)
                        self.check_slewing_after_async(test_name, "SlewToTargetAsync", can)
                        self.wait_for_slew(test_name, "Slewing to target asynchronously")
            else:  # Alt/Az slews
                if self.can_set_tracking and t.Tracking:
                    t.Tracking = False
                if test_type == "SlewToAltAz":
                    self.target_altitude, self.target_azimuth = 50.0, 150.0
                    alt, az = self.target_altitude, self.target_azimuth
                    self.time_method("SlewToAltAz", lambda: t.SlewToAltAz(az, alt), EXTENDED)
                else:
                    self.target_altitude, self.target_azimuth = 55.0, 155.0
                    alt, az = self.target_altitude, self.target_azimuth
                    self.time_method("SlewToAltAzAsync", lambda: t.SlewToAltAzAsync(az, alt), STANDARD)
                    self.check_slewing_after_async(test_name, "SlewToAltAzAsync", can)
                    self.wait_for_slew(test_name, "Slewing to Alt/Az asynchronously")
            if not can:
                self.log_issue(test_name, f"{can_name} is false but no exception was generated on use")
                return
            if test_type.startswith("SlewToAltAz"):
                actual_az, actual_alt = t.Azimuth, t.Altitude
                az_diff = abs(actual_az - self.target_azimuth)
                if az_diff > 350.0:
                    az_diff = 360.0 - az_diff
                # QUIRK (§E): Azimuth in degrees against the arcsecond slew tolerance (10), Altitude against 1 degree.
                if az_diff <= self.settings.telescope_slew_tolerance:
                    self.log_ok(test_name, f"Slewed to target Azimuth OK within tolerance: "
                                           f"{self.settings.telescope_slew_tolerance} arc seconds. Actual Azimuth: "
                                           f"{to_dms(actual_az)}, Target Azimuth: {to_dms(self.target_azimuth)}")
                else:
                    self.log_issue(test_name, f"Slewed {az_diff:.1f} arc seconds away from Azimuth target: "
                                              f"{to_dms(self.target_azimuth)} Actual Azimuth: {to_dms(actual_az)}.")
                alt_diff = abs(actual_alt - self.target_altitude)
                if alt_diff <= self.settings.dome_slew_tolerance:
                    self.log_ok(test_name, f"Slewed to target Altitude OK within tolerance. Actual Altitude: "
                                           f"{to_dms(actual_alt)}, Target Altitude: {to_dms(self.target_altitude)}")
                else:
                    self.log_issue(test_name, f"Slewed {alt_diff:.1f} degree(s) away from Altitude target: "
                                              f"{to_dms(self.target_altitude)} Actual Altitude: {to_dms(actual_alt)}.")
                return
            self.check_scope_position(test_name, "Slewed", self.target_right_ascension, self.target_declination)
            self.check_target_read_back(test_name, self.target_right_ascension, self.target_declination,
                                        self.settings.telescope_slew_tolerance)
        except Exception as ex:
            if can:
                self.handle_exception(test_name, METHOD, MUST_BE, ex, f"{can_name} is True")
            else:
                self.handle_exception(test_name, METHOD, MUST_NOT_BE, ex, f"{can_name} is False")

    def check_slewing_after_async(self, test_name: str, member: str, can: bool) -> None:
        """§7.9/§7.12/§7.14: Slewing must already be true when an asynchronous slew returns."""
        if not can:
            return
        if self.t.Slewing:
            self.log_ok(test_name, f"Slewing is TRUE immediately after {member} returned")
        else:
            self.log_issue(test_name, f"Slewing is FALSE after {member} returned")

    def check_target_read_back(self, test_name: str, ra: float, dec: float, tolerance: float) -> None:
        """After a slew or sync, TargetRightAscension/TargetDeclination must equal the coordinates used."""
        t = self.t
        for member, expected in (("TargetRightAscension", ra), ("TargetDeclination", dec)):
            try:
                actual = getattr(t, member)
                if member == "TargetRightAscension":
                    good = ra_difference_arcsec(actual, expected) <= tolerance
                    shown, fmt = (to_hms(actual), to_hms(expected)), "RA"
                else:
                    good = round_away(abs(actual - expected) * 3600.0, 1) <= tolerance
                    shown, fmt = (to_dms(actual), to_dms(expected)), "Declination"
                if good:
                    self.log_ok(test_name, f"The {member} property: {shown[0]} matches the expected {fmt} "
                                           f"{shown[1]} within tolerance ±{tolerance} arc seconds.")
                else:
                    self.log_issue(test_name, f"The {member} property: {shown[0]} does not match the expected {fmt} "
                                              f"{shown[1]} within tolerance ±{tolerance} arc seconds.")
            except InvalidOperationException:
                self.log_issue(test_name, f"The driver did not set the {member} property as required by the Telescope "
                                          "specification, An InvalidOperationException was thrown instead.")
            except Exception as ex:
                if self.is_not_set_exception(ex):
                    self.log_issue(test_name, f"The driver did not set the {member} property as required by the "
                                              "Telescope specification, A ValueNotSet DriverException was thrown "
                                              "instead.")
                else:
                    self.handle_exception(test_name, PROPERTY, MANDATORY, ex, "")

    def check_scope_position(self, test_name: str, function_name: str, expected_ra: float, expected_dec: float) -> None:
        """TT CheckScopePosition (L7621-L7655): RA and Dec within 10 arcseconds."""
        t = self.t
        actual_ra = t.RightAscension
        actual_dec = t.Declination
        tolerance = self.settings.telescope_slew_tolerance
        difference = ra_difference_arcsec(actual_ra, expected_ra)
        if difference <= tolerance:
            self.log_ok(test_name, f"{function_name} OK within tolerance: ±{tolerance} arc seconds. Actual RA: "
                                   f"{to_hms(actual_ra)}, Target RA: {to_hms(expected_ra)}")
        else:
            self.log_issue(test_name, f"{function_name} {difference:.1f} arc seconds away from RA target: "
                                      f"{to_hms(expected_ra)} Actual RA: {to_hms(actual_ra)}. Tolerance: ±{tolerance} "
                                      "arc seconds")
        difference = round_away(abs(actual_dec - expected_dec) * 3600.0, 1)
        if difference <= tolerance:
            self.log_ok(test_name, f"{function_name} OK within tolerance: ±{tolerance} arc seconds. Actual DEC: "
                                   f"{to_dms(actual_dec)}, Target DEC: {to_dms(expected_dec)}")
        else:
            self.log_issue(test_name, f"{function_name} {difference:.1f} arc seconds from the expected DEC: "
                                      f"{to_dms(expected_dec)}. Actual DEC: {to_dms(actual_dec)}. Tolerance: "
                                      f"±{tolerance} degrees.")

    # -- bad coordinates (§8.6, TelescopeBadCoordinateTest L4873-L5302) -----------------------------------------
    def bad_coordinate_test(self, name: str, test: str, bad1: float, bad2: float) -> None:
        t = self.t
        if test in ("SlewToCoordinates", "SlewToCoordinatesAsync", "SyncToCoordinates"):
            if self.can_set_tracking and not t.Tracking:
                t.Tracking = True
            verb = "sync" if test.startswith("Sync") else "slew"
            call = {"SlewToCoordinates": t.SlewToCoordinates, "SlewToCoordinatesAsync": t.SlewToCoordinatesAsync,
                    "SyncToCoordinates": t.SyncToCoordinates}[test]
            for ra, dec, what, shown in ((bad1, 0.0, "RA", to_hms(bad1)),
                                         (self.ra_from_sidereal_time(-3.0 if verb == "sync" else -2.0), bad2, "Dec",
                                          to_dms(bad2))):
                try:
                    call(ra, dec)
                    if verb == "slew":
                        with contextlib.suppress(Exception):
                            t.AbortSlew()
                    self.log_issue(name, f"Failed to reject bad {what} coordinate: {shown}")
                except Exception as ex:
                    self.handle_invalid_value_exception_as_ok(name, METHOD, MANDATORY, ex,
                                                              f"{verb}ing to bad {what} coordinate",
                                                              f"Correctly rejected bad {what} coordinate: {shown}")
        elif test in ("SlewToTarget", "SlewToTargetAsync", "SyncToTarget"):
            if self.can_set_tracking and not t.Tracking:
                t.Tracking = True
            verb = "sync" if test.startswith("Sync") else "slew"
            call = {"SlewToTarget": t.SlewToTarget, "SlewToTargetAsync": t.SlewToTargetAsync,
                    "SyncToTarget": t.SyncToTarget}[test]
            offset = -3.0 if verb == "sync" else -2.0
            cases = (("TargetRightAscension", bad1, "TargetDeclination", None, "RA", to_hms(bad1), "TargetRA"),
                     ("TargetDeclination", bad2, "TargetRightAscension", offset, "Dec", to_dms(bad2),
                      "TargetDeclination"))
            for bad_member, bad_value, good_member, ra_offset, what, shown, setter_name in cases:
                try:
                    # The good RA is taken from SiderealTime at the start of its case, as ConformU does.
                    good_value = 0.0 if ra_offset is None else self.ra_from_sidereal_time(ra_offset)
                    setattr(t, bad_member, bad_value)
                    with contextlib.suppress(Exception):
                        setattr(t, good_member, good_value)
                    try:
                        call()
                        if verb == "slew":
                            with contextlib.suppress(Exception):
                                t.AbortSlew()
                        self.log_issue(name, f"Failed to reject bad {what} coordinate: {shown}")
                    except Exception as ex:
                        self.handle_invalid_value_exception_as_ok(name, METHOD, MANDATORY, ex,
                                                                  f"{verb}ing to bad {what} coordinate",
                                                                  f"Correctly rejected bad {what} coordinate: {shown}")
                except Exception as ex:
                    self.handle_invalid_value_exception_as_ok(name, PROPERTY, MUST_BE, ex,
                                                              f"Exception setting bad {what} coordinate",
                                                              f"Telescope.{setter_name} correctly rejected bad {what} "
                                                              f"coordinate: {shown}")
        else:  # Alt/Az slews and syncs
            if self.can_set_tracking and t.Tracking:
                t.Tracking = False
            verb = "sync" if test.startswith("Sync") else "slew"
            call = {"SlewToAltAz": t.SlewToAltAz, "SlewToAltAzAsync": t.SlewToAltAzAsync,
                    "SyncToAltAz": t.SyncToAltAz}[test]
            for alt, az, what, shown in ((bad1, 45.0, "Altitude", to_dms(bad1)), (45.0, bad2, "Azimuth", to_dms(bad2))):
                try:
                    call(az, alt)
                    if verb == "slew":
                        with contextlib.suppress(Exception):
                            t.AbortSlew()
                    self.log_issue(name, f"Failed to reject bad {what} coordinate: {shown}")
                except Exception as ex:
                    self.handle_invalid_value_exception_as_ok(name, METHOD, MANDATORY, ex,
                                                              f"{verb}ing to bad {what} coordinate",
                                                              f"Correctly rejected bad {what} coordinate: {shown}")

    # -- Target writes (§7.11) -----------------------------------------------------------------------------------
    def target_write_tests(self) -> None:
        t = self.t
        for bad, what in ((-1.0, "< 0 hours"), (25.0, "> 24 hours")):
            try:
                t.TargetRightAscension = bad
                self.log_issue("TargetRightAscension Write", f"No error generated on set TargetRightAscension {what}")
            except Exception as ex:
                self.handle_invalid_value_exception_as_ok("TargetRightAscension Write", PROPERTY, OPTIONAL, ex, "",
                                                          "Invalid Value exception generated as expected on set "
                                                          f"TargetRightAscension {what}")
        try:
            self.target_right_ascension = self.ra_from_sidereal_time(-4.0)
            t.TargetRightAscension = self.target_right_ascension
            try:
                difference = abs(t.TargetRightAscension - self.target_right_ascension)
                self.grade_target_write("TargetRightAscension Write", difference,
                                        f"Legal value {to_hms(self.target_right_ascension)} HH:MM:SS written "
                                        "successfully", "Target RightAscension", "second", to_hms)
            except Exception as ex:
                self.handle_exception("TargetRightAscension Write", PROPERTY, MUST_BE, ex,
                                      "Unable to read TargetRightAscension before writing to it.")
        except Exception as ex:
            self.handle_exception("TargetRightAscension Write", PROPERTY, OPTIONAL, ex, "")
        for bad, what in ((-91.0, "< -90 degrees"), (91.0, "> 90 degrees")):
            try:
                t.TargetDeclination = bad
                self.log_issue("TargetDeclination Write", f"No error generated on set TargetDeclination {what}")
            except Exception as ex:
                self.handle_invalid_value_exception_as_ok("TargetDeclination Write", PROPERTY, OPTIONAL, ex, "",
                                                          "Invalid Value exception generated as expected on set "
                                                          "TargetDeclination < -90 degrees")
        try:
            self.target_declination = 1.0
            t.TargetDeclination = self.target_declination
            try:
                difference = abs(t.TargetDeclination - self.target_declination)
                self.grade_target_write("TargetDeclination Write", difference,
                                        f"Legal value {to_dms(self.target_declination)} DD:MM:SS written "
                                        "successfully", "Target Declination", "second", to_dms)
            except Exception as ex:
                self.handle_exception("TargetDeclination Write", PROPERTY, MUST_BE, ex,
                                      "Unable to read TargetDeclination before writing to it.")
        except Exception as ex:
            self.handle_exception("TargetDeclination Write", PROPERTY, OPTIONAL, ex, "")

    def grade_target_write(self, test: str, difference: float, exact: str, what: str, unit: str,
                           fmt: Callable[[float], str]) -> None:
        if difference == 0.0:
            self.log_ok(test, exact)
        elif difference <= 1.0 / 3600.0:
            self.log_ok(test, f"{what} is within 1 {unit} of the value set")
        elif difference <= 2.0 / 3600.0:
            self.log_ok(test, f"{what} is within 2 {unit}s of the value set")
        elif difference <= 5.0 / 3600.0:
            self.log_ok(test, f"{what} is within 5 {unit}s of the value set")
        else:
            self.log_info(test, f"{what} differs from the value set by {fmt(difference)}")

    # -- Syncs (§7.10, §7.15, §7.16; TelescopeSyncTest L4151-L4509) ---------------------------------------------
    def sync_test(self, test_type: str, test_name: str, can: bool, can_name: str) -> None:
        t = self.t
        sync_ra, sync_dec = t.RightAscension, t.Declination
        if not can:
            try:
                if test_type == "SyncToCoordinates":
                    if self.can_set_tracking and not t.Tracking:
                        t.Tracking = True
                    t.SyncToCoordinates(sync_ra, sync_dec)
                    self.log_issue(test_name, "CanSyncToCoordinates is False but call to SyncToCoordinates did not "
                                              "throw an exception.")
                elif test_type == "SyncToTarget":
                    if self.can_set_tracking and not t.Tracking:
                        t.Tracking = True
                    for member, value in (("TargetRightAscension", sync_ra), ("TargetDeclination", sync_dec)):
                        with contextlib.suppress(Exception):
                            setattr(t, member, value)
                    t.SyncToTarget()
                    self.log_issue(test_name, "CanSyncToTarget is False but call to SyncToTarget did not throw an "
                                              "exception.")
                else:
                    alt = t.Altitude if self.can_read_altitude else 0.0
                    az = t.Azimuth if self.can_read_azimuth else 0.0
                    if self.can_set_tracking and t.Tracking:
                        t.Tracking = False
                    t.SyncToAltAz(az, alt)
                    self.log_issue(test_name, "CanSyncToAltAz is False but call to SyncToAltAz did not throw an "
                                              "exception.")
            except Exception as ex:
                self.handle_exception(test_name, METHOD, MUST_NOT_BE, ex, f"{can_name} is False")
            return
        try:
            if test_type in ("SyncToCoordinates", "SyncToTarget"):
                start_ra = self.ra_from_hour_angle(3.0)
                if self.site_latitude > 0.0:
                    start_dec = 90.0 - (180.0 - self.site_latitude) * 0.5
                else:
                    start_dec = -90.0 + (180.0 + self.site_latitude) * 0.5
                self.slew_scope(start_ra, start_dec, "start position")
                self.check_scope_position(test_name, "Slewed to start position", start_ra, start_dec)
                sync_ra = start_ra - SYNC_SIMULATED_ERROR / (15.0 * 60.0)
                if sync_ra < 0.0:
                    sync_ra += 24.0
                sync_dec = start_dec - SYNC_SIMULATED_ERROR / 60.0
                self.sync_scope(test_name, can_name, test_type, sync_ra, sync_dec)
                self.check_scope_position(test_name, "Synced to sync position", sync_ra, sync_dec)
                if test_type == "SyncToCoordinates":
                    self.check_target_read_back(test_name, sync_ra, sync_dec, SLEW_SYNC_OK_TOLERANCE)
                self.slew_scope(start_ra, start_dec, "original position in post-sync coordinates")
                self.check_scope_position(test_name, "Slewed back to start position", start_ra, start_dec)
                sync_ra = start_ra + SYNC_SIMULATED_ERROR / (15.0 * 60.0)
                if sync_ra >= 24.0:
                    sync_ra -= 24.0
                sync_dec = start_dec + SYNC_SIMULATED_ERROR / 60.0
                self.sync_scope(test_name, can_name, test_type, sync_ra, sync_dec)
                self.check_scope_position(test_name, "Synced to reversed sync position", sync_ra, sync_dec)
                self.slew_scope(start_ra, start_dec, "original position in pre-sync coordinates")
                self.check_scope_position(test_name, "Slewed back to start position", start_ra, start_dec)
            else:
                current_alt = t.Altitude if self.can_read_altitude else 0.0
                current_az = t.Azimuth if self.can_read_azimuth else 0.0
                sync_alt, sync_az = current_alt - 1.0, current_az + 1.0
                if sync_alt < 0.0:
                    sync_alt = 1.0
                if sync_az > 359.0:
                    sync_az = 358.0
                if self.can_set_tracking and t.Tracking:
                    t.Tracking = False
                t.SyncToAltAz(sync_az, sync_alt)
                if self.can_read_altitude and self.can_read_azimuth:
                    new_alt, new_az = t.Altitude, t.Azimuth
                    for what, wanted, got in (("Altitude", sync_alt, new_alt), ("Azimuth", sync_az, new_az)):
                        difference = abs(wanted - got)
                        if difference <= 1.0 / 3600:
                            self.log_ok(test_name, f"Synced {what} OK")
                        elif difference <= 2.0 / 3600:
                            self.log_ok(test_name, f"Synced within 2 seconds of {what}")
                        else:
                            self.log_info(test_name, f"Synced to within {to_dms(difference)} DD:MM:SS of expected "
                                                     f"{what}: {to_dms(wanted)}")
                else:
                    self.log_info(test_name, "Can't test SyncToAltAz because Altitude or Azimuth values are not "
                                             "implemented")
        except Exception as ex:
            self.handle_exception(test_name, METHOD, MUST_BE, ex, f"{can_name} is True")

    def sync_scope(self, test_name: str, can_name: str, test_type: str, ra: float, dec: float) -> None:
        t = self.t
        if self.can_set_tracking and not t.Tracking:
            t.Tracking = True
        if test_type == "SyncToCoordinates":
            self.time_method(test_name, lambda: t.SyncToCoordinates(ra, dec), STANDARD)
            return
        for member, value in (("TargetRightAscension", ra), ("TargetDeclination", dec)):
            try:
                setattr(t, member, value)
            except Exception as ex:
                self.handle_exception(test_name, PROPERTY, MUST_BE, ex, f"{can_name} is True but can't set {member}")
        self.time_method(test_name, t.SyncToTarget, STANDARD)

    # -- SideOfPier model tests (§7.17) --------------------------------------------------------------------------
    def side_of_pier_model_tests(self) -> None:
        t = self.t
        if self.get_interface_version() <= 1:
            return
        if not self.can_read_sop("SideOfPier Model Tests"):
            self.log_info("SideOfPier Model Tests", "Tests skipped because this driver does Not support SideOfPier "
                                                    "Read")
            return
        if t.AlignmentMode != GERMAN_POLAR:
            self.log_info("SideOfPier Model Tests", "Test skipped because this Is Not a German equatorial mount")
            return
        if -SIDE_OF_PIER_INVALID_LATITUDE <= self.site_latitude <= SIDE_OF_PIER_INVALID_LATITUDE:
            self.log_info("SideOfPier Model Tests", f"Tests skipped because the site latitude is reported as "
                                                    f"{to_dms(self.site_latitude)}")
            return
        if self.settings.test_side_of_pier_write:
            self.optional_method_test("SideOfPierWrite", "SideOfPier Write", self.can_set_pierside)
        self.side_of_pier_tests()

    def side_of_pier_tests(self) -> None:
        """TT SideOfPierTests (L7410-L7527)."""
        start_ra = self.ra_from_hour_angle(-3.0)
        start_dec = self.get_test_declination_less_than_65("SideofPier", start_ra)
        dec3 = self.get_test_declination_halfway_to_horizon("SideOfPierTests", start_ra)
        dec9 = self.get_test_declination_halfway_to_horizon("SideOfPierTests", self.ra_from_hour_angle(-9.0))
        self.log_debug("SideofPier", f"Declination for HA +-3: {to_dms(dec3)}, for HA +-9: {to_dms(dec9)}")
        minus3 = self.sop_pier_test(self.ra_from_hour_angle(-3.0), dec3, start_ra, start_dec, "hour angle -3.0")
        minus9 = self.sop_pier_test(self.ra_from_hour_angle(-9.0), dec9, start_ra, start_dec, "hour angle -9.0")
        plus3 = self.sop_pier_test(self.ra_from_hour_angle(3.0), dec3, start_ra, start_dec, "hour angle +3.0")
        plus9 = self.sop_pier_test(self.ra_from_hour_angle(9.0), dec9, start_ra, start_dec, "hour angle +9.0")
        self.analyse_pier_model("SideofPier", "SideofPier", minus3.side_of_pier, minus9.side_of_pier,
                                plus3.side_of_pier, plus9.side_of_pier, "is returned when the mount is observing")
        dsop = (minus3.destination_side_of_pier, minus9.destination_side_of_pier, plus3.destination_side_of_pier,
                plus9.destination_side_of_pier)
        if all(v == PIER_UNKNOWN for v in dsop):
            self.log_info("DestinationSideofPier", "Analysis skipped as this method is not implemented")
        else:
            self.analyse_pier_model("DestinationSideofPier", "DestinationSideofPier", *dsop,
                                    "is returned when the mount will observe")
        if self.can_set_tracking:
            self.t.Tracking = False

    def analyse_pier_model(self, test: str, what: str, minus3: int, minus9: int, plus3: int, plus9: int,
                           phrase: str) -> None:
        if minus3 == plus9 and plus3 == minus9:
            self.log_issue(test, f"{what} reports physical pier side rather than pointing state")
        elif minus3 == minus9 and plus3 == plus9:
            self.log_ok(test, "Reports the pointing state of the mount as expected")
        else:
            self.log_info(test, f"Unknown {what} reporting model: HA-3: {minus3} HA-9: {minus9} HA+3: {plus3} "
                                f"HA+9: {plus9}")
        self.log_info(test, f"Reported {what} at HA -9, +9: {PIER_NAMES.get(minus9)} {PIER_NAMES.get(plus9)}")
        self.log_info(test, f"Reported {what} at HA -3, +3: {PIER_NAMES.get(minus3)} {PIER_NAMES.get(plus3)}")
        if minus3 == PIER_WEST:
            self.log_ok(test, f"pierWest {phrase} at an hour angle between -6.0 and 0.0")
        else:
            self.log_issue(test, f"pierEast {phrase} at an hour angle between -6.0 and 0.0")
            self.log_info(test, "ASCOM has adopted a convention that, for German Equatorial mounts, pierWest must be "
                                "returned when observing at hour angles from -6.0 to -0.0 and that pierEast must be "
                                "returned at hour angles from 0.0 to +6.0.")
        if plus3 == PIER_EAST:
            self.log_ok(test, f"pierEast {phrase} at an hour angle between 0.0 and +6.0")
        else:
            self.log_issue(test, f"pierWest {phrase} at an hour angle between 0.0 and +6.0")
            self.log_info(test, "ASCOM has adopted a convention that, for German Equatorial mounts, pierWest must be "
                                "returned when observing at hour angles from -6.0 to -0.0 and that pierEast must be "
                                "returned at hour angles from 0.0 to +6.0.")

    def sop_pier_test(self, test_ra: float, test_dec: float, start_ra: float, start_dec: float,
                      message: str) -> SideOfPierResults:
        """TT SopPierTest (L7529-L7590)."""
        t = self.t
        results = SideOfPierResults()
        try:
            self.slew_scope(start_ra, start_dec, "start position")
            current = t.SideOfPier
            self.log_debug("SOPPierTest", f"{message}: pointing state at the start position {PIER_NAMES.get(current)}")
            try:
                results.destination_side_of_pier = self.time_func(
                    "DestinatitonSideOfPier", lambda: t.DestinationSideOfPier(test_ra, test_dec), FAST)
            except NotImplementedException:
                results.destination_side_of_pier = PIER_UNKNOWN
            except Exception as ex:
                self.log_issue("SOPPierTest", f"DestinationSideOfPier Exception: {ex!r}")
            self.slew_scope(test_ra, test_dec, f"test position {message}")
            results.side_of_pier = t.SideOfPier
            self.log_debug("SOPPierTest", f"{message}: SideOfPier {PIER_NAMES.get(results.side_of_pier)}, "
                                          f"DestinationSideOfPier {PIER_NAMES.get(results.destination_side_of_pier)}")
        except Exception as ex:
            self.log_issue("SOPPierTest", f"SideofPierException: {ex!r}")
        return results

    # =================================================================================================
    # PostRunCheck (§7.19)
    # =================================================================================================
    def post_run_check(self) -> None:
        try:
            if self.t.CanSetTracking:
                self.t.Tracking = False
                self.log_ok("Mount Safety", "Tracking stopped to protect your mount.")
            else:
                self.log_info("Mount Safety", "Tracking can't be turned off for this mount, please switch off "
                                              "manually.")
        except Exception as ex:
            self.log_issue("Mount Safety", f"Exception when disabling tracking to protect mount: {ex!r}")

    # =================================================================================================
    # Support code
    # =================================================================================================
    def can_read_sop(self, test_name: str) -> bool:
        if self.can_read_side_of_pier is None:
            try:
                _ = self.t.SideOfPier
                self.can_read_side_of_pier = True
            except Exception:
                self.can_read_side_of_pier = False
        return self.can_read_side_of_pier

    def slew_to_ha(self, target_ha: float) -> None:
        """TT SlewToHa (L8707-L8741)."""
        t = self.t
        if self.can_set_tracking:
            t.Tracking = True
        target_ra = condition_ra(t.SiderealTime - target_ha)
        target_dec = self.get_test_declination_less_than_65("SlewToHa", target_ra)
        t.SlewToCoordinatesAsync(target_ra, target_dec)
        self.wait_for_slew("SlewToHa", f"Slewing to HA {target_ha:+.1f}")
        side = t.SideOfPier if self.get_interface_version() > 2 and self.can_read_sop("SlewToHa") else PIER_UNKNOWN
        self.log_debug("SlewToHa", f"Slewed to RA: {to_hms(t.RightAscension)}, Dec: {to_dms(t.Declination)}, "
                                   f"Pointing state: {PIER_NAMES.get(side)}")

    def slew_scope(self, ra: float, dec: float, message: str) -> None:
        """TT SlewScope (L7728-L7761)."""
        t = self.t
        if self.can_set_tracking:
            t.Tracking = True
        if self.can_slew_async:
            t.SlewToCoordinatesAsync(ra, dec)
            self.wait_for_slew(message, f"Slewing asynchronously to {message}")
        elif self.can_slew:
            t.SlewToCoordinates(ra, dec)
        else:
            self.log_info("SlewScope", "Unable to slew this scope as both CanSlew and CanSlewAsync are false, slew "
                                       "omitted")

    def wait_for_slew(self, test_name: str, action: str) -> None:
        """TT WaitForSlew (L7763-L7773): at least 5 s, then while Slewing (300 s timeout)."""
        sw = Stopwatch(self.clock)
        self.wait_while(action, lambda: self.t.Slewing or sw.elapsed <= WAIT_FOR_SLEW_MINIMUM_DURATION,
                        SLEEP_TIME_MS, self.settings.telescope_maximum_slew_time)

    def ra_from_hour_angle(self, hour_angle: float) -> float:
        if self.can_read_sidereal_time:
            ra = self.t.SiderealTime - hour_angle
            if ra < 0.0:
                ra += 24.0
            elif ra >= 24.0:
                ra -= 24.0
            return ra
        return 0.0 - hour_angle

    def ra_from_sidereal_time(self, offset: float) -> float:
        if self.can_read_sidereal_time:
            lst = self.t.SiderealTime
            if lst < 0.0 or lst >= 24.0:
                lst = 0.0
            ra = lst + offset
            if ra < 0.0:
                ra += 24.0
            elif ra >= 24.0:
                ra -= 24.0
            return ra
        return 0.0 + offset

    def elevation_topocentric(self, ra: float, dec: float, latitude: float, longitude: float) -> float:
        """ASCOM Transform's topocentric elevation (refraction off), from the emulated clock.

        Transform works in SOFA's apparent frame; this uses ConformU's own sidereal-time formula and
        spherical trigonometry. The difference (well under 0.1 degree) is irrelevant against the
        10-degree declination grid these helpers search.
        """
        lst = conform_lst(julian_date(self.clock.utcnow()), longitude)
        ha = math.radians((lst - ra) * 15.0)
        lat, d = math.radians(latitude), math.radians(dec)
        return math.degrees(math.asin(math.sin(lat) * math.sin(d) + math.cos(lat) * math.cos(d) * math.cos(ha)))

    def _site(self) -> tuple[float, float]:
        latitude = self.t.SiteLatitude
        longitude = self.t.SiteLongitude
        _ = self.t.SiteElevation
        return latitude, longitude

    def get_test_declination_less_than_65(self, test_name: str, test_ra: float) -> float:
        """TT GetTestDeclinationLessThan65 (L8159-L8209)."""
        latitude, longitude = self._site()
        best_dec, best_elevation = 0.0, -math.inf
        dec = -85.0
        while dec < 90.0:
            elevation = self.elevation_topocentric(test_ra, dec, latitude, longitude)
            if elevation < 65.0 and elevation > best_elevation:
                best_dec, best_elevation = dec, elevation
            dec += 10.0
        if best_elevation < 0.0:
            raise InvalidOperationException(f"The highest elevation available: {to_dms(best_elevation)} is below the "
                                            "horizon")
        return best_dec

    def get_test_declination_halfway_to_horizon(self, test_name: str, test_ra: float) -> float:
        """TT GetTestDeclinationHalfwayToHorizon (L8217-L8302)."""
        latitude, longitude = self._site()
        lowest = math.inf if latitude >= 0 else -math.inf
        dec = -85.0
        while dec < 90.0:
            if self.elevation_topocentric(test_ra, dec, latitude, longitude) > 0.0:
                lowest = min(lowest, dec) if latitude >= 0.0 else max(lowest, dec)
            dec += 10.0
        if -90.0 < lowest < 90.0:
            return (lowest + 90.0) / 2.0 if latitude >= 0.0 else (lowest - 90.0) / 2.0
        raise InvalidOperationException(f"GetTestDeclinationHalfwayToHorizon was unable to find a declination above "
                                        f"the horizon at RA: {to_hms(test_ra)}.")
