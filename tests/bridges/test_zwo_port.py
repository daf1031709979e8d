"""The shared ZWO-protocol port, spoken to over real sockets, next to a real Alpaca client.

Replies are compared byte for byte with what the emulator itself answers for the same state (the
emulator is the reference for the mount's formats); commands are checked by their effect as an
Alpaca client (alpyca) and the emulated mount see it. Garbage, floods and connection storms must
drop only the offender while an Alpaca client keeps polling.
"""

from __future__ import annotations

import dataclasses
import random
import threading
import time
from collections.abc import Callable, Iterator
from datetime import datetime, timezone

import pytest
from alpaca.telescope import Telescope as AlpacaTelescope

from alpaca_zwo import sky
from alpaca_zwo.config.settings import EmulatorSettings, LimitSettings, ZwoPortSettings
from alpaca_zwo.server import AlpacaZwoServer
from alpaca_zwo.zwo import wire_values
from alpaca_zwo.zwo.protocol import ReplyKind
from tests.conftest import ServerFactory, make_settings
from tests.support.zwo_client import ZwoClient, offend

SPEED = 10.0  # emulated seconds per real second: GOTOs end quickly


def until(condition: Callable[[], object], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}")


@pytest.fixture
def server(server_factory: ServerFactory) -> AlpacaZwoServer:
    settings = make_settings(
        emulator=EmulatorSettings(speed=SPEED, baud=0),
        zwo_port=ZwoPortSettings(enabled=True, host="127.0.0.1", port=0),
        limits=LimitSettings(min_altitude_deg=10.0, horizon=((0.0, 20.0), (90.0, 20.0), (180.0, 20.0))),
    )
    return server_factory(settings)


@pytest.fixture
def alpaca(server: AlpacaZwoServer) -> Iterator[AlpacaTelescope]:
    client = AlpacaTelescope(f"127.0.0.1:{server.port}", 0)
    client.Connected = True
    yield client
    client.Connected = False


@pytest.fixture
def zwo(server: AlpacaZwoServer) -> Iterator[ZwoClient]:
    client = ZwoClient(server.zwo_port.port)
    yield client
    client.close()


def _emulator(server: AlpacaZwoServer) -> ZwoClient:
    return ZwoClient(server.emulators[0].server.port)


def _goto(zwo: ZwoClient, ra: float, dec: float) -> bytes:
    assert zwo.ask(":Sr" + wire_values.format_hms(ra) + "#") == b"1"
    assert zwo.ask(":Sd" + wire_values.format_dms(dec) + "#") == b"1"
    return zwo.ask(":MS#")


def _wait_idle(alpaca: AlpacaTelescope) -> None:
    until(lambda: not alpaca.Slewing, 30, "the slew to end")


#: Replies that must be identical bytes; the second group changes with time, so a pair of
#: answers may straddle a second boundary and is asked again.
STATIC_QUERIES = [":GD#", ":GU#", ":GAT#", ":Gm#", ":Gt#", ":Gg#", ":GMGE#", ":GG#", ":GC#", ":GT#", ":Ggr#",
                  ":GBu#", ":GVP#", ":GV#", ":GTa#", ":GLC#", ":GLH#", ":GLL#", ":GRl#", ":GH#", ":Gr#", ":Gd#",
                  ":GMeq#", ":Gps#", ":Gh#"]
MOVING_QUERIES = [":GR#", ":GMEQ#"]


def test_queries_answer_the_same_bytes_as_the_mount(server: AlpacaZwoServer, alpaca: AlpacaTelescope,
                                                    zwo: ZwoClient) -> None:
    emulator = _emulator(server)
    try:
        # A state with something in it: tracking after a GOTO two hours east of the meridian.
        ra = sky.wrap_hours_24(alpaca.SiderealTime + 2.0)
        assert _goto(zwo, ra, 40.0) == b"0"
        until(lambda: alpaca.Slewing, 5, "Alpaca to see the GOTO")
        _wait_idle(alpaca)
        until(lambda: server.telescopes[0].mount.state.status_time is not None and not
              server.telescopes[0].mount.state.goto_running, 5, "a poll after the slew")
        for command in STATIC_QUERIES:
            assert zwo.ask(command) == emulator.ask(command), command
        for command in MOVING_QUERIES:
            pairs = [(zwo.ask(command), emulator.ask(command)) for _ in range(4)]
            assert any(ours == mount for ours, mount in pairs), (command, pairs)
        # Altitude and azimuth turn with the mount's clock, which keeps whole seconds (its time was
        # set truncated, so it trails the server's by up to a second): same format, within a
        # second of sky motion (< 30").
        for command in (":GA#", ":GZ#", ":GMZA#"):
            ours, mount = zwo.ask(command).decode(), emulator.ask(command).decode()
            assert len(ours) == len(mount) and ours[-1] == "#" and ours.index("*") == mount.index("*"), (ours, mount)
            for a, b in zip(ours[:-1].split("&"), mount[:-1].split("&"), strict=True):
                assert abs(wire_values.parse_dms(a) - wire_values.parse_dms(b)) < 30 / 3600, (command, ours, mount)
        # Sidereal and local time: the server's clock, which the mount's whole-second clock trails by < 1 s.
        ours_lst = wire_values.parse_hms(zwo.ask(":GS#").decode()[:-1])
        mount_lst = wire_values.parse_hms(emulator.ask(":GS#").decode()[:-1])
        assert abs(sky.wrap_hours_12(ours_lst - mount_lst)) <= 1.5 / 3600
        ours = wire_values.parse_time(zwo.ask(":GL#").decode()[:-1])
        mount = wire_values.parse_time(emulator.ask(":GL#").decode()[:-1])
        assert abs((ours.hour * 3600 + ours.minute * 60 + ours.second)
                   - (mount.hour * 3600 + mount.minute * 60 + mount.second)) % 86400 in (0, 1, 86399)
        # Unknown and miscased commands: silence, as from the mount.
        for command in (":GX#", ":gr#", ":STA00+00#"):
            assert zwo.silent(command) and emulator.silent(command)
        assert zwo.ask(":GR#") == emulator.ask(":GR#") or zwo.ask(":GR#") == emulator.ask(":GR#")
    finally:
        emulator.close()


def test_goto_refusals_carry_the_mounts_error_codes(server: AlpacaZwoServer, alpaca: AlpacaTelescope,
                                                    zwo: ZwoClient) -> None:
    lst = alpaca.SiderealTime
    # Under the horizon profile (20 degrees): e5; south at HA 0, Dec -25 is at about 13.5 degrees.
    assert _goto(zwo, lst, -25.0) == b"e5#"
    # Below altitude 0 is "below the horizon" too.
    assert _goto(zwo, sky.wrap_hours_24(lst + 12.0), -60.0) == b"e5#"
    assert not alpaca.Slewing
    # Bad target formats: e2#, the mount's answer.
    assert zwo.ask(":Sr24:00:00#") == b"e2#"
    assert zwo.ask(":Sd+95*00:00#") == b"e2#"
    # A GOTO while a GOTO runs: e3#, as on the mount; :Q# from this program stops it for Alpaca too.
    assert _goto(zwo, sky.wrap_hours_24(lst + 3.0), 10.0) == b"0"
    until(lambda: alpaca.Slewing, 5, "Alpaca to see the GOTO")
    assert zwo.ask(":MS#") == b"e3#"
    assert zwo.silent(":Q#")
    until(lambda: not alpaca.Slewing, 5, "the abort")
    status = server.zwo_port.status()
    assert status["refusals"] == 3
    assert status["last_refusal"]["command"] == ":MS#"
    # Parked: the mount's (emulator's) code for a GOTO it will not make.
    alpaca.Park()
    until(lambda: alpaca.AtPark, 60, "park")
    assert _goto(zwo, sky.wrap_hours_24(lst + 2.0), 40.0) == b"e4#"
    assert zwo.ask(":Te#") == b"0"
    assert zwo.ask(":Gps#") == b"2#"
    assert zwo.ask(":Spu#") == b"1"
    assert not alpaca.AtPark


def test_altitude_limit_is_e6(server_factory: ServerFactory) -> None:
    settings = make_settings(emulator=EmulatorSettings(speed=SPEED, baud=0),
                             zwo_port=ZwoPortSettings(enabled=True, host="127.0.0.1", port=0),
                             limits=LimitSettings(min_altitude_deg=30.0))
    server = server_factory(settings)
    client = ZwoClient(server.zwo_port.port)
    try:
        lst = wire_values.parse_hms(client.ask(":GS#").decode()[:-1])
        assert _goto(client, lst, -10.0) == b"e6#"  # altitude about 28.5 degrees
    finally:
        client.close()


def test_motion_tracking_and_guiding_go_through_the_telescope(server: AlpacaZwoServer, alpaca: AlpacaTelescope,
                                                              zwo: ZwoClient) -> None:
    model = server.emulators[0].model
    assert _goto(zwo, sky.wrap_hours_24(alpaca.SiderealTime + 2.0), 40.0) == b"0"
    _wait_idle(alpaca)
    assert alpaca.Tracking
    assert zwo.ask(":Td#") == b"1"
    until(lambda: not alpaca.Tracking, 5, "tracking off")
    assert zwo.ask(":Te#") == b"1"
    assert alpaca.Tracking
    # Lunar rate (Alpaca 1) and back, answered by :GT# in INDI's digits.
    assert zwo.silent(":TL#")
    until(lambda: alpaca.TrackingRate == 1, 5, "the lunar rate")
    assert zwo.ask(":GT#") == b"2#"
    assert zwo.silent(":TQ#")
    until(lambda: alpaca.TrackingRate == 0, 5, "the sidereal rate")
    # INDI's unterminated :Rg0.30 must not swallow the next command (the mount drops the fragment).
    assert zwo.ask(":Rg0.30:Ggr#", kind=ReplyKind.TEXT) == b"0.50#"
    assert zwo.silent(":Rg0.30#", window=0.05)
    until(lambda: zwo.ask(":Ggr#") == b"0.30#", 5, "the guide rate")
    assert alpaca.GuideRateDeclination == pytest.approx(0.3 * sky.SIDEREAL_DEG_S, rel=1e-3)
    # A pulse north moves Dec as Alpaca reads it: 2 s at 0.3x sidereal is 9" of emulated... x SPEED.
    dec_before = alpaca.Declination
    assert zwo.silent(":Mgn0500#", window=0.05)
    until(lambda: alpaca.Declination > dec_before + 0.5 * 0.3 * 15 * 0.8 / 3600, 5, "the pulse")
    # Manual move at :R7# (60x) east, seen by Alpaca as Slewing; :Qe# stops it.
    assert zwo.silent(":R7#", window=0.05) and zwo.silent(":Me#", window=0.05)
    until(lambda: alpaca.Slewing, 5, "the move")
    assert 0 in server.telescopes[0].mount.state.moving_axes
    assert zwo.silent(":Qe#", window=0.05)
    until(lambda: not alpaca.Slewing, 5, "the move to stop")
    # A move left running by a program that disconnects is stopped.
    mover = ZwoClient(server.zwo_port.port)
    assert mover.silent(":Mn#", window=0.05)
    until(lambda: 1 in server.telescopes[0].mount.state.moving_axes, 5, "the second move")
    mover.close()
    until(lambda: not server.telescopes[0].mount.state.moving_axes and not model.status().slewing, 5,
          "the orphaned move to stop")
    # Home: :GU# shows H when done.
    assert zwo.silent(":hC#", window=0.05)
    until(lambda: b"H" in zwo.ask(":GU#"), 60, "home")
    assert alpaca.AtHome


def test_alpacas_abort_stops_a_zwo_goto(server: AlpacaZwoServer, alpaca: AlpacaTelescope, zwo: ZwoClient) -> None:
    target = (sky.wrap_hours_24(alpaca.SiderealTime + 3.0), 10.0)
    assert _goto(zwo, *target) == b"0"
    until(lambda: b"N" not in zwo.ask(":GU#"), 5, "the GOTO to show in :GU#")
    alpaca.AbortSlew()
    until(lambda: b"N" in zwo.ask(":GU#"), 5, "the ZWO program to see the abort")
    ra, dec = wire_values.parse_hms(zwo.ask(":GR#").decode()[:-1]), wire_values.parse_dms(zwo.ask(":GD#").decode()[:-1])
    assert sky.angular_separation(ra, dec, *target) > 5.0


def test_a_goto_100_ms_after_a_stop_is_accepted_and_lands(server: AlpacaZwoServer, alpaca: AlpacaTelescope,
                                                           zwo: ZwoClient) -> None:
    """INDI's LX200 Goto during a slew (lx200telescope.cpp ``LX200Telescope::Goto``): ``:Q#``, 100 ms,
    then ``:Sr :Sd :MS#``. The mount would still be braking (its answer would be ``e3#``); the port
    queues the GOTO behind the braking and answers ``0``, and the emulator lands on the new target."""
    emulator = server.emulators[0]
    assert emulator is not None
    model = emulator.model
    lst = alpaca.SiderealTime
    assert _goto(zwo, sky.wrap_hours_24(lst + 3.0), 10.0) == b"0"
    until(lambda: max(abs(v) for v in model.snapshot()["velocity_deg_s"]) > 5.0, 10, "the GOTO at full speed")
    assert zwo.silent(":Q#", window=0.1)  # INDI's abort, and its 100 ms sleep
    assert model.snapshot()["braking"], "the emulator should still be braking when the new GOTO arrives"
    ra = wire_values.parse_hms(wire_values.format_hms(sky.wrap_hours_24(lst - 1.0)))  # as :Sr carries it
    target = (ra, 30.0)
    assert _goto(zwo, *target) == b"0"
    until(lambda: b"N" in zwo.ask(":GU#"), 30, "the new GOTO to end")
    until(lambda: not alpaca.Slewing, 30, "the landing")
    error = sky.angular_separation(*model.position(), *target) * 3600.0
    assert error < 5.0, f"the emulator is {error:.0f}″ from the new target"
    assert server.zwo_port.status()["refusals"] == 0


def test_sync_and_targets_are_per_program(server: AlpacaZwoServer, alpaca: AlpacaTelescope, zwo: ZwoClient) -> None:
    other = ZwoClient(server.zwo_port.port)
    try:
        ra = sky.wrap_hours_24(alpaca.SiderealTime + 2.0)
        assert _goto(zwo, ra, 40.0) == b"0"
        _wait_idle(alpaca)
        assert other.ask(":Sr01:00:00#") == b"1"  # another program's target does not move ours
        assert zwo.ask(":Gr#") == (wire_values.format_hms(ra) + "#").encode()
        assert zwo.ask(":Sd+40*06:00#") == b"1"
        assert zwo.ask(":CM#") == b"N/A#"
        until(lambda: abs(alpaca.Declination - 40.1) < 2 / 3600, 5, "the sync")
        # A sync while moving: e4#.
        assert zwo.silent(":Mw#", window=0.05)
        until(lambda: alpaca.Slewing, 5, "the move")
        assert zwo.ask(":CM#") == b"e4#"
        assert zwo.silent(":Q#")
    finally:
        other.close()


def test_time_and_site_setters_go_through_the_telescope(server: AlpacaZwoServer, alpaca: AlpacaTelescope,
                                                        zwo: ZwoClient) -> None:
    # Site (INDI order): longitude east-negative, then latitude; Alpaca reads them back.
    assert zwo.ask(":Sg-011*30:00#") == b"1"
    assert zwo.ask(":St+48*06:00#") == b"1"
    assert alpaca.SiteLongitude == pytest.approx(11.5, abs=1e-6)
    assert alpaca.SiteLatitude == pytest.approx(48.1, abs=1e-6)
    assert server.emulators[0].model.clock_site.latitude() == pytest.approx(48.1, abs=1 / 3600)
    assert zwo.ask(":St+95*00:00#") == b"0"  # the Telescope's validation
    assert alpaca.SiteLatitude == pytest.approx(48.1, abs=1e-6)
    # The same clock again (whole seconds) changes nothing; another date moves UTCDate for everyone.
    assert zwo.ask(":SG-03:00#") == b"1"
    assert zwo.ask(":GG#") == b"-03:00#"
    assert zwo.ask(":SC01/15/30#") == b"1"
    until(lambda: alpaca.UTCDate.date() == datetime(2030, 1, 15, tzinfo=timezone.utc).date()
          or alpaca.UTCDate.date() == datetime(2030, 1, 14, tzinfo=timezone.utc).date(), 5, "the date")
    assert zwo.ask(":GC#") == b"01/15/30#"
    assert zwo.ask(":SL12:00:00#") == b"1"
    utc = alpaca.UTCDate
    assert (utc.hour, utc.minute) in ((9, 0), (9, 1))  # local 12:00 at UTC+3
    assert zwo.ask(":SC13/45/30#") == b"0"
    assert zwo.ask(":SL25:00:00#") == b"0"


def test_commands_that_affect_everyone_are_refused_unless_allowed(server: AlpacaZwoServer, alpaca: AlpacaTelescope,
                                                                   zwo: ZwoClient) -> None:
    model = server.emulators[0].model
    assert zwo.silent(":AA#")  # mode switch: no reply either way, and nothing reaches the mount
    assert zwo.ask(":SRl720#") == b"0"
    assert zwo.ask(":NSC#") == b"0"
    assert zwo.ask(":SLE#") == b"0"
    assert zwo.ask(":STa01+05#") == b"0"
    assert zwo.ask(":BSabc123#") == b"NO#"
    assert zwo.ask(":GRl#") == b"1440#"
    assert model.flash.max_speed() == 1440
    assert zwo.ask(":GLC#") == b"0#"
    assert server.zwo_port.status()["refusals"] == 6
    server.store.update(lambda s: dataclasses.replace(
        s, zwo_port=dataclasses.replace(s.zwo_port, allow_dangerous=("SRl", "STa"))))
    assert zwo.ask(":SRl720#") == b"1"
    assert model.flash.max_speed() == 720
    assert zwo.ask(":GRl#") == b"720#"
    assert zwo.ask(":STa01+05#") == b"1"
    assert zwo.ask(":GTa#") == b"01+05#"
    assert zwo.ask(":NSC#") == b"0"  # still guarded


def _alpaca_poller(port: int, stop: threading.Event, answered: list[float], errors: list[str]) -> None:
    """An Alpaca client polling as N.I.N.A. does; ``answered`` gets the time each reply came."""
    client = AlpacaTelescope(f"127.0.0.1:{port}", 0)
    while not stop.is_set():
        try:
            _ = client.RightAscension
        except Exception as exc:  # any failure is what the test counts
            errors.append(repr(exc))
        answered.append(time.monotonic())


def test_junk_floods_and_connection_storms_drop_only_the_offender(server: AlpacaZwoServer,
                                                                  alpaca: AlpacaTelescope) -> None:
    """Each offender is closed alone: a well-behaved program on the port and an Alpaca client are answered
    throughout. What the offences cost the Alpaca client in latency is measured, not asserted here:
    benchmarks/zwo_port_flood.py (BENCHMARKS.md)."""
    port = server.zwo_port.port
    stop = threading.Event()
    answered: list[float] = []
    errors: list[str] = []
    poller = threading.Thread(target=_alpaca_poller, args=(server.port, stop, answered, errors), daemon=True)
    poller.start()
    good = ZwoClient(port)
    try:
        assert good.ask(":GVP#") == b"AM5#"
        until(lambda: len(answered) >= 10, 30, "the Alpaca client's first polls")
        began = time.monotonic()
        offend(port, random.Random(16))
        ended = time.monotonic()
        assert good.ask(":GVP#") == b"AM5#"
        until(lambda: len(server.zwo_port.status()["programs"]) == 1, 10, "the storm to drain")
    finally:
        stop.set()
        poller.join()
        good.close()
    assert server.zwo_port.status()["dropped"] >= 4
    assert errors == []
    during = [t for t in answered if began < t < ended]
    assert len(during) >= 10, f"{len(during)} Alpaca replies in the {ended - began:.1f} s of the offences"
    assert alpaca.Connected


def test_off_by_default_and_the_command_line_turns_it_on(server_factory: ServerFactory) -> None:
    from alpaca_zwo.server import Overrides

    assert server_factory(make_settings()).zwo_port is None
    server = server_factory(make_settings(zwo_port=ZwoPortSettings(host="127.0.0.1")), Overrides(zwo_port=0),
                            config_name="other.toml")
    client = ZwoClient(server.zwo_port.port)
    try:
        assert client.ask(":GVP#") == b"AM5#"
        status = server.zwo_port.status()
        assert status["enabled"] and status["port"] == server.zwo_port.port
        assert [p["last_command"] for p in status["programs"]] == [":GVP#"]
    finally:
        client.close()


def test_allow_dangerous_accepts_only_guarded_codes() -> None:
    from alpaca_zwo._exceptions import ConfigError
    from alpaca_zwo.config.settings import settings_from_dict

    settings = settings_from_dict({"zwo_port": {"allow_dangerous": ["AA", "all"]}})
    assert settings.zwo_port.allow_dangerous == ("AA", "all")
    with pytest.raises(ConfigError, match="allow_dangerous"):
        settings_from_dict({"zwo_port": {"allow_dangerous": ["GR"]}})
