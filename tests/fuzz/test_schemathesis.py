"""Schemathesis against the official Alpaca OpenAPI files, on a live server with the emulator behind it.

Every telescope and common Device API operation and every Management API operation is fuzzed with
schema-valid and schema-violating requests (schemathesis' examples, coverage and fuzzing phases).
Each reply must: never be a 5xx, conform to the official schema (patched only where the schema
itself is wrong: see ``alpaca_fuzz.py``, SPEC PROBLEM 1-6), and keep the Alpaca rules the schema
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

import pytest
from hypothesis import HealthCheck, settings
from schemathesis import Case

from tests.fuzz.alpaca_fuzz import (
    DEVICE_SPEC,
    MANAGEMENT_SPEC,
    SPEC_SHA256,
    LiveServer,
    Stats,
    check_consistent,
    device_spec,
    exercise,
    load_device_schema,
    load_management_schema,
    spec_sha256,
    start_live_server,
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
    check_consistent(live.keeper, live.base_url, live.site)
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
def test_spec_copies_are_pristine(path: Path) -> None:
    """The YAML files are the upstream bytes; every correction lives in code, with its reason."""
    assert spec_sha256(path) == SPEC_SHA256[path.name]


def test_spec_patches_still_needed() -> None:
    """If upstream fixes a spec problem, the patch stops changing anything and this says so."""
    import yaml

    raw = yaml.safe_load(DEVICE_SPEC.read_text(encoding="utf-8"))
    patched = device_spec()
    response = raw["components"]["schemas"]["AlpacaResponse"]["properties"]["ClientTransactionID"]
    assert response["minimum"] == 1  # SPEC PROBLEM 2
    assert "maximum" not in raw["components"]["parameters"]["device_number"]["schema"]  # SPEC PROBLEM 1
    state = raw["components"]["responses"]["DeviceStateResponse"]["content"]["application/json"]["schema"]
    assert "oneOf" in state["allOf"][1]["properties"]["Value"]["items"]["properties"]["Value"]  # PROBLEM 4
    put = raw["paths"]["/telescope/{device_number}/slewtocoordinatesasync"]["put"]
    assert "required" not in put["requestBody"]  # SPEC PROBLEM 5
    assert raw["components"]["schemas"]["RightAscension"]["maximum"] == 23.9999999999  # SPEC PROBLEM 7
    assert patched["components"]["parameters"]["device_number"]["schema"]["maximum"] == 4294967295
