"""The shared ZWO port answers every ZWO command, well formed or not, with the bytes it answered
before the command set was put in one table (issue 34), and refuses the same ones:
``zwo_port_replies.json``, recorded from the tree before that change by
``python -m tests.support.zwo_capture port``. Re-recorded once since, deliberately: the southern site's
date, time and zone (``:GC#``, ``:GL#``, ``:GG#``, ``:GMTI#``) are now the mount's, set in the site's own zone
(Sydney, +11 on 2025-03-20 20:00 UTC: 03/21/25 07:00:00, ``-11:00`` in ZWO's sign), where they were UTC's.

Seven configurations (both mount modes, a northern and a southern site, guarded commands refused,
all allowed or some, firmware without the meridian settings); over the port's real socket, on a
Telescope whose clock is the emulator's frozen universe, so the bytes are the same on every run.
"""

from __future__ import annotations

import pytest

from tests.support import zwo_capture


@pytest.mark.parametrize("name", list(zwo_capture.PORT_CONFIGS))
def test_the_port_answers_as_recorded(name: str) -> None:
    recorded = zwo_capture.read(zwo_capture.PORT_FILE)[name]
    answered = zwo_capture.capture_port(name).rows
    assert [row["request"] for row in answered] == [row["request"] for row in recorded]
    for ours, theirs in zip(answered, recorded, strict=True):
        assert ours == theirs, ours["request"]
