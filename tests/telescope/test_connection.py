"""Connection over HTTP: Platform 7 Connect/Disconnect, and many clients sharing the mount."""

from __future__ import annotations

import threading
import time

from tests.support import wait_until
from tests.telescope.harness import Api


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
