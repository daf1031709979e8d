"""The member table against the official Alpaca spec, and how a device is held to the table.

Every row names who answers it (a part of the device, the device itself) or gives its constant; the
real Telescope's handlers are checked against the rows in tests/telescope/test_member_owners.py.
"""

from __future__ import annotations

import inspect
from pathlib import Path

import pytest

from alpaca_zwo import __version__
from alpaca_zwo.alpaca.device import AlpacaDevice, handler_for, missing_handlers
from alpaca_zwo.alpaca.members import (
    CAPABILITIES,
    CLOCK,
    COMMON_MEMBERS,
    CONNECTION,
    DEVICE_MEMBERS,
    RAW_COMMANDS,
    TARGETS,
    TELESCOPE_DEVICE_STATE,
    TELESCOPE_MEMBERS,
    Constant,
    Member,
    Param,
    ValueType,
    reference_markdown,
    routes,
    snake,
)

SPEC = Path("/work/shared/alpaca/spec/AlpacaDeviceAPI_v1.yaml")
MEMBERS = DEVICE_MEMBERS["telescope"]

_SPEC_TYPES = {("boolean", None): ValueType.BOOL, ("integer", "int32"): ValueType.INT,
               ("integer", None): ValueType.INT, ("number", "double"): ValueType.FLOAT,
               ("number", None): ValueType.FLOAT, ("string", None): ValueType.STR,
               ("string", "date-time"): ValueType.UTCDATE}


def _spec_members() -> dict[tuple[str, str], dict[str, ValueType]]:
    """``{(VERB, path): {param name: type}}`` for every telescope and common path in the YAML."""
    yaml = pytest.importorskip("yaml")
    spec = yaml.safe_load(SPEC.read_text())

    def resolve(node: dict) -> dict:
        while "$ref" in node:
            target = spec
            for part in node["$ref"].lstrip("#/").split("/"):
                target = target[part]
            node = target
        return node

    def properties(schema: dict) -> dict[str, dict]:
        schema = resolve(schema)
        props: dict[str, dict] = {}
        for sub in schema.get("allOf", []):
            props.update(properties(sub))
        props.update({k: resolve(v) for k, v in schema.get("properties", {}).items()})
        return props

    found = {}
    for path, operations in spec["paths"].items():
        if not path.startswith(("/telescope/", "/{device_type}/")):
            continue
        for verb, op in operations.items():
            params: dict[str, dict] = {}
            if verb == "get":
                for p in op.get("parameters", []):
                    p = resolve(p)
                    if p["in"] == "query":
                        params[p["name"]] = resolve(p["schema"])
            else:
                body = resolve(op["requestBody"])["content"]["application/x-www-form-urlencoded"]["schema"]
                params = properties(body)
            typed = {name: _SPEC_TYPES[(s.get("type"), s.get("format"))] for name, s in params.items()
                     if name not in ("ClientID", "ClientTransactionID")}
            found[(verb.upper(), path.rsplit("/", 1)[1])] = typed
    return found


@pytest.fixture(scope="module")
def spec_members() -> dict[tuple[str, str], dict[str, ValueType]]:
    if not SPEC.exists():
        pytest.skip("shared Alpaca spec not available")
    return _spec_members()


def test_table_covers_exactly_the_spec(spec_members: dict) -> None:
    ours = {(m.verb, m.path): {p.name: p.type for p in m.params} for m in MEMBERS}
    assert ours == spec_members


def test_counts() -> None:
    assert len({m.path for m in TELESCOPE_MEMBERS}) == 65
    assert len({m.path for m in COMMON_MEMBERS}) == 15
    assert len(MEMBERS) == 96  # 15 read/write properties have both a GET and a PUT


@pytest.mark.parametrize(("name", "expected"), [
    ("RightAscension", "right_ascension"), ("CanSlewAltAzAsync", "can_slew_alt_az_async"),
    ("UTCDate", "utc_date"), ("IsPulseGuiding", "is_pulse_guiding"), ("DeviceState", "device_state"),
    ("InterfaceVersion", "interface_version"), ("SupportedActions", "supported_actions"),
    ("SlewToAltAz", "slew_to_alt_az"), ("Unpark", "unpark"), ("SetPark", "set_park"),
    ("GuideRateRightAscension", "guide_rate_right_ascension"), ("CommandBlind", "command_blind"),
])
def test_snake(name: str, expected: str) -> None:
    assert snake(name) == expected


def test_handler_naming_rule() -> None:
    by_key = {(m.verb, m.name): m for m in MEMBERS}
    assert by_key[("PUT", "Tracking")].handler == "set_tracking"
    assert by_key[("PUT", "Tracking")].setter
    assert by_key[("PUT", "Connected")].handler == "set_connected"
    assert by_key[("PUT", "SetPark")].handler == "set_park"
    assert not by_key[("PUT", "SetPark")].setter
    def kwargs(verb: str, name: str) -> list[str]:
        return [p.kwarg for p in by_key[(verb, name)].params]

    assert kwargs("PUT", "SlewToCoordinatesAsync") == ["right_ascension", "declination"]
    assert kwargs("PUT", "Action") == ["action", "parameters"]
    assert kwargs("GET", "DestinationSideOfPier") == ["right_ascension", "declination"]
    assert len({m.handler for m in MEMBERS}) == len(MEMBERS)


def test_value_returning_puts() -> None:
    assert {m.name for m in MEMBERS if m.verb == "PUT" and m.returns} == {"Action", "CommandBool",
                                                                          "CommandString"}
    assert all(m.returns for m in MEMBERS if m.verb == "GET")


_CONSTANT_TYPES = {ValueType.BOOL: bool, ValueType.INT: int, ValueType.STR: str}


def test_every_row_names_who_answers_it() -> None:
    """A part of the device, the device itself, or a constant of the row's own type: nothing else."""
    assert {m.owner for m in MEMBERS} == {None, CONNECTION, CAPABILITIES, CLOCK, TARGETS, RAW_COMMANDS}
    for m in MEMBERS:
        if m.constant is not None:
            assert m.verb == "GET" and not m.params and m.owner is None, m.name
            assert m.returns is not None and type(m.constant.value) is _CONSTANT_TYPES[m.returns], m.name
    constants = {m.name: m.constant.value for m in MEMBERS if m.constant is not None}
    assert constants == {
        "CanFindHome": True, "CanPark": True, "CanPulseGuide": True, "CanSetDeclinationRate": True,
        "CanSetGuideRates": True, "CanSetPark": True, "CanSetRightAscensionRate": True, "CanSetTracking": True,
        "CanSlew": True, "CanSlewAltAz": True, "CanSlewAltAzAsync": True, "CanSlewAsync": True, "CanSync": True,
        "CanSyncAltAz": True, "CanUnpark": True, "DoesRefraction": False, "EquatorialSystem": 1,
        "InterfaceVersion": 4, "DriverVersion": __version__,
        "DriverInfo": "alpaca-zwo: ASCOM Alpaca server for ZWO AM3/AM5/AM7 mounts (ITelescopeV4)",
    }
    with pytest.raises(ValueError, match="constant"):
        Member("Tracking", "PUT", (Param("Tracking", ValueType.BOOL),), "set_tracking", None, True, False, "",
               constant=Constant(True))


def test_a_constant_needs_no_handler_and_answers_itself() -> None:
    can_park = next(m for m in MEMBERS if m.name == "CanPark")
    handler = handler_for(object(), can_park)
    assert handler is not None and handler() is True
    assert "can_park" not in missing_handlers(object(), MEMBERS)


def test_the_protocol_is_the_identity_alone() -> None:
    """Handlers are the table's business (owner + handler name); the Protocol keeps what the management API reads."""
    declared = {name for name, value in vars(AlpacaDevice).items()
                if not name.startswith("_") and (inspect.isfunction(value) or isinstance(value, property))}
    assert declared == {"device_name", "unique_id"}
    for identity in declared:
        assert isinstance(vars(AlpacaDevice)[identity], property), identity


def test_device_state_names_match_conformu() -> None:
    assert set(TELESCOPE_DEVICE_STATE) == {"Altitude", "AtHome", "AtPark", "Azimuth", "Declination",
                                           "IsPulseGuiding", "RightAscension", "SideOfPier", "SiderealTime",
                                           "Slewing", "Tracking", "UTCDate"}


def test_routes_and_duplicates() -> None:
    table = routes(MEMBERS)
    assert len(table["GET"]) + len(table["PUT"]) == 96
    assert table["PUT"]["unpark"].handler == "unpark"
    with pytest.raises(ValueError, match="duplicate"):
        routes([*MEMBERS, MEMBERS[0]])


def test_param_types_restricted() -> None:
    with pytest.raises(ValueError):
        Param("Rates", ValueType.AXIS_RATES)


def test_reference_lists_every_member() -> None:
    text = reference_markdown()
    for m in MEMBERS:
        assert f"/api/v1/telescope/{{n}}/{m.path}`" in text
        assert f"`{m.answered_by}" in text
    assert "`move_axis(axis=, rate=)`" in text
    assert "`set_tracking(value)`" in text
    assert "`capabilities.axis_rates(axis=)`" in text
    assert "`connection.set_connected(value)`" in text
    assert "`constant True`" in text


def test_missing_handlers_reports_names() -> None:
    class Partial:
        device_name = "x"

        def tracking(self) -> bool:
            return True

    lacking = missing_handlers(Partial(), MEMBERS)
    assert "tracking" not in lacking
    assert "set_tracking" in lacking and "unique_id" in lacking
    assert "connection.connected" in lacking and "capabilities.axis_rates" in lacking


def test_missing_handlers_looks_on_the_owner_and_at_the_parameters() -> None:
    """A handler on the wrong part, or taking other parameters than the row's, is as good as missing."""

    class Capabilities:
        def axis_rates(self, axis: int) -> list[tuple[float, float]]:
            return []

        def can_move_axis(self, axes: int) -> bool:  # mis-named keyword
            return True

        def set_site_latitude(self, value: float, extra: float) -> None:  # a setter takes one value
            pass

    class Device:
        device_name = unique_id = "x"
        capabilities = Capabilities()

        def site_longitude(self) -> float:  # on the device, but the table says capabilities
            return 0.0

    lacking = missing_handlers(Device(), MEMBERS)
    assert "capabilities.axis_rates" not in lacking
    assert "capabilities.can_move_axis taking ['axis']" in lacking
    assert "capabilities.set_site_latitude taking (value)" in lacking
    assert "capabilities.site_longitude" in lacking


def test_create_app_refuses_a_device_lacking_a_handler() -> None:
    from alpaca_zwo.alpaca import ServerInfo, create_app
    from alpaca_zwo.clients import ClientRegistry

    class Nameless:
        device_name = unique_id = "x"

    with pytest.raises(TypeError, match=r"lacks .*connection\.connected"):
        create_app([Nameless()], ClientRegistry(), ServerInfo("s", "m", "0", "l"))


def test_member_is_frozen() -> None:
    member: Member = MEMBERS[0]
    with pytest.raises(AttributeError):
        member.name = "x"  # type: ignore[misc]
