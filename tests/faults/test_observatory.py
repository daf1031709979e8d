"""The observatory interlock (issue 35): the mount obeys a real Alpaca SafetyMonitor and roof, whatever a client asks.

The devices are alpaca-simulators from PyPI (tests/support/observatory.py), a third-party Alpaca server
on a loopback port, toggled through its own Alpaca API and finally stopped (unreachable). The mount is
judged by the emulator's truth: its axes' velocities, its tracking, its position at home, and the wire
recorder (which commands reached it).
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Iterator
from datetime import datetime
from pathlib import Path
from typing import Any

import pytest

from alpaca_zwo.alpaca.members import DEVICE_MEMBERS
from alpaca_zwo.bridges.zwo_backend import Session, SharedZone, TelescopeBackend
from alpaca_zwo.clients import ClientKey
from alpaca_zwo.config.settings import EmulatorSettings, SafetySettings
from alpaca_zwo.observatory.response import INTERLOCK_CLIENT
from alpaca_zwo.zwo import dispatch
from tests.faults.conftest import Rig, RigFactory
from tests.faults.harness import Verdict, report
from tests.support import AlpacaClient, wait_until
from tests.support.observatory import AlpacaSimulators
from tests.telescope.expectations import args_for

INVALID_OPERATION = 0x40B
#: Command codes that move the mount or let it move (GOTO, moves, pulses, home, park, tracking on, flip limit).
MOTION_CODES = ("MS", "Me", "Mw", "Mn", "Ms", "Mg", "hC", "hP", "Te", "STa")
POLL_S = 0.2
FAST = EmulatorSettings(speed=4.0, baud=0)  # slews and homes in a few real seconds


@pytest.fixture
def sims(tmp_path: Path) -> Iterator[AlpacaSimulators]:
    with AlpacaSimulators(tmp_path) as simulators:
        yield simulators


def interlock(sims: AlpacaSimulators, *, roof: bool = False, on_unsafe: str = "park",
              unreachable_s: float = 5.0) -> SafetySettings:
    return SafetySettings(monitor=sims.monitor_url, roof=sims.roof_url if roof else "", poll_s=POLL_S,
                          unreachable_s=unreachable_s, on_unsafe=on_unsafe)  # type: ignore[arg-type]


def safety(client: AlpacaClient) -> dict[str, Any]:
    reply: dict[str, Any] = json.loads(client.command("action", Action="zwo:Safety", Parameters="").value)
    return reply


def wait_state(client: AlpacaClient, state: str, timeout: float = 10.0) -> dict[str, Any]:
    wait_until(lambda: safety(client)["state"] == state, timeout, f"the interlock to say {state}", interval=0.05)
    return safety(client)


def motion_sent(rig: Rig, since: int) -> list[str]:
    return [e.body for e in rig.recorder.all()[since:] if e.body.startswith(MOTION_CODES)]


def still(rig: Rig) -> bool:
    snap = rig.snapshot()
    return (snap["velocity_deg_s"] == [0.0, 0.0] and snap["slew"] is None and not snap["tracking"]
            and snap["moves_deg_s"] == [None, None])


def refused_by_interlock(call: Any) -> bool:
    return call.error_number == INVALID_OPERATION and "safety monitor" in call.error_message


# ==================================================================================================
# Every door, every member
# ==================================================================================================

#: PUT members that start (or allow) motion, with arguments that would start it: refused while unsafe.
REFUSED: dict[str, dict[str, object]] = {
    "SlewToCoordinates": {"RightAscension": None, "Declination": 30.0},
    "SlewToCoordinatesAsync": {"RightAscension": None, "Declination": 30.0},
    "SlewToTarget": {},
    "SlewToTargetAsync": {},
    "SlewToAltAz": {"Azimuth": 120.0, "Altitude": 45.0},
    "SlewToAltAzAsync": {"Azimuth": 120.0, "Altitude": 45.0},
    "FindHome": {},
    "Unpark": {},
    "PulseGuide": {"Direction": 0, "Duration": 500},
    "MoveAxis": {"Axis": 0, "Rate": 1.0},
    "SideOfPier": {"SideOfPier": None},  # the other side
    "Tracking": {"Tracking": True},
    "RightAscensionRate": {"RightAscensionRate": 0.01},
    "DeclinationRate": {"DeclinationRate": 0.5},
}
#: Every other PUT member: never refused by the interlock (the ones marked True must succeed), in this order.
ALLOWED: dict[str, bool] = {
    "Action": True, "CommandBlind": False, "CommandBool": False, "CommandString": False, "Connect": True,
    "Connected": True, "DoesRefraction": False, "GuideRateDeclination": True, "GuideRateRightAscension": True,
    "SiteElevation": True, "SiteLatitude": True, "SiteLongitude": True, "SlewSettleTime": True,
    "TargetDeclination": True, "TargetRightAscension": True, "TrackingRate": True, "UTCDate": True,
    "SyncToCoordinates": True, "SyncToTarget": True, "SyncToAltAz": False, "AbortSlew": True, "SetPark": True,
    "Park": True, "Disconnect": True,
}
#: Also allowed, beyond the table: MoveAxis rate 0, zero rate offsets, Tracking=false.
STOPS: list[tuple[str, dict[str, object]]] = [
    ("MoveAxis", {"Axis": 0, "Rate": 0.0}), ("MoveAxis", {"Axis": 1, "Rate": 0.0}),
    ("RightAscensionRate", {"RightAscensionRate": 0.0}), ("DeclinationRate", {"DeclinationRate": 0.0}),
    ("Tracking", {"Tracking": False}),
]


def test_every_put_member_is_classified() -> None:
    """A member added to the Alpaca table must be put in REFUSED or ALLOWED here, so none can slip past."""
    puts = {m.name for m in DEVICE_MEMBERS["telescope"] if m.verb == "PUT"}
    assert set(REFUSED) | set(ALLOWED) == puts, (sorted(puts - set(REFUSED) - set(ALLOWED)),
                                                 sorted((set(REFUSED) | set(ALLOWED)) - puts))
    assert not set(REFUSED) & set(ALLOWED)


def test_unsafe_refuses_every_motion_member_and_allows_the_rest(rig_factory: RigFactory,
                                                                sims: AlpacaSimulators) -> None:
    """With the monitor unsafe (on_unsafe = "nothing", so the server itself moves nothing), every member
    that would start motion answers InvalidOperation naming the safety monitor and sends nothing that moves
    the mount; SyncToCoordinates, AbortSlew, Tracking=false, MoveAxis 0, Park and every other member work."""
    rig = rig_factory(safety=interlock(sims, on_unsafe="nothing"), emulator=FAST)
    verdict = Verdict("every member while unsafe")
    main = rig.clients[0]
    wait_state(main, "safe")
    main.command("tracking", Tracking=True)
    # Near the meridian, where SideOfPier may flip (from home, at HA -6 h, the Telescope refuses it first).
    main.command("slewtocoordinates", RightAscension=(main.value("siderealtime") + 0.3) % 24.0, Declination=40.0)
    ra = main.value("rightascension")
    main.command("targetrightascension", TargetRightAscension=(ra + 1.0) % 24.0)
    main.command("targetdeclination", TargetDeclination=40.0)
    sims.set_safe(False)
    state = wait_state(main, "unsafe")
    verdict.check(state["safe"] is False and state["source"] == sims.monitor_url and state["reason"] == "IsSafe=false"
                  and state["since"], f"zwo:Safety while unsafe: {state}")
    for name, args in REFUSED.items():
        args = dict(args)
        if name.startswith("SlewToCoordinates"):
            args["RightAscension"] = (ra + 1.0) % 24.0
        if name == "SideOfPier":
            args["SideOfPier"] = 1 - main.value("sideofpier")
        before = len(rig.recorder.all())
        call = main.put(name.lower(), **args)
        verdict.check(refused_by_interlock(call), f"{name} not refused by the interlock: {call.describe()}")
        sent = motion_sent(rig, before)
        verdict.check(not sent, f"{name} still sent {sent} to the mount")
    verdict.check(rig.snapshot()["slew"] is None and rig.snapshot()["moves_deg_s"] == [None, None],
                  "something moves after the refusals")
    for name, args in STOPS:
        before = len(rig.recorder.all())
        call = main.put(name.lower(), **args)
        verdict.check(not motion_sent(rig, before), f"{name} {args} sent {motion_sent(rig, before)} to the mount")
        verdict.check(call.ok, f"{name} {args} refused while unsafe: {call.describe()}")
    for name, must_succeed in ALLOWED.items():
        args = args_for("PUT", name)
        if name == "Action":
            args = {"Action": "zwo:Safety", "Parameters": ""}
        if name == "Connected":
            args = {"Connected": True}
        if name in ("SyncToCoordinates", "SyncToTarget"):
            continue  # below, with tracking on as a sync needs
        before = len(rig.recorder.all())
        call = main.put(name.lower(), **args)
        verdict.check(not refused_by_interlock(call), f"{name} refused by the interlock: {call.describe()}")
        if name != "Park":  # an allowed member moves nothing (a motion member put here by mistake fails)
            verdict.check(not motion_sent(rig, before), f"{name} sent {motion_sent(rig, before)} to the mount")
        if must_succeed:
            verdict.check(call.ok, f"{name} failed while unsafe: {call.describe()}")
        if name == "Park":
            wait_until(lambda: main.value("atpark") is True, 60, "the park to finish")
            verdict.check(still(rig), f"not still after Park: {rig.snapshot()}")
    report("every member while unsafe", refused=len(REFUSED), allowed=len(ALLOWED) + len(STOPS))
    verdict.conclude()


def test_syncs_work_while_unsafe(rig_factory: RigFactory, sims: AlpacaSimulators) -> None:
    """A sync moves nothing: SyncToCoordinates and SyncToTarget work while the monitor says unsafe."""
    rig = rig_factory(safety=interlock(sims, on_unsafe="nothing"))
    main = rig.clients[0]
    wait_state(main, "safe")
    main.command("tracking", Tracking=True)
    ra, dec = main.value("rightascension"), main.value("declination")
    sims.set_safe(False)
    wait_state(main, "unsafe")
    target = (ra + 0.01) % 24.0
    main.command("synctocoordinates", RightAscension=target, Declination=dec)
    assert abs(main.value("rightascension") - target) < 0.001
    main.command("synctotarget")
    assert main.value("tracking") is True  # left as it was ("nothing"), never turned on by the server either


# ==================================================================================================
# Turning unsafe: park / stop, then never unpark
# ==================================================================================================


def test_unsafe_mid_goto_parks_with_tracking_off_and_stays_parked(rig_factory: RigFactory, sims: AlpacaSimulators,
                                                                 caplog: pytest.LogCaptureFixture) -> None:
    """A GOTO runs when IsSafe turns false: the server stops it and parks (home), tracking off; the log names
    the monitor's answer; when safe again the mount stays parked until a client unparks it."""
    caplog.set_level(logging.INFO, logger="alpaca_zwo")
    rig = rig_factory(safety=interlock(sims), emulator=FAST)
    verdict = Verdict("unsafe during a GOTO")
    main = rig.clients[0]
    wait_state(main, "safe")
    main.command("tracking", Tracking=True)
    ra = main.value("siderealtime")
    main.command("slewtocoordinatesasync", RightAscension=(ra + 3.0) % 24.0, Declination=20.0)
    wait_until(lambda: rig.snapshot()["slew"] is not None, 5, "the GOTO to start")
    turned = time.monotonic()
    sims.set_safe(False)
    wait_until(lambda: main.value("atpark") is True, 90, "the server to park the mount")
    parked_after = time.monotonic() - turned
    snap = rig.snapshot()
    verdict.check(still(rig) and snap["at_home"], f"emulator truth after the park: {snap}")
    verdict.check(main.value("tracking") is False, "Tracking still true after the safety park")
    messages = [r.getMessage() for r in caplog.records]
    verdict.check(any("UNSAFE: IsSafe=false" in m and sims.monitor_url in m for m in messages),
                  "no log line with the monitor's answer")
    # The page shows it: the status feed's safety, with the event.
    feed = main.session.get(f"{main.base}/setup/api/telescope/0/status", timeout=10).json()["safety"]
    verdict.check(feed["state"] == "unsafe" and any("parked" in e["text"] for e in feed["events"]),
                  f"status feed: {feed}")
    sims.set_safe(True)
    wait_state(main, "safe")
    time.sleep(3 * POLL_S)  # several polls and responder ticks after the all-clear: still parked
    verdict.check(main.value("atpark") is True and still(rig), "the server unparked or moved the mount by itself")
    main.command("unpark")
    verdict.check(main.value("atpark") is False, "Unpark did not work once safe")
    report("unsafe during a GOTO", parked_after_s=parked_after)
    verdict.conclude()


def test_stop_mode_ends_moves_pulses_and_offsets(rig_factory: RigFactory, sims: AlpacaSimulators) -> None:
    """on_unsafe = "stop": a MoveAxis and a rate offset are stopped, tracking off, the mount not parked."""
    rig = rig_factory(safety=interlock(sims, on_unsafe="stop"), emulator=FAST)
    main = rig.clients[0]
    wait_state(main, "safe")
    main.command("tracking", Tracking=True)
    main.command("declinationrate", DeclinationRate=5.0)
    main.command("moveaxis", Axis=0, Rate=0.5)
    wait_until(lambda: rig.snapshot()["moves_deg_s"][0] is not None, 5, "the move to start")
    sims.set_safe(False)
    wait_until(lambda: still(rig), 20, "the server to stop the mount, tracking off")
    assert main.value("atpark") is False
    assert main.value("declinationrate") == 0.0
    time.sleep(1.0)
    assert still(rig), rig.snapshot()  # and nothing starts again (offsets are not paid without tracking)


def test_a_long_pulse_is_cut_short(rig_factory: RigFactory, sims: AlpacaSimulators) -> None:
    """A 20 s PulseGuide (sent in 3 s chunks) runs when it turns unsafe: the server ends it at once (no further
    chunk), IsPulseGuiding drops, and the mount is parked with tracking off."""
    rig = rig_factory(safety=interlock(sims), emulator=FAST)
    main = rig.clients[0]
    wait_state(main, "safe")
    main.command("tracking", Tracking=True)
    main.command("pulseguide", Direction=0, Duration=20000)
    wait_until(lambda: any(rig.snapshot()["pulses"]), 5, "the pulse to start")
    started = time.monotonic()
    sims.set_safe(False)
    wait_until(lambda: main.value("ispulseguiding") is False, 5, "the pulse to end")
    assert time.monotonic() - started < 5.0  # not its 20 s
    wait_until(lambda: main.value("atpark") is True, 60, "the park")
    assert still(rig) and rig.snapshot()["pulses"] == [None, None], rig.snapshot()


def test_roof_must_be_open(rig_factory: RigFactory, sims: AlpacaSimulators) -> None:
    """With a roof configured, its closed shutter (the simulator starts closed) refuses motion; opened, it
    allows it; closed during a MoveAxis, the server parks."""
    rig = rig_factory(safety=interlock(sims, roof=True), emulator=FAST)
    main = rig.clients[0]
    state = wait_state(main, "unsafe")
    assert state["source"] == sims.roof_url and state["reason"] == "ShutterStatus=1 (closed)", state
    wait_until(lambda: main.value("atpark") is True, 60, "the server to park under a closed roof")
    call = main.put("unpark")
    assert refused_by_interlock(call) and "ShutterStatus=1 (closed)" in call.error_message, call.describe()
    sims.open_roof()
    wait_state(main, "safe")
    main.command("unpark")
    main.command("moveaxis", Axis=1, Rate=0.5)
    sims.close_roof()
    wait_until(lambda: main.value("atpark") is True, 60, "the server to park when the roof closes")
    assert still(rig), rig.snapshot()


def test_unreachable_monitor_counts_as_unsafe(rig_factory: RigFactory, sims: AlpacaSimulators) -> None:
    """The monitor's server stops: unreachable_s after its last answer (not sooner) the server says unsafe and
    parks the mount.

    "Not sooner" is judged from the server's own record (the last answer's time, the verdict's since), not from
    when the test stopped the monitor: the simulator's graceful stop can take longer than a poll on a busy
    machine, and its last answer may come before that stop returns (a clean-clone CI run: 1.68 s after it)."""
    unreachable_s = 2.0
    rig = rig_factory(safety=interlock(sims, unreachable_s=unreachable_s), emulator=FAST)
    main = rig.clients[0]
    wait_state(main, "safe")
    main.command("tracking", Tracking=True)
    sims.stop()
    gone = time.monotonic()
    sims.wait_gone()
    state = wait_state(main, "unsafe", timeout=unreachable_s + 5)
    unsafe_after = time.monotonic() - gone
    assert "no answer for" in state["reason"], state
    assert unsafe_after <= unreachable_s + 2.0, unsafe_after
    view = main.session.get(f"{main.base}/setup/api/safety", timeout=10).json()
    silent_s = (datetime.fromisoformat(view["since"]) - datetime.fromisoformat(view["monitor"]["at"])).total_seconds()
    assert unreachable_s - 0.05 <= silent_s <= unreachable_s + 2.0, view  # 0.05 s: the wall and monotonic stamps
    wait_until(lambda: main.value("atpark") is True, 60, "the park")
    assert still(rig), rig.snapshot()
    report("unreachable monitor", unreachable_s=unreachable_s, unsafe_after_s=unsafe_after, silent_s=silent_s,
           reason=state["reason"])


def test_a_running_park_is_left_to_finish(rig_factory: RigFactory, sims: AlpacaSimulators) -> None:
    """IsSafe turns false while a client's park runs: the park is not aborted and sent again, it finishes."""
    rig = rig_factory(safety=interlock(sims), emulator=FAST)
    main = rig.clients[0]
    wait_state(main, "safe")
    main.command("slewtoaltazasync", Azimuth=200.0, Altitude=40.0)
    wait_until(lambda: main.value("slewing") is False, 60, "the slew away from home")
    before = len(rig.recorder.all())
    main.command("park")
    wait_until(lambda: rig.snapshot()["slew"] is not None, 5, "the park to start")
    sims.set_safe(False)
    wait_state(main, "unsafe")
    wait_until(lambda: main.value("atpark") is True, 60, "the park to finish")
    bodies = [e.body for e in rig.recorder.all()[before:]]
    assert bodies.count("hC") == 1 and "Q" not in bodies, [b for b in bodies if b in ("hC", "Q", "MS")]
    assert still(rig), rig.snapshot()


def test_starting_while_unsafe_parks_a_mount_nobody_connected(rig_factory: RigFactory,
                                                             sims: AlpacaSimulators) -> None:
    """The server starts while the monitor says unsafe and no client connects: it connects the mount itself,
    parks it, and lets go of it afterwards."""
    sims.set_safe(False)
    rig = rig_factory(safety=interlock(sims), emulator=FAST, connect=False)
    wait_until(lambda: rig.telescope.motion.parked, 60, "the server to park the mount on its own")
    wait_until(lambda: INTERLOCK_CLIENT not in rig.telescope.connection.clients(), 10, "the interlock to let go")
    assert still(rig), rig.snapshot()
    client = rig.client(7)
    client.command("connected", Connected=True)
    call = client.put("unpark")
    assert refused_by_interlock(call), call.describe()


def test_mount_away_when_it_turns_unsafe_is_parked_when_it_returns(rig_factory: RigFactory,
                                                                  sims: AlpacaSimulators) -> None:
    """The mount's link stalls (WiFi gone) as the monitor turns unsafe: the park cannot go out then; it is
    carried out once the mount answers again, the monitor still saying unsafe."""
    rig = rig_factory(safety=interlock(sims), emulator=FAST)
    main = rig.clients[0]
    wait_state(main, "safe")
    main.command("tracking", Tracking=True)
    rig.faults.stall(6000)
    time.sleep(0.3)
    sims.set_safe(False)
    wait_state(main, "unsafe")
    wait_until(lambda: rig.telescope.motion.parked, 90, "the park after the mount came back")
    assert still(rig), rig.snapshot()


# ==================================================================================================
# The other doors: the shared ZWO port, the page
# ==================================================================================================


def test_zwo_port_answers_as_the_mount_refuses(rig_factory: RigFactory, sims: AlpacaSimulators) -> None:
    """Through the ZWO port's responder: a GOTO answers e4#, :Spu# and :Te# answer 0, a move is silent,
    and none of them reaches the mount; :Q# and :CM# still work."""
    rig = rig_factory(safety=interlock(sims, on_unsafe="nothing"))
    main = rig.clients[0]
    wait_state(main, "safe")
    sims.set_safe(False)
    wait_state(main, "unsafe")
    backend = TelescopeBackend(rig.telescope, Session(ClientKey("127.0.0.1:5000", 1)), SharedZone())
    rig.telescope.connection.set_connected(True)  # as the port does for its programs
    before = len(rig.recorder.all())
    assert dispatch.answer(backend, "Sr01:00:00") == "1"
    assert dispatch.answer(backend, "Sd+40*00:00") == "1"
    replies = {}
    for body in ("MS", "Spu", "Te", "Me", "Mgn0500", "hC"):
        try:
            replies[body] = dispatch.answer(backend, body)
        except Exception as exc:  # Refusal carries the reply the mount would send
            replies[body] = getattr(exc, "reply", repr(exc))
    assert replies == {"MS": "e4#", "Spu": "0", "Te": "0", "Me": None, "Mgn0500": None, "hC": None}, replies
    assert not motion_sent(rig, before), motion_sent(rig, before)
    assert dispatch.answer(backend, "Q") is None


def test_page_refuses_motion_and_shows_the_state(rig_factory: RigFactory, sims: AlpacaSimulators) -> None:
    """The page's controls go through the same gate: a jog and Unpark are refused with the monitor's reason;
    /setup/api/safety shows the state, the last answer and its age."""
    rig = rig_factory(safety=interlock(sims, on_unsafe="nothing"))
    main = rig.clients[0]
    wait_state(main, "safe")
    sims.set_safe(False)
    wait_state(main, "unsafe")
    page = f"{main.base}/setup/api"
    headers = {"X-Alpaca-Zwo": "1", "Content-Type": "application/json", "Origin": main.base}
    reply = main.session.post(f"{page}/telescope/0/action/move", json={"axis": 0, "rate": 1.0}, headers=headers,
                              timeout=10)
    assert reply.status_code >= 400 and "safety monitor" in reply.text, (reply.status_code, reply.text)
    view = main.session.get(f"{page}/safety", timeout=10).json()
    assert view["state"] == "unsafe" and view["monitor"]["answer"] == "IsSafe=false", view
    assert 0.0 <= view["monitor"]["age_s"] < 2.0 and view["monitor"]["url"] == sims.monitor_url, view
    assert rig.snapshot()["moves_deg_s"] == [None, None]


def test_stellarium_goto_is_refused(rig_factory: RigFactory, sims: AlpacaSimulators) -> None:
    """Stellarium's goto goes through the same gate: refused (its protocol has no reply; the page's bridge
    table shows why), nothing sent to the mount."""
    from alpaca_zwo.config.settings import StellariumSettings
    from tests.bridges.stellarium_client import StellariumClient

    rig = rig_factory(safety=interlock(sims, on_unsafe="nothing"),
                      stellarium=StellariumSettings(enabled=True, host="127.0.0.1", port=0, equinox="JNow"))
    main = rig.clients[0]
    wait_state(main, "safe")
    sims.set_safe(False)
    wait_state(main, "unsafe")
    before = len(rig.recorder.all())
    stellarium = StellariumClient(rig.server.stellarium.port)
    try:
        stellarium.read_position()
        stellarium.goto((main.value("siderealtime") + 1.0) % 24.0, 30.0)
        wait_until(lambda: (rig.server.stellarium.status()["last_error"] or {}).get("message", ""), 10,
                   "the bridge to record the refusal")
    finally:
        stellarium.close()
    message = rig.server.stellarium.status()["last_error"]["message"]
    assert "goto refused" in message and "safety monitor" in message, message
    assert not motion_sent(rig, before), motion_sent(rig, before)
