"""The owner's survey (issue 39 item 5) against the real emulator over a real TCP link.

What an owner is promised: only the fixed list is ever sent (the emulator's own record of what it received),
the mount is byte-for-byte the same afterwards (its whole snapshot and its flash, on a frozen clock), every
exchange is written with its timing and without the site, and the verdict names each preset's switches.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from dataclasses import asdict, fields
from pathlib import Path

import pytest

from alpaca_zwo.emulator import EmulatorServer, ManualClock, MountModel
from alpaca_zwo.zwo import protocol
from alpaca_zwo.zwo.firmware import PRESETS, FirmwareVariant, preset
from alpaca_zwo.zwo.link import Link
from alpaca_zwo.zwo.survey import (
    PRIVATE,
    SURVEY_COMMANDS,
    SWITCH_PROBES,
    Exchange,
    SurveyContext,
    SurveyReport,
    redact,
    run_survey,
)
from tests.emulator.emuclient import START_UTC
from tests.faults.harness import MountRecorder

CONTEXT = SurveyContext("test", "2026-12-02T09:00:00Z", "a test", "the built-in emulator")
#: Queries that name one mount or its owner: never on the list.
IDENTIFIERS = ("GMA", "GMB", "GMhc", "GBl", "BS")


def _state(model: MountModel) -> str:
    """Everything the emulated mount keeps (snapshot, flash, firmware) as one comparable text."""
    return json.dumps({"snapshot": model.snapshot(), "flash": asdict(model.flash.persist)}, sort_keys=True,
                      default=str)


class Rig:
    """A mount on a frozen clock behind a real emulator server, its received commands recorded, and a link."""

    def __init__(self, firmware: FirmwareVariant, timeout: float = 1.0) -> None:
        self.clock = ManualClock(START_UTC)
        self.model = MountModel(self.clock, firmware)
        self.server = EmulatorServer(self.model, host="127.0.0.1", port=0, baud=0).start()
        self.recorder = MountRecorder(self.server)
        self.link = Link(f"socket://127.0.0.1:{self.server.port}", timeout=timeout)
        self.link.open()

    def survey(self) -> SurveyReport:
        return run_survey(self.link.exchange, CONTEXT)

    def close(self) -> None:
        self.link.close()
        self.recorder.uninstall()
        self.server.stop()


@pytest.fixture
def rigs() -> Iterator[list[Rig]]:
    made: list[Rig] = []
    yield made
    for rig in made:
        rig.close()


def _expected(variant: FirmwareVariant, switch: str) -> object:
    return getattr(variant, switch)


# ---------------------------------------------------------------- the list and the table


def test_every_survey_command_is_a_query_that_changes_nothing() -> None:
    for code in SURVEY_COMMANDS:
        command = protocol.BY_CODE[code]
        assert command.kind is protocol.ReplyKind.TEXT, code
        assert command.effects == protocol.Effect.NONE, code
        assert command.args is None and code.startswith("G"), code
    assert not set(SURVEY_COMMANDS) & set(IDENTIFIERS)
    assert len(set(SURVEY_COMMANDS)) == len(SURVEY_COMMANDS)


def test_every_firmware_switch_says_how_it_is_settled() -> None:
    """A new FirmwareVariant switch must get a row: the commands that decide it, or why none can."""
    switches = {f.name for f in fields(FirmwareVariant)} - {"name", "description"}
    assert switches <= {probe.switch for probe in SWITCH_PROBES}
    for probe in SWITCH_PROBES:
        assert set(probe.commands) <= set(SURVEY_COMMANDS), probe.switch
        assert probe.classify is not None or probe.needs, probe.switch


def test_the_docs_list_exactly_what_is_sent() -> None:
    """docs/survey.md is the owner's promise: its list and its table are the code's list."""
    text = (Path(__file__).resolve().parents[2] / "docs" / "survey.md").read_text(encoding="utf-8")
    listed = re.search(r"<!-- survey-commands: ([^>]*) -->", text)
    assert listed is not None and tuple(listed.group(1).split()) == SURVEY_COMMANDS
    table = text[text.index("## What is sent"):text.index("## What the report holds")]
    rows = "\n".join(line for line in table.splitlines() if line.startswith("|"))
    assert sorted(re.findall(r"`:(\w+)#`", rows)) == sorted(SURVEY_COMMANDS)


def test_azimuths_read_during_a_slew_settle_nothing() -> None:
    readings = {"GU": "nG000000000#", "GZ": "010*00:00#", "GMZA": "190*00:00&+20*00:00#"}
    classify = next(probe.classify for probe in SWITCH_PROBES if probe.switch == "gmza_south_azimuth")
    assert classify is not None and classify(readings) is None
    assert classify({**readings, "GU": "nNG000000000#"}) == frozenset({True})


def test_redaction_keeps_the_shape_and_the_first_field() -> None:
    assert redact("+37*07:51#") == "+37*xx:xx#"
    assert redact("-006*06:03#") == "-006*xx:xx#"
    assert redact("10:13:56#") == "10:xx:xx#"
    assert redact("180*00:00&+31*15:41#") == "180*xx:xx&+31*xx:xx#"
    assert redact("#") == "#"
    garbled = Exchange("Gt", ":Gt#", None, 0.0, 1.0, "not one reply: implausible reply '+37*07:51\\x01#' to :Gt#")
    assert "07:51" not in garbled.shown_reply() and garbled.shown_reply().startswith("(nothing: not one reply")


# ---------------------------------------------------------------- against every preset


@pytest.mark.parametrize("name", list(PRESETS))
def test_survey_sends_only_the_list_changes_nothing_and_names_the_preset(name: str, rigs: list[Rig]) -> None:
    variant = preset(name)
    rig = Rig(variant)
    rigs.append(rig)
    before = _state(rig.model)
    report = rig.survey()
    assert _state(rig.model) == before
    received = [exchange.body for exchange in rig.recorder.all()]
    assert received and set(received) <= set(SURVEY_COMMANDS), received
    # ... and not one byte besides those commands reached the emulator (nothing that framed as no command)
    assert rig.server.stats()["total"]["bytes_in"] == sum(len(f":{body}#") for body in received)
    assert [e.code for e in report.exchanges] == list(SURVEY_COMMANDS) and not report.stopped
    settled = 0
    for verdict in report.verdicts():
        assert verdict.state != "unexpected", verdict
        if verdict.state in ("settled", "narrowed"):
            assert _expected(variant, verdict.switch) in verdict.values, verdict
        settled += verdict.state == "settled"
        assert (verdict.state == "settled") == (len(verdict.values) == 1)
    assert {v.switch for v in report.verdicts() if v.state == "settled"} >= {"model", "version", "compile_time",
                                                                              "gps_reply", "gmza_south_azimuth",
                                                                              "home_reading"}  # at home at power-up


def test_a_tracking_mount_away_from_home_is_left_exactly_as_it_was(rigs: list[Rig]) -> None:
    rig = Rig(preset("am5n-1.6.3"))
    rigs.append(rig)
    model = rig.model
    model.initialize(START_UTC)
    assert model.set_target_ra(3.5) and model.set_target_dec(40.0)
    assert model.goto() == 0
    rig.clock.advance(300.0)
    assert not model.slewing() and model.snapshot()["tracking"]
    before = _state(model)
    report = rig.survey()
    assert _state(model) == before
    assert {e.body for e in rig.recorder.all()} <= set(SURVEY_COMMANDS)
    verdicts = {v.switch: v for v in report.verdicts()}
    assert verdicts["gmza_south_azimuth"].values == (True,)
    assert verdicts["home_flag"].state == "open"  # away from home the status word says nothing of 'H'


def test_an_h_at_home_narrows_the_home_flag_and_none_a_hair_off_home_proves_nothing(rigs: list[Rig]) -> None:
    """am5-x2 shows 'H' at home: 'never' is ruled out. Moved a few arcseconds in RA (the readings, in whole
    seconds, may not show it) it shows no 'H', which must not be read as 'not always_at_home'."""
    rig = Rig(preset("am5-x2"))
    rigs.append(rig)
    home = {v.switch: v for v in rig.survey().verdicts()}["home_flag"]
    assert (home.state, home.values) == ("narrowed", ("after_home", "always_at_home"))
    rig.model.select_speed(1)  # 0.5x sidereal: ~7.5 arcseconds a second
    assert rig.model.move("w")
    rig.clock.advance(0.5)
    rig.model.stop()
    rig.clock.advance(5.0)
    assert not rig.model.snapshot()["at_home"]
    home = {v.switch: v for v in rig.survey().verdicts()}["home_flag"]
    assert home.state == "open"


# ---------------------------------------------------------------- the report


def test_the_report_records_silence_and_goes_on(rigs: list[Rig]) -> None:
    """Firmware before 1.2.4 has no :GTa#: the survey writes the silence and asks the rest."""
    rig = Rig(preset("am5-1.9.2", version="1.2.0"), timeout=0.3)
    rigs.append(rig)
    report = rig.survey()
    by_code = {e.code: e for e in report.exchanges}
    silent = by_code["GTa"]
    assert silent.reply is None and silent.shown_reply().startswith("(nothing: silence")
    assert silent.took_ms >= 250.0
    assert by_code["GLC"].reply in ("0#", "1#") and len(report.exchanges) == len(SURVEY_COMMANDS)
    assert {e.body for e in rig.recorder.all()} <= set(SURVEY_COMMANDS)  # the link's resync probe is :GVP#


def test_the_report_has_every_exchange_timed_and_no_site(rigs: list[Rig]) -> None:
    rig = Rig(preset("am5-1.9.2"))
    rigs.append(rig)
    rig.model.clock_site.set_latitude(47.123)  # 47*07:23
    text = rig.survey().text()
    lines = text.splitlines()
    rows = [re.fullmatch(r" *(\d+\.\d) +(\d+\.\d)  (:\w+#) +-> (.+)", line) for line in lines]
    timed = [row.groups() for row in rows if row]
    assert [sent for _, _, sent, _ in timed] == [f":{code}#" for code in SURVEY_COMMANDS]
    assert all(float(started) >= 0.0 and float(took) >= 0.0 for started, took, _, _ in timed)
    assert '"+47*xx:xx#" (10 B)' in text and "07:23" not in text
    assert '"#" (1 B)' in text  # :Gh#'s lone '#' written so it cannot be mistaken for silence
    assert "model = 'AM5'" in text and "version = '1.9.2'" in text
    assert all(code in PRIVATE for code in ("Gt", "Gg", "GS"))


def test_a_lost_link_ends_the_survey_and_keeps_what_was_asked(rigs: list[Rig]) -> None:
    rig = Rig(preset("am5-1.9.2"), timeout=0.3)
    rigs.append(rig)
    asked: list[str] = []

    def send(request: protocol.Request) -> str:
        if len(asked) == 4:
            rig.server.stop()  # the mount's WiFi goes away after four questions
        asked.append(request.text)
        return rig.link.exchange(request)

    report = run_survey(send, CONTEXT)
    assert report.stopped, report.text()
    assert [e.sent for e in report.exchanges[:4]] == [":GVP#", ":GV#", ":GVT#", ":GU#"]
    assert all(e.reply for e in report.exchanges[:4]) and len(report.exchanges) < len(SURVEY_COMMANDS)
    text = report.text()
    assert "survey stopped early: " in text and "model = 'AM5'" in text


def test_a_mount_that_stops_answering_ends_the_survey_after_three_silences(rigs: list[Rig]) -> None:
    rig = Rig(preset("am5-1.9.2"), timeout=0.3)
    rigs.append(rig)

    def send(request: protocol.Request) -> str:
        if request.text == ":Gps#":
            rig.model.faults.drop_replies(1000)  # every reply from here on is lost
        return rig.link.exchange(request)

    report = run_survey(send, CONTEXT)
    assert [e.sent for e in report.exchanges[-3:]] == [":Gps#", ":Gh#", ":Gm#"]
    assert all(e.reply is None for e in report.exchanges[-3:])
    assert report.stopped == "the mount stopped answering (3 questions in a row without a reply)"
    verdicts = {v.switch: v for v in report.verdicts()}
    assert verdicts["gps_reply"].state == "open" and verdicts["model"].values == ("AM5",)
