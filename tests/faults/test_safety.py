"""Safety nets that do not depend on any client behaving: the MoveAxis watchdog and the server's own limits.

The mount has no watchdog of its own (field notes §5.5: it keeps moving if the host disappears
during ``:Me#``), so a client that starts a manual move and then crashes would leave the mount
driving into the pier. The server stops such a move itself, and refuses GOTOs below the configured
horizon before anything reaches the mount, in addition to the mount's own altitude limit.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path

import pytest

from alpaca_zwo import sky
from alpaca_zwo.config.file import load_settings
from alpaca_zwo.config.settings import LimitSettings, SafetySettings
from tests.faults.conftest import RigFactory
from tests.faults.harness import RECONNECT_LIMIT_S, Verdict, report
from tests.support import AlpacaClient, wait_until

WATCHDOG_S = 2.0
#: The supervisor looks every 0.1 s; the stop command then needs one exchange.
WATCHDOG_SLACK_S = 1.0


def test_watchdog_default_is_15_s(tmp_path: Path) -> None:
    """Without configuration a silent client's MoveAxis is stopped after 15 s, as the issue asks."""
    assert SafetySettings().moveaxis_watchdog_s == 15.0
    path = tmp_path / "config.toml"
    path.write_text("[safety]\non_shutdown = 'stop'\n")
    assert load_settings(path).safety.moveaxis_watchdog_s == 15.0


def test_moveaxis_watchdog(rig_factory: RigFactory, caplog: pytest.LogCaptureFixture) -> None:
    """A client that talks keeps its move; once it falls silent the server stops the axis and says why."""
    caplog.set_level(logging.INFO, logger="alpaca_zwo")
    rig = rig_factory(safety=SafetySettings(moveaxis_watchdog_s=WATCHDOG_S))
    verdict = Verdict("MoveAxis watchdog")
    nina = rig.clients[0]  # another program, polling all along: its traffic must not keep the move alive
    mover = rig.client(31)
    mover.command("connected", Connected="true")
    mover.command("moveaxis", Axis=0, Rate=1.0)
    stop_polling = time.monotonic() + 2.5 * WATCHDOG_S
    while time.monotonic() < stop_polling:  # the mover is alive: it reads Slewing twice a second
        verdict.check(mover.value("slewing") is True, "Slewing false while the axis moves")
        nina.device_state()
        time.sleep(0.5)
    verdict.check(rig.snapshot()["moves_deg_s"][0] is not None,
                  f"the axis stopped although its client kept talking for {2.5 * WATCHDOG_S:.0f} s")
    last = mover.log.calls()[-1]
    silent_from = last.started + last.elapsed

    def stopped() -> bool:
        nina.device_state()
        return rig.snapshot()["moves_deg_s"][0] is None

    wait_until(stopped, WATCHDOG_S + 5, "the watchdog to stop the axis", interval=0.05)
    stop_after = time.monotonic() - silent_from
    verdict.check(WATCHDOG_S - 0.1 <= stop_after <= WATCHDOG_S + WATCHDOG_SLACK_S,
                  f"the axis stopped {stop_after:.2f} s after its client fell silent (watchdog {WATCHDOG_S} s)")
    wait_until(lambda: rig.snapshot()["velocity_deg_s"][0] == 0.0, 10, "the axis to come to rest")
    # Slewing ends once the readings show the mount at rest (issue 13): a few polls after the axis stops.
    rested = time.monotonic()
    wait_until(lambda: nina.value("slewing") is False, 5, "Slewing to end after the watchdog stop")
    verdict.check(time.monotonic() - rested < 2.0, "Slewing stayed true for 2 s after the axis came to rest")
    why = [r.getMessage() for r in caplog.records if "went silent" in r.getMessage()]
    verdict.check(why and "MoveAxis" in why[0] and r"#31" in why[0],
                  f"no log line saying which client went silent: {why}")
    verdict.extend(rig.log.problems())
    report("MoveAxis watchdog", configured_s=WATCHDOG_S, stopped_after_silence_s=stop_after, log=why[0] if why else "")
    verdict.conclude()


def test_moveaxis_watchdog_outlasts_a_link_stall(rig_factory: RigFactory, caplog: pytest.LogCaptureFixture) -> None:
    """The client vanishes and, as the watchdog fires, the mount's WiFi stalls for 8 s: the stop cannot
    get through then, so it must get through when the mount answers again (it keeps moving otherwise)."""
    caplog.set_level(logging.INFO, logger="alpaca_zwo")
    stall_s = 8.0
    rig = rig_factory(safety=SafetySettings(moveaxis_watchdog_s=WATCHDOG_S))
    verdict = Verdict("MoveAxis watchdog during a link stall")
    mover = rig.client(31)
    mover.command("connected", Connected="true")
    mover.command("moveaxis", Axis=0, Rate=1.0)
    silent_from = time.monotonic()
    wait_until(lambda: rig.snapshot()["moves_deg_s"][0] is not None, 5, "the move to start")
    time.sleep(WATCHDOG_S / 2)
    rig.faults.stall(stall_s * 1000)
    mount_back = time.monotonic() + stall_s
    wait_until(lambda: any("went silent" in r.getMessage() for r in caplog.records), WATCHDOG_S + 5,
               "the watchdog to fire")
    fired = time.monotonic() - silent_from
    deadline = mount_back + RECONNECT_LIMIT_S
    while time.monotonic() < deadline and rig.snapshot()["moves_deg_s"][0] is not None:
        time.sleep(0.1)
    moving = rig.snapshot()["moves_deg_s"][0] is not None
    stopped_after = time.monotonic() - mount_back
    verdict.check(not moving, f"the axis still moves {RECONNECT_LIMIT_S:.0f} s after the mount answered again; "
                              f"log: {[r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]}")
    if moving:
        rig.clients[0].put("abortslew")  # leave the emulator still for teardown
    report("MoveAxis watchdog during a link stall", fired_after_s=fired,
           stopped_after_mount_back_s=stopped_after if not moving else "never")
    verdict.conclude()


def test_moveaxis_stops_at_the_horizon(rig_factory: RigFactory, caplog: pytest.LogCaptureFixture) -> None:
    """A manual move that would take the telescope below the altitude limit is stopped by the server."""
    caplog.set_level(logging.INFO, logger="alpaca_zwo")
    floor = 48.0
    rig = rig_factory(limits=LimitSettings(min_altitude_deg=floor))
    verdict = Verdict("manual move at the horizon limit")
    main = rig.clients[0]
    main.command("moveaxis", Axis=1, Rate=-4.0)  # from the pole (altitude = latitude, 51.5°) towards the horizon
    wait_until(lambda: rig.snapshot()["moves_deg_s"][1] is not None, 5, "the move to start")  # :Ms# has no reply
    wait_until(lambda: rig.snapshot()["moves_deg_s"][1] is None, 20, "the server to stop the move")
    wait_until(lambda: rig.snapshot()["velocity_deg_s"][1] == 0.0, 10, "the axis to come to rest")
    altitude = rig.snapshot()["alt_deg"]
    # Braking-aware (issue 13): it comes to rest before the limit, not past it, and not absurdly early.
    verdict.check(floor <= altitude < floor + 4.0, f"the move stopped at altitude {altitude:.2f}°")
    why = [r.getMessage() for r in caplog.records if "horizon limit" in r.getMessage()]
    verdict.check(bool(why), "no log line saying the horizon limit stopped the move")
    verdict.extend(rig.log.problems())
    report("manual move at the limit", limit_deg=floor, stopped_at_deg=altitude)
    verdict.conclude()


def _radec(client: AlpacaClient, latitude: float, altitude: float, azimuth: float) -> tuple[float, float]:
    ha, dec = sky.horizontal_to_equatorial(altitude, azimuth, latitude)
    return sky.ra_from_hour_angle(client.value("siderealtime"), ha), dec


HORIZON = ((0.0, 10.0), (60.0, 10.0), (90.0, 35.0), (120.0, 10.0))


@pytest.mark.parametrize(("member", "altitude", "azimuth"), [
    ("slewtocoordinatesasync", 15.0, 250.0),  # under the 20° minimum altitude
    ("slewtocoordinatesasync", 30.0, 90.0),  # above the minimum, under the horizon profile's 35° there
    ("slewtocoordinates", 15.0, 250.0),
    ("slewtotargetasync", 30.0, 90.0),
    ("slewtoaltazasync", 30.0, 90.0),
    ("slewtoaltaz", 15.0, 250.0),
])
def test_goto_below_the_limits_is_refused_before_the_mount(rig_factory: RigFactory, member: str, altitude: float,
                                                           azimuth: float) -> None:
    """Every way of asking for a GOTO meets the server's limits first: a clear InvalidValue, no bytes sent."""
    rig = rig_factory(limits=LimitSettings(min_altitude_deg=20.0, horizon=HORIZON))
    verdict = Verdict(f"{member} below the limits")
    main = rig.clients[0]
    main.command("tracking", Tracking="true")
    ra, dec = _radec(main, rig.server.settings.site.latitude, altitude, azimuth)
    sent_before = len(rig.recorder.all())
    if member.startswith("slewtoaltaz"):
        call = main.put(member, Azimuth=azimuth, Altitude=altitude)
    elif member == "slewtotargetasync":
        main.command("targetrightascension", TargetRightAscension=ra)
        main.command("targetdeclination", TargetDeclination=dec)
        call = main.put(member)
    else:
        call = main.put(member, RightAscension=ra, Declination=dec)
    verdict.check(call.error_number == 0x401 and "horizon" in call.error_message,
                  f"not a clear InvalidValue naming the horizon: {call.describe()}")
    sent = [e.body for e in rig.recorder.all()[sent_before:] if e.body[:2] in ("Sr", "Sd", "MS")]
    verdict.check(not sent, f"the refused target still reached the mount: {sent}")
    verdict.check(main.value("slewing") is False and rig.snapshot()["slew"] is None, "something slews")
    verdict.extend(rig.log.problems(allowed_errors=[0x401]))
    verdict.conclude()


def test_goto_above_the_limits_is_carried_out(rig_factory: RigFactory) -> None:
    """The same limits let a legal target through (the refusals above are not a blanket refusal)."""
    rig = rig_factory(limits=LimitSettings(min_altitude_deg=20.0, horizon=HORIZON))
    main = rig.clients[0]
    main.command("tracking", Tracking="true")
    ra, dec = _radec(main, rig.server.settings.site.latitude, 40.0, 90.0)  # 5° over the profile's 35°
    main.command("slewtocoordinatesasync", RightAscension=ra, Declination=dec)
    assert main.value("slewing") is True
    main.command("abortslew")
    assert not rig.log.problems(since=0.0)


def test_refusal_names_the_limit(rig_factory: RigFactory) -> None:
    """The message tells the user which limit and where, so the refusal can be acted on."""
    rig = rig_factory(limits=LimitSettings(min_altitude_deg=20.0, horizon=HORIZON))
    main = rig.clients[0]
    ra, dec = _radec(main, rig.server.settings.site.latitude, 30.0, 90.0)
    call = main.put("slewtocoordinatesasync", RightAscension=ra, Declination=dec)
    assert call.error_number == 0x401
    assert "35.00°" in call.error_message and "azimuth 90" in call.error_message, call.error_message
    report("GOTO under the horizon", error=f"0x{call.error_number:X} {call.error_message}")

