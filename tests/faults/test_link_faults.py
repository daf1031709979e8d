"""The fault matrix: each way a real mount link misbehaves, injected behind a running server.

For every fault the same promises are checked from the outside: HTTP keeps answering (no 5xx, no
request slower than real clients wait), ``Connected`` stays true through a short outage while
DeviceState carries the true age of the position, commands fail with a clear DriverError rather
than hanging, the link comes back by itself within 5 s of the mount, no stale position is ever
stamped as fresh, and no reply is attributed to the wrong request (the link's trace is audited
against what the emulated mount really answered). Each scenario collects every broken promise
before failing, so one run shows the whole picture.
"""

from __future__ import annotations

import time
from datetime import datetime, timedelta

import pytest

from alpaca_zwo import sky
from alpaca_zwo.config.settings import EmulatorSettings
from alpaca_zwo.sky import SIDEREAL_DEG_S
from alpaca_zwo.zwo import protocol
from tests.faults.conftest import MAIN_ID, Rig, RigFactory
from tests.faults.harness import (
    RECONNECT_LIMIT_S,
    Monitor,
    MountExchange,
    Sample,
    Verdict,
    is_clear_driver_error,
    parse_alpaca_time,
    report,
)
from tests.support import AlpacaClient, Call, wait_until

#: A reading taken just before a fault may still be published by the poll cycle in flight.
IN_FLIGHT_S = 0.5
#: ASCOM numbers a command may legitimately fail with while the mount is unreachable.
LINK_ERRORS = range(0x500, 0x600)
#: The mount prints whole seconds of RA and whole arcseconds of Dec.
RA_TOLERANCE_H = 1.5 / 3600.0
DEC_TOLERANCE_DEG = 1.5 / 3600.0


def _altaz_target(rig: Rig, client: AlpacaClient, altitude: float, azimuth: float) -> tuple[float, float]:
    """RA/Dec that stands at ``altitude``/``azimuth`` now, by the server's own sidereal time and site."""
    lst = client.value("siderealtime")
    latitude = rig.server.settings.site.latitude
    ha, dec = sky.horizontal_to_equatorial(altitude, azimuth, latitude)
    return sky.ra_from_hour_angle(lst, ha), dec


def _fresh_after(monitor: Monitor, truth: datetime, since: float, timeout: float) -> Sample:
    """The first sample whose position was read after ``truth`` (emulated UTC)."""
    return wait_until(
        lambda: next((s for s in monitor.between(since) if s.timestamp is not None and s.timestamp > truth), None),
        timeout, f"a position read after {truth.isoformat()}", interval=0.05)


def _check_stale_never_fresh(samples: list[Sample], fault_truth: datetime, verdict: Verdict) -> float:
    """During a fault no sample may claim a reading newer than the fault's start; return the largest age."""
    limit = fault_truth + timedelta(seconds=IN_FLIGHT_S)
    worst = 0.0
    for sample in samples:
        if not verdict.check(sample.timestamp is not None, f"DeviceState failed during the fault: {sample}"):
            continue
        assert sample.timestamp is not None
        verdict.check(sample.timestamp <= limit,
                      f"position stamped {sample.timestamp.isoformat()} served as fresh during a fault that "
                      f"began at {fault_truth.isoformat()}")
        worst = max(worst, sample.age or 0.0)
    return worst


def _command_loop(client: AlpacaClient, until: float, period: float = 1.0) -> list[Call]:
    """An imaging program keeps trying: tracking on, then a short guide pulse, alternately."""
    calls = []
    index = 0
    while time.monotonic() < until:
        started = time.monotonic()
        if index % 2 == 0:
            calls.append(client.put("tracking", Tracking="true"))
        else:
            calls.append(client.put("pulseguide", Direction=2, Duration=200))
        index += 1
        time.sleep(max(0.0, period - (time.monotonic() - started)))
    return calls


def _check_commands_clear(calls: list[Call], verdict: Verdict) -> None:
    for call in calls:
        verdict.check(call.ok or is_clear_driver_error(call), f"unclear failure: {call.describe()}")


def _check_healthy(rig: Rig, verdict: Verdict, also_allowed: tuple[int, ...] = ()) -> None:
    """HTTP promises for every request of the scenario, and the audit of every reply on the wire.
    ``also_allowed``: ASCOM errors the scenario provokes on purpose (a refusal it checks itself)."""
    verdict.extend(rig.log.problems(allowed_errors={*LINK_ERRORS, *also_allowed}))
    audit = rig.audit()
    verdict.extend(f"misattributed reply: {m}" for m in audit.mismatches)
    verdict.check(audit.checked > 0, "the link trace held no exchange to audit")


def _check_position_true(rig: Rig, client: AlpacaClient, verdict: Verdict, what: str) -> None:
    """The position served, once re-read after this moment, agrees with where the mount really points.

    Called with the mount at rest (tracking), so its RA/Dec do not change while the server catches up.
    """
    truth = rig.snapshot()
    read_after = datetime.fromisoformat(truth["true_utc"])
    state = wait_until(lambda: (lambda s: s if parse_alpaca_time(s["TimeStamp"]) > read_after else None)(
        client.device_state()), RECONNECT_LIMIT_S, f"a position read {what}")
    dra = abs((state["RightAscension"] - truth["ra_h"] + 12.0) % 24.0 - 12.0)
    ddec = abs(state["Declination"] - truth["dec_deg"])
    verdict.check(dra <= RA_TOLERANCE_H and ddec <= DEC_TOLERANCE_DEG,
                  f"{what}: served RA/Dec {state['RightAscension']:.5f} h/{state['Declination']:.5f}° but the mount "
                  f"is at {truth['ra_h']:.5f} h/{truth['dec_deg']:.5f}°")


def _slowest(rig: Rig, verb: str) -> float:
    call = rig.log.slowest(verb)
    return call.elapsed if call else 0.0


# --- WiFi stalls ------------------------------------------------------------------------------------


@pytest.mark.parametrize("stall_s", [2.0, 10.0, 30.0])
def test_wifi_stall(rig_factory: RigFactory, stall_s: float) -> None:
    """The mount's access point goes quiet: nothing arrives for ``stall_s``, then the queued replies do."""
    rig = rig_factory()
    verdict = Verdict(f"WiFi stall of {stall_s:.0f} s")
    main = rig.clients[0]
    main.command("tracking", Tracking="true")
    with Monitor(rig.client(MAIN_ID), rig.truth) as monitor:
        time.sleep(0.5)  # a few samples of the healthy state
        fault_at, fault_truth = time.monotonic(), rig.truth()
        rig.faults.stall(stall_s * 1000)
        end = fault_at + stall_s
        calls = _command_loop(rig.client(MAIN_ID), end - 0.5)
        fresh = _fresh_after(monitor, fault_truth + timedelta(seconds=stall_s), fault_at, stall_s + 10)
        recovery = fresh.at - end
        after = main.put("tracking", Tracking="true")

    during = monitor.between(fault_at + IN_FLIGHT_S, end)
    verdict.check(during and all(s.connected is True for s in during),
                  f"Connected was not true throughout the stall: {[s.connected for s in during]}")
    worst_age = _check_stale_never_fresh(during, fault_truth, verdict)
    verdict.check(worst_age >= stall_s - 1.5, f"the age shown grew only to {worst_age:.1f} s in a {stall_s} s stall")
    _check_commands_clear(calls, verdict)
    verdict.check(recovery <= RECONNECT_LIMIT_S, f"fresh position only {recovery:.2f} s after the stall ended")
    verdict.check(after.ok, f"first command after the stall failed: {after.describe()}")
    _check_position_true(rig, main, verdict, "after the stall")
    _check_healthy(rig, verdict)
    report(f"stall {stall_s:.0f} s", max_age_s=worst_age, fresh_after_s=recovery,
           failed_commands=f"{sum(not c.ok for c in calls)}/{len(calls)}",
           slowest_get_s=_slowest(rig, "GET"), slowest_put_s=_slowest(rig, "PUT"))
    verdict.conclude()


# --- WiFi access point gone (connections reset) ---------------------------------------------------


def test_wifi_outage(rig_factory: RigFactory) -> None:
    """The access point disappears for 4 s: every connection is reset and new ones are refused."""
    outage_s = 4.0
    rig = rig_factory()
    verdict = Verdict("WiFi outage")
    main = rig.clients[0]
    main.command("tracking", Tracking="true")
    with Monitor(rig.client(MAIN_ID), rig.truth) as monitor:
        time.sleep(0.5)
        reconnects = rig.link.status.reconnects
        fault_at, fault_truth = time.monotonic(), rig.truth()
        rig.faults.outage(outage_s)
        end = fault_at + outage_s
        calls = _command_loop(rig.client(MAIN_ID), end - 0.3, period=0.5)
        wait_until(lambda: rig.link.status.reconnects > reconnects, outage_s + 10, "the link to reconnect")
        relinked = time.monotonic() - end
        fresh = _fresh_after(monitor, fault_truth + timedelta(seconds=outage_s), fault_at, 10)
        recovery = fresh.at - end
        after = main.put("tracking", Tracking="true")

    during = monitor.between(fault_at + IN_FLIGHT_S, end)
    verdict.check(during and all(s.connected is True for s in during),
                  f"Connected was not true throughout the outage: {[s.connected for s in during]}")
    worst_age = _check_stale_never_fresh(during, fault_truth, verdict)
    verdict.check(worst_age >= outage_s - 1.5, f"the age shown grew only to {worst_age:.1f} s")
    refused = [c for c in calls if fault_at + IN_FLIGHT_S < c.started < end - 0.5]
    verdict.check(refused and all(not c.ok for c in refused),
                  f"a command reported success while the mount was unreachable: {[c.describe() for c in refused]}")
    _check_commands_clear(calls, verdict)
    verdict.check(relinked <= RECONNECT_LIMIT_S, f"link back only {relinked:.2f} s after the mount")
    verdict.check(recovery <= RECONNECT_LIMIT_S, f"fresh position only {recovery:.2f} s after the mount came back")
    verdict.check(after.ok, f"first command after the outage failed: {after.describe()}")
    _check_position_true(rig, main, verdict, "after the outage")
    _check_healthy(rig, verdict)
    report("WiFi outage 4 s", max_age_s=worst_age, relink_s=relinked, fresh_after_s=recovery,
           slowest_refusal_s=max((c.elapsed for c in refused), default=0.0), refused=len(refused))
    verdict.conclude()


# --- USB cable pulled --------------------------------------------------------------------------------


def test_usb_unplugged_mid_slew(rig_factory: RigFactory) -> None:
    """The USB cable is pulled (pty hang-up) half way through a GOTO and the port comes back at once."""
    rig = rig_factory(usb=True)
    verdict = Verdict("USB unplugged mid-slew")
    main = rig.clients[0]
    main.command("tracking", Tracking="true")
    ra, dec = sky.ra_from_hour_angle(main.value("siderealtime"), -4.0), 60.0  # 30° on each axis from home
    with Monitor(rig.client(MAIN_ID), rig.truth, interval=0.1) as monitor:
        main.command("slewtocoordinatesasync", RightAscension=ra, Declination=dec)
        slew_at = time.monotonic()
        wait_until(lambda: rig.snapshot()["slew"] == "goto" and time.monotonic() - slew_at > 1.5, 10,
                   "the GOTO to be under way")
        reconnects = rig.link.status.reconnects
        fault_at = time.monotonic()
        rig.faults.close_connections()
        wait_until(lambda: rig.link.status.reconnects > reconnects, 10, "the link to reconnect")
        relinked = time.monotonic() - fault_at

        def finished() -> bool:
            if main.value("slewing"):
                return False
            verdict.check(rig.snapshot()["slew"] is None, "Slewing went false while the mount was still slewing")
            return True

        wait_until(finished, 90, "the GOTO to finish", interval=0.1)
        done_at = time.monotonic()

    during = monitor.between(slew_at, done_at - 0.2)
    flicker = [round(s.at - slew_at, 2) for s in during if s.state and s.state["Slewing"] is not True]
    verdict.check(not flicker, f"Slewing flickered false mid-slew at {flicker} s")
    verdict.check(relinked <= RECONNECT_LIMIT_S, f"link back only {relinked:.2f} s after the port returned")
    truth = rig.snapshot()
    verdict.check(abs((truth["ra_h"] - ra + 12) % 24 - 12) <= RA_TOLERANCE_H and abs(truth["dec_deg"] - dec) <= 2e-3,
                  f"the mount did not arrive: at {truth['ra_h']:.5f} h/{truth['dec_deg']:.5f}°, "
                  f"target {ra:.5f} h/{dec:.5f}°")
    _check_position_true(rig, main, verdict, "after the slew")
    _check_healthy(rig, verdict)
    report("USB unplugged mid-slew", relink_s=relinked, slew_s=done_at - slew_at, flickers=len(flicker))
    verdict.conclude()


@pytest.mark.parametrize("pulse_ms", [2000, 5000])
def test_usb_unplugged_mid_pulse(rig_factory: RigFactory, pulse_ms: int) -> None:
    """The cable is pulled during a guide pulse; the mount, which never saw the cable go, finishes it.

    A 5 s pulse is longer than the mount accepts in one command (3 s): the server sends the rest
    when the first part ends, which is when the cable is pulled here.
    """
    rig = rig_factory(usb=True)
    verdict = Verdict(f"USB unplugged mid-pulse ({pulse_ms} ms)")
    main = rig.clients[0]
    main.command("tracking", Tracking="false")
    before = rig.snapshot()["primary_deg"]
    reconnects = rig.link.status.reconnects
    call = main.put("pulseguide", Direction=2, Duration=pulse_ms)
    sent = time.monotonic()
    verdict.check(call.ok, f"the pulse was refused: {call.describe()}")
    unplug_at = sent + min(pulse_ms, 3000) / 1000.0 - 0.25  # the link has noticed by the time a part ends
    guiding: list[tuple[float, bool | None]] = []
    while time.monotonic() < sent + pulse_ms / 1000.0 + 2.0:  # PHD2: IsPulseGuiding every 50 ms
        if time.monotonic() >= unplug_at and rig.link.status.reconnects == reconnects and unplug_at > 0:
            rig.faults.close_connections()
            unplug_at = -1.0
        poll = main.get("ispulseguiding")
        guiding.append((poll.started - sent, poll.value if poll.ok else None))
        time.sleep(0.05)
    wait_until(lambda: rig.link.status.reconnects > reconnects, 10, "the link to reconnect")
    wait_until(lambda: rig.snapshot()["pulses"] == [None, None], 5, "the mount to end the pulse")
    moved = abs(rig.snapshot()["primary_deg"] - before)
    expected = 0.5 * SIDEREAL_DEG_S * pulse_ms / 1000.0
    ended = next((t for t, value in guiding if value is False), None)
    verdict.check(ended is not None and ended >= pulse_ms / 1000.0 - 0.15,
                  f"IsPulseGuiding went false {ended} s into a {pulse_ms} ms pulse")
    verdict.check(ended is not None and ended <= pulse_ms / 1000.0 + 1.0,
                  f"IsPulseGuiding still true {ended} s into a {pulse_ms} ms pulse")
    verdict.check(abs(moved - expected) <= 0.1 * expected,
                  f"the mount moved {moved * 3600:.1f}″ for a {pulse_ms} ms pulse worth {expected * 3600:.1f}″")
    verdict.check(all(value is not None for _, value in guiding), "IsPulseGuiding failed during the outage")
    again = main.put("pulseguide", Direction=3, Duration=300)
    verdict.check(again.ok, f"a pulse after the reconnect failed: {again.describe()}")
    _check_healthy(rig, verdict)
    report(f"USB unplugged mid-pulse {pulse_ms} ms", pulse_guiding_for_s=ended or 0.0,
           moved_arcsec=moved * 3600, expected_arcsec=expected * 3600)
    verdict.conclude()


# --- garbage and lost replies ------------------------------------------------------------------------


def test_garbage_bytes(rig_factory: RigFactory) -> None:
    """Line noise: junk bytes before some replies, and junk instead of others."""
    rig = rig_factory()
    verdict = Verdict("garbage bytes")
    main = rig.clients[0]
    main.command("tracking", Tracking="true")
    commander = rig.client(MAIN_ID)
    with Monitor(rig.client(MAIN_ID), rig.truth) as monitor:
        time.sleep(0.5)
        fault_at = time.monotonic()
        rig.faults.garble_replies(4)
        calls = []
        deadline = time.monotonic() + 20
        while rig.faults.pending()["garble"] > 0 and time.monotonic() < deadline:
            calls.extend(_command_loop(commander, time.monotonic() + 0.6, period=0.3))
        rig.faults.garble_replies(2, replace=True)
        while rig.faults.pending()["garble"] > 0 and time.monotonic() < deadline:
            calls.extend(_command_loop(commander, time.monotonic() + 0.6, period=0.3))
        verdict.check(rig.faults.garbled >= 6, f"only {rig.faults.garbled} replies were garbled")
        last_garble_truth = rig.truth()
        last_garble = time.monotonic()
        fresh = _fresh_after(monitor, last_garble_truth, last_garble, 10)
        recovery = fresh.at - last_garble

    _check_commands_clear(calls, verdict)
    truth = rig.snapshot()
    wrong = [s for s in monitor.between(fault_at) if s.state and
             (abs((s.state["RightAscension"] - truth["ra_h"] + 12) % 24 - 12) > RA_TOLERANCE_H
              or abs(s.state["Declination"] - truth["dec_deg"]) > DEC_TOLERANCE_DEG)]
    verdict.check(not wrong, f"{len(wrong)} samples served a position the mount never had, e.g. {wrong[:1]}")
    verdict.check(recovery <= RECONNECT_LIMIT_S, f"fresh position only {recovery:.2f} s after the noise")
    audit = rig.audit()
    _check_healthy(rig, verdict)
    report("garbage bytes", garbled=rig.faults.garbled, rejected_by_server=audit.garbled_rejected,
           failed_commands=f"{sum(not c.ok for c in calls)}/{len(calls)}", fresh_after_s=recovery)
    verdict.conclude()


def _arm_on(rig: Rig, body_prefix: str, arm: str) -> None:
    """Arm a reply fault exactly when the mount acts on the next request starting with ``body_prefix``."""
    responder = rig.emulator.responder
    wrapped = responder.handle

    def handle(body: str) -> str | None:
        reply = wrapped(body)
        if body.startswith(body_prefix) and responder.handle is handle:
            responder.handle = wrapped  # once
            getattr(rig.faults, arm)(1)
        return reply

    responder.handle = handle


def test_dropped_reply(rig_factory: RigFactory) -> None:
    """A reply lost on the way: once to a background poll, once to a GOTO that the mount did start."""
    rig = rig_factory()
    verdict = Verdict("dropped reply")
    main = rig.clients[0]
    main.command("tracking", Tracking="true")
    with Monitor(rig.client(MAIN_ID), rig.truth) as monitor:
        time.sleep(0.3)
        dropped = rig.faults.dropped
        rig.faults.drop_replies(1)
        wait_until(lambda: rig.faults.dropped > dropped, 5, "a reply to be dropped", interval=0.01)
        fault_at, fault_truth = time.monotonic(), rig.truth()
        fresh = _fresh_after(monitor, fault_truth, fault_at, 15)
        poll_recovery = fresh.at - fault_at

        ra, dec = sky.ra_from_hour_angle(main.value("siderealtime"), -4.0), 60.0  # 30° on each axis
        _arm_on(rig, "MS", "drop_replies")
        goto = main.put("slewtocoordinatesasync", RightAscension=ra, Declination=dec)
        verdict.check(goto.ok or is_clear_driver_error(goto), f"unclear GOTO failure: {goto.describe()}")
        goto_done = time.monotonic()
        disagreements = []
        while time.monotonic() < goto_done + 30:
            moving = rig.snapshot()["slew"] is not None
            slewing = main.value("slewing")
            if moving and time.monotonic() - goto_done > 1.5 and not slewing:
                disagreements.append(round(time.monotonic() - goto_done, 2))
            if not moving and not slewing:
                break
            time.sleep(0.1)

    verdict.check(not disagreements,
                  f"the mount was slewing (its GOTO reply was lost) while Slewing read false at {disagreements[:5]} s "
                  f"after the PUT (reply to the client: {goto.describe()})")
    verdict.check(poll_recovery <= rig.link.timeout + RECONNECT_LIMIT_S,
                  f"fresh position only {poll_recovery:.2f} s after a dropped poll reply")
    _check_position_true(rig, main, verdict, "after the dropped replies")
    _check_healthy(rig, verdict)
    report("dropped reply", poll_fresh_after_s=poll_recovery, goto_reply=goto.error_message or "ok",
           goto_put_s=goto.elapsed, slewing_false_while_moving=len(disagreements))
    verdict.conclude()


# --- the mount restarts ---------------------------------------------------------------------------


def _init_before_goto(exchanges: list[MountExchange], verdict: Verdict, what: str) -> None:
    """The first GOTO the mount accepted after power-up came after date, time, zone and site were set."""
    needed = {"SC", "SL", "SG", "St", "Sg"}
    done: set[str] = set()
    for exchange in exchanges:
        match = protocol.match_command(exchange.body)
        if match is not None and match.command.code in needed and exchange.reply == "1":
            done.add(match.command.code)
        if exchange.body == "MS":
            verdict.check(needed <= done, f"{what}: :MS# sent with only {sorted(done)} set since power-up")
            verdict.check(exchange.reply == "0", f"{what}: the mount refused the GOTO: {exchange.reply!r}")
            return
    verdict.check(False, f"{what}: no GOTO reached the mount")


def _check_mount_clock_and_site(rig: Rig, verdict: Verdict) -> None:
    truth = rig.snapshot()
    site = rig.server.settings.site
    skew = abs((datetime.fromisoformat(truth["mount_utc"]) - datetime.fromisoformat(truth["true_utc"]))
               .total_seconds())
    verdict.check(truth["initialized"], "the mount was left uninitialised")
    verdict.check(skew <= 2.0 * rig.model.clock.speed, f"the mount's clock is {skew:.1f} s off")
    verdict.check(abs(truth["latitude"] - site.latitude) < 1 / 3600 and
                  abs(truth["longitude_east"] - site.longitude) < 1 / 3600,
                  f"the mount's site is {truth['latitude']}/{truth['longitude_east']}, not "
                  f"{site.latitude}/{site.longitude}")


def test_mount_reboot(rig_factory: RigFactory) -> None:
    """The mount power-cycles for 3 s: it comes back at home with no date, time or site."""
    down_s = 3.0
    rig = rig_factory(emulator=EmulatorSettings(speed=4.0, baud=0))
    verdict = Verdict("mount reboot")
    main = rig.clients[0]
    main.command("tracking", Tracking="true")
    ra, dec = _altaz_target(rig, main, 45.0, 120.0)
    main.command("slewtocoordinatesasync", RightAscension=ra, Declination=dec)
    wait_until(lambda: not main.value("slewing"), 60, "the first GOTO to finish", interval=0.1)
    with Monitor(rig.client(MAIN_ID), rig.truth) as monitor:
        reconnects = rig.link.status.reconnects
        power_ups = rig.model.power_ups
        fault_at, fault_truth = time.monotonic(), rig.truth()
        rig.faults.reboot(down_s)
        time.sleep(0.5)
        ra2, dec2 = _altaz_target(rig, main, 60.0, 200.0)
        while_down = main.put("slewtocoordinatesasync", RightAscension=ra2, Declination=dec2)
        wait_until(lambda: rig.link.status.reconnects > reconnects, down_s + 10, "the link to reconnect")
        relinked = time.monotonic() - (fault_at + down_s)
        goto_at = time.monotonic()
        ra2, dec2 = _altaz_target(rig, main, 60.0, 200.0)
        goto = main.put("slewtocoordinatesasync", RightAscension=ra2, Declination=dec2)
        wait_until(lambda: not main.value("slewing"), 60, "the GOTO after the reboot to finish", interval=0.1)

    verdict.check(not while_down.ok and is_clear_driver_error(while_down),
                  f"a GOTO while the mount was off was not refused clearly: {while_down.describe()}")
    verdict.check(goto.ok, f"the first GOTO after the reboot failed: {goto.describe()}")
    verdict.check(relinked <= RECONNECT_LIMIT_S, f"link back only {relinked:.2f} s after the mount")
    rebooted = [e for e in rig.recorder.all() if e.power_ups > power_ups]
    _init_before_goto(rebooted, verdict, "after the reboot")
    _check_mount_clock_and_site(rig, verdict)
    truth = rig.snapshot()
    verdict.check(abs((truth["ra_h"] - ra2 + 12) % 24 - 12) <= RA_TOLERANCE_H and abs(truth["dec_deg"] - dec2) < 2e-3,
                  f"the GOTO after the reboot ended at {truth['ra_h']:.5f} h/{truth['dec_deg']:.5f}°, "
                  f"not {ra2:.5f} h/{dec2:.5f}°")
    # Between the reboot and the new GOTO the mount stood at home (Dec +90): any sample stamped after
    # the reboot must show that, and anything else must carry its pre-reboot age.
    for sample in monitor.between(fault_at + IN_FLIGHT_S, goto_at):
        stamp = sample.timestamp
        if stamp is None or sample.state is None:
            verdict.check(False, f"DeviceState failed after the reboot: {sample}")
            continue
        if stamp > fault_truth + timedelta(seconds=IN_FLIGHT_S * rig.model.clock.speed):
            verdict.check(abs(sample.state["Declination"] - 90.0) < 1e-3,
                          f"position stamped {stamp.isoformat()} after the reboot shows Dec "
                          f"{sample.state['Declination']:.4f}°, not the home the mount restarted at")
    verdict.check(all(s.connected for s in monitor.between(fault_at, goto_at)),
                  "Connected went false during the reboot")
    _check_healthy(rig, verdict)
    report("mount reboot 3 s", relink_s=relinked, refused_goto_s=while_down.elapsed, goto_after_reboot="ok"
           if goto.ok else goto.error_message)
    verdict.conclude()


def test_reboot_the_link_did_not_see(rig_factory: RigFactory) -> None:
    """The mount restarts but the connection survives (a USB hub kept power): the next GOTO meets e7."""
    rig = rig_factory(emulator=EmulatorSettings(speed=4.0, baud=0))
    verdict = Verdict("reboot unseen by the link")
    main = rig.clients[0]
    main.command("tracking", Tracking="true")
    power_ups = rig.model.power_ups
    rig.model.power_cycle()
    time.sleep(0.5)
    ra, dec = _altaz_target(rig, main, 50.0, 220.0)
    goto = main.put("slewtocoordinatesasync", RightAscension=ra, Declination=dec)
    verdict.check(goto.ok, f"the GOTO was not carried out after re-initialising: {goto.describe()}")
    wait_until(lambda: not main.value("slewing"), 60, "the GOTO to finish", interval=0.1)
    rebooted = [e for e in rig.recorder.all() if e.power_ups > power_ups]
    accepted = [e for e in rebooted if e.body != "MS" or e.reply == "0"]  # the refused e7 attempt is the trigger
    _init_before_goto(accepted, verdict, "after the unseen reboot")
    _check_mount_clock_and_site(rig, verdict)
    truth = rig.snapshot()
    verdict.check(abs((truth["ra_h"] - ra + 12) % 24 - 12) <= RA_TOLERANCE_H and abs(truth["dec_deg"] - dec) < 2e-3,
                  f"ended at {truth['ra_h']:.5f} h/{truth['dec_deg']:.5f}°, not {ra:.5f} h/{dec:.5f}°")
    _check_healthy(rig, verdict)
    report("reboot unseen by the link", goto_put_s=goto.elapsed)
    verdict.conclude()


def test_mount_refuses_a_goto(rig_factory: RigFactory) -> None:
    """The mount's own altitude limit (30°) refuses a target the server's limits allow: e6#."""
    rig = rig_factory(emulator=EmulatorSettings(speed=4.0, baud=0))
    verdict = Verdict("GOTO refused by the mount")
    main = rig.clients[0]
    main.command("tracking", Tracking="true")
    rig.model.flash.set_limits_enabled(True)
    assert rig.model.flash.set_lower_limit(30)
    ra, dec = _altaz_target(rig, main, 20.0, 200.0)
    refused = main.put("slewtocoordinatesasync", RightAscension=ra, Declination=dec)
    verdict.check(refused.error_number == 0x401 and "altitude limits (e6)" in refused.error_message,
                  f"not a clear refusal: {refused.describe()}")
    verdict.check(main.value("slewing") is False, "Slewing true after a refused GOTO")
    verdict.check(rig.snapshot()["slew"] is None, "the mount slews after refusing")
    ra, dec = _altaz_target(rig, main, 50.0, 200.0)
    accepted = main.put("slewtocoordinatesasync", RightAscension=ra, Declination=dec)
    verdict.check(accepted.ok, f"the next GOTO failed: {accepted.describe()}")
    wait_until(lambda: not main.value("slewing"), 60, "the GOTO to finish", interval=0.1)
    _check_position_true(rig, main, verdict, "after the accepted GOTO")
    _check_healthy(rig, verdict, also_allowed=(0x401,))  # the refusal above, checked there
    report("GOTO refused by the mount", error=f"0x{refused.error_number or 0:X} {refused.error_message}",
           put_s=refused.elapsed)
    verdict.conclude()
