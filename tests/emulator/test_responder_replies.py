"""The emulator answers every ZWO command, well formed or not, with the bytes it answered before the
command set was put in one table (issue 34): ``responder_replies.json``, recorded from the tree
before that change by ``python -m tests.support.zwo_capture emulator``.

Eleven configurations (every firmware preset, both mount modes, a northern and a southern site, and
the switches no preset turns on); each reply and, after every command, the mount's readings.
"""

from __future__ import annotations

import pytest

from tests.support import zwo_capture


@pytest.mark.parametrize("name", list(zwo_capture.EMULATOR_CONFIGS))
def test_the_emulator_answers_as_recorded(name: str) -> None:
    recorded = zwo_capture.read(zwo_capture.EMULATOR_FILE)[name]
    answered = zwo_capture.capture_emulator(name).rows
    assert [row["request"] for row in answered] == [row["request"] for row in recorded]
    for ours, theirs in zip(answered, recorded, strict=True):
        assert ours == theirs, ours["request"]
