"""Request framing: unknown and miscased commands are silent, ':' restarts a command only before
a letter, and the quirks real drivers produce (field notes §8) still get their answers."""

from __future__ import annotations

import pytest

from alpaca_zwo.zwo.request_framer import RequestFramer
from tests.emulator.emuclient import MountClient


@pytest.mark.parametrize(
    "request_text",
    [
        ":STA00+00#",  # capital A: not :STa (X2)
        ":gr#",
        ":Gx#",
        ":GX95#",  # OnStep
        ":hR#",  # OnStep unpark
        ":SRC#",
        ":TM#",  # INDI custom track mode
        ":MA#",
        ":U#",
        ":GVN#",
        ":GRx#",  # an argument-less query with trailing text is not that query
        ":STR05#",  # custom tracking: absent on real firmware
    ],
)
def test_unknown_and_miscased_commands_get_no_reply(mount: MountClient, request_text: str) -> None:
    mount.assert_silent(request_text)
    assert mount.ask(":GVP#") == "AM5#"  # and the line is still in step


def test_motion_commands_are_silent(mount: MountClient) -> None:
    mount.assert_silent(":Q#:R2#:Mn#:Qn#:RG#:TQ#:Mgn0010#:Rg0.50#:hC#:SBu1#:AP#")


def test_indi_unterminated_guide_rate_glued_to_the_next_poll(mount: MountClient) -> None:
    """INDI 1.9.9 sends ':Rg0.30' without '#': the ':GU#' after it must still be answered."""
    assert mount.exact(":Rg0.30:GU#") == "nNG000000000#"


def test_colons_inside_arguments_are_not_command_starts(mount: MountClient) -> None:
    assert mount.exact(":SL21:09:08#") == "1"
    assert mount.ask(":GL#") == "21:09:08#"
    assert mount.exact(":SMTI03/20/25&22:00:00&-08:00#") == "1"


def test_noise_between_commands_is_ignored(mount: MountClient) -> None:
    """CR/LF, stray '#', an LX200 ACK byte and garbage outside ':...#' change nothing."""
    assert mount.exact(b"\r\n#\x06garbage:GVP#\r\n") == "AM5#"


def test_pipelined_requests_are_answered_in_order(mount: MountClient) -> None:
    assert mount.exact(":GVP#:GV#:SLE#:GLC#:Q#:GTa#") == "AM5#1.9.2#11#00+00#"


def test_runaway_command_is_dropped(mount: MountClient) -> None:
    mount.assert_silent(":G" + "R" * 100 + "#")
    assert mount.exact(":GVP#") == "AM5#"


def test_framer_rules() -> None:
    framer = RequestFramer()
    assert framer.feed(b":SL22:05:09#:Rg0.30:GU#\r\n#junk:GR#:Q") == ["SL22:05:09", "GU", "GR"]
    assert framer.feed(b"#") == ["Q"]
    assert framer.dropped == 1
    assert framer.feed(b":" + b"x" * 100 + b"#:GD#") == ["GD"]
    # byte by byte, the colon's role is decided by the byte after it
    out: list[str] = []
    for byte in b":Sd+45*30:15#:Rg0.3:Gm#":
        out += framer.feed(bytes([byte]))
    assert out == ["Sd+45*30:15", "Gm"]
