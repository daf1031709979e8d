"""A busy mount that answers ``:Te#``/``:Td#`` late or never (real 1.8.8: no reply within 1.5 s during
a GOTO, real-transcripts-1.8.8.md §2 item 8): Tracking is confirmed by what the mount reports, the
link stays on line and in step, and the next slew lands where it was asked to.
"""

from __future__ import annotations

import pytest

from alpaca_zwo.config.settings import EmulatorSettings
from alpaca_zwo.emulator import EmulatorServer
from alpaca_zwo.server import AlpacaZwoServer
from tests.conftest import ServerFactory, make_settings
from tests.telescope.harness import SPEED, Api, assert_at, slew_to_ha


@pytest.fixture(params=["late", "never"])
def server(request: pytest.FixtureRequest, server_factory: ServerFactory) -> AlpacaZwoServer:
    server = server_factory(make_settings(emulator=EmulatorSettings(speed=SPEED, baud=0, preset="am5-1.8.8")))
    emulator = server.emulators[0]
    assert emulator is not None
    emulator.model.firmware.ack_while_slewing = request.param  # a running model's switch (firmware.py)
    return server


def _record_held_acks(emulator: EmulatorServer) -> list[str]:
    """The acknowledgements the emulated mount really held back, in order (its own judgement, recorded)."""
    held: list[str] = []
    judge = emulator.responder.held_ack

    def recorded(body: str) -> str | None:
        mode = judge(body)
        if mode is not None:
            held.append(body)
        return mode

    emulator.responder.held_ack = recorded  # type: ignore[method-assign]
    return held


def _long_slew(api: Api) -> None:
    api.ok("SlewToCoordinatesAsync", RightAscension=api.ra_at_ha(-4.0), Declination=-10.0)


def test_tracking_changed_while_the_mount_is_busy_is_confirmed(server: AlpacaZwoServer, api: Api) -> None:
    emulator = server.emulators[0]
    assert emulator is not None
    model, link = emulator.model, server.telescopes[0].mount.link
    held = _record_held_acks(emulator.server)
    _long_slew(api)
    assert model.slewing()
    api.ok("Tracking", Tracking=True)  # :Te# held back by the slewing mount; :GAT# read back decides
    assert api.value("Tracking") is True
    if not model.slewing():
        _long_slew(api)
    api.ok("AbortSlew")
    api.ok("Tracking", Tracking=False)  # :Td# right after :Q#, the axes still braking: held back too
    assert api.value("Tracking") is False
    api.wait_idle()
    assert model.snapshot()["tracking"] is False
    assert link.status.connected and link.status.reconnects == 0  # a silent acknowledgement is not a lost link
    # :Te# during the slew is always held back; :Td# right after :Q# only if the axes are still braking when it
    # arrives (a busy computer can deliver it after they stopped): whatever the mount held, the server confirmed.
    assert held[0] == "Te"
    if model.firmware.ack_while_slewing == "never":
        assert link.counters.timeouts >= len(held)  # each went unanswered, and each was confirmed all the same
    api.ok("Tracking", Tracking=True)
    ra, dec = slew_to_ha(api, 1.5, 25.0)  # in step: the replies are each its own command's
    assert_at(api, ra, dec)
