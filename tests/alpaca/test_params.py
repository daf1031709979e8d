"""Strict wire parsers and reply renderers, without HTTP."""

from __future__ import annotations

import json
import math
import threading
from datetime import datetime, timedelta, timezone
from urllib.parse import parse_qsl

import pytest
from hypothesis import given
from hypothesis import strategies as st

from alpaca_zwo.alpaca.members import Param, ValueType
from alpaca_zwo.alpaca.params import (
    UINT32_MAX,
    BadRequest,
    form_fields,
    missing,
    parse_bool,
    parse_float,
    parse_id,
    parse_int,
    parse_uint32,
    parse_utc_date,
    query_fields,
    split_pairs,
)
from alpaca_zwo.alpaca.render import (
    RENDERERS,
    TransactionCounter,
    error_body,
    format_utc_date,
    method_body,
    value_body,
)

UTC = timezone.utc

# --- transaction IDs ---------------------------------------------------------------------------


@pytest.mark.parametrize("text", ["0", "1", "67890", "4294967295", "00012"])
def test_uint32_accepts(text: str) -> None:
    assert parse_uint32(text) == int(text)


@pytest.mark.parametrize("text", ["", "     ", "-12345", "NASDAQ", "qweqwe", "-67890", "4294967296",
                                  "+5", " 5", "5 ", "1_000", "1.0", "٣", "²", "99999999999", "0x10"])
def test_uint32_rejects(text: str) -> None:
    assert parse_uint32(text) is None


@given(st.integers(min_value=0, max_value=UINT32_MAX))
def test_uint32_round_trip(value: int) -> None:
    assert parse_uint32(str(value)) == value


@given(st.integers(min_value=UINT32_MAX + 1, max_value=10**12))
def test_uint32_too_big(value: int) -> None:
    assert parse_uint32(str(value)) is None


def test_parse_id_absent_is_zero_and_invalid_names_itself() -> None:
    assert parse_id("ClientID", None) == 0
    with pytest.raises(BadRequest, match="ClientTransactionID='-1'"):
        parse_id("ClientTransactionID", "-1")


# --- values ------------------------------------------------------------------------------------


@pytest.mark.parametrize(("text", "expected"), [("true", True), ("True", True), ("TRUE", True),
                                                ("false", False), ("False", False), ("fAlSe", False)])
def test_bool(text: str, expected: bool) -> None:
    assert parse_bool("Tracking", text) is expected


@pytest.mark.parametrize("text", ["", "1", "0", "yes", " true", "true ", "asduio6fghZZ", "t"])
def test_bool_rejects(text: str) -> None:
    with pytest.raises(BadRequest, match="Tracking"):
        parse_bool("Tracking", text)


@pytest.mark.parametrize(("text", "expected"), [("0", 0), ("-1", -1), ("+3", 3), ("2147483647", 2**31 - 1),
                                                ("-2147483648", -(2**31)), ("007", 7)])
def test_int(text: str, expected: int) -> None:
    assert parse_int("Axis", text) == expected


@pytest.mark.parametrize("text", ["", " ", "1.0", "1e3", "1_000", "1,000", "+", "-", " 1", "1 ", "nan",
                                  "2147483648", "-2147483649", "٣", "0x1", "asduio6fghZZ", "12345678901"])
def test_int_rejects(text: str) -> None:
    with pytest.raises(BadRequest, match="Axis"):
        parse_int("Axis", text)


@pytest.mark.parametrize(("text", "expected"), [("0", 0.0), ("0.0", 0.0), ("-1.5", -1.5), ("+2", 2.0),
                                                ("1.", 1.0), (".5", 0.5), ("1e3", 1000.0), ("1.5E-3", 0.0015),
                                                ("23.9999999999", 23.9999999999), ("-0.0", -0.0)])
def test_float(text: str, expected: float) -> None:
    assert parse_float("Rate", text) == expected


@pytest.mark.parametrize("text", ["", " ", "nan", "NaN", "inf", "-inf", "Infinity", "1e999", "1,5",
                                  "23,456", "1_000", " 1.0", "1.0 ", "1.0.0", "asduio6fghZZ", "0x1p3",
                                  "١.٥", "e5", ".", "+-1"])
def test_float_rejects(text: str) -> None:
    with pytest.raises(BadRequest, match="Rate"):
        parse_float("Rate", text)


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_float_round_trip(value: float) -> None:
    assert parse_float("Rate", repr(value)) == value


@pytest.mark.parametrize(("text", "expected"), [
    ("2016-03-04T17:45:31Z", datetime(2016, 3, 4, 17, 45, 31, tzinfo=UTC)),
    ("2016-03-04T17:45:31.1Z", datetime(2016, 3, 4, 17, 45, 31, 100000, tzinfo=UTC)),
    ("2016-03-04T17:45:31.1234567Z", datetime(2016, 3, 4, 17, 45, 31, 123456, tzinfo=UTC)),
    ("2022-12-04T17:45:31.1234567Z", datetime(2022, 12, 4, 17, 45, 31, 123456, tzinfo=UTC)),
    # alpyca sends datetime.isoformat(): an explicit offset is converted, not guessed.
    ("2024-01-01T12:00:00+00:00", datetime(2024, 1, 1, 12, tzinfo=UTC)),
    ("2024-01-01T12:00:00.5+02:00", datetime(2024, 1, 1, 10, 0, 0, 500000, tzinfo=UTC)),
    ("2024-01-01T01:00:00-03:30", datetime(2024, 1, 1, 4, 30, tzinfo=UTC)),
])
def test_utc_date(text: str, expected: datetime) -> None:
    parsed = parse_utc_date("UTCDate", text)
    assert parsed == expected
    assert parsed.tzinfo == UTC


@pytest.mark.parametrize("text", ["", "2016-03-04T17:45:31", "2016-03-04 17:45:31Z", "2016-03-04T17:45:31.Z",
                                  "2016-13-04T17:45:31Z",
                                  "2016-02-30T00:00:00Z", "2016-03-04T24:00:00Z", "2016-03-04T17:45:31z",
                                  "2016-03-04t17:45:31Z", "2016-03-04T17:45:31 Z", "04/03/2016",
                                  "2016-03-04T17:45:31+25:00", "2016-03-04T17:45:31+0000", "asduio6fghZZ",
                                  "0001-01-01T00:00:00+01:00"])
def test_utc_date_rejects(text: str) -> None:
    with pytest.raises(BadRequest, match="UTCDate"):
        parse_utc_date("UTCDate", text)


# --- field extraction --------------------------------------------------------------------------


def test_query_fields_lower_cases_and_keeps_blanks() -> None:
    assert query_fields("ClientID=&aXIS=1&Extra=x+y") == {"clientid": "", "axis": "1", "extra": "x y"}
    assert query_fields("") == {}


def test_form_fields_keep_case_and_blanks() -> None:
    assert form_fields(b"Tracking=True&clientid=&A=%26") == {"Tracking": "True", "clientid": "", "A": "&"}
    assert form_fields(b"") == {}
    with pytest.raises(BadRequest, match="UTF-8"):
        form_fields(b"Tracking=\xff")


def test_missing_message_names_miscased_key() -> None:
    param = Param("Tracking", ValueType.BOOL)
    assert "tRACKING" in missing(param, {"tRACKING": "True"}, case_sensitive=True).message
    assert missing(param, {}, case_sensitive=False).message == "Missing parameter Tracking"


# --- rendering ---------------------------------------------------------------------------------


def test_format_utc_date_seven_digits_and_z() -> None:
    stamp = datetime(2024, 1, 31, 21, 5, 0, 123456, tzinfo=UTC)
    assert format_utc_date(stamp) == "2024-01-31T21:05:00.1234560Z"
    assert format_utc_date(datetime(5, 1, 1, tzinfo=UTC)) == "0005-01-01T00:00:00.0000000Z"
    eastern = timezone(timedelta(hours=-5))
    assert format_utc_date(datetime(2024, 1, 1, 19, 0, tzinfo=eastern)) == "2024-01-02T00:00:00.0000000Z"
    with pytest.raises(ValueError, match="naive"):
        format_utc_date(datetime(2024, 1, 1))


@given(st.datetimes(min_value=datetime(1900, 1, 1), max_value=datetime(2200, 1, 1), timezones=st.just(UTC)))
def test_utc_date_round_trip(value: datetime) -> None:
    assert parse_utc_date("UTCDate", format_utc_date(value)) == value


def test_renderers() -> None:
    assert RENDERERS[ValueType.AXIS_RATES]([(0.0, 4.0), (5, 6)]) == [{"Minimum": 0.0, "Maximum": 4.0},
                                                                     {"Minimum": 5, "Maximum": 6}]
    stamp = datetime(2024, 1, 1, tzinfo=UTC)
    state = RENDERERS[ValueType.DEVICE_STATE]([("Tracking", True), ("UTCDate", stamp)])
    assert state == [{"Name": "Tracking", "Value": True},
                     {"Name": "UTCDate", "Value": "2024-01-01T00:00:00.0000000Z"}]


def test_bodies_have_exact_keys_in_order() -> None:
    assert list(json.loads(value_body(1.5, 3, 4))) == ["Value", "ClientTransactionID", "ServerTransactionID",
                                                       "ErrorNumber", "ErrorMessage"]
    assert json.loads(method_body(3, 4)) == {"ClientTransactionID": 3, "ServerTransactionID": 4,
                                             "ErrorNumber": 0, "ErrorMessage": ""}
    assert json.loads(error_body(0.0, 3, 4, 0x401, "bad")) == {
        "Value": 0.0, "ClientTransactionID": 3, "ServerTransactionID": 4, "ErrorNumber": 0x401,
        "ErrorMessage": "bad"}
    assert json.loads(error_body((), 3, 4, 0x407, "off"))["Value"] == []
    assert "Value" not in json.loads(error_body(None, 3, 4, 0x401, "bad"))


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, [1.0, math.nan], {"x": math.inf}])
def test_nan_is_refused(value: object) -> None:
    with pytest.raises(ValueError):
        value_body(value, 0, 1)


def test_transaction_counter_wraps_to_one() -> None:
    counter = TransactionCounter(start=TransactionCounter.MAX - 1)
    assert [counter.next() for _ in range(4)] == [TransactionCounter.MAX - 1, TransactionCounter.MAX, 1, 2]


def test_transaction_counter_is_unique_across_threads() -> None:
    counter = TransactionCounter()
    seen: list[list[int]] = []

    def work() -> None:
        mine = [counter.next() for _ in range(2000)]
        seen.append(mine)

    threads = [threading.Thread(target=work) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    everything = [n for mine in seen for n in mine]
    assert sorted(everything) == list(range(1, 16001))
    assert all(mine == sorted(mine) for mine in seen)


_QUERY_PIECES = st.sampled_from([*"aZ09=&+%;._-~ é", "%20", "%2", "%zz", "%C3%A9", "%26", "%FF"])
_QUERY_TEXT = st.lists(_QUERY_PIECES, max_size=20).map("".join)


@given(_QUERY_TEXT)
def test_split_pairs_matches_parse_qsl(text: str) -> None:
    assert split_pairs(text) == parse_qsl(text, keep_blank_values=True)


@given(st.one_of(st.booleans(), st.integers(), st.floats(allow_nan=False, allow_infinity=False), st.text(),
                 st.lists(st.integers()), st.none()))
def test_value_body_is_the_json_of_the_envelope(value: object) -> None:
    expected = {"Value": value, "ClientTransactionID": 7, "ServerTransactionID": 9, "ErrorNumber": 0,
                "ErrorMessage": ""}
    body = value_body(value, 7, 9)
    assert json.loads(body) == expected
    assert body == json.dumps(expected, separators=(",", ":")).encode()
