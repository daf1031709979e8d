"""The official Alpaca OpenAPI files as the fuzz suite loads them, and where they are corrected.

The two YAML files in ``spec/`` are copies of ASCOMInitiative/ASCOMRemote ``Swagger/`` at commit
bf34ab38aa81947a5ae4e5674ac2fd714fcb5836 (MIT licence header kept; provenance and sha256 sums in
``shared/alpaca/spec/SOURCE.md``). The management file is byte-for-byte upstream; the device file
differs in exactly one place, :data:`SPEC_EDIT` (the reply ClientTransactionID minimum, 1 -> 0, with
a comment in the file saying why), and ``test_spec_copies_match_upstream`` proves both.

Where the official schema is itself wrong (SPEC PROBLEM 1-6 below, each with its reason and a test
that it is still there upstream), :func:`device_spec` and :func:`management_spec` correct the loaded
dict; one more entry is a deliberate, documented server leniency. Nothing here relaxes a rule the
server could keep: an error reply's ``Value`` in particular is held to the member's schema type
(the server sends the type's default, never null), which ``test_no_correction_touches_reply_values``
guards.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import schemathesis
import yaml

SPEC_DIR = Path(__file__).parent / "spec"
DEVICE_SPEC = SPEC_DIR / "AlpacaDeviceAPI_v1.yaml"
MANAGEMENT_SPEC = SPEC_DIR / "AlpacaManagementAPI_v1.yaml"
#: The one change in the device YAML copy (protocol-rules §15.10): (upstream text, text in the copy).
SPEC_EDIT = (
    "          minimum: 1\n          description: Client's transaction ID (1 to 4294967295), as supplied",
    "          # alpaca-zwo test copy, the ONE change from upstream: minimum lowered from 1 to 0. A device must\n"
    "          # echo 0 when the client sent no ClientTransactionID (Alpaca Reference 2.6; this description's own\n"
    "          # \"Zero indicates that a valid value was not supplied\"; ConformU checks it; protocol-rules 15.10).\n"
    "          minimum: 0\n          description: Client's transaction ID (1 to 4294967295), as supplied",
)
#: sha256 of the upstream files (shared/alpaca/spec/SOURCE.md).
SPEC_SHA256 = {
    DEVICE_SPEC.name: "3c8d9569d0a6dbedea6393a05b87dba64c185f972a556bc4c833d7b43697ce1b",
    MANAGEMENT_SPEC.name: "986080e160d5bbe1fd0a7f9349d39d8904d58e666f7c25f72a7c47270d276aa0",
}

UINT32_MAX = 4294967295
INT32_MIN, INT32_MAX = -(2**31), 2**31 - 1
#: Device-API paths that belong to a telescope: its own and the common ones.
DEVICE_PATHS = r"^/(telescope|\{device_type\})/"


def spec_sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def upstream_sha256(path: Path) -> str:
    """sha256 of the copy with :data:`SPEC_EDIT` undone: equal to upstream's iff that is the only change."""
    text = path.read_bytes().decode("utf-8")
    if path == DEVICE_SPEC:
        assert text.count(SPEC_EDIT[1]) == 1, "the documented edit is missing from the device spec copy"
        text = text.replace(SPEC_EDIT[1], SPEC_EDIT[0])
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


# ================================================================================================
# The official schemas, and where they are wrong
# ================================================================================================


def _walk(node: Any) -> Iterator[dict[str, Any]]:
    """Every mapping in a loaded YAML tree (schemas nest in lists and mappings alike)."""
    if isinstance(node, dict):
        yield node
        for value in node.values():
            yield from _walk(value)
    elif isinstance(node, list):
        for value in node:
            yield from _walk(value)


def bound_integer_formats(raw: dict[str, Any]) -> int:
    """SPEC PROBLEM 1: ``format: uint32`` / ``int32`` without ``minimum``/``maximum``.

    In OpenAPI 3.1 (JSON Schema 2020-12) ``format`` is an annotation, not a constraint, so the
    schema as written accepts ClientID 10**20 or Duration 2**40, which the spec's own prose ("1 to
    4294967295") and every real client rule out, and a generator produces them as *valid* data. The
    intended range is added explicitly; existing tighter bounds are kept.
    """
    patched = 0
    for node in _walk(raw):
        fmt = node.get("format")
        if node.get("type") == "integer" and fmt in ("uint32", "int32"):
            low, high = (0, UINT32_MAX) if fmt == "uint32" else (INT32_MIN, INT32_MAX)
            node["minimum"] = max(node.get("minimum", low), low)
            node["maximum"] = min(node.get("maximum", high), high)
            patched += 1
    return patched


def _allow_zero_request_ids(raw: dict[str, Any]) -> None:
    """SPEC PROBLEM 2: request ClientID / ClientTransactionID ``minimum: 1``.

    The Device API says 1..4294967295 ("zero is reserved, clients should not use it"), the
    Management API says 0..4294967295 for the very same parameters, and the Reference (§2.6)
    recommends ClientID 0..65535 and does not require servers to reject 0. The server accepts the
    wider range (protocol-rules §15.3), so 0 is treated as valid data here rather than as data the
    server must refuse.

    (The *reply* ClientTransactionID ``minimum: 1`` is the one change made in the YAML copy itself:
    see the comment there and :data:`SPEC_EDIT`.)
    """
    components = raw["components"]
    for name in ("ClientIDQuery", "ClientTransactionIDQuery"):
        components["parameters"][name]["schema"]["minimum"] = 0
    for prop in ("ClientID", "ClientTransactionID"):
        components["schemas"]["AlpacaRequest"]["properties"][prop]["minimum"] = 0


def _device_state_values_any_of(raw: dict[str, Any]) -> None:
    """SPEC PROBLEM 3: DeviceState item ``Value`` is a ``oneOf`` with two string branches.

    The branches are "type: string" and "type: string, format: date-time, pattern ...Z". ``oneOf``
    requires exactly one match, so every ISO 8601 date (UTCDate, TimeStamp: the values the
    description says must be ISO strings) matches both and is rejected. ``anyOf`` is what is meant.
    """
    state = raw["components"]["responses"]["DeviceStateResponse"]["content"]["application/json"]["schema"]
    item_value = state["allOf"][1]["properties"]["Value"]["items"]["properties"]["Value"]
    item_value["anyOf"] = item_value.pop("oneOf")


def _action_parameters_optional(raw: dict[str, Any]) -> None:
    """DELIBERATE SERVER LENIENCY (not a spec error): ``Action`` without ``Parameters``.

    The spec makes ``Parameters`` required, but alpyca, the ASCOM Initiative's own Python client,
    omits the field when an action is called without parameters (``T.Action("zwo:MountInfo")``),
    which is how every ZWO action reads; the server treats a missing field as "" (members.py) so
    that client works. Liberal in what it accepts (Reference §1.7), so the field is optional here.
    Replies are untouched: an Action reply is still held to the StringResponse schema.
    """
    body = raw["paths"]["/{device_type}/{device_number}/action"]["put"]["requestBody"]
    schema = body["content"]["application/x-www-form-urlencoded"]["schema"]
    for part in schema["allOf"]:
        if "required" in part:
            part["required"] = [name for name in part["required"] if name != "Parameters"]


def _bodies_with_required_fields_are_required(raw: dict[str, Any]) -> int:
    """SPEC PROBLEM 4: no PUT ``requestBody`` is marked ``required: true``.

    OpenAPI's ``requestBody.required`` defaults to false, so by the letter of the file
    ``PUT /telescope/0/slewtocoordinatesasync`` with no body at all is a valid request, although the
    body schema requires RightAscension and Declination; a server can only answer it 400. Bodies
    whose schema has required properties are marked required.
    """
    patched = 0
    bodies = raw["components"].get("requestBodies", {})
    for operations in raw["paths"].values():
        put = operations.get("put")
        if put is None or "requestBody" not in put:
            continue
        body = put["requestBody"]
        if "$ref" in body:
            body = bodies[body["$ref"].rsplit("/", 1)[-1]]
        schema = body["content"]["application/x-www-form-urlencoded"]["schema"]
        parts = schema.get("allOf", [schema])
        if any(part.get("required") for part in parts):
            if "$ref" in put["requestBody"]:
                put["requestBody"] = {**body, "required": True}
            else:
                body["required"] = True
            patched += 1
    return patched


def _right_ascension_below_24(raw: dict[str, Any]) -> None:
    """SPEC PROBLEM 6: ``RightAscension`` has ``maximum: 23.9999999999``.

    Right ascension is 0 <= RA < 24 hours (ASCOM; ConformU flags ``>= 24``). The decimal cut-off
    makes a perfectly good 23.99999999995 "invalid", in requests and in replies (an RA read just
    before 0h), though no such value is wrong; the range meant is ``exclusiveMaximum: 24``.
    """
    schema = raw["components"]["schemas"]["RightAscension"]
    del schema["maximum"]
    schema["exclusiveMaximum"] = 24.0


def device_spec() -> dict[str, Any]:
    raw = yaml.safe_load(DEVICE_SPEC.read_text(encoding="utf-8"))
    _action_parameters_optional(raw)
    _bodies_with_required_fields_are_required(raw)
    _right_ascension_below_24(raw)
    _allow_zero_request_ids(raw)
    bound_integer_formats(raw)
    _device_state_values_any_of(raw)
    return raw


def _management_400_for_bad_parameters(raw: dict[str, Any]) -> None:
    """SPEC PROBLEM 5: description and configureddevices document no 400.

    All three management GETs take the same optional ClientID / ClientTransactionID, but only
    apiversions documents "400: Method or parameter value error"; the other two list 200, 403
    and 500, so a malformed ``ClientTransactionID=abc`` has no documented answer there. The
    server answers 400 text/plain on all three, as apiversions and the whole Device API specify.
    """
    bad_request = raw["paths"]["/management/apiversions"]["get"]["responses"]["400"]
    for path in ("/management/v1/description", "/management/v1/configureddevices"):
        raw["paths"][path]["get"]["responses"].setdefault("400", bad_request)


def management_spec() -> dict[str, Any]:
    raw = yaml.safe_load(MANAGEMENT_SPEC.read_text(encoding="utf-8"))
    bound_integer_formats(raw)
    _management_400_for_bad_parameters(raw)
    return raw


def load_device_schema() -> Any:
    return schemathesis.openapi.from_dict(device_spec()).include(path_regex=DEVICE_PATHS)


def load_management_schema() -> Any:
    return schemathesis.openapi.from_dict(management_spec())
