"""The firmware's own park as real 1.8.8 mounts showed it (docs/firmware-evidence.md, issue 39):
``:hP#`` ignored while tracking, parked state kept across a reboot, every motion command refused
with ``e14#`` until ``:Spu#``, and the 1.8.8 ``:GU#`` word (``n`` alone, ``M``, last digit 5, no ``P``).
The default preset keeps the documents' behaviour, checked here too so the switch stays a switch."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from alpaca_zwo.emulator import EmulatorServer, FirmwareVariant, ManualClock, MountModel
from alpaca_zwo.zwo.firmware import PARKED_REFUSED, preset
from tests.emulator.emuclient import MountClient, initialize, slew, target_at
from tests.support.wait import wait_until

REAL = [preset("am5-1.8.8"), preset("am5n-1.8.8")]


def park(client: MountClient, clock: ManualClock, limit_s: float = 120.0) -> float:
    """Send :hP# (silent on 1.8.8) and advance emulated time until :Gps# says parked; the seconds taken."""
    assert client.exact(":hP#") == ""
    elapsed = 0.0
    while client.ask(":Gps#") != "2#":
        assert elapsed < limit_s, "park did not end"
        clock.advance(0.5)
        elapsed += 0.5
    return elapsed


@pytest.mark.parametrize("firmware", REAL, ids=lambda f: f.name)
def test_hp_while_tracking_is_silently_ignored(mount: MountClient, model: MountModel, clock: ManualClock) -> None:
    initialize(mount, clock)
    assert mount.exact(":Te#") == "1"
    before = model.axes()
    assert mount.exact(":hP#") == ""
    clock.advance(20.0)
    assert mount.ask(":Gps#") == "0#"
    assert mount.ask(":GU#") == "NGM000000001#"
    assert model.snapshot()["slew"] is None and model.axes() != before  # only tracking moved it


@pytest.mark.parametrize("firmware", REAL, ids=lambda f: f.name)
def test_parked_mount_refuses_motion_with_e14_until_spu(
    mount: MountClient, model: MountModel, clock: ManualClock,
) -> None:
    initialize(mount, clock)
    assert mount.ask(":GU#") == "nNGM000000000#"  # idle, unparked (S1 ASIMount trace after :Spu#)
    assert mount.exact(":Spu#") == "0"  # nothing to cancel
    slew(mount, clock, target_at(model, -2.0), 40.0)
    assert mount.exact(":Td#") == "1"
    seconds = park(mount, clock)
    assert 5.0 < seconds < 60.0  # the real park took ~12-15 s (S1)
    assert mount.ask(":GU#") == "nGM000000005#"
    assert (mount.ask(":GD#"), mount.ask(":Gm#"), mount.ask(":GZ#")) == ("+90*00:00#", "E#", "360*00:00#")
    ra = target_at(model, -2.0)
    assert mount.exact(f":Sr{int(ra):02d}:00:00#") == "1"  # setting a target is not motion
    assert mount.exact(":Sd+30*00:00#") == "1"
    axes = model.axes()
    for body in (*PARKED_REFUSED, "Mgn1000", "Mge0500"):
        assert mount.exact(f":{body}#") == "e14#", body
    assert mount.exact(":Q#") == ""  # stopping is not refused
    clock.advance(5.0)
    assert model.axes() == axes and model.snapshot()["tracking"] is False
    assert mount.ask(":GD#") == mount.ask(":GD#")
    assert mount.exact(":Spu#") == "1"
    assert mount.ask(":Gps#") == "0#"
    assert mount.ask(":GU#") == "nNGM000000000#"
    assert mount.exact(":Te#") == "1"
    assert mount.exact(":Mn#") == ""  # motion is silent again once unparked
    assert mount.ask(":GU#") == "NGM000000003#"


@pytest.mark.parametrize("firmware", REAL, ids=lambda f: f.name)
def test_parked_state_survives_the_control_ports_reboot(
    emu: EmulatorServer, mount: MountClient, clock: ManualClock, connect: Callable[[], MountClient],
) -> None:
    initialize(mount, clock)
    park(mount, clock)
    emu.faults.reboot(0.2)
    wait_until(lambda: not emu.faults.refusing(), 5.0, "the reboot to end", interval=0.02)
    client = connect()
    assert client.ask(":GC#") == "01/01/00#"  # it did power-cycle
    assert client.ask(":Gps#") == "2#"
    assert client.ask(":GU#") == "nGM000000005#"
    assert client.exact(":MS#") == "e14#"
    assert client.exact(":Spu#") == "1"
    assert client.ask(":Gps#") == "0#"


def test_default_preset_keeps_the_documents_park(mount: MountClient, clock: ManualClock) -> None:
    """The default build: :hP# parks while tracking, refuses a GOTO with e4#, moves stay silent."""
    initialize(mount, clock)
    assert mount.exact(":Te#") == "1"
    park(mount, clock)
    assert mount.exact(":MS#") == "e4#"
    assert mount.exact(":Te#") == "0"
    assert mount.exact(":Ms#") == ""
    assert mount.ask(":GU#") == "nNG000000000#"  # the documents: no M, no state digit
    assert mount.exact(":Spu#") == "1"


def test_switch_alone_turns_e14_on(connect: Callable[[], MountClient], model: MountModel, clock: ManualClock) -> None:
    """``park_refusal`` is a switch of its own: flipped on a running default mount, it answers e14#."""
    mount = connect()
    initialize(mount, clock)
    park(mount, clock)
    model.firmware.park_refusal = "e14"
    assert mount.exact(":Ms#") == "e14#"
    assert mount.exact(":hU#") == "e14#"
    model.firmware.park_refusal = "documents"
    assert mount.exact(":hU#") == ""


def test_variant_rejects_unknown_park_switch_values() -> None:
    with pytest.raises(ValueError, match="park_refusal"):
        FirmwareVariant(park_refusal="e15")
