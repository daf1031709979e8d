"""``zwo/dispatch.py`` on the real emulated mount: the one command table, answered by the MountModel as
its backend (``emulator/responder.ModelBackend``), judged by the model's own state.

What the table gives every backend: unknown codes are silent and reach nobody; a malformed argument
gets the row's refusal without reaching the mount; a value is framed by the row; and each row's
argument codec and reply formatter read back what they write.
"""

from __future__ import annotations

import math
from datetime import datetime, timezone
from typing import Any

import pytest

from alpaca_zwo._exceptions import ProtocolError
from alpaca_zwo.emulator import ManualClock, MountModel
from alpaca_zwo.emulator.responder import ModelBackend
from alpaca_zwo.zwo import dispatch
from alpaca_zwo.zwo.protocol import BY_CODE, COMMANDS, Effect, ReplyKind, match_command
from tests.support.zwo_capture import ARGUMENTS

START = datetime(2025, 3, 20, 20, 0, 0, tzinfo=timezone.utc)
#: The methods a row may ask of its backend: the Backend Protocol's, nothing else.
BACKEND_METHODS = {name for name in vars(dispatch.Backend) if not name.startswith("_")}


class Asked:
    """The real ModelBackend, with the names of the methods the table asked of it (``intercept`` aside)."""

    def __init__(self, backend: ModelBackend) -> None:
        self._backend = backend
        self.asked: list[str] = []

    def __getattr__(self, name: str) -> Any:
        if name != "intercept":
            self.asked.append(name)
        return getattr(self._backend, name)


@pytest.fixture
def model() -> MountModel:
    return MountModel(ManualClock(START), initialized=True)


@pytest.fixture
def backend(model: MountModel) -> Asked:
    return Asked(ModelBackend(model))


def answer(backend: Asked, body: str) -> str | None:
    return dispatch.answer(backend, body)  # type: ignore[arg-type]  # Asked is the backend, recorded


def test_every_row_asks_its_backend_only_what_the_protocol_declares(backend: Asked) -> None:
    """Every row has its ``asks``, and every well-formed sample of every command calls Backend methods only."""
    assert [c.code for c in COMMANDS if c.asks is None] == []
    for command in COMMANDS:
        bodies = [command.code + a for a in ARGUMENTS.get(command.code, [""])]
        for body in bodies:
            match = match_command(body)
            if match is None or not match.well_formed:
                continue
            backend.asked.clear()
            answer(backend, body)
            assert set(backend.asked) <= BACKEND_METHODS, (body, backend.asked)


@pytest.mark.parametrize("body", ["GX", "gr", "STA00+00", "", " ", "Xyz", "sr05:00:00", "GRGD"])
def test_what_the_mount_does_not_know_is_silent_and_reaches_nobody(backend: Asked, body: str) -> None:
    assert answer(backend, body) is None
    assert backend.asked == []


@pytest.mark.parametrize(("body", "refusal"), [
    ("Sr24:00:00", "e2#"), ("Sr05:60:00", "e2#"), ("Srabc", "e2#"), ("Sdabc", "e2#"), ("Sd", "e2#"),
    ("SC13/45/25", "0"), ("SL25:00:00", "0"), ("SG5", "0"), ("SG+15", "0"), ("SMTI03/20/25", "0"),
    ("St+45", "0"), ("STa00+5", "0"), ("SLH100", "0"), ("SS99:00:00", "e2#"), ("SMeq05:34:32", "e2#"),
    ("SMMC05:34:32", "e2#"), ("Rgabc", None), ("Mgx0100", None), ("R10", None), ("Tex", None),
])
def test_a_malformed_argument_gets_the_rows_refusal_and_changes_nothing(
        model: MountModel, backend: Asked, body: str, refusal: str | None) -> None:
    before = {q: answer(backend, q) for q in ("GMTI", "GMeq", "GMGE", "GTa", "GLH", "GT", "GAT", "Ggr")}
    backend.asked.clear()
    assert answer(backend, body) == refusal
    assert backend.asked == [], "a malformed request must not reach the mount"
    assert {q: answer(backend, q) for q in before} == before


def test_a_setter_changes_the_model_and_its_query_reads_it_back(model: MountModel, backend: Asked) -> None:
    assert answer(backend, "Sr05:30:00") == "1"
    assert answer(backend, "Sd-12*30:00") == "1"
    ra, dec = model.target()
    assert math.isclose(ra, 5.5) and math.isclose(dec, -12.5)
    assert answer(backend, "GMeq") == "05:30:00&-12*30:00#"
    assert answer(backend, "SG-03") == "1"  # the negated offset: UTC+3
    assert model.clock_site.utc_offset() == 3.0
    assert answer(backend, "GG") == "-03:00#"
    assert answer(backend, "SLH80") == "1"
    assert model.flash.persist.upper_limit == 80
    assert answer(backend, "GLH") == "80#"


def test_a_goto_the_mount_refuses_answers_its_error_code(model: MountModel, backend: Asked) -> None:
    """A target under the horizon: the model's code 5, framed by the GOTO row as ``e5#``; nothing moves."""
    assert answer(backend, "Sr12:00:00") == "1"
    assert answer(backend, "Sd-80*00:00") == "1"
    assert answer(backend, "MS") == "e5#"
    assert answer(backend, "GU").startswith("n")  # not slewing: 'n' leads the status while idle


def test_every_query_reply_reads_back_to_itself(backend: Asked) -> None:
    """Each query row's formatter and parser are inverses on what the real model answers."""
    checked = 0
    for command in COMMANDS:
        if command.kind is not ReplyKind.TEXT or command.args is not None or command.effects != Effect.NONE:
            continue
        reply = answer(backend, command.code)
        if reply is None:  # this firmware answers nothing to it (:GVT#, :GBl# …)
            continue
        assert command.parse is not None, command.code
        assert command.reply_text(command.parse(reply[:-1])) == reply, command.code
        checked += 1
    assert checked >= 30


def test_every_argument_codec_reads_back_what_it_writes() -> None:
    """For each sample argument a row accepts, its codec formats the value into a well-formed request
    that parses back to the same value (the driver's builder and the mount's parser agree)."""
    checked = 0
    for code, samples in ARGUMENTS.items():
        command = BY_CODE[code]
        assert command.argument is not None, code
        for text in samples:
            match = match_command(code + text)
            if match is None or not match.well_formed:
                continue
            try:
                value = command.argument.parse(text)
            except (ProtocolError, ValueError):  # well formed, but out of range: nothing to write back
                continue
            written = command.request(value).text[1 + len(code):-1]  # checked against the row's pattern
            again = command.argument.parse(written)
            assert _same(again, value), (code, text, written)
            assert command.argument.format(again) == written, (code, text, written)  # the text is a fixed point
            checked += 1
    assert checked >= 40


def _same(a: object, b: object) -> bool:
    """Equal; floats within the coarsest text form's resolution (a guide rate's 0.01, rounded), angles
    modulo a turn (a longitude of +190° is written as -170°)."""
    if isinstance(a, float) and isinstance(b, float):
        return math.isclose((a - b + 180.0) % 360.0 - 180.0, 0.0, abs_tol=0.005 + 1e-9)
    if isinstance(a, tuple) and isinstance(b, tuple):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    return a == b
