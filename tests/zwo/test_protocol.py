"""The ZWO command language: table completeness, formats, parsers, reply kinds and framing."""

from __future__ import annotations

import contextlib
import itertools
from datetime import date, time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from alpaca_zwo._exceptions import MountReplyError, ProtocolError
from alpaca_zwo.zwo import protocol as p
from alpaca_zwo.zwo import request_framer
from alpaca_zwo.zwo import wire_values as w

# Every command of ZWO's V1.1 document and every real command of field-notes §2 named in the issue.
DOCUMENT_CODES = {
    "SC", "GC", "SL", "GL", "SS", "GS", "GH", "SH", "SG", "GG", "St", "Gt", "Sg", "Gg", "Gm", "Sr", "Gr",
    "Sd", "Gd", "GR", "GD", "GZ", "GA", "MS", "Q", "R", "RG", "RC", "RM", "RS", "Me", "Qe", "Mw", "Qw", "Mn",
    "Qn", "Ms", "Qs", "TQ", "TS", "TL", "GT", "STR", "Te", "Td", "Mg", "Rg", "CM", "hC", "SMTI", "GMTI",
    "SMGE", "GMGE", "SMeq", "GMeq", "SMMC", "GMEQ", "GMZA", "GU", "GVT", "GV", "GVP", "SBu", "GBu",
}
FIELD_CODES = {
    "STa", "GTa", "SLE", "SLD", "GLC", "SLH", "GLH", "SLL", "GLL", "SRl", "GRl", "GAT", "Ggr", "Rv", "NSC",
    "SOa", "hP", "Sp01", "Spu", "Gps", "AP", "AA", "Gh",
}


def test_table_holds_every_documented_and_field_command() -> None:
    missing = (DOCUMENT_CODES | FIELD_CODES) - set(p.BY_CODE)
    assert not missing


@pytest.mark.parametrize(
    ("code", "kind"),
    [("MS", p.ReplyKind.GOTO), ("Sr", p.ReplyKind.CHAR), ("Te", p.ReplyKind.CHAR), ("GR", p.ReplyKind.TEXT),
     ("CM", p.ReplyKind.TEXT), ("Q", p.ReplyKind.NONE), ("Mg", p.ReplyKind.NONE), ("Rg", p.ReplyKind.NONE),
     ("hC", p.ReplyKind.NONE), ("SLE", p.ReplyKind.CHAR), ("GAT", p.ReplyKind.TEXT), ("SBu", p.ReplyKind.NONE)],
)
def test_reply_kinds_follow_real_mounts(code: str, kind: p.ReplyKind) -> None:
    assert p.BY_CODE[code].kind is kind


# --- formats --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("hours", "text"),
    [(0.0, "00:00:00"), (12.5, "12:30:00"), (23 + 59 / 60 + 59.7 / 3600, "00:00:00"),
     (1 + 59 / 60 + 59.5 / 3600, "02:00:00"), (5 + 0.49 / 3600, "05:00:00"), (-0.5 / 60, "23:59:30"),
     (24.0, "00:00:00")],
)
def test_format_hms_carries_and_wraps(hours: float, text: str) -> None:
    assert w.format_hms(hours) == text


@pytest.mark.parametrize(
    ("degrees", "text"),
    [(-30 / 3600, "-00*00:30"), (-0.4 / 3600, "+00*00:00"), (89.99999, "+90*00:00"), (45 + 59 / 60 + 59.6 / 3600,
     "+46*00:00"), (-12.5, "-12*30:00"), (0.0, "+00*00:00")],
)
def test_format_dms_carries_and_keeps_sign(degrees: float, text: str) -> None:
    assert w.format_dms(degrees) == text


def test_longitude_is_east_negative_with_three_digits() -> None:
    assert w.format_longitude(120 + 43 / 60 + 11 / 3600) == "-120*43:11"
    assert w.format_longitude(-6.1) == "+006*06:00"
    assert w.parse_longitude("-120*43:11") == pytest.approx(120 + 43 / 60 + 11 / 3600)
    assert w.format_longitude(180.0) == "+180*00:00"


def test_time_zone_sign_is_negated() -> None:
    assert w.format_utc_offset(8) == "-08:00"
    assert w.format_utc_offset(-5) == "+05:00"
    assert w.format_utc_offset(5.5) == "-05:30"
    assert w.format_utc_offset(0) == "+00:00"
    assert w.parse_utc_offset("-08:00") == 8.0
    assert w.parse_utc_offset("+05") == -5.0


def test_date_and_time_formats() -> None:
    assert w.format_date(date(2026, 7, 10)) == "07/10/26"
    assert w.format_time(time(20, 0, 5, 999999)) == "20:00:05"
    assert w.parse_date("01/01/00") == date(2000, 1, 1)
    assert p.set_date_time_zone(date(2026, 7, 10), time(20, 0), 1.0).text == ":SMTI07/10/26&20:00:00&-01:00#"


@pytest.mark.parametrize("text", ["+31*15:41", "+31°15:41", "+31ß15:41", "+31\xdf15:41", "+31*15'41", "+31:15:41"])
def test_parse_dms_accepts_every_degree_mark(text: str) -> None:
    assert w.parse_dms(text) == pytest.approx(31 + 15 / 60 + 41 / 3600)


def test_parse_dms_without_seconds_and_negative_zero() -> None:
    assert w.parse_dms("+21*17") == pytest.approx(21 + 17 / 60)
    assert w.parse_dms("-00*00:30") == pytest.approx(-30 / 3600)


@pytest.mark.parametrize("text", ["", "12", "+91*00:60", "+10*60:00", "ab*cd:ef", "24:00:00x"])
def test_parse_dms_rejects_garbage(text: str) -> None:
    with pytest.raises(ProtocolError):
        w.parse_dms(text)


@pytest.mark.parametrize("text", ["24:00:00", "12:60:00", "12:00:60", "1200", ""])
def test_parse_hms_rejects_out_of_range(text: str) -> None:
    with pytest.raises(ProtocolError):
        w.parse_hms(text)


def test_parse_hms_short_format() -> None:
    assert w.parse_hms("12:30.5") == pytest.approx(12.5 + 0.5 / 60)


@given(st.floats(min_value=0, max_value=24, exclude_max=True))
def test_hms_round_trip_within_half_a_second(hours: float) -> None:
    back = w.parse_hms(w.format_hms(hours))
    assert abs((back - hours + 12) % 24 - 12) <= 0.5 / 3600 + 1e-12


@given(st.floats(min_value=-90, max_value=90))
def test_dms_round_trip_within_half_an_arcsecond(degrees: float) -> None:
    assert abs(w.parse_dms(w.format_dms(degrees)) - degrees) <= 0.5 / 3600 + 1e-12


# --- status flags ---------------------------------------------------------------------------


def test_status_letters_decode() -> None:
    idle = w.parse_status("nNG000000000")
    assert not idle.tracking and not idle.slewing and idle.mode is w.MountMode.EQUATORIAL and not idle.at_home
    busy = w.parse_status("G001000060")
    assert busy.tracking and busy.slewing
    odd = w.parse_status("nNZtM000000440")
    assert odd.mode is w.MountMode.ALTAZ and odd.st4_dec and odd.other_flags == "M" and odd.digits == "000000440"
    full = w.parse_status("NLHhGSsTtP000000000")
    assert all([full.low_voltage, full.at_home, full.homing, full.ra_stall, full.dec_stall, full.st4_ra, full.parked])


def test_status_format_round_trips() -> None:
    status = w.MountStatus(tracking=True, slewing=False, at_home=True, digits="000000870")
    assert w.format_status(status) == "NHG000000870"
    assert w.parse_status(w.format_status(status)) == status


def test_error_codes_cover_one_to_twelve_and_the_parked_fourteen() -> None:
    assert sorted(p.ERROR_CODES) == [*range(1, 13), 14]  # e14#: refused while parked (real 1.8.8, S1)


def test_real_status_words_show_the_firmware_park_by_their_last_digit() -> None:
    """Real 1.8.8 shows its park as a status word ending in 5, never a 'P' (real-transcripts §1)."""
    parked = w.parse_status("nGM000000005")
    assert parked.parked and not parked.tracking and parked.slewing  # no 'N': only :Gps# tells parked from parking
    assert not w.parse_status("nNGM000000000").parked  # right after :Spu# (S1's ASIMount trace)
    assert not w.parse_status("NGM011000211").parked  # tracking (S2)
    assert w.parse_status("nNGP000000000").parked  # the documents' 'P' still counts


# --- requests and replies -------------------------------------------------------------------


def test_reply_complete_never_waits_for_a_hash_after_a_bare_character() -> None:
    assert p.reply_complete(p.ReplyKind.CHAR, b"1")
    assert p.reply_complete(p.ReplyKind.GOTO, b"0")
    assert not p.reply_complete(p.ReplyKind.GOTO, b"e")
    assert not p.reply_complete(p.ReplyKind.GOTO, b"e7")
    assert p.reply_complete(p.ReplyKind.GOTO, b"e7#")
    assert not p.reply_complete(p.ReplyKind.TEXT, b"12:00")
    assert p.reply_complete(p.ReplyKind.TEXT, b"12:00:00#")
    assert p.reply_complete(p.ReplyKind.NONE, b"")


def test_goto_success_is_a_bare_zero_and_errors_carry_their_meaning() -> None:
    goto = p.query("MS")
    assert goto.parse("0") is True
    with pytest.raises(MountReplyError) as info:
        goto.parse("e7#")
    assert info.value.code == 7 and "time and site" in info.value.meaning
    with pytest.raises(MountReplyError):
        goto.parse("1")  # classic LX200 "1" is a failure on ZWO


def test_setter_replies() -> None:
    assert p.set_target_ra(12.0).parse("1") is True
    with pytest.raises(MountReplyError):
        p.set_target_ra(12.0).parse("0")
    with pytest.raises(MountReplyError) as info:
        p.set_target_dec(12.0).parse("e2#")
    assert info.value.code == 2
    with pytest.raises(ProtocolError):
        p.set_target_ra(12.0).parse("x")


def test_gat_error_is_a_value_not_a_refusal() -> None:
    assert p.query("GAT").parse("e8#") == p.TrackingState(False, 8)
    assert p.query("GAT").parse("1#") == p.TrackingState(True)


def test_compound_replies_parse() -> None:
    ra, dec = p.query("GMEQ").parse("09:31:44&+90*00:00#")
    assert ra == pytest.approx(9 + 31 / 60 + 44 / 3600) and dec == 90.0
    az, alt = p.query("GMZA").parse("180*00:00&+31*15:41#")
    assert az == 180.0 and alt == pytest.approx(31 + 15 / 60 + 41 / 3600)
    day, clock, offset = p.query("GMTI").parse("07/10/26&20:00:00&-01:00#")
    assert (day, clock, offset) == (date(2026, 7, 10), time(20, 0), 1.0)
    assert p.query("CM").parse("N/A#") is True
    assert p.query("Gps").parse("#") is None
    assert p.query("GTa").parse("11+05#") == w.MeridianSettings(True, True, 5)


def test_builders_apply_unit_and_sign_conventions() -> None:
    assert p.set_latitude(31 + 15 / 60 + 24 / 3600).text == ":St+31*15:24#"
    assert p.set_longitude(120.5).text == ":Sg-120*30:00#"
    assert p.set_utc_offset(8).text == ":SG-08:00#"
    assert p.pulse_guide(w.Direction.NORTH, 1000).text == ":Mgn1000#"
    assert p.set_guide_rate(0.3).text == ":Rg0.30#"
    assert p.set_variable_speed(720).text == ":Rv720.00#"
    assert p.set_meridian(w.MeridianSettings(False, True, -10)).text == ":STa01-10#"
    assert p.set_lower_limit(5).text == ":SLL05#"
    assert p.set_heavy_duty(True).text == ":SRl720#"
    with pytest.raises(ProtocolError):
        p.set_guide_rate(1.0)
    with pytest.raises(ProtocolError):
        p.set_lower_limit(-1)
    with pytest.raises(ProtocolError):
        p.request("GR", "x")


def test_match_command_prefers_exact_and_longest_codes() -> None:
    def code(body: str) -> str | None:
        match = p.match_command(body)
        return match.command.code if match else None

    assert code("GVP") == "GVP" and code("GV") == "GV"
    assert code("SLE") == "SLE" and code("SLH90") == "SLH" and code("SL12:00:00") == "SL"
    assert code("Rvr12") == "Rvr" and code("Rv12.5") == "Rv" and code("R5") == "R" and code("RG") == "RG"
    assert code("Mgn1000") == "Mg" and code("Ms") == "Ms"
    assert code("GX95") is None and code("STA11+05") is None and code("hR") is None
    malformed = p.match_command("Sd+12*30:xx")
    assert malformed is not None and malformed.command.code == "Sd" and not malformed.well_formed


def test_framer_keeps_colons_inside_arguments() -> None:
    framer = request_framer.RequestFramer()
    assert framer.feed(b":SL22:05:09#:Sd+45*30:15#:SMTI07/10/26&20:00:00&-01:00#") == [
        "SL22:05:09", "Sd+45*30:15", "SMTI07/10/26&20:00:00&-01:00"]
    assert framer.feed(b":Sr12:3") == [] and framer.feed(b"4:56#") == ["Sr12:34:56"]  # split across reads


def test_framer_drops_unterminated_fragments_and_stray_bytes() -> None:
    framer = request_framer.RequestFramer()
    assert framer.feed(b":Rg0.30:GU#\r\n#garbage:GR#:Q") == ["GU", "GR"]  # INDI's ':Rg0.30' without '#'
    assert framer.feed(b"#") == ["Q"]
    assert framer.dropped == 1
    assert framer.feed(b":" + b"x" * 100 + b"#:GD#") == ["GD"]


# --- fuzzing: parsers raise only our own errors ---------------------------------------------

REPLY_ALPHABET = st.text(alphabet=st.characters(min_codepoint=0, max_codepoint=255), max_size=40)


@settings(max_examples=300)
@given(REPLY_ALPHABET, st.sampled_from([c for c in p.COMMANDS if c.args is None]))
def test_any_reply_text_raises_only_our_errors(reply: str, command: p.Command) -> None:
    with contextlib.suppress(ProtocolError, MountReplyError):
        p.Request(command, f":{command.code}#").parse(reply)


@settings(max_examples=300)
@given(st.binary(max_size=200))
def test_framer_never_raises_and_yields_bounded_bodies(data: bytes) -> None:
    framer = request_framer.RequestFramer()
    for body in framer.feed(data):
        assert len(body) <= request_framer.RequestFramer.MAX_LENGTH
        assert "#" not in body
        assert all(not (a == ":" and b.isascii() and b.isalpha()) for a, b in itertools.pairwise(body))
        p.match_command(body)  # never raises


@settings(max_examples=200)
@given(st.text(max_size=30))
def test_value_parsers_raise_only_protocol_errors(text: str) -> None:
    for parser in (w.parse_hms, w.parse_dms, w.parse_longitude, w.parse_date, w.parse_time, w.parse_utc_offset,
                   w.parse_status, w.parse_meridian):
        with contextlib.suppress(ProtocolError):
            parser(text)
