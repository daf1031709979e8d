"""The member tables: what every member answers in each situation, driven from the server's member table.

A member added to ``alpaca_zwo/alpaca/members.py`` without an expectation here fails
``test_member_tables.py::test_member_tables_cover_every_member`` instead of going untested.
"""

from __future__ import annotations

from alpaca_zwo.alpaca.members import DEVICE_MEMBERS
from alpaca_zwo.sky import SIDEREAL_DEG_S
from tests.telescope.harness import (
    ACTION_NOT_IMPLEMENTED,
    INVALID_VALUE,
    MEMBERS,
    NOT_CONNECTED,
    NOT_IMPLEMENTED,
    OK,
    PARKED,
    VALUE_NOT_SET,
    Case,
    case,
)

#: Valid arguments for each member that takes some (targets and positions are harmless placeholders).
VALID_ARGS: dict[str, dict[str, object]] = {
    "Action": {"Action": "nosuchaction", "Parameters": ""},
    "CommandBlind": {"Command": ":GVP#", "Raw": True},
    "CommandBool": {"Command": ":GVP#", "Raw": True},
    "CommandString": {"Command": ":GVP#", "Raw": True},
    "AxisRates": {"Axis": 0},
    "CanMoveAxis": {"Axis": 0},
    "DestinationSideOfPier": {"RightAscension": 1.0, "Declination": 10.0},
    "MoveAxis": {"Axis": 0, "Rate": 0.0},
    "PulseGuide": {"Direction": 2, "Duration": 0},
    "SlewToAltAz": {"Azimuth": 150.0, "Altitude": 50.0},
    "SlewToAltAzAsync": {"Azimuth": 150.0, "Altitude": 50.0},
    "SyncToAltAz": {"Azimuth": 150.0, "Altitude": 50.0},
    "SlewToCoordinates": {"RightAscension": 1.0, "Declination": 10.0},
    "SlewToCoordinatesAsync": {"RightAscension": 1.0, "Declination": 10.0},
    "SyncToCoordinates": {"RightAscension": 1.0, "Declination": 10.0},
    # property setters
    "Connected": {"Connected": False},
    "DeclinationRate": {"DeclinationRate": 0.0},
    "DoesRefraction": {"DoesRefraction": False},
    "GuideRateDeclination": {"GuideRateDeclination": 0.5 * SIDEREAL_DEG_S},
    "GuideRateRightAscension": {"GuideRateRightAscension": 0.5 * SIDEREAL_DEG_S},
    "RightAscensionRate": {"RightAscensionRate": 0.0},
    "SideOfPier": {"SideOfPier": 0},
    "SiteElevation": {"SiteElevation": 46.0},
    "SiteLatitude": {"SiteLatitude": 51.4769},
    "SiteLongitude": {"SiteLongitude": -0.0005},
    "SlewSettleTime": {"SlewSettleTime": 0},
    "TargetDeclination": {"TargetDeclination": 10.0},
    "TargetRightAscension": {"TargetRightAscension": 1.0},
    "Tracking": {"Tracking": False},
    "TrackingRate": {"TrackingRate": 0},
    "UTCDate": {"UTCDate": "2026-01-01T00:00:00.0000000Z"},
}


def args_for(verb: str, name: str) -> dict[str, object]:
    member = MEMBERS[(verb, name)]
    if not member.params:
        return {}
    args = VALID_ARGS[name]
    assert set(args) == {p.name for p in member.params}, f"VALID_ARGS[{name}] does not match the member table"
    return dict(args)


#: Answer with no client connected. Members that only describe the driver must work (R3); a few
#: static capabilities and cached settings may work or answer 0x407 (the interface says "may raise");
#: everything that reads or moves the mount must answer 0x407.
_DRIVER_INFO = {"InterfaceVersion", "Name", "Description", "DriverInfo", "DriverVersion", "SupportedActions",
                "Connected", "Connecting"}
_EITHER_OK_OR_407 = {
    "CanFindHome", "CanPark", "CanPulseGuide", "CanSetDeclinationRate", "CanSetGuideRates", "CanSetPark",
    "CanSetPierSide", "CanSetRightAscensionRate", "CanSetTracking", "CanSlew", "CanSlewAltAz",
    "CanSlewAltAzAsync", "CanSlewAsync", "CanSync", "CanSyncAltAz", "CanUnpark", "CanMoveAxis", "AxisRates",
    "TrackingRates", "EquatorialSystem", "AlignmentMode", "SiteElevation", "SiteLatitude", "SiteLongitude",
    "SlewSettleTime", "DoesRefraction", "DeclinationRate", "RightAscensionRate", "TargetDeclination",
    "TargetRightAscension",
}
_NOT_IMPLEMENTED_GETS = {"ApertureArea", "ApertureDiameter", "FocalLength"}
_NOT_IMPLEMENTED_PUTS: set[str] = set()  # SideOfPier flips in equatorial mode (tests/motion/test_meridian_flip.py)
_COMMANDS = {"CommandBlind", "CommandBool", "CommandString"}


def disconnected_expectation(verb: str, name: str) -> frozenset[int]:
    if verb == "PUT" and name in ("Connected", "Disconnect"):
        return frozenset({OK})
    if verb == "GET" and name in _DRIVER_INFO:
        return frozenset({OK})
    if name == "Action":
        return frozenset({ACTION_NOT_IMPLEMENTED, NOT_CONNECTED})
    if name in _COMMANDS:
        return frozenset({NOT_IMPLEMENTED, NOT_CONNECTED})
    if verb == "GET" and name in _NOT_IMPLEMENTED_GETS:
        return frozenset({NOT_IMPLEMENTED, NOT_CONNECTED})
    if verb == "PUT" and name in _NOT_IMPLEMENTED_PUTS:
        return frozenset({NOT_IMPLEMENTED, NOT_CONNECTED})
    if name in _EITHER_OK_OR_407:
        return frozenset({OK, NOT_CONNECTED})
    return frozenset({NOT_CONNECTED})


def disconnected_cases() -> list[Case]:
    """Every member except Connect (which would connect), targets first so SlewToTarget is not 0x402."""
    first = [("PUT", "TargetRightAscension"), ("PUT", "TargetDeclination")]
    rest = [(m.verb, m.name) for m in DEVICE_MEMBERS["telescope"] if (m.verb, m.name) not in first
            and m.name != "Connect"]
    return [Case(verb, name, args_for(verb, name), disconnected_expectation(verb, name))
            for verb, name in first + rest]


#: While parked (ConformU's TelescopeParkedExceptionTest plus the other motions and syncs).
def parked_cases() -> list[Case]:
    ra_dec = {"RightAscension": 3.0, "Declination": 20.0}
    alt_az = {"Azimuth": 150.0, "Altitude": 50.0}
    return [
        case("PUT", "AbortSlew", PARKED),
        case("PUT", "FindHome", PARKED),
        case("PUT", "MoveAxis", PARKED, Axis=0, Rate=0.0),
        case("PUT", "MoveAxis", PARKED, Axis=1, Rate=0.0),
        case("PUT", "MoveAxis", PARKED, Axis=0, Rate=1.0),
        case("PUT", "PulseGuide", PARKED, Direction=2, Duration=0),
        case("PUT", "PulseGuide", PARKED, Direction=0, Duration=1000),
        case("PUT", "SlewToCoordinates", PARKED, **ra_dec),
        case("PUT", "SlewToCoordinatesAsync", PARKED, **ra_dec),
        case("PUT", "SlewToTarget", PARKED),
        case("PUT", "SlewToTargetAsync", PARKED),
        case("PUT", "SlewToAltAz", PARKED, **alt_az),
        case("PUT", "SlewToAltAzAsync", PARKED, **alt_az),
        case("PUT", "SyncToCoordinates", PARKED, **ra_dec),
        case("PUT", "SyncToTarget", PARKED),
        case("PUT", "SyncToAltAz", PARKED, **alt_az),
        case("PUT", "Tracking", PARKED, Tracking=True),
        case("PUT", "SideOfPier", PARKED, SideOfPier=0),
        case("PUT", "SideOfPier", PARKED, SideOfPier=1),
        # What must still work while parked.
        case("PUT", "Tracking", OK, Tracking=False),
        case("PUT", "Park", OK),
        case("GET", "AtPark", OK),
        case("GET", "RightAscension", OK),
        case("GET", "DestinationSideOfPier", OK, RightAscension=3.0, Declination=20.0),
        case("PUT", "TargetRightAscension", OK, TargetRightAscension=3.0),
    ]


#: Capabilities a ZWO mount lacks: the flag is false and using it answers exactly 0x400.
def not_implemented_cases() -> list[Case]:
    return [
        case("GET", "ApertureArea", NOT_IMPLEMENTED),
        case("GET", "ApertureDiameter", NOT_IMPLEMENTED),
        case("GET", "FocalLength", NOT_IMPLEMENTED),
        case("PUT", "DoesRefraction", NOT_IMPLEMENTED, DoesRefraction=True),
        case("PUT", "MoveAxis", NOT_IMPLEMENTED, Axis=2, Rate=0.0),  # CanMoveAxis(2) is false
        case("PUT", "CommandBlind", NOT_IMPLEMENTED, Command=":Q#", Raw=True),
        case("PUT", "CommandBool", NOT_IMPLEMENTED, Command=":Te#", Raw=True),
        case("PUT", "CommandString", NOT_IMPLEMENTED, Command=":GVP#", Raw=False),
        case("PUT", "Action", ACTION_NOT_IMPLEMENTED, Action="nosuchaction", Parameters=""),
        # ... and what stays readable: the rates read 0, DoesRefraction false, DoesRefraction=false accepted.
        case("GET", "DeclinationRate", OK),
        case("GET", "RightAscensionRate", OK),
        case("GET", "DoesRefraction", OK),
        case("PUT", "DoesRefraction", OK, DoesRefraction=False),
    ]


#: Well-formed but out-of-range values: HTTP 200 with 0x401, and nothing happens.
def invalid_value_cases() -> list[Case]:
    c = case
    return [
        c("PUT", "SiteLatitude", INVALID_VALUE, SiteLatitude=90.0001),
        c("PUT", "SiteLatitude", INVALID_VALUE, SiteLatitude=-90.5),
        c("PUT", "SiteLongitude", INVALID_VALUE, SiteLongitude=180.5),
        c("PUT", "SiteLongitude", INVALID_VALUE, SiteLongitude=-181.0),
        c("PUT", "SiteElevation", INVALID_VALUE, SiteElevation=-301.0),
        c("PUT", "SideOfPier", INVALID_VALUE, SideOfPier=2),
        c("PUT", "SideOfPier", INVALID_VALUE, SideOfPier=-1),
        c("PUT", "SiteElevation", INVALID_VALUE, SiteElevation=10001.0),
        c("PUT", "TargetRightAscension", INVALID_VALUE, TargetRightAscension=-0.1),
        c("PUT", "TargetRightAscension", INVALID_VALUE, TargetRightAscension=24.0),
        c("PUT", "TargetDeclination", INVALID_VALUE, TargetDeclination=90.1),
        c("PUT", "TargetDeclination", INVALID_VALUE, TargetDeclination=-91.0),
        c("PUT", "SlewSettleTime", INVALID_VALUE, SlewSettleTime=-1),
        c("PUT", "TrackingRate", INVALID_VALUE, TrackingRate=3),  # King: not in TrackingRates
        c("PUT", "TrackingRate", INVALID_VALUE, TrackingRate=5),
        c("PUT", "TrackingRate", INVALID_VALUE, TrackingRate=-1),
        c("PUT", "GuideRateRightAscension", INVALID_VALUE, GuideRateRightAscension=0.05 * SIDEREAL_DEG_S),
        c("PUT", "GuideRateRightAscension", INVALID_VALUE, GuideRateRightAscension=1.0 * SIDEREAL_DEG_S),
        c("PUT", "GuideRateDeclination", INVALID_VALUE, GuideRateDeclination=-0.001),
        c("PUT", "GuideRateDeclination", INVALID_VALUE, GuideRateDeclination=0.1),
        c("PUT", "SlewToCoordinates", INVALID_VALUE, RightAscension=24.0, Declination=10.0),
        c("PUT", "SlewToCoordinatesAsync", INVALID_VALUE, RightAscension=-1.0, Declination=10.0),
        c("PUT", "SlewToCoordinatesAsync", INVALID_VALUE, RightAscension=1.0, Declination=91.0),
        c("PUT", "SyncToCoordinates", INVALID_VALUE, RightAscension=25.0, Declination=10.0),
        c("PUT", "SyncToCoordinates", INVALID_VALUE, RightAscension=1.0, Declination=-100.0),
        c("GET", "DestinationSideOfPier", INVALID_VALUE, RightAscension=24.5, Declination=10.0),
        c("GET", "DestinationSideOfPier", INVALID_VALUE, RightAscension=1.0, Declination=95.0),
        # ConformU's Alt/Az set: (Alt -100, Az 45), (Alt 45, Az -10), (Alt 100, Az 45), (Alt 45, Az 370).
        c("PUT", "SlewToAltAz", INVALID_VALUE, Azimuth=45.0, Altitude=-100.0),
        c("PUT", "SlewToAltAzAsync", INVALID_VALUE, Azimuth=-10.0, Altitude=45.0),
        c("PUT", "SlewToAltAzAsync", INVALID_VALUE, Azimuth=45.0, Altitude=100.0),
        c("PUT", "SyncToAltAz", INVALID_VALUE, Azimuth=370.0, Altitude=45.0),
        c("PUT", "SyncToAltAz", INVALID_VALUE, Azimuth=45.0, Altitude=-100.0),
        c("PUT", "PulseGuide", INVALID_VALUE, Direction=4, Duration=100),
        c("PUT", "PulseGuide", INVALID_VALUE, Direction=-1, Duration=100),
        c("PUT", "PulseGuide", INVALID_VALUE, Direction=0, Duration=-1),
        c("PUT", "MoveAxis", INVALID_VALUE, Axis=3, Rate=0.0),
        c("PUT", "MoveAxis", INVALID_VALUE, Axis=-1, Rate=0.0),
        c("GET", "CanMoveAxis", INVALID_VALUE, Axis=3),
        c("GET", "AxisRates", INVALID_VALUE, Axis=3),
        # None of the above may have moved or changed anything.
        c("GET", "TargetRightAscension", VALUE_NOT_SET),
        c("GET", "TargetDeclination", VALUE_NOT_SET),
        c("GET", "Slewing", OK),
    ]
