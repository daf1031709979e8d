"""The member table against the official Alpaca spec, and the AlpacaDevice protocol against the table."""

from __future__ import annotations

import inspect
from pathlib import Path

import pytest

from alpaca_zwo.alpaca.device import AlpacaDevice, missing_handlers
from alpaca_zwo.alpaca.members import (
    COMMON_MEMBERS,
    DEVICE_MEMBERS,
    TELESCOPE_DEVICE_STATE,
    TELESCOPE_MEMBERS,
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


_ANNOTATIONS = {ValueType.BOOL: "bool", ValueType.INT: "int", ValueType.FLOAT: "float",
                ValueType.STR: "str", ValueType.UTCDATE: "datetime", ValueType.STR_LIST: "list[str]",
                ValueType.INT_LIST: "list[int]", ValueType.AXIS_RATES: "AxisRateList",
                ValueType.DEVICE_STATE: "DeviceStateList", None: "None"}


def test_protocol_matches_table() -> None:
    declared = {name for name, value in vars(AlpacaDevice).items()
                if inspect.isfunction(value) and not name.startswith("_")}
    assert declared == {m.handler for m in MEMBERS}
    for m in MEMBERS:
        signature = inspect.signature(getattr(AlpacaDevice, m.handler))
        params = list(signature.parameters.values())[1:]
        if m.setter:
            assert [p.name for p in params] == ["value"], m.handler
            assert params[0].annotation == _ANNOTATIONS[m.params[0].type], m.handler
        else:
            assert [p.name for p in params] == [p.kwarg for p in m.params], m.handler
            assert [p.annotation for p in params] == [_ANNOTATIONS[p.type] for p in m.params], m.handler
        assert signature.return_annotation == _ANNOTATIONS[m.returns], m.handler
    for identity in ("device_name", "unique_id"):  # read-only properties the management API reads
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
        assert f"`{m.handler}(" in text
    assert "`move_axis(axis=, rate=)`" in text
    assert "`set_tracking(value)`" in text


def test_missing_handlers_reports_names() -> None:
    class Partial:
        device_name = "x"

        def tracking(self) -> bool:
            return True

    lacking = missing_handlers(Partial(), MEMBERS)
    assert "tracking" not in lacking
    assert "set_tracking" in lacking and "unique_id" in lacking


def test_member_is_frozen() -> None:
    member: Member = MEMBERS[0]
    with pytest.raises(AttributeError):
        member.name = "x"  # type: ignore[misc]
