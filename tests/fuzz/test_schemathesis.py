"""Schemathesis against the official Alpaca OpenAPI files, on a live server with the emulator behind it.

Every telescope and common Device API operation and every Management API operation is fuzzed with
schema-valid and schema-violating requests (schemathesis' examples, coverage and fuzzing phases).
Each reply must: never be a 5xx, conform to the official schema (patched only where the schema
itself is wrong: see ``spec_fixes.py``, SPEC PROBLEM 1-6), and keep the Alpaca rules the schema
cannot express. About one case in five is sent to a device number or type this server does not
have, to hold it to the documented 400. Afterwards the server must still serve and the mount's state
must be coherent, with motion still working.

CI runs a bounded number of examples per operation (``ALPACA_FUZZ_EXAMPLES``, default 25,
derandomized so CI is repeatable); ``long_run.py`` does the 20,000+ request run.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import requests
import yaml
from hypothesis import HealthCheck, settings
from schemathesis import Case

from alpaca_zwo.alpaca.members import DEVICE_MEMBERS, ValueType, routes
from tests.fuzz.alpaca_fuzz import (
    LiveServer,
    Stats,
    check_consistent,
    exercise,
    start_live_server,
)
from tests.fuzz.spec_fixes import (
    DEVICE_SPEC,
    MANAGEMENT_SPEC,
    SPEC_SHA256,
    bound_integer_formats,
    device_spec,
    load_device_schema,
    load_management_schema,
    spec_sha256,
    upstream_sha256,
)

EXAMPLES = int(os.environ.get("ALPACA_FUZZ_EXAMPLES", "25"))
DERANDOMIZE = os.environ.get("ALPACA_FUZZ_RANDOM", "") == ""
FUZZ_SETTINGS = settings(max_examples=EXAMPLES, deadline=None, derandomize=DERANDOMIZE, database=None,
                         suppress_health_check=list(HealthCheck), print_blob=True)

device_schema = load_device_schema()
management_schema = load_management_schema()
STATS = Stats()


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    server = start_live_server(tmp_path_factory.mktemp("fuzz") / "config.toml")
    yield server
    server.server.stop()
    stats_path = os.environ.get("ALPACA_FUZZ_STATS")
    if stats_path:  # long_run.py reads what this session did
        Path(stats_path).write_text(json.dumps(STATS.summary(), indent=2, default=str), encoding="utf-8")


def run(case: Case, live: LiveServer, base_path: str) -> None:
    problems = exercise(case, live.base_url + base_path, live.keeper.session, STATS)
    live.keeper.after(case)
    if STATS.requests % 97 == 0:
        live.keeper.check_state()
    assert not problems, "\n\n".join(problems)


@device_schema.parametrize()
@FUZZ_SETTINGS
def test_device_api(case: Case, live: LiveServer) -> None:
    run(case, live, "/api/v1")


@management_schema.parametrize()
@FUZZ_SETTINGS
def test_management_api(case: Case, live: LiveServer) -> None:
    run(case, live, "")


def test_server_still_serves_and_state_is_consistent(live: LiveServer) -> None:
    """Runs after the fuzzing above (file order): everything still answers and hangs together."""
    check_consistent(live)
    assert STATS.statuses.get(500, 0) == 0
    if STATS.requests:  # the fuzz tests ran in this session (not deselected)
        assert STATS.kinds["telescope0"] and STATS.kinds["absent-device"] and STATS.kinds["negative-path"]


def test_operations_under_test() -> None:
    """All 80 telescope + common Device API paths (96 operations) and the 5 management ones."""
    device_ops = [result.ok() for result in device_schema.get_all_operations()]
    assert len(device_ops) == 96
    assert len({op.path for op in device_ops}) == 80
    assert all(op.path.startswith(("/telescope/", "/{device_type}/")) for op in device_ops)
    assert len([result.ok() for result in management_schema.get_all_operations()]) == 5


@pytest.mark.parametrize("path", [DEVICE_SPEC, MANAGEMENT_SPEC], ids=lambda p: Path(p).name)
def test_spec_copies_match_upstream(path: Path) -> None:
    """The YAML files are the upstream bytes except the one documented edit (SPEC_EDIT)."""
    assert upstream_sha256(path) == SPEC_SHA256[path.name]
    if path == DEVICE_SPEC:
        assert spec_sha256(path) != SPEC_SHA256[path.name]  # the edit is really there...
        reply = yaml.safe_load(path.read_text(encoding="utf-8"))["components"]["schemas"]["AlpacaResponse"]
        assert reply["properties"]["ClientTransactionID"]["minimum"] == 0  # ...and is what it says


def test_spec_patches_still_needed() -> None:
    """If upstream fixes a spec problem, the correction stops changing anything and this says so."""
    raw = yaml.safe_load(DEVICE_SPEC.read_text(encoding="utf-8"))
    patched = device_spec()
    assert "maximum" not in raw["components"]["parameters"]["device_number"]["schema"]  # SPEC PROBLEM 1
    assert patched["components"]["parameters"]["device_number"]["schema"]["maximum"] == 4294967295
    assert raw["components"]["schemas"]["AlpacaRequest"]["properties"]["ClientID"]["minimum"] == 1  # PROBLEM 2
    state = raw["components"]["responses"]["DeviceStateResponse"]["content"]["application/json"]["schema"]
    assert "oneOf" in state["allOf"][1]["properties"]["Value"]["items"]["properties"]["Value"]  # PROBLEM 3
    put = raw["paths"]["/telescope/{device_number}/slewtocoordinatesasync"]["put"]
    assert "required" not in put["requestBody"]  # SPEC PROBLEM 4
    management = yaml.safe_load(MANAGEMENT_SPEC.read_text(encoding="utf-8"))
    assert "400" not in management["paths"]["/management/v1/description"]["get"]["responses"]  # PROBLEM 5
    assert raw["components"]["schemas"]["RightAscension"]["maximum"] == 23.9999999999  # SPEC PROBLEM 6


def test_no_correction_touches_reply_values() -> None:
    """Error replies are held to the published Value types: no correction may widen a reply's Value."""
    raw = yaml.safe_load(DEVICE_SPEC.read_text(encoding="utf-8"))
    bound_integer_formats(raw)  # SPEC PROBLEM 1 only narrows (int32/uint32 ranges), so it is allowed here
    patched = device_spec()
    for name, response in raw["components"]["responses"].items():
        if name == "DeviceStateResponse":
            continue  # SPEC PROBLEM 3 is inside the items of an array, not the reply's Value type
        assert patched["components"]["responses"][name] == response, name


GET_PARAMS = {"axis": "0", "rightascension": "1.5", "declination": "10.0"}


def _check_every_get(base_url: str) -> dict[int, int]:
    """GET every telescope and common member once; each reply must match its official schema."""
    session = requests.Session()
    errors: dict[int, int] = {}
    for result in device_schema.get_all_operations():
        operation = result.ok()
        if operation.method.upper() != "GET":
            continue
        member = operation.path.rsplit("/", 1)[-1]
        url = f"{base_url}/api/v1/telescope/0/{member}"
        query = {p.name: GET_PARAMS[p.name.lower()] for p in operation.query if p.name.lower() in GET_PARAMS}
        response = session.get(url, params={**query, "ClientTransactionID": "7"}, timeout=30)
        assert response.status_code == 200, (member, response.text)
        operation.validate_response(response)  # raises on any schema violation, Value type included
        body = response.json()
        assert body["Value"] is not None and body["ClientTransactionID"] == 7, (member, body)
        errors[body["ErrorNumber"]] = errors.get(body["ErrorNumber"], 0) + 1
    return errors


def test_every_get_error_reply_matches_the_official_schema(server_factory: Any) -> None:
    """Deterministic companion to the fuzzing: error replies of every GET, not only those it happens on.

    Disconnected, every member that needs the mount answers NotConnected (0x407); connected, the
    unset targets answer ValueNotSet (0x402). Each reply carries its member's default Value.
    """
    server = server_factory()
    base_url = f"http://127.0.0.1:{server.port}"
    disconnected = _check_every_get(base_url)
    assert disconnected.get(0x407, 0) >= 15, disconnected
    reply = requests.put(f"{base_url}/api/v1/telescope/0/connected", data={"Connected": "true"}, timeout=30)
    assert reply.json()["ErrorNumber"] == 0
    connected = _check_every_get(base_url)
    assert connected.get(0x402, 0) == 2 and 0x407 not in connected, connected


PUT_SAMPLES = {ValueType.BOOL: "true", ValueType.INT: "0", ValueType.FLOAT: "1.5", ValueType.STR: "zwo:Nope",
               ValueType.UTCDATE: "2024-01-31T21:05:00.0000000Z"}
CONNECTION_MEMBERS = ("connect", "connected", "disconnect")


def test_every_put_error_reply_matches_the_official_schema(server_factory: Any) -> None:
    """Disconnected, every PUT fails; a method's error reply has no Value, Action/Command* carry their default."""
    server = server_factory()
    base_url = f"http://127.0.0.1:{server.port}"
    session = requests.Session()
    members = routes(DEVICE_MEMBERS["telescope"])["PUT"]
    errors = 0
    for result in device_schema.get_all_operations():
        operation = result.ok()
        path = operation.path.rsplit("/", 1)[-1]
        if operation.method.upper() != "PUT" or path in CONNECTION_MEMBERS:
            continue
        member = members[path]
        form = {p.name: PUT_SAMPLES[p.type] for p in member.params}
        response = session.put(f"{base_url}/api/v1/telescope/0/{path}", data={**form, "ClientTransactionID": "9"},
                               timeout=30)
        assert response.status_code == 200, (path, response.text)
        operation.validate_response(response)
        body = response.json()
        assert body["ClientTransactionID"] == 9, (path, body)
        if body["ErrorNumber"]:
            errors += 1
            if member.returns is None:
                assert "Value" not in body, (path, body)
            else:
                assert body["Value"] == member.error_value, (path, body)
    assert errors >= 25
