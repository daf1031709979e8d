"""Connection: Platform 7 Connect/Disconnect and many clients sharing the mount, over HTTP; and the
``Connection`` part alone, on the real emulator (tests/telescope/parts.py), named clients and all.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from alpaca_zwo._exceptions import ERR_LINK, DriverError, NotConnected
from alpaca_zwo.clients import ClientKey, current_client
from alpaca_zwo.zwo.wire_values import MeridianSettings
from tests.support import wait_until
from tests.telescope.harness import Api
from tests.telescope.parts import Rig, closed_port, parts_rig, with_limits


def test_connect_and_disconnect_are_asynchronous_and_quick(fresh: Api) -> None:
    assert fresh.value("Connecting") is False
    for _ in range(3):  # idempotent, as ConformU calls them repeatedly
        started = time.monotonic()
        fresh.ok("Connect")
        assert time.monotonic() - started < 1.0
        wait_until(lambda: fresh.value("Connecting") is False, 5.0, "Connecting to become false after Connect")
        assert time.monotonic() - started < 5.0
        assert fresh.value("Connected") is True
        assert isinstance(fresh.value("RightAscension"), float)
    for _ in range(2):
        started = time.monotonic()
        fresh.ok("Disconnect")
        wait_until(lambda: fresh.value("Connecting") is False, 5.0, "Connecting to become false after Disconnect")
        assert time.monotonic() - started < 5.0
        assert fresh.value("Connected") is False


def test_connected_setter_is_synchronous_and_idempotent(fresh: Api) -> None:
    for _ in range(3):
        started = time.monotonic()
        fresh.ok("Connected", Connected=True)
        assert time.monotonic() - started < 5.0
        assert fresh.value("Connected") is True
        assert fresh.value("Connecting") is False
    for _ in range(3):
        fresh.ok("Connected", Connected=False)
        assert fresh.value("Connected") is False


def test_connecting_is_observed_true_or_already_done(fresh: Api) -> None:
    """Connecting may be seen true only between Connect and completion, never after."""
    fresh.ok("Connect")
    seen = [fresh.value("Connecting") for _ in range(3)]
    wait_until(lambda: fresh.value("Connecting") is False, 5.0, "Connect to finish")
    assert seen == sorted(seen, reverse=True), f"Connecting went false then true again: {seen}"
    assert fresh.value("Connected") is True


def test_many_clients_share_the_connection(url: str) -> None:
    """R6: PHD2, NINA and a planetarium connected at once; one disconnecting must not drop the others."""
    nina, phd2, cdc = Api(url, client_id=1), Api(url, client_id=2), Api(url, client_id=98765)
    nina.connect()
    phd2.ok("Connect")
    wait_until(lambda: phd2.value("Connecting") is False, 5.0, "PHD2's Connect")
    cdc.connect()
    for client in (nina, phd2, cdc):
        assert client.value("Connected") is True
    nina.ok("Connected", Connected=False)
    assert nina.value("Connected") is False
    for client in (phd2, cdc):
        assert client.value("Connected") is True, client.client_id
        assert isinstance(client.value("RightAscension"), float)
    phd2.ok("Tracking", Tracking=True)
    phd2.ok("PulseGuide", Direction=0, Duration=200)
    wait_until(lambda: phd2.value("IsPulseGuiding") is False, 5.0, "PHD2's pulse")
    cdc.ok("Disconnect")
    wait_until(lambda: cdc.value("Connecting") is False, 5.0, "CdC's Disconnect")
    assert cdc.value("Connected") is False
    assert phd2.value("Connected") is True and phd2.value("Tracking") is True
    phd2.ok("Connected", Connected=False)
    assert phd2.value("Connected") is False


def test_concurrent_clients_connect_at_once(url: str) -> None:
    """Eight clients connecting in parallel all end up connected, each in well under 5 s."""
    clients = [Api(url, client_id=100 + i) for i in range(8)]
    errors: list[str] = []
    durations: list[float] = []

    def connect(client: Api) -> None:
        try:
            started = time.monotonic()
            client.ok("Connected", Connected=True)
            durations.append(time.monotonic() - started)
        except AssertionError as exc:
            errors.append(str(exc))

    threads = [threading.Thread(target=connect, args=(c,)) for c in clients]
    for t in threads:
        t.start()
    for t in threads:
        t.join(10)
    assert not errors, errors
    assert max(durations) < 5.0
    assert all(c.value("Connected") is True for c in clients)


# ================================================================================================
# The part alone: Connection on a real Mount, MotionSupervisor and emulator
# ================================================================================================

NINA, PHD2 = ClientKey("192.0.2.10", 1), ClientKey("192.0.2.11", 2)


@contextmanager
def as_client(key: ClientKey) -> Iterator[None]:
    """Run as the Alpaca door runs a request: with the caller named in ``current_client``."""
    token = current_client.set(key)
    try:
        yield
    finally:
        current_client.reset(token)


def test_the_first_client_opens_the_link_and_pushes_the_configured_settings(tmp_path: Path) -> None:
    """The configuration is the source of truth: a mount reset to other settings gets them back at connect."""
    settings = with_limits(meridian_limit_deg=-10.0, meridian_track_past=False)
    with parts_rig(tmp_path, settings=settings) as rig:
        assert rig.model.flash.set_meridian(MeridianSettings(False, True, 5))
        rig.model.set_tracking_rate("lunar")
        connection = rig.connection()
        assert not rig.mount.running and not connection.held_by(None)
        connection.attach(NINA)
        assert rig.mount.running
        assert rig.model.flash.meridian() == MeridianSettings(False, False, -10)
        # "Start up with a known tracking rate": :TQ# has no reply, so the emulator may take it a moment later.
        wait_until(lambda: rig.model.tracking_rate() == "sidereal", 5.0, "the sidereal rate")
        assert connection.clients() == {NINA}
        assert connection.held_by(NINA) and connection.held_by(None) and not connection.held_by(PHD2)
        connection.require_connected()  # held: no NotConnected


def test_the_members_name_their_client_from_the_request_context(tmp_path: Path) -> None:
    with parts_rig(tmp_path) as rig:
        connection = rig.connection()
        with as_client(NINA):
            assert connection.connected() is False
            connection.set_connected(True)
            assert connection.connected() is True
        with as_client(PHD2):
            assert connection.connected() is False  # NINA holds it, PHD2 does not
            connection.connect()
            wait_until(lambda: connection.connecting() is False, 10.0, "Connect to finish")
            assert connection.connected() is True
        assert connection.clients() == {NINA, PHD2}
        assert connection.connected() is True  # an internal caller: anyone holds it
        with as_client(PHD2):
            connection.disconnect()
        assert connection.clients() == {NINA}
        with as_client(NINA):
            connection.set_connected(False)
        assert connection.clients() == frozenset() and connection.connected() is False
        connection.set_connected(True)  # an internal caller holds it under its own name
        assert connection.clients() == {ClientKey("internal", 0)}
        with pytest.raises(NotConnected):
            rig.connection().require_connected()  # another device nobody holds


def test_the_link_lingers_after_the_last_client_then_closes(tmp_path: Path) -> None:
    with parts_rig(tmp_path) as rig:
        connection = rig.connection(linger_s=0.3)
        connection.attach(NINA)
        connection.release(NINA)
        assert rig.mount.running, "closed at once: a client reconnecting would wait for the connect sequence"
        with pytest.raises(NotConnected):
            connection.require_connected()  # lingering is not connected
        wait_until(lambda: not rig.mount.running, 10.0, "the link to close after the linger")
        connection.attach(PHD2)  # and it opens again
        assert rig.mount.running and connection.clients() == {PHD2}


def test_a_client_returning_within_the_linger_keeps_the_link(tmp_path: Path) -> None:
    with parts_rig(tmp_path) as rig:
        connection = rig.connection(linger_s=0.3)
        connection.attach(NINA)
        connection.release(NINA)
        connection.attach(PHD2)
        time.sleep(1.0)  # an observation window three lingers long, in which a close not cancelled would fire
        assert rig.mount.running and connection.held_by(PHD2)
        connection.close()  # server shutdown: no timer left behind
        connection.release(PHD2)
        assert rig.mount.running


def test_the_last_client_leaving_stops_manual_motion(tmp_path: Path) -> None:
    """A vanished client must not leave the mount moving (a MoveAxis owner's last word was "move")."""
    with parts_rig(tmp_path) as rig:
        connection = rig.connection()
        connection.attach(NINA)
        rig.registry.touch(NINA, "N.I.N.A.")  # a client the server has heard from (the MoveAxis watchdog asks)
        rig.motion.move_axis(0, 1.0, NINA)
        wait_until(lambda: axis_speed(rig) > 0.5, 10.0, "the axis to move")
        connection.attach(PHD2)
        connection.release(NINA)  # another client still holds it: the move goes on
        assert rig.motion.moves and axis_speed(rig) > 0.5
        connection.release(PHD2)
        wait_until(lambda: axis_speed(rig) == 0.0 and not rig.motion.moves, 20.0, "the move to stop")


def axis_speed(rig: Rig) -> float:
    """The RA axis's speed on the emulator, deg/s (tracking is off at home: 0 at rest)."""
    return abs(float(rig.model.snapshot()["velocity_deg_s"][0]))


def test_a_mount_that_cannot_be_reached(tmp_path: Path) -> None:
    """Connected=true fails with the URL in the message; Connect() only logs; nobody is counted in."""
    url = f"socket://127.0.0.1:{closed_port()}"
    with parts_rig(tmp_path, url=url) as rig:
        connection = rig.connection()
        with pytest.raises(DriverError) as info:
            connection.attach(NINA)
        assert info.value.number == ERR_LINK and url in info.value.message
        connection.connect_in_background(PHD2)
        wait_until(lambda: connection.connecting() is False, 10.0, "the failed Connect to end")
        assert connection.clients() == frozenset() and not rig.mount.running
        with pytest.raises(NotConnected):
            connection.require_connected()
