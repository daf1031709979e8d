"""The one table of Alpaca members this server speaks: every ITelescopeV4 member plus the common ones.

Routing, parameter parsing, handler dispatch, the start-up handler check and the member reference
are all derived from :data:`DEVICE_MEMBERS`, so adding or fixing a member is a row here (and, unless
the row gives a constant, the handler on the part it names) rather than an endpoint class, a parser,
a forwarding method and a doc entry kept in step by hand.

Each row says who answers it:

- ``constant=``: the value itself (``CanPark`` is true on every ZWO mount), served with no call at all;
- ``owner=``: the device's part that answers, by attribute name: ``owner=CONNECTION`` means
  ``device.connection.connected()``; no owner means the device object itself.

Naming rule for handlers (the Telescope and its parts are written to match):

- property GET ``RightAscension`` -> ``right_ascension()`` (snake_case of the ASCOM name);
- property PUT ``Tracking`` -> ``set_tracking(value)`` (one positional value);
- GET functions and PUT methods -> snake_case name with snake_case *keyword* parameters,
  e.g. ``move_axis(axis=0, rate=1.5)``, ``capabilities.axis_rates(axis=0)``.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from enum import Enum
from typing import Literal

from alpaca_zwo import __version__


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


#: The parts of a telescope that answer members, by the attribute that holds each on the device
#: (``telescope/device.py``'s ``Telescope``; what each owns is in docs/ARCHITECTURE.md).
CONNECTION = "connection"  # telescope/connection.py: who holds the device connected, the link's life
CAPABILITIES = "capabilities"  # telescope/capabilities.py: the flags that vary, rates, site
CLOCK = "clock"  # telescope/clock.py: UTCDate and the sidereal time at the site
TARGETS = "targets"  # telescope/targets.py: TargetRightAscension/Declination, SlewSettleTime
RAW_COMMANDS = "raw_commands"  # telescope/raw_commands.py: CommandBlind/Bool/String


@dataclass(frozen=True)
class Constant:
    """A member's fixed answer (a box, so that ``False`` and ``0`` are answers too)."""

    value: object


@dataclass(frozen=True)
class Member:
    """One (verb, path) of the Device API and who serves it: a constant, or a handler on the device or one
    of its parts."""

    name: str  # ASCOM name, exact casing
    verb: Verb
    params: tuple[Param, ...]
    handler: str  # snake_case of the name (set_ for a property PUT); never called for a constant
    returns: ValueType | None  # None: a MethodResponse without "Value"
    setter: bool  # property PUT: the handler takes the single value positionally
    common: bool  # defined for every device type, not only telescopes
    summary: str
    device_state: bool = False  # reported by the Telescope's DeviceState
    owner: str | None = None  # the device attribute holding the part that answers; None: the device itself
    constant: Constant | None = None  # the answer itself, for a member that never changes
    path: str = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "path", self.name.lower())
        if self.constant is not None and (self.owner is not None or self.params or self.verb != "GET"):
            raise ValueError(f"{self.name}: a constant is a parameterless GET with no owner")

    @property
    def answered_by(self) -> str:
        """``owner.handler`` (``capabilities.axis_rates``), the handler alone on the device, or the constant."""
        if self.constant is not None:
            return f"constant {self.constant.value!r}"
        return self.handler if self.owner is None else f"{self.owner}.{self.handler}"

    @property
    def error_value(self) -> object | None:
        """``Value`` of this member's ASCOM error reply; None: the reply has no ``Value`` (MethodResponse)."""
        return None if self.returns is None else ERROR_VALUES[self.returns]


def _get(name: str, returns: ValueType, summary: str, *, common: bool = False, state: bool = False,
         owner: str | None = None) -> tuple[Member, ...]:
    """A read-only property."""
    return (Member(name, "GET", (), snake(name), returns, False, common, summary, state, owner),)


def _const(name: str, returns: ValueType, value: object, summary: str, *, common: bool = False) -> tuple[Member, ...]:
    """A read-only property whose answer never changes: served from here, with no handler."""
    return (Member(name, "GET", (), snake(name), returns, False, common, summary, constant=Constant(value)),)


def _rw(name: str, type_: ValueType, summary: str, *, common: bool = False, state: bool = False,
        owner: str | None = None, constant: object = None) -> tuple[Member, ...]:
    """A read/write property: a GET and a PUT whose form parameter has the property's own name.

    ``constant`` (not None): the GET's fixed answer; the PUT still has a handler (it may refuse).
    """
    get = (Member(name, "GET", (), snake(name), type_, False, common, summary, state, owner) if constant is None
           else _const(name, type_, constant, summary, common=common)[0])
    return (get, Member(name, "PUT", (Param(name, type_),), f"set_{snake(name)}", None, True, common, summary,
                        owner=owner))


def _fn(name: str, returns: ValueType, summary: str, *params: Param, owner: str | None = None) -> tuple[Member, ...]:
    """A GET that takes query parameters (a function rather than a property)."""
    return (Member(name, "GET", params, snake(name), returns, False, False, summary, owner=owner),)


def _do(name: str, summary: str, *params: Param, returns: ValueType | None = None, common: bool = False,
        owner: str | None = None) -> tuple[Member, ...]:
    """A PUT method; a few (Action, CommandBool, CommandString) also return a Value."""
    return (Member(name, "PUT", params, snake(name), returns, False, common, summary, owner=owner),)


_B, _I, _F, _S, _D = ValueType.BOOL, ValueType.INT, ValueType.FLOAT, ValueType.STR, ValueType.UTCDATE
_RA, _DEC = Param("RightAscension", _F), Param("Declination", _F)
_AZ, _ALT = Param("Azimuth", _F), Param("Altitude", _F)
_AXIS = Param("Axis", _I)
_COMMAND = (Param("Command", _S), Param("Raw", _B))

_CONN, _CAPS, _CLOCK, _TARGETS, _RAW = CONNECTION, CAPABILITIES, CLOCK, TARGETS, RAW_COMMANDS

COMMON_MEMBERS: tuple[Member, ...] = (
    *_do("Action", "Invoke a device-specific action", Param("Action", _S), Param("Parameters", _S, ""),
         returns=_S, common=True),
    *_do("CommandBlind", "Send a raw command, no reply", *_COMMAND, common=True, owner=_RAW),
    *_do("CommandBool", "Send a raw command, boolean reply", *_COMMAND, returns=_B, common=True, owner=_RAW),
    *_do("CommandString", "Send a raw command, string reply", *_COMMAND, returns=_S, common=True, owner=_RAW),
    *_do("Connect", "Start an asynchronous connect (Platform 7)", common=True, owner=_CONN),
    *_rw("Connected", _B, "Connection state; PUT connects or disconnects synchronously", common=True, owner=_CONN),
    *_get("Connecting", _B, "True while Connect/Disconnect is in progress", common=True, owner=_CONN),
    *_get("Description", _S, "Description of the device", common=True),
    *_get("DeviceState", ValueType.DEVICE_STATE, "Operational state snapshot in one call", common=True),
    *_do("Disconnect", "Start an asynchronous disconnect (Platform 7)", common=True, owner=_CONN),
    *_const("DriverInfo", _S, "alpaca-zwo: ASCOM Alpaca server for ZWO AM3/AM5/AM7 mounts (ITelescopeV4)",
            "Description of the driver", common=True),
    *_const("DriverVersion", _S, __version__, "Driver version as major.minor", common=True),
    *_const("InterfaceVersion", _I, 4, "ASCOM interface version (4 for ITelescopeV4)", common=True),
    *_get("Name", _S, "Short display name of the device", common=True),
    *_get("SupportedActions", ValueType.STR_LIST, "Names of the actions Action() accepts", common=True),
)

# The constant Can* flags: what every ZWO AM mount can do in either mode. CanSetPierSide (equatorial
# mode, firmware with meridian settings) and CanMoveAxis (per axis) vary and are asked of Capabilities.
TELESCOPE_MEMBERS: tuple[Member, ...] = (
    *_get("AlignmentMode", _I, "Mount alignment: 0 AltAz, 1 Polar, 2 GermanPolar"),
    *_get("Altitude", _F, "Altitude above the horizon, degrees", state=True),
    *_get("ApertureArea", _F, "Aperture area, square metres", owner=_CAPS),
    *_get("ApertureDiameter", _F, "Aperture diameter, metres", owner=_CAPS),
    *_get("AtHome", _B, "True when at the home position after FindHome", state=True),
    *_get("AtPark", _B, "True when parked", state=True),
    *_get("Azimuth", _F, "Azimuth, degrees, north-referenced, east positive", state=True),
    *_const("CanFindHome", _B, True, "FindHome is supported"),
    *_const("CanPark", _B, True, "Park is supported"),
    # In alt-az mode, where :Mg moves nothing (field notes §2.5), pulses are timed moves (motion/guiding.py).
    *_const("CanPulseGuide", _B, True, "PulseGuide is supported"),
    # Rate offsets are paid in guide pulses, timed moves in alt-az (motion/offsets.py).
    *_const("CanSetDeclinationRate", _B, True, "DeclinationRate can be written"),
    *_const("CanSetGuideRates", _B, True, "Guide rates can be written"),
    *_const("CanSetPark", _B, True, "SetPark is supported"),
    *_get("CanSetPierSide", _B, "SideOfPier can be written", owner=_CAPS),
    *_const("CanSetRightAscensionRate", _B, True, "RightAscensionRate can be written"),
    *_const("CanSetTracking", _B, True, "Tracking can be written"),
    *_const("CanSlew", _B, True, "Synchronous equatorial slews are supported"),
    *_const("CanSlewAltAz", _B, True, "Synchronous alt/az slews are supported"),
    *_const("CanSlewAltAzAsync", _B, True, "Asynchronous alt/az slews are supported"),
    *_const("CanSlewAsync", _B, True, "Asynchronous equatorial slews are supported"),
    *_const("CanSync", _B, True, "Equatorial syncs are supported"),
    *_const("CanSyncAltAz", _B, True, "Alt/az syncs are supported"),
    *_const("CanUnpark", _B, True, "Unpark is supported"),
    *_get("Declination", _F, "Declination, degrees, in EquatorialSystem", state=True),
    *_rw("DeclinationRate", _F, "Declination tracking offset, arcsec/s", owner=_CAPS),
    # The mount does no refraction correction: false, and the PUT refuses true.
    *_rw("DoesRefraction", _B, "Whether the mount applies refraction correction", owner=_CAPS, constant=False),
    *_const("EquatorialSystem", _I, 1, "Coordinate system: 1 Topocentric, 2 J2000, ..."),  # JNow: the mount's
    *_get("FocalLength", _F, "Focal length, metres", owner=_CAPS),
    *_rw("GuideRateDeclination", _F, "Declination guide rate, degrees/s", owner=_CAPS),
    *_rw("GuideRateRightAscension", _F, "Right ascension guide rate, degrees/s", owner=_CAPS),
    *_get("IsPulseGuiding", _B, "True while a PulseGuide is in progress", state=True),
    *_get("RightAscension", _F, "Right ascension, hours, in EquatorialSystem", state=True),
    *_rw("RightAscensionRate", _F, "Right ascension tracking offset, seconds of RA per sidereal second",
         owner=_CAPS),
    *_rw("SideOfPier", _I, "Pointing state: 0 East, 1 West, -1 Unknown; PUT flips", state=True),
    *_get("SiderealTime", _F, "Local apparent sidereal time, hours", state=True, owner=_CLOCK),
    *_rw("SiteElevation", _F, "Site elevation, metres", owner=_CAPS),
    *_rw("SiteLatitude", _F, "Site latitude, degrees, north positive", owner=_CAPS),
    *_rw("SiteLongitude", _F, "Site longitude, degrees, east positive", owner=_CAPS),
    *_get("Slewing", _B, "True while any motion other than tracking is in progress", state=True),
    *_rw("SlewSettleTime", _I, "Extra settle time after a slew, seconds", owner=_TARGETS),
    *_rw("TargetDeclination", _F, "Target declination for SlewToTarget/SyncToTarget, degrees", owner=_TARGETS),
    *_rw("TargetRightAscension", _F, "Target right ascension for SlewToTarget/SyncToTarget, hours",
         owner=_TARGETS),
    *_rw("Tracking", _B, "Sidereal (or TrackingRate) tracking on/off", state=True),
    *_rw("TrackingRate", _I, "Drive rate: 0 Sidereal, 1 Lunar, 2 Solar, 3 King", owner=_CAPS),
    *_get("TrackingRates", ValueType.INT_LIST, "Supported drive rates", owner=_CAPS),
    *_rw("UTCDate", _D, "The mount's UTC date and time", state=True, owner=_CLOCK),
    *_do("AbortSlew", "Stop any slew, park, find-home or move-axis motion"),
    *_fn("AxisRates", ValueType.AXIS_RATES, "MoveAxis rate ranges for an axis, degrees/s", _AXIS, owner=_CAPS),
    *_fn("CanMoveAxis", _B, "MoveAxis is supported on an axis", _AXIS, owner=_CAPS),
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
    lines = ["| Verb | Path | Parameters | Returns | Answered by | Summary |",
             "| --- | --- | --- | --- | --- | --- |"]
    for m in sorted(DEVICE_MEMBERS[device_type], key=lambda m: (m.path, m.verb)):
        params = ", ".join(f"{p.name}: {p.type.value}" + (" (optional)" if p.default is not None else "")
                           for p in m.params)
        returns = m.returns.value if m.returns else ""
        args = "value" if m.setter else ", ".join(f"{p.kwarg}=" for p in m.params)
        answer = f"`{m.answered_by}`" if m.constant is not None else f"`{m.answered_by}({args})`"
        lines.append(f"| {m.verb} | `/api/v1/{device_type}/{{n}}/{m.path}` | {params} | {returns} "
                     f"| {answer} | {m.summary} |")
    return "\n".join(lines) + "\n"
