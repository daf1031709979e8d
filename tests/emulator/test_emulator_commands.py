"""Every command in ``protocol.COMMANDS`` over real TCP, with its exact reply bytes.

Each row runs on a freshly powered-up mount: request, the exact bytes it must produce (or a
regex), and optionally a follow-up query proving the setter really took effect.
"""

from __future__ import annotations

import re
from datetime import datetime, timezone

import pytest

from alpaca_zwo import sky
from alpaca_zwo.emulator.model import FACTORY_LONGITUDE
from alpaca_zwo.zwo import protocol, wire_values
from tests.emulator.emuclient import MountClient

HMS = r"\d{2}:\d{2}:\d{2}"
_POWER_UP_LST = sky.local_sidereal_time(datetime(2000, 1, 1, tzinfo=timezone.utc), FACTORY_LONGITUDE)
POWER_UP_GS = wire_values.format_hms(_POWER_UP_LST) + "#"
POWER_UP_GR = wire_values.format_hms(_POWER_UP_LST + 6.0) + "#"  # home: RA = LST + 6 h

# (request, expected reply: exact text or compiled regex, optional (follow-up query, its reply))
Row = tuple[str, "str | re.Pattern[str]", "tuple[str, str] | None"]
ROWS: list[Row] = [
    # Date, time, site
    (":SC03/20/25#", "1", (":GC#", "03/20/25#")),
    (":SC13/40/25#", "0", (":GC#", "01/01/00#")),
    (":SC3/20/25#", "0", None),
    (":GC#", "01/01/00#", None),
    (":SL22:05:09#", "1", (":GL#", "22:05:09#")),
    (":SL25:00:00#", "0", (":GL#", "00:00:00#")),
    (":GL#", "00:00:00#", None),
    (":SS10:00:00#", "1", (":GS#", "10:00:00#")),
    (":SS10:61:00#", "e2#", None),
    (":GS#", POWER_UP_GS, None),
    (":GH#", "0#", None),
    (":SH1#", "1", (":GH#", "1#")),
    (":SH2#", "0", (":GH#", "0#")),
    (":SG-08#", "1", (":GG#", "-08:00#")),
    (":SG+05:30#", "1", (":GG#", "+05:30#")),
    (":SG+15#", "0", (":GG#", "+00:00#")),
    (":SG08#", "0", None),
    (":GG#", "+00:00#", None),
    (":St+48*07:30#", "1", (":Gt#", "+48*07:30#")),
    (":St-33*52:04#", "1", (":Gt#", "-33*52:04#")),
    (":St+91*00:00#", "0", (":Gt#", "+31*15:41#")),
    (":Gt#", "+31*15:41#", None),
    (":Sg-011*34:56#", "1", (":Gg#", "-011*34:56#")),
    (":Sg+074*00:21#", "1", (":Gg#", "+074*00:21#")),
    (":Sg+181*00:00#", "0", (":Gg#", "-120*43:11#")),
    (":Gg#", "-120*43:11#", None),
    (":SMTI03/20/25&22:00:00&-08:00#", "1", (":GMTI#", "03/20/25&22:00:00&-08:00#")),
    (":SMTI03/20/25&22:00#", "0", (":GMTI#", "01/01/00&00:00:00&+00:00#")),
    (":GMTI#", "01/01/00&00:00:00&+00:00#", None),
    (":SMGE+48*07:30&-011*34:56#", "1", (":GMGE#", "+48*07:30&-011*34:56#")),
    (":SMGE+48*07#", "0", (":GMGE#", "+31*15:41&-120*43:11#")),
    (":GMGE#", "+31*15:41&-120*43:11#", None),
    # Position and target
    (":Gm#", "N#", None),
    (":Sr12:34:56#", "1", (":Gr#", "12:34:56#")),
    (":Sr12:34:60#", "e2#", (":Gr#", "00:00:00#")),
    (":Sr12:60:00#", "e2#", None),
    (":Sr 05:06:07#", "1", (":Gr#", "05:06:07#")),
    (":Sr12:34#", "e2#", None),
    (":Gr#", "00:00:00#", None),
    (":Sd+45*30:15#", "1", (":Gd#", "+45*30:15#")),
    (":Sd-05*00:01#", "1", (":Gd#", "-05*00:01#")),
    (":Sd+45*30:60#", "e2#", (":Gd#", "+00*00:00#")),
    (":Sd+45:30:15#", "1", (":Gd#", "+45*30:15#")),  # the V1.1 document's template
    (":Sd+95*00:00#", "e2#", None),
    (":Gd#", "+00*00:00#", None),
    (":GR#", POWER_UP_GR, None),
    (":GD#", "+90*00:00#", None),
    (":GZ#", "000*00:00#", None),
    (":GA#", "+31*15:41#", None),
    (":GMeq#", "00:00:00&+00*00:00#", None),
    (":GMEQ#", POWER_UP_GR[:-1] + "&+90*00:00#", None),
    (":GMZA#", "000*00:00&+31*15:41#", None),
    # Motion
    (":MS#", "e7#", (":GU#", "nNG000000000#")),
    (":SMeq12:00:00&+45*00:00#", "e2#", (":GU#", "nNG000000000#")),
    (":Q#", "", None),
    (":Me#", "", None),
    (":Mw#", "", None),
    (":Mn#", "", None),
    (":Ms#", "", None),
    (":Qe#", "", None),
    (":Qw#", "", None),
    (":Qn#", "", None),
    (":Qs#", "", None),
    (":R0#", "", None),
    (":R9#", "", None),
    (":RG#", "", None),
    (":RC#", "", None),
    (":RM#", "", None),
    (":RS#", "", None),
    (":Rv100.5#", "", None),
    (":Rvr12#", "", None),
    (":Rvd12#", "", None),
    # Tracking
    (":TQ#", "", (":GT#", "0#")),
    (":TS#", "", (":GT#", "1#")),
    (":TL#", "", (":GT#", "2#")),
    (":GT#", "0#", None),
    (":STR05#", "", (":GT#", "0#")),  # custom tracking is absent on real firmware: no reply
    (":Te#", "1", (":GAT#", "1#")),
    (":Td#", "1", (":GAT#", "0#")),
    (":GAT#", "0#", None),
    # Guiding
    (":Mgn0100#", "", None),
    (":Mgw10000#", "", None),
    (":Rg0.30#", "", (":Ggr#", "0.30#")),
    (":Rg0.9#", "", (":Ggr#", "0.90#")),
    (":Rg4.5#", "", (":Ggr#", "0.30#")),  # V1.1's x15 form
    (":Rg0.95#", "", (":Ggr#", "0.50#")),
    (":Ggr#", "0.50#", None),
    # Sync and alignment
    (":CM#", "e11#", None),  # at the polar home
    (":SMMC12:00:00&+45*00:00#", "e2#", None),
    (":NSC#", "1", None),
    # Home, park
    (":hC#", "", None),
    (":Gh#", "#", None),
    (":SOa#", "1", (":Gm#", "N#")),
    (":hP#", "", (":Gps#", "1#")),
    (":Sp01#", "5", None),  # not homed since power-up
    (":Spu#", "0", None),  # nothing latched
    (":Gps#", "0#", None),
    # Meridian and limits
    (":STa01+05#", "1", (":GTa#", "01+05#")),
    (":STa00-10#", "1", (":GTa#", "00-10#")),
    (":STa01+16#", "0", (":GTa#", "00+00#")),
    (":STa1#", "0", (":GTa#", "00+00#")),
    (":GTa#", "00+00#", None),
    (":SLE#", "1", (":GLC#", "1#")),
    (":SLD#", "1", (":GLC#", "0#")),
    (":GLC#", "0#", None),
    (":SLH75#", "1", (":GLH#", "75#")),
    (":SLH50#", "0", (":GLH#", "90#")),
    (":SLH+75#", "0", None),
    (":GLH#", "90#", None),
    (":SLL05#", "1", (":GLL#", "5#")),
    (":SLL00#", "1", (":GLL#", "0#")),
    (":SLL-05#", "0", (":GLL#", "0#")),
    (":SLL-5#", "0", None),
    (":SLL+15#", "0", None),
    (":SLL31#", "0", None),
    (":GLL#", "0#", None),
    (":SRl720#", "1", (":GRl#", "720#")),
    (":SRl1440#", "1", (":GRl#", "1440#")),
    (":SRl999#", "0", (":GRl#", "1440#")),
    (":GRl#", "1440#", None),
    # Mode, buzzer, identity
    (":AP#", "", (":GU#", "nNG000000000#")),
    (":AA#", "", (":GU#", "nNG000000000#")),  # takes effect after a reboot
    (":SBu2#", "", (":GBu#", "2#")),
    (":SBu0#", "", (":GBu#", "0#")),
    (":GBu#", "1#", None),
    (":GU#", "nNG000000000#", None),
    (":GV#", "1.9.2#", None),
    (":GVP#", "AM5#", None),
    (":GVT#", "10:24:36#", None),
    (":GBl#", "AM5_123456#", None),
    (":SBlABC789#", "1", (":GBl#", "AM5_123456#")),  # new name after a reboot
    (":SBlAB-9#", "0", None),
    (":BSab12cd#", "OK#", None),
    (":BSab1#", "NO#", None),
]


def _code(request: str) -> str:
    match = protocol.match_command(request.strip(":#"))
    assert match is not None, request
    return match.command.code


def test_every_command_in_the_shared_table_is_covered() -> None:
    covered = {_code(request) for request, _, _ in ROWS}
    assert covered == {command.code for command in protocol.COMMANDS}


@pytest.mark.parametrize(("request_text", "expected", "follow_up"), ROWS, ids=[row[0] for row in ROWS])
def test_command_reply_is_exact(
    mount: MountClient, request_text: str, expected: str | re.Pattern[str], follow_up: tuple[str, str] | None
) -> None:
    reply = mount.exact(request_text)
    if isinstance(expected, str):
        assert reply == expected
    else:
        assert expected.fullmatch(reply), reply
    if follow_up is not None:
        query, answer = follow_up
        assert mount.exact(query) == answer


def test_replies_read_by_kind_leave_nothing_behind(mount: MountClient) -> None:
    """Reading each reply by its protocol kind consumes exactly the reply: the next one lines up."""
    for request in (":SC03/20/25#", ":GC#", ":Sd+95*00:00#", ":GV#", ":MS#", ":Te#", ":GAT#", ":CM#", ":GVP#"):
        mount.ask(request)
    assert mount.exact(":GVP#") == "AM5#"


def test_setters_answer_one_bare_character(mount: MountClient) -> None:
    """Setters answer one bare character, never followed by '#' (a '#'-waiting reader would stall)."""
    for request in (":SG-08:00#", ":SL20:00:00#", ":SC03/20/25#", ":St+31*15:41#", ":Sg-120*43:11#"):
        assert mount.exact(request) == "1"
