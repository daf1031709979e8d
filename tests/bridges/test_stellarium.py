"""Stellarium's telescope protocol served by alpaca-zwo, driven by a client written from the protocol.

Everything runs over loopback against the real server on the real emulator in real time; what
the mount does is checked through Alpaca, conversions against ERFA by a different route.
"""

from __future__ import annotations

import itertools
import logging
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from alpaca_zwo.bridges.stellarium import BRIDGE_CLIENT
from tests.bridges.stellarium_client import Position, StellariumClient
from tests.bridges.stellarium_rig import (
    Rig,
    rate_hz,
    reference_to_apparent,
    reference_to_j2000,
    running_server,
    separation_arcsec,
    wait_until,
)
from tests.conftest import ServerFactory
from tests.support.sites import EQUATOR, SYDNEY, Site

pytestmark = pytest.mark.timeout(300)

RESOLUTION_ARCSEC = 360.0 * 3600.0 / 2**32  # one unit of the 32-bit RA encoding (0.0003")


@pytest.fixture(scope="module")
def rig(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Rig]:
    """J2000 server with one Alpaca client connected, tracking, pointed 1 h west of the meridian at Dec +40."""
    with running_server(tmp_path_factory.mktemp("stellarium")) as rig:
        rig.point_high()
        yield rig


@pytest.fixture
def client(rig: Rig) -> Iterator[StellariumClient]:
    c = StellariumClient(rig.stellarium_port)
    yield c
    c.close()


def _stream(client: StellariumClient, seconds: float) -> list[Position]:
    end = time.monotonic() + seconds
    positions = [client.read_position()]
    while time.monotonic() < end:
        positions.append(client.read_position())
    return positions


def _queued(client: StellariumClient) -> list[Position]:
    """Every position already received (at least one is waited for)."""
    positions = [client.read_position()]
    while True:
        try:
            positions.append(client.read_position(timeout=0.05))
        except TimeoutError:
            return positions


def test_position_stream_is_2hz_or_faster_and_well_formed(client: StellariumClient) -> None:
    positions = _stream(client, 4.0)
    arrivals = [p.received for p in positions[1:]]  # the first one is sent on connect
    assert rate_hz(arrivals) >= 2.0, f"{rate_hz(arrivals):.2f} Hz"
    assert max(b - a for a, b in itertools.pairwise(arrivals)) < 1.0  # no stall (sent every 0.25 s)
    for p in positions:
        assert (p.length, p.kind, p.status) == (24, 0, 0)
        # TIME is when the position was true, on Stellarium's (wall) clock, in microseconds
        assert abs(p.server_time_us / 1e6 - time.time()) < 10.0
    server_times = [p.server_time_us for p in positions]
    assert server_times == sorted(server_times)


def test_j2000_positions_agree_with_alpaca_converted_by_erfa(rig: Rig, client: StellariumClient) -> None:
    for _ in range(5):
        ra, dec, when = rig.alpaca.radec_and_time()
        sent = client.latest_position()
        expected = reference_to_j2000(ra, dec, when)
        error = separation_arcsec(sent.ra_hours, sent.dec_degrees, *expected)
        assert error <= 0.1, f"J2000 {sent.ra_hours:.7f} h {sent.dec_degrees:+.6f} vs ERFA {expected}: {error:.3f}\""
        # and the conversion is not a no-op: J2000 differs from the mount's coordinates of date
        assert separation_arcsec(sent.ra_hours, sent.dec_degrees, ra, dec) > 60.0


def test_jnow_mode_sends_the_mount_coordinates(tmp_path: Path) -> None:
    with running_server(tmp_path, equinox="JNow") as rig:
        client = StellariumClient(rig.stellarium_port)
        try:
            for _ in range(3):
                ra, dec, _when = rig.alpaca.radec_and_time()
                sent = client.latest_position()
                error = separation_arcsec(sent.ra_hours, sent.dec_degrees, ra, dec)
                assert error <= 0.1, f"JNow {sent.ra_hours} {sent.dec_degrees} vs Alpaca {ra} {dec}: {error:.3f}\""
            assert rig.server.stellarium.status()["equinox"] == "JNow"
            # A JNow goto is the mount's own target, unconverted; an Alpaca AbortSlew stops it.
            lst = float(rig.alpaca.get("siderealtime"))
            target = ((lst - 2.0) % 24.0, 30.0)
            client.goto(*target)
            wait_until(lambda: rig.alpaca.get("slewing"), 10.0, "the Stellarium goto to start")
            aimed = float(rig.alpaca.get("targetrightascension")), float(rig.alpaca.get("targetdeclination"))
            assert separation_arcsec(*aimed, *target) <= 0.1
            rig.alpaca.put("abortslew")
            wait_until(lambda: not rig.alpaca.get("slewing"), 10.0, "the abort to stop the slew")
            stopped = rig.alpaca.radec_and_time()[:2]
            assert separation_arcsec(*stopped, *target) > 600.0, "the slew was not cut short"
            sent = client.latest_position()
            assert separation_arcsec(sent.ra_hours, sent.dec_degrees, *stopped) <= 5.0
        finally:
            client.close()


def test_goto_slews_the_mount_to_the_j2000_target(rig: Rig, client: StellariumClient,
                                                  caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="alpaca_zwo.bridges.stellarium")
    lst = float(rig.alpaca.get("siderealtime"))
    target = ((lst + 0.5) % 24.0, 25.0)  # J2000, just east of the meridian
    client.goto(*target)
    wait_until(lambda: rig.alpaca.get("slewing"), 10.0, "the mount to start slewing")
    rig.alpaca.wait_slew_done()
    _, _, when = rig.alpaca.radec_and_time()
    expected = reference_to_apparent(*target, when)
    # The target the Telescope was given is the J2000 target of date, exactly (0.1").
    aimed = float(rig.alpaca.get("targetrightascension")), float(rig.alpaca.get("targetdeclination"))
    assert separation_arcsec(*aimed, *expected) <= 0.1
    ra, dec, _ = rig.alpaca.radec_and_time()
    assert separation_arcsec(ra, dec, *expected) <= 5.0, "the mount is not on the target"
    sent = client.latest_position()
    assert separation_arcsec(sent.ra_hours, sent.dec_degrees, *target) <= 5.0
    status = rig.server.stellarium.status()
    assert status["last_command"]["result"] == "slewing"
    assert abs(status["last_command"]["ra_hours"] - target[0]) * 54000 < 0.01
    assert any("goto from" in r.getMessage() for r in caplog.records if r.levelno == logging.INFO)


@pytest.mark.parametrize("site", [SYDNEY, EQUATOR], ids=["sydney", "equator"])
def test_positions_and_gotos_south_of_the_equator_and_on_it(tmp_path: Path, site: Site) -> None:
    """Issue 30: the stream agrees with ERFA for the site, and a goto toward the elevated pole lands
    on the J2000 target (ERFA's place of date) from the side DestinationSideOfPier promised."""
    with running_server(tmp_path, site=site.settings()) as rig:
        rig.point_high(dec=site.dec(40.0))
        client = StellariumClient(rig.stellarium_port)
        try:
            ra, dec, when = rig.alpaca.radec_and_time()
            sent = client.latest_position()
            expected = reference_to_j2000(ra, dec, when, site.settings())
            assert separation_arcsec(sent.ra_hours, sent.dec_degrees, *expected) <= 0.1
            lst = float(rig.alpaca.get("siderealtime"))
            target = ((lst + 0.5) % 24.0, site.dec(25.0))  # J2000, just east of the meridian
            client.goto(*target)
            wait_until(lambda: rig.alpaca.get("slewing"), 10.0, "the mount to start slewing")
            rig.alpaca.wait_slew_done()
            ra, dec, when = rig.alpaca.radec_and_time()
            assert separation_arcsec(ra, dec, *reference_to_apparent(*target, when, site.settings())) <= 5.0
            assert rig.alpaca.get("sideofpier") == 1  # east of the meridian: pierWest, in both hemispheres
        finally:
            client.close()


def test_goto_below_the_horizon_is_refused_and_the_connection_stays(rig: Rig, client: StellariumClient) -> None:
    before = rig.alpaca.radec_and_time()
    lst = float(rig.alpaca.get("siderealtime"))
    client.goto((lst + 12.0) % 24.0, -60.0)  # under the pole, far below the horizon at 51 N
    wait_until(lambda: "below the horizon" in str(rig.server.stellarium.status()["last_error"]), 10.0,
               "the refusal to be recorded")
    assert rig.server.stellarium.status()["last_command"]["result"].startswith("refused")
    assert not rig.alpaca.get("slewing")
    after = rig.alpaca.radec_and_time()
    assert separation_arcsec(*before[:2], *after[:2]) < 1.0
    client.read_position()
    client.latest_position()  # still streaming on the same connection


def test_goto_while_parked_is_refused_and_the_connection_stays(rig: Rig, client: StellariumClient) -> None:
    rig.alpaca.put("park")
    rig.alpaca.wait_slew_done()
    wait_until(lambda: rig.alpaca.get("atpark"), 60.0, "AtPark")
    try:
        lst = float(rig.alpaca.get("siderealtime"))
        client.goto(lst, 30.0)
        wait_until(lambda: "parked" in str(rig.server.stellarium.status()["last_error"]), 10.0,
                   "the parked refusal to be recorded")
        assert not rig.alpaca.get("slewing")
        assert rig.alpaca.get("atpark")
        client.latest_position()
    finally:
        rig.alpaca.put("unpark")
        rig.alpaca.put("tracking", Tracking=True)
    rig.point_high()


def test_several_stellariums_at_once(rig: Rig) -> None:
    clients = [StellariumClient(rig.stellarium_port) for _ in range(5)]
    try:
        wait_until(lambda: len(rig.server.stellarium.status()["clients"]) == 5, 5.0, "5 connected programs")
        for c in clients:
            c.read_position()  # each has its first position
        time.sleep(3.0)  # a measurement window: every client's stream queues up meanwhile
        for c in clients:
            stream = _queued(c)
            # rate by the server's TIME stamps: these reads are bunched, the sending was not
            times = [p.server_time_us / 1e6 for p in stream]
            assert len(stream) >= 6 and times[-1] - times[0] >= 2.0
            assert rate_hz(times) >= 2.0, f"{rate_hz(times):.2f} Hz"
        # every client gets the same broadcast: the last server times line up
        last_times = {c.latest_position().server_time_us for c in clients}
        assert len(last_times) <= 2  # a broadcast tick may fall between two reads
        addresses = {c["address"] for c in rig.server.stellarium.status()["clients"]}
        assert addresses == {f"127.0.0.1:{c.sock.getsockname()[1]}" for c in clients}
    finally:
        for c in clients:
            c.close()
    wait_until(lambda: not rig.server.stellarium.status()["clients"], 5.0, "the programs to be gone")


def test_bridge_holds_the_telescope_connected_while_stellarium_is(tmp_path: Path) -> None:
    with running_server(tmp_path, connect_alpaca=False) as rig:
        telescope = rig.server.telescopes[0]
        assert BRIDGE_CLIENT not in telescope.connection.clients()
        first, second = StellariumClient(rig.stellarium_port), StellariumClient(rig.stellarium_port)
        # With no Alpaca client at all, Stellarium alone connects the mount and gets positions.
        wait_until(lambda: BRIDGE_CLIENT in telescope.connection.clients(), 20.0, "the bridge to connect the mount")
        assert first.read_position(timeout=10.0).status == 0
        first.close()
        second.latest_position()
        assert BRIDGE_CLIENT in telescope.connection.clients(), "released while a Stellarium is still connected"
        second.close()
        wait_until(lambda: BRIDGE_CLIENT not in telescope.connection.clients(), 5.0, "the bridge to let go")
        status = rig.server.stellarium.status()
        assert status["clients"] == [] and status["enabled"] and status["port"] == rig.stellarium_port


@pytest.mark.parametrize("seed", range(3))
def test_conversions_match_erfa_by_another_route(seed: int) -> None:
    """The server's J2000 <-> apparent agrees with atco13/atoc13 all over the sky and across years."""
    import random
    from datetime import datetime, timedelta, timezone

    from alpaca_zwo.bridges.stellarium import apparent_to_j2000, j2000_to_apparent
    from tests.bridges.stellarium_rig import SITE

    rng = random.Random(seed)
    for _ in range(200):
        when = datetime(2024, 1, 1, tzinfo=timezone.utc) + timedelta(days=rng.uniform(0, 365 * 5))  # to 2028
        ra, dec = rng.uniform(0, 24), rng.uniform(-89.9, 89.9)
        assert separation_arcsec(*apparent_to_j2000(ra, dec, when, SITE), *reference_to_j2000(ra, dec, when)) < 0.01
        assert separation_arcsec(*j2000_to_apparent(ra, dec, when, SITE), *reference_to_apparent(ra, dec, when)) < 0.01
        back = apparent_to_j2000(*j2000_to_apparent(ra, dec, when, SITE), when, SITE)
        assert separation_arcsec(*back, ra, dec) < 0.001


def test_config_section_is_checked_like_the_others() -> None:
    from alpaca_zwo._exceptions import ConfigError
    from alpaca_zwo.config.settings import Settings, settings_from_dict

    assert Settings().stellarium.enabled is False and Settings().stellarium.port == 10001
    assert settings_from_dict({"stellarium": {"equinox": "jnow"}}).stellarium.equinox == "JNow"
    with pytest.raises(ConfigError) as info:
        settings_from_dict({"stellarium": {"equinox": "B1950", "port": 70000, "enabeld": True}}, "f.toml")
    message = str(info.value)
    assert "stellarium.equinox: must be one of 'J2000', 'JNow'" in message
    assert "stellarium.port: must be between 0 and 65535" in message
    assert "did you mean 'enabled'" in message


def test_off_by_default(server_factory: ServerFactory) -> None:
    server = server_factory()
    assert server.stellarium is None
    assert not any(line.startswith("Stellarium") for line in server.urls())


def test_command_line_option_turns_it_on_for_the_run(tmp_path: Path) -> None:
    import signal
    import subprocess
    import sys

    config = tmp_path / "config.toml"
    config.write_text('[site]\nlatitude = 51.4769\nlongitude = -0.0005\n[emulator]\nspeed = 1.0\n')
    proc = subprocess.Popen([sys.executable, "-m", "alpaca_zwo", "--config", str(config), "--host", "127.0.0.1",
                             "--port", "0", "--discovery-port", "0", "--stellarium-port", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        assert proc.stdout is not None
        port = None
        deadline = time.monotonic() + 30.0
        while port is None and time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line:
                break
            if line.strip().startswith("Stellarium:"):
                port = int(line.split("TCP port")[1].split()[0])
        assert port, "no Stellarium line among the start-up lines"
        client = StellariumClient(port)
        try:
            assert client.read_position(timeout=20.0).status == 0  # Stellarium alone connects the mount
        finally:
            client.close()
        from alpaca_zwo.config.file import load_settings

        saved = load_settings(config).stellarium
        assert saved.enabled is False, "the option is for this run only and must not be saved"
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=30) == 0


def test_five_stellariums_add_no_serial_traffic(tmp_path: Path) -> None:
    """The stream is served from the server's state: five programs cost the mount's line nothing."""
    with running_server(tmp_path) as rig:
        counters = rig.server.telescopes[0].mount.link.counters
        rig.alpaca.get("rightascension")

        def exchanges_during(seconds: float) -> int:
            before = counters.exchanges
            time.sleep(seconds)  # a measurement window, not synchronisation
            return counters.exchanges - before

        alone = exchanges_during(5.0)
        clients = [StellariumClient(rig.stellarium_port) for _ in range(5)]
        try:
            for c in clients:
                c.read_position()
            with_five = exchanges_during(5.0)
            assert all(c.latest_position().status == 0 for c in clients)
        finally:
            for c in clients:
                c.close()
        print(f"serial exchanges in 5 s: {alone} with Alpaca alone, {with_five} with 5 Stellariums too")
        # The poller's own count varies by one 4-exchange cycle per window; a per-message read by
        # the bridge would add 5 x 4 Hz = 20 exchanges a second, 100 per window.
        assert with_five <= alone * 1.1 + 8, f"{alone} exchanges in 5 s alone, {with_five} with 5 Stellariums"


def test_unreachable_mount_is_reported_and_stellarium_stays(tmp_path: Path) -> None:
    import dataclasses
    import socket

    from alpaca_zwo.config.settings import DeviceSettings, StellariumSettings
    from alpaca_zwo.config.store import SettingsStore
    from alpaca_zwo.server import AlpacaZwoServer
    from tests.conftest import make_settings

    with socket.socket() as s:  # a port with nothing listening: the mount is "switched off"
        s.bind(("127.0.0.1", 0))
        dead = s.getsockname()[1]
    settings = make_settings(stellarium=StellariumSettings(enabled=True, host="127.0.0.1", port=0))
    device = dataclasses.replace(settings.devices[0], url=f"socket://127.0.0.1:{dead}", timeout=0.5)
    settings = dataclasses.replace(settings, devices=(device,))
    assert isinstance(device, DeviceSettings)
    server = AlpacaZwoServer(SettingsStore(settings, tmp_path / "config.toml"))
    server.start()
    try:
        client = StellariumClient(server.stellarium.port)
        try:
            wait_until(lambda: "cannot connect the telescope" in str(server.stellarium.status()["last_error"]),
                       20.0, "the failed mount connection to be recorded")
            with pytest.raises(TimeoutError):
                client.read_position(timeout=1.0)  # no position to show, but the connection stays
            assert len(server.stellarium.status()["clients"]) == 1
        finally:
            client.close()
    finally:
        server.stop()
