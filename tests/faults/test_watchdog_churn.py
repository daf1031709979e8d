"""The MoveAxis watchdog under client churn (issue 23, item 2).

The client registry is bounded (256 entries, least recently seen evicted). Before this fix a burst of
GETs from 256 other ClientIDs evicted a MoveAxis owner, and the watchdog skipped an owner it could not
find: the axis drove on for ever. Now the owner of a running move is never evicted, and an owner the
server cannot find counts as silent. Judged by the emulator's truth (its axis moves), not by Slewing.
"""

from __future__ import annotations

import http.client
import logging
import threading
import time
from collections.abc import Iterator

import pytest

from alpaca_zwo.clients import ClientKey, ClientRegistry
from alpaca_zwo.config.settings import SafetySettings
from tests.faults.conftest import Rig, RigFactory
from tests.faults.harness import Verdict, report
from tests.support import wait_until

#: Short enough for the suite; long enough that 300 GETs fit well inside it on a loaded machine, so the
#: old code has evicted the owner before its watchdog could have fired.
WATCHDOG_S = 4.0
#: The supervisor looks every 0.1 s; a busy flood of GETs in the same process slows its ticks.
SLACK_S = 1.5
MOVER_ID = 500
FLOOD_THREADS = 4
FIRST_OTHER_ID = 10_000  # clear of the mover and of the rig's main client (4242)


def _flood(port: int, ids: list[int], answered: list[int]) -> None:
    """GET Slewing once per ClientID over one keep-alive connection, counting HTTP 200s."""
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    try:
        for client_id in ids:
            conn.request("GET", f"/api/v1/telescope/0/slewing?ClientID={client_id}&ClientTransactionID=1")
            response = conn.getresponse()
            response.read()
            if response.status == 200:
                answered.append(client_id)
    finally:
        conn.close()


def _start_flood(port: int, count: int, answered: list[int]) -> list[threading.Thread]:
    ids = list(range(FIRST_OTHER_ID, FIRST_OTHER_ID + count))
    threads = [threading.Thread(target=_flood, args=(port, ids[i::FLOOD_THREADS], answered), daemon=True)
               for i in range(FLOOD_THREADS)]
    for thread in threads:
        thread.start()
    return threads


@pytest.fixture
def moving_rig(rig_factory: RigFactory) -> Iterator[Rig]:
    rig = rig_factory(safety=SafetySettings(moveaxis_watchdog_s=WATCHDOG_S))
    yield rig
    if rig.snapshot()["moves_deg_s"][0] is not None:
        rig.clients[0].put("abortslew")  # leave the emulator still for teardown


@pytest.mark.parametrize("others", [300, 5000])
def test_watchdog_survives_client_churn(moving_rig: Rig, others: int, caplog: pytest.LogCaptureFixture) -> None:
    """MoveAxis by ClientID 500, then GETs from ``others`` other ClientIDs: the axis stops by the watchdog."""
    caplog.set_level(logging.INFO, logger="alpaca_zwo")
    rig = moving_rig
    verdict = Verdict(f"MoveAxis watchdog with {others} other ClientIDs")
    mover = rig.client(MOVER_ID)
    mover.command("connected", Connected="true")
    mover.command("moveaxis", Axis=0, Rate=1.0)
    last = mover.log.calls()[-1]
    silent_from = last.started + last.elapsed
    wait_until(lambda: rig.snapshot()["moves_deg_s"][0] is not None, 5, "the move to start")
    answered: list[int] = []
    flood = _start_flood(rig.port, others, answered)
    wait_until(lambda: rig.snapshot()["moves_deg_s"][0] is None, WATCHDOG_S + 10,
               f"the watchdog to stop the axis while {others} other ClientIDs poll", interval=0.02)
    stop_after = time.monotonic() - silent_from
    for thread in flood:
        thread.join(120)
    verdict.check(len(answered) == others, f"only {len(answered)} of {others} GETs were answered")
    verdict.check(WATCHDOG_S - 0.1 <= stop_after <= WATCHDOG_S + SLACK_S,
                  f"the axis stopped {stop_after:.2f} s after its client fell silent (watchdog {WATCHDOG_S} s)")
    why = [r.getMessage() for r in caplog.records if "went silent" in r.getMessage()]
    verdict.check(why and f"#{MOVER_ID}" in why[0], f"no log line naming the silent client: {why}")
    clients = rig.server.registry.snapshot()
    verdict.check(len(clients) <= rig.server.registry.max_clients + 1,
                  f"the registry grew to {len(clients)} entries")
    report(f"MoveAxis watchdog, {others} other ClientIDs", configured_s=WATCHDOG_S, stopped_after_silence_s=stop_after)
    verdict.conclude()


def test_watchdog_stops_an_owner_the_server_cannot_find(moving_rig: Rig, caplog: pytest.LogCaptureFixture) -> None:
    """A move whose owner is not in the registry counts as silent: stopped at the next look, not never."""
    caplog.set_level(logging.INFO, logger="alpaca_zwo")
    rig = moving_rig
    ghost = ClientKey("203.0.113.9", 77)  # never made a request
    started = time.monotonic()
    rig.telescope.motion.move_axis(0, 1.0, ghost)

    def stopped_as_silent() -> bool:
        return any("no longer known" in r.getMessage() and str(ghost) in r.getMessage() for r in caplog.records)

    wait_until(stopped_as_silent, WATCHDOG_S, "the watchdog to stop the unknown owner's move")
    assert time.monotonic() - started < 1.0, "an unknown owner's move ran on towards the watchdog time"
    wait_until(lambda: rig.snapshot()["moves_deg_s"][0] is None and rig.snapshot()["velocity_deg_s"][0] == 0.0,
               10, "the axis to come to rest")


def test_registry_keeps_protected_keys_and_stays_bounded() -> None:
    """5,000 other ClientIDs evict everyone but a protected owner; the registry stays at its bound."""
    registry = ClientRegistry(max_clients=256)
    owner = ClientKey("127.0.0.1", MOVER_ID)
    registry.touch(owner, now=0.0)
    owners = [owner]
    registry.protect(lambda: owners)
    for i in range(5000):
        registry.touch(ClientKey("127.0.0.1", FIRST_OTHER_ID + i), now=1.0 + i)
    assert registry.last_seen(owner) == 0.0
    assert len(registry.snapshot()) == 256
    owners.clear()  # the move ended: the owner is an ordinary, oldest entry again
    registry.touch(ClientKey("127.0.0.1", 1), now=9999.0)
    assert registry.last_seen(owner) is None
    assert len(registry.snapshot()) == 256
