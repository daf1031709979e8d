"""Acknowledgements a busy mount sends late, or never: the link stays in step and on line.

A real AM5N on 1.8.8 left ``:Te#`` unanswered for the whole 1.5 s its driver waited while a GOTO ran
(real-transcripts-1.8.8.md §2 item 8). The emulator's 1.8.8 presets hold those acknowledgements back
(``FirmwareVariant.ack_while_slewing``): "late" sends the byte once the slew has ended, in the middle
of whatever the link is doing then; "never" drops it. Neither may be read as a later command's reply.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from alpaca_zwo._exceptions import LinkTimeout
from alpaca_zwo.emulator import EmulatorServer, MountModel, ScaledClock
from alpaca_zwo.zwo import protocol as p
from alpaca_zwo.zwo.firmware import preset
from alpaca_zwo.zwo.link import Link
from alpaca_zwo.zwo.wire_values import MountStatus

#: Fast enough that the test is short, slow enough that the GOTO outlasts the link's timeout.
SPEED = 4.0


@pytest.fixture(params=["late", "never"])
def model(request: pytest.FixtureRequest) -> MountModel:
    firmware = preset("am5-1.8.8", ack_while_slewing=request.param)
    return MountModel(ScaledClock(speed=SPEED), firmware=firmware, initialized=True)


@pytest.fixture
def link(model: MountModel) -> Iterator[Link]:
    emulator = EmulatorServer(model, host="127.0.0.1", port=0, baud=0).start()
    link = Link(f"socket://127.0.0.1:{emulator.port}", timeout=1.0, reconnect_delays=(0.1, 0.2, 0.5))
    link.open()
    link.expect_probe_reply("AM5")
    yield link
    link.close()
    emulator.stop()


def _start_a_long_goto(link: Link, model: MountModel) -> None:
    lst = model.clock_site.sidereal_time()
    assert link.execute(p.set_target_ra((lst + 3.0) % 24.0)) is True  # east, low: a long way from home
    assert link.execute(p.set_target_dec(-10.0)) is True
    assert link.execute(p.query("MS")) is True
    assert model.slewing()


def _poll(link: Link) -> MountStatus:
    """What the server's poller reads; every reply must parse as its own command's."""
    ra, dec = link.execute(p.query("GMEQ"))
    assert 0.0 <= ra < 24.0 and -90.0 <= dec <= 90.0
    status: MountStatus = link.execute(p.query("GU"))
    link.execute(p.query("GAT"))
    assert link.execute(p.query("Gm")) in ("E", "W", "N")
    assert link.execute(p.query("Gps")) == 0
    return status


def test_a_held_acknowledgement_is_never_read_as_a_later_reply(link: Link, model: MountModel) -> None:
    _start_a_long_goto(link, model)
    with pytest.raises(LinkTimeout):
        link.execute(p.query("Te"))  # the busy mount does not answer within the link's timeout
    assert model.slewing(), "the GOTO ended before the timeout: the test proves nothing"
    assert link.status.connected  # a silent acknowledgement is not a lost link
    while _poll(link).slewing:  # polls run through the moment the late byte comes
        pass
    for _ in range(20):  # and well after it
        _poll(link)
    assert link.execute(p.set_target_ra(3.0)) is True  # a setter's own '1', not the owed one
    assert link.execute(p.query("GAT")).on  # the command took effect when it arrived
    late = [entry for entry in link.trace() if "late acknowledgement" in entry.note]
    if model.firmware.ack_while_slewing == "late":
        assert [(entry.request, entry.reply) for entry in late] == [(":Te#", "1")]
    else:
        assert late == []
    assert link.status.connected
