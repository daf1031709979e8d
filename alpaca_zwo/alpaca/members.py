"""The one table of Alpaca members this server speaks: every ITelescopeV4 member plus the common ones.

Routing, parameter parsing, handler dispatch, the ``AlpacaDevice`` protocol check and the member
reference are all derived from :data:`DEVICE_MEMBERS`, so adding or fixing a member is a one-line
change here rather than an endpoint class, a parser and a doc entry kept in step by hand.

Naming rule for handlers on the device (the Telescope is written to match):

- property GET ``RightAscension`` -> ``device.right_ascension()`` (snake_case of the ASCOM name);
- property PUT ``Tracking`` -> ``device.set_tracking(value)`` (one positional value);
- GET functions and PUT methods -> snake_case name with snake_case *keyword* parameters,
  e.g. ``device.move_axis(axis=0, rate=1.5)``, ``device.axis_rates(axis=0)``.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from enum import Enum
from typing import Literal


class ValueType(str, Enum):
    """Wire types of parameters and reply values; the first five may also be request parameters."""

    BOOL = "bool"
    INT = "int"
    FLOAT = "float"
    STR = "str"
    UTCDATE = "utcdate"
    STR_LIST = "list[str]"
    INT_LIST = "list[int]"
    AXIS_RATES = "axisrates"
    DEVICE_STATE = "devicestate"


#: Types a request parameter can have (the rest only ever travel in replies).
PARAM_TYPES = frozenset({ValueType.BOOL, ValueType.INT, ValueType.FLOAT, ValueType.STR, ValueType.UTCDATE})

#: ``Value`` of an ASCOM error reply, as sent on the wire: the type's default, never null.
#: The official schema types ``Value`` per member and has no null; the ASCOM .NET simulators send
#: a fresh typed response (0, 0.0, false, "", []) and typed clients deserialise it before they look
#: at ErrorNumber (protocol-rules §6 "Value on error", §15.6). A date's default is .NET's
#: ``DateTime.MinValue`` written the way UTCDate is, so it still matches the schema's ``...Z`` pattern.
ERROR_VALUES: dict[ValueType, object] = {
    ValueType.BOOL: False,
    ValueType.INT: 0,
    ValueType.FLOAT: 0.0,
    ValueType.STR: "",
    ValueType.UTCDATE: "0001-01-01T00:00:00.0000000Z",
    ValueType.STR_LIST: (),
    ValueType.INT_LIST: (),
    ValueType.AXIS_RATES: (),
    ValueType.DEVICE_STATE: (),
}

Verb = Literal["GET", "PUT"]

_WORD_BOUNDARY = re.compile(r"(?<=[a-z0-9])(?=[A-Z])|(?<=[A-Z])(?=[A-Z][a-z])")


def snake(name: str) -> str:
    """Handler and keyword names derive from this, so table and Protocol cannot drift apart.

    ``CanSlewAltAzAsync`` -> ``can_slew_alt_az_async``; acronyms stay whole: ``UTCDate`` -> ``utc_date``.
    """
    return _WORD_BOUNDARY.sub("_", name).lower()


@dataclass(frozen=True)
class Param:
    """A request parameter, named exactly as the spec cases it: PUT form names are case-sensitive."""

    name: str
    type: ValueType
    #: Used when the parameter is absent; only for Action's Parameters, which alpyca omits when empty.
    default: str | None = None
    kwarg: str = field(init=False)

    def __post_init__(self) -> None:
        if self.type not in PARAM_TYPES:
            raise ValueError(f"{self.type} cannot be a request parameter")
        object.__setattr__(self, "kwarg", snake(self.name))


@dataclass(frozen=True)
class Member:
    """One (verb, path) of the Device API and the device handler that serves it."""

    name: str  # ASCOM name, exact casing
    verb: Verb
    params: tuple[Param, ...]
    handler: str
    returns: ValueType | None  # None: a MethodResponse without "Value"
    setter: bool  # property PUT: the handler takes the single value positionally
    common: bool  # defined for every device type, not only telescopes
    summary: str
    device_state: bool = False  # reported by the Telescope's DeviceState
    path: str = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "path", self.name.lower())

    @property
    def error_value(self) -> object | None:
        """``Value`` of this member's ASCOM error reply; None: the reply has no ``Value`` (MethodResponse)."""
        return None if self.returns is None else ERROR_VALUES[self.returns]


def _get(name: str, returns: ValueType, summary: str, *, common: bool = False,
         state: bool = False) -> tuple[Member, ...]:
    """A read-only property."""
    return (Member(name, "GET", (), snake(name), returns, False, common, summary, state),)


def _rw(name: str, type_: ValueType, summary: str, *, common: bool = False,
        state: bool = False) -> tuple[Member, ...]:
    """A read/write property: a GET and a PUT whose form parameter has the property's own name."""
    return (
        Member(name, "GET", (), snake(name), type_, False, common, summary, state),
        Member(name, "PUT", (Param(name, type_),), f"set_{snake(name)}", None, True, common, summary),
    )


def _fn(name: str, returns: ValueType, summary: str, *params: Param) -> tuple[Member, ...]:
    """A GET that takes query parameters (a function rather than a property)."""
    return (Member(name, "GET", params, snake(name), returns, False, False, summary),)


def _do(name: str, summary: str, *params: Param, returns: ValueType | None = None,
        common: bool = False) -> tuple[Member, ...]:
    """A PUT method; a few (Action, CommandBool, CommandString) also return a Value."""
    return (Member(name, "PUT", params, snake(name), returns, False, common, summary),)


_B, _I, _F, _S, _D = ValueType.BOOL, ValueType.INT, ValueType.FLOAT, ValueType.STR, ValueType.UTCDATE
_RA, _DEC = Param("RightAscension", _F), Param("Declination", _F)
_AZ, _ALT = Param("Azimuth", _F), Param("Altitude", _F)
_AXIS = Param("Axis", _I)
_COMMAND = (Param("Command", _S), Param("Raw", _B))

COMMON_MEMBERS: tuple[Member, ...] = (
    *_do("Action", "Invoke a device-specific action", Param("Action", _S), Param("Parameters", _S, ""),
         returns=_S, common=True),
    *_do("CommandBlind", "Send a raw command, no reply", *_COMMAND, common=True),
    *_do("CommandBool", "Send a raw command, boolean reply", *_COMMAND, returns=_B, common=True),
    *_do("CommandString", "Send a raw command, string reply", *_COMMAND, returns=_S, common=True),
    *_do("Connect", "Start an asynchronous connect (Platform 7)", common=True),
    *_rw("Connected", _B, "Connection state; PUT connects or disconnects synchronously", common=True),
    *_get("Connecting", _B, "True while Connect/Disconnect is in progress", common=True),
    *_get("Description", _S, "Description of the device", common=True),
    *_get("DeviceState", ValueType.DEVICE_STATE, "Operational state snapshot in one call", common=True),
    *_do("Disconnect", "Start an asynchronous disconnect (Platform 7)", common=True),
    *_get("DriverInfo", _S, "Description of the driver", common=True),
    *_get("DriverVersion", _S, "Driver version as major.minor", common=True),
    *_get("InterfaceVersion", _I, "ASCOM interface version (4 for ITelescopeV4)", common=True),
    *_get("Name", _S, "Short display name of the device", common=True),
    *_get("SupportedActions", ValueType.STR_LIST, "Names of the actions Action() accepts", common=True),
)

TELESCOPE_MEMBERS: tuple[Member, ...] = (
    *_get("AlignmentMode", _I, "Mount alignment: 0 AltAz, 1 Polar, 2 GermanPolar"),
    *_get("Altitude", _F, "Altitude above the horizon, degrees", state=True),
    *_get("ApertureArea", _F, "Aperture area, square metres"),
    *_get("ApertureDiameter", _F, "Aperture diameter, metres"),
    *_get("AtHome", _B, "True when at the home position after FindHome", state=True),
    *_get("AtPark", _B, "True when parked", state=True),
    *_get("Azimuth", _F, "Azimuth, degrees, north-referenced, east positive", state=True),
    *_get("CanFindHome", _B, "FindHome is supported"),
    *_get("CanPark", _B, "Park is supported"),
    *_get("CanPulseGuide", _B, "PulseGuide is supported"),
    *_get("CanSetDeclinationRate", _B, "DeclinationRate can be written"),
    *_get("CanSetGuideRates", _B, "Guide rates can be written"),
    *_get("CanSetPark", _B, "SetPark is supported"),
    *_get("CanSetPierSide", _B, "SideOfPier can be written"),
    *_get("CanSetRightAscensionRate", _B, "RightAscensionRate can be written"),
    *_get("CanSetTracking", _B, "Tracking can be written"),
    *_get("CanSlew", _B, "Synchronous equatorial slews are supported"),
    *_get("CanSlewAltAz", _B, "Synchronous alt/az slews are supported"),
    *_get("CanSlewAltAzAsync", _B, "Asynchronous alt/az slews are supported"),
    *_get("CanSlewAsync", _B, "Asynchronous equatorial slews are supported"),
    *_get("CanSync", _B, "Equatorial syncs are supported"),
    *_get("CanSyncAltAz", _B, "Alt/az syncs are supported"),
    *_get("CanUnpark", _B, "Unpark is supported"),
    *_get("Declination", _F, "Declination, degrees, in EquatorialSystem", state=True),
    *_rw("DeclinationRate", _F, "Declination tracking offset, arcsec/s"),
    *_rw("DoesRefraction", _B, "Whether the mount applies refraction correction"),
    *_get("EquatorialSystem", _I, "Coordinate system: 1 Topocentric, 2 J2000, ..."),
    *_get("FocalLength", _F, "Focal length, metres"),
    *_rw("GuideRateDeclination", _F, "Declination guide rate, degrees/s"),
    *_rw("GuideRateRightAscension", _F, "Right ascension guide rate, degrees/s"),
    *_get("IsPulseGuiding", _B, "True while a PulseGuide is in progress", state=True),
    *_get("RightAscension", _F, "Right ascension, hours, in EquatorialSystem", state=True),
    *_rw("RightAscensionRate", _F, "Right ascension tracking offset, seconds of RA per sidereal second"),
    *_rw("SideOfPier", _I, "Pointing state: 0 East, 1 West, -1 Unknown; PUT flips", state=True),
    *_get("SiderealTime", _F, "Local apparent sidereal time, hours", state=True),
    *_rw("SiteElevation", _F, "Site elevation, metres"),
    *_rw("SiteLatitude", _F, "Site latitude, degrees, north positive"),
    *_rw("SiteLongitude", _F, "Site longitude, degrees, east positive"),
    *_get("Slewing", _B, "True while any motion other than tracking is in progress", state=True),
    *_rw("SlewSettleTime", _I, "Extra settle time after a slew, seconds"),
    *_rw("TargetDeclination", _F, "Target declination for SlewToTarget/SyncToTarget, degrees"),
    *_rw("TargetRightAscension", _F, "Target right ascension for SlewToTarget/SyncToTarget, hours"),
    *_rw("Tracking", _B, "Sidereal (or TrackingRate) tracking on/off", state=True),
    *_rw("TrackingRate", _I, "Drive rate: 0 Sidereal, 1 Lunar, 2 Solar, 3 King"),
    *_get("TrackingRates", ValueType.INT_LIST, "Supported drive rates"),
    *_rw("UTCDate", _D, "The mount's UTC date and time", state=True),
    *_do("AbortSlew", "Stop any slew, park, find-home or move-axis motion"),
    *_fn("AxisRates", ValueType.AXIS_RATES, "MoveAxis rate ranges for an axis, degrees/s", _AXIS),
    *_fn("CanMoveAxis", _B, "MoveAxis is supported on an axis", _AXIS),
    *_fn("DestinationSideOfPier", _I, "Side of pier a slew to these coordinates would end on", _RA, _DEC),
    *_do("FindHome", "Start moving to the home position"),
    *_do("MoveAxis", "Move an axis at a rate (0 stops)", _AXIS, Param("Rate", _F)),
    *_do("Park", "Start moving to the park position"),
    *_do("PulseGuide", "Guide in a direction for a duration (ms), asynchronously",
         Param("Direction", _I), Param("Duration", _I)),
    *_do("SetPark", "Make the current position the park position"),
    *_do("SlewToAltAz", "Slew to alt/az and wait", _AZ, _ALT),
    *_do("SlewToAltAzAsync", "Start a slew to alt/az", _AZ, _ALT),
    *_do("SlewToCoordinates", "Slew to RA/Dec and wait", _RA, _DEC),
    *_do("SlewToCoordinatesAsync", "Start a slew to RA/Dec", _RA, _DEC),
    *_do("SlewToTarget", "Slew to the target RA/Dec and wait"),
    *_do("SlewToTargetAsync", "Start a slew to the target RA/Dec"),
    *_do("SyncToAltAz", "Declare the current position to be this alt/az", _AZ, _ALT),
    *_do("SyncToCoordinates", "Declare the current position to be this RA/Dec", _RA, _DEC),
    *_do("SyncToTarget", "Declare the current position to be the target RA/Dec"),
    *_do("Unpark", "Start leaving the park position"),
)

#: Members served per device type (the lower-case path element).
DEVICE_MEMBERS: dict[str, tuple[Member, ...]] = {"telescope": COMMON_MEMBERS + TELESCOPE_MEMBERS}

#: The names ConformU expects in a Telescope's DeviceState (plus an optional ``TimeStamp``).
TELESCOPE_DEVICE_STATE: tuple[str, ...] = tuple(m.name for m in TELESCOPE_MEMBERS
                                                if m.verb == "GET" and m.device_state)


def routes(members: Iterable[Member]) -> dict[str, dict[str, Member]]:
    """``{verb: {path: member}}`` for the router."""
    table: dict[str, dict[str, Member]] = {"GET": {}, "PUT": {}}
    for member in members:
        if member.path in table[member.verb]:
            raise ValueError(f"duplicate member {member.verb} {member.path}")
        table[member.verb][member.path] = member
    return table


def reference_markdown(device_type: str = "telescope") -> str:
    """The member reference as a Markdown table, for docs and the setup page."""
    lines = ["| Verb | Path | Parameters | Returns | Handler | Summary |",
             "| --- | --- | --- | --- | --- | --- |"]
    for m in sorted(DEVICE_MEMBERS[device_type], key=lambda m: (m.path, m.verb)):
        params = ", ".join(f"{p.name}: {p.type.value}" + (" (optional)" if p.default is not None else "")
                           for p in m.params)
        returns = m.returns.value if m.returns else ""
        args = "value" if m.setter else ", ".join(f"{p.kwarg}=" for p in m.params)
        lines.append(f"| {m.verb} | `/api/v1/{device_type}/{{n}}/{m.path}` | {params} | {returns} "
                     f"| `{m.handler}({args})` | {m.summary} |")
    return "\n".join(lines) + "\n"
