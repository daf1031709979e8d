"""The motion supervisor, judged by the emulator's own truth (issue 13).

Each test drives the real server over HTTP and checks what the emulated mount physically did: its
axes' velocity after a stop, where it pointed when the server said a slew was over, whether a
GOTO was started after an abort. The emulator runs faster than real time (``SPEED``) so slews take
seconds; every wait is a bounded poll of a condition.
"""

from __future__ import annotations

import math
import random
import threading
import time
from typing import Any

import pytest

from alpaca_zwo.config.settings import EmulatorSettings, LimitSettings, SafetySettings
from alpaca_zwo.emulator import MountModel
from alpaca_zwo.server import AlpacaZwoServer
from alpaca_zwo.sky import SIDEREAL_DEG_S
from tests.conftest import ServerFactory, make_settings
from tests.support import AlpacaClient, wait_until
from tests.support.sites import NORTH, SITE_IDS, SITES, Site

SPEED = 4.0
ARCSEC = 1.0 / 3600.0
MAX_RATE = 1440 * SIDEREAL_DEG_S  # deg/s, the highest MoveAxis rate


def _server(server_factory: ServerFactory, speed: float = SPEED, site: Site = NORTH,
            **sections: Any) -> AlpacaZwoServer:
    return server_factory(make_settings(emulator=EmulatorSettings(speed=speed, baud=0), site=site.settings(),
                                        **sections))


def _model(server: AlpacaZwoServer) -> MountModel:
    emulator = server.emulators[0]
    assert emulator is not None
    return emulator.model


class Api(AlpacaClient):
    """The shared client with the few conveniences these scenarios read best with."""

    def ok(self, member: str, **params: Any) -> None:
        self.command(member.lower(), **params)

    def value(self, member: str, **params: Any) -> Any:
        return super().value(member.lower(), **params)

    def error(self, member: str, **params: Any) -> int:
        return int(self.put(member.lower(), **params).error_number or 0)

    def ra_at_ha(self, ha_hours: float) -> float:
        return (self.value("SiderealTime") - ha_hours) % 24.0


def _api(server: AlpacaZwoServer, client_id: int = 4242) -> Api:
    api = Api(server.port, client_id)
    api.ok("Connected", Connected=True)
    return api


def wrap12(hours: float) -> float:
    return (hours + 12.0) % 24.0 - 12.0


def _at_rest(model: MountModel) -> bool:
    """No axis moves except the RA axis at the sidereal rate while tracking (the other way round
    south of the equator)."""
    v_ra, v_dec = model.snapshot()["velocity_deg_s"]
    tracking_rate = SIDEREAL_DEG_S if model.tracking_state()[0] else 0.0
    return v_dec == 0.0 and abs(abs(v_ra) - tracking_rate) < 1e-9


def _mount_seconds(server: AlpacaZwoServer) -> float:
    emulator = server.emulators[0]
    assert emulator is not None
    return emulator.clock.seconds()


def _sky_error_arcsec(a: tuple[float, float], b: tuple[float, float]) -> float:
    """Angular distance between two (RA h, Dec deg) or (alt, az) pairs treated as sky positions."""
    ra1, d1 = math.radians(a[0] * 15.0), math.radians(a[1])
    ra2, d2 = math.radians(b[0] * 15.0), math.radians(b[1])
    cos = math.sin(d1) * math.sin(d2) + math.cos(d1) * math.cos(d2) * math.cos(ra1 - ra2)
    return math.degrees(math.acos(max(-1.0, min(1.0, cos)))) * 3600.0


def _altaz_error_arcsec(got: tuple[float, float], alt: float, az: float) -> float:
    """Great-circle distance between (alt, az) pairs."""
    return _sky_error_arcsec((got[1] / 15.0, got[0]), (az / 15.0, alt))


# -- 1. Slewing stays true until the mount is at rest ------------------------------------------


@pytest.mark.parametrize("kind", ["goto", "moveaxis"])
def test_abort_keeps_slewing_until_the_mount_is_at_rest(server_factory: ServerFactory, kind: str) -> None:
    """Observation 1: after AbortSlew (or MoveAxis 0) the mount brakes for seconds; Slewing must stay
    true until it has stopped, and 3 s after it reads false the mount has moved less than 5″."""
    server = _server(server_factory)
    api, model = _api(server), _model(server)
    api.ok("Tracking", Tracking=True)
    if kind == "goto":
        api.ok("SlewToCoordinatesAsync", RightAscension=api.ra_at_ha(-4.0), Declination=70.0)
        start = _mount_seconds(server)
        wait_until(lambda: _mount_seconds(server) - start > 1.5, 30, "1.5 s of slew")
        api.ok("AbortSlew")
    else:
        api.ok("Tracking", Tracking=False)
        api.ok("MoveAxis", Axis=1, Rate=-MAX_RATE)
        start = _mount_seconds(server)
        wait_until(lambda: _mount_seconds(server) - start > 3.0, 30, "3 s of MoveAxis")
        api.ok("MoveAxis", Axis=1, Rate=0.0)
    assert api.value("Slewing") is True, "Slewing went false the moment the stop was sent"
    assert not _at_rest(model), "the emulator should still be braking right after the stop"
    wait_until(lambda: api.value("Slewing") is False, 30, "Slewing to become false")
    assert _at_rest(model), f"Slewing read false while the axes still moved: {model.snapshot()['velocity_deg_s']}"
    tracking = api.value("Tracking")
    before, t0 = model.axes(), _mount_seconds(server)
    wait_until(lambda: _mount_seconds(server) - t0 >= 3.0, 30, "3 mount seconds")
    after, t1 = model.axes(), _mount_seconds(server)
    drift = (360.0 / 86164.0905) * (t1 - t0) if tracking else 0.0
    moved = max(abs(after[0] - before[0] - drift), abs(after[1] - before[1])) * 3600.0
    assert moved < 5.0, f"the mount moved {moved:.1f}″ in the 3 s after Slewing read false"


# -- 2. Alt/Az and coordinate slews land where asked ---------------------------------------------


ALTAZ_CASES = [  # (altitude, azimuth, tracking): short and long slews, east and west of the meridian
    (45.0, 120.0, False),
    (30.0, 180.0, False),
    (60.0, 250.0, False),
    (50.0, 100.0, True),
    (35.0, 230.0, True),
]


#: Where the users are (issue 30): every case north of the equator, two of them at Sydney and on it.
ALTAZ_SITE_CASES = [(NORTH, *case) for case in ALTAZ_CASES] + [
    (site, *case) for site in SITES[1:] for case in (ALTAZ_CASES[1], ALTAZ_CASES[4])]


@pytest.mark.parametrize(("site", "alt", "az", "tracking"), ALTAZ_SITE_CASES,
                         ids=[f"{c[0].name}-{c[1]:g}-{c[2]:g}-{c[3]}" for c in ALTAZ_SITE_CASES])
def test_alt_az_slews_land_within_five_arcseconds(server_factory: ServerFactory, site: Site, alt: float, az: float,
                                                   tracking: bool) -> None:
    """Observation 2: the sky turns during the slew; the landing must still be within 5″ (goal 1″)."""
    server = _server(server_factory, site=site)
    api, model = _api(server), _model(server)
    api.ok("Tracking", Tracking=tracking)
    api.ok("SlewToAltAzAsync", Azimuth=az, Altitude=alt)
    wait_until(lambda: api.value("Slewing") is False, 60, "the Alt/Az slew to end", interval=0.002)
    error = _altaz_error_arcsec(model.horizontal(), alt, az)
    assert error < 5.0, f"landed {error:.2f}″ from Alt {alt} Az {az} (tracking {tracking})"
    assert api.value("Tracking") is tracking
    if not tracking:  # frozen on the requested Alt/Az: it stays there
        t0 = _mount_seconds(server)
        wait_until(lambda: _mount_seconds(server) - t0 >= 2.0, 30, "2 mount seconds")
        error = _altaz_error_arcsec(model.horizontal(), alt, az)
        assert error < 5.0, f"drifted to {error:.2f}″ from Alt {alt} Az {az} after landing"


@pytest.mark.parametrize("site", SITES, ids=SITE_IDS)
@pytest.mark.parametrize(("ha", "dec"), [(-2.0, 20.0), (1.5, 45.0), (-0.2, 80.0)])
def test_coordinate_slews_land_within_one_arcsecond(server_factory: ServerFactory, site: Site, ha: float,
                                                    dec: float) -> None:
    """The mount takes whole seconds of RA; the residual is guided away, so the landing is exact. The
    declinations point toward the site's elevated pole."""
    server = _server(server_factory, site=site)
    api, model = _api(server), _model(server)
    api.ok("Tracking", Tracking=True)
    ra = (api.ra_at_ha(ha) + 0.37 / 3600.0) % 24.0  # deliberately between whole seconds
    dec = site.dec(dec + 0.43 * ARCSEC)
    api.ok("SlewToCoordinatesAsync", RightAscension=ra, Declination=dec)
    wait_until(lambda: api.value("Slewing") is False, 60, "the slew to end")
    error = _sky_error_arcsec(model.position(), (ra, dec))
    assert error < 1.0, f"landed {error:.2f}″ from the requested RA/Dec"
    served = (api.value("RightAscension"), api.value("Declination"))
    assert _sky_error_arcsec(served, (ra, dec)) < 1.0


@pytest.mark.parametrize("site", SITES, ids=SITE_IDS)
def test_custom_park_position_is_reached_exactly(server_factory: ServerFactory, site: Site) -> None:
    from alpaca_zwo.config.settings import ParkSettings

    park_dec = site.dec(30.0)
    server = _server(server_factory, site=site, park=ParkSettings(mode="custom", ha_hours=-1.25, dec_deg=park_dec))
    api, model = _api(server), _model(server)
    api.ok("Park")
    wait_until(lambda: api.value("AtPark") is True, 60, "AtPark")
    assert api.value("Slewing") is False
    assert api.value("Tracking") is False
    ra, dec = model.position()
    ha = wrap12(api.value("SiderealTime") - ra)
    assert abs(ha - (-1.25)) * 15 * 3600 * math.cos(math.radians(dec)) < 5.0
    assert abs(dec - park_dec) * 3600 < 5.0


# -- 3. An abort is never overtaken ---------------------------------------------------------------


def test_abort_during_a_replacing_goto_is_not_overtaken(server_factory: ServerFactory) -> None:
    """Observation 3: a GOTO that replaces a running one must stop it and wait; an AbortSlew that
    arrives meanwhile answers at once and the replacing GOTO never starts."""
    # Paced at 9600 baud, as over USB: the replacing GOTO's wait for the mount's idle flag spans
    # several exchanges, so the abort usually lands inside it.
    server = server_factory(make_settings(emulator=EmulatorSettings(speed=2.0, baud=9600)))
    api, model = _api(server), _model(server)
    other = _api(server, client_id=77)
    api.ok("Tracking", Tracking=True)
    api.ok("SlewToCoordinatesAsync", RightAscension=api.ra_at_ha(-3.0), Declination=10.0)
    wait_until(lambda: model.slewing(), 10, "the first GOTO to run")
    target_b = (api.ra_at_ha(2.0), 60.0)
    replies: list[int] = []
    second = threading.Thread(target=lambda: replies.append(
        other.error("SlewToCoordinatesAsync", RightAscension=target_b[0], Declination=target_b[1])))
    second.start()
    wait_until(lambda: not model.slewing(), 10, "the replacing GOTO to stop the first")
    started = time.monotonic()
    api.ok("AbortSlew")
    abort_s = time.monotonic() - started
    second.join(30)
    assert abort_s < 0.5, f"AbortSlew waited {abort_s:.2f} s behind the replacing GOTO"
    assert replies, "the replacing GOTO never answered"  # refused (cancelled) or started before the abort
    wait_until(lambda: api.value("Slewing") is False, 30, "rest after the abort")
    t0 = _mount_seconds(server)
    wait_until(lambda: _mount_seconds(server) - t0 >= 3.0, 30, "3 mount seconds")
    assert not model.slewing(), "a GOTO started after the abort"
    assert _sky_error_arcsec(model.position(), target_b) > 3600.0, "the mount went to the aborted target"


MOTIONS = ["goto-replacing-goto", "moveaxis", "pulse", "park", "home"]


def _start(kind: str, api: Api) -> None:
    if kind == "goto-replacing-goto":
        api.ok("SlewToCoordinatesAsync", RightAscension=api.ra_at_ha(-2.0), Declination=20.0)
        threading.Thread(target=lambda: api.error("SlewToCoordinatesAsync", RightAscension=api.ra_at_ha(1.0),
                                                  Declination=50.0), daemon=True).start()
    elif kind == "moveaxis":
        api.ok("MoveAxis", Axis=0, Rate=MAX_RATE / 2)
    elif kind == "pulse":
        api.ok("PulseGuide", Direction=0, Duration=5000)
    elif kind == "park":
        api.ok("Park")
    else:
        api.ok("FindHome")


@pytest.mark.parametrize("seed", range(3))
def test_randomised_abort_trials(server_factory: ServerFactory, seed: int) -> None:
    """Over seeded trials, AbortSlew at a random moment of each kind of motion leaves the mount at
    rest within the braking time and starts nothing after it."""
    rng = random.Random(seed)
    server = _server(server_factory)
    api, model = _api(server), _model(server)
    for kind in rng.sample(MOTIONS, len(MOTIONS)):
        api.ok("Unpark")
        api.ok("Tracking", Tracking=True)
        api.ok("SlewToCoordinatesAsync", RightAscension=api.ra_at_ha(-1.0), Declination=30.0)
        wait_until(lambda: api.value("Slewing") is False, 60, "the set-up slew")
        _start(kind, api)
        delay = rng.uniform(0.0, 2.0)
        t0 = _mount_seconds(server)
        wait_until(lambda d=delay, t=t0: _mount_seconds(server) - t >= d, 30, "the random moment")
        if api.value("AtPark"):
            continue  # the park finished first: nothing left to abort
        api.ok("AbortSlew")
        stopped_at = _mount_seconds(server)
        wait_until(lambda: api.value("Slewing") is False and api.value("IsPulseGuiding") is False, 30,
                   f"rest after aborting {kind}")
        assert _at_rest(model), f"{kind}: still moving after Slewing read false"
        assert _mount_seconds(server) - stopped_at < 2.0 + 3.0 * SPEED, f"{kind}: took too long to come to rest"
        t1 = _mount_seconds(server)
        wait_until(lambda t=t1: _mount_seconds(server) - t >= 2.0, 30, "2 mount seconds")
        assert not model.slewing(), f"{kind}: a GOTO started after the abort"
        assert model.snapshot()["moves_deg_s"] == [None, None], f"{kind}: a move started after the abort"


# -- 4. Guards that exist only on paper: now wired ------------------------------------------------


def test_guide_max_ms_limits_pulse_length(server_factory: ServerFactory) -> None:
    server = _server(server_factory, safety=SafetySettings(guide_max_ms=1500))
    api = _api(server)
    api.ok("Tracking", Tracking=True)
    assert api.error("PulseGuide", Direction=0, Duration=1501) == 0x401
    api.ok("PulseGuide", Direction=0, Duration=1500)


def test_sync_reads_back_the_synced_position_whatever_the_poll_was_doing(server_factory: ServerFactory) -> None:
    """Observation (third-party client, 1 in 9): a sync right after an offset slew read back the
    pre-sync position, 63″ off: a poll that read the position before the sync published it after.
    Paced at 2400 baud so a poll (four exchanges, ~240 ms) overlaps a sync often; the syncs
    alternate between two positions 63″ apart and every read after each must show the new one."""
    server = server_factory(make_settings(emulator=EmulatorSettings(speed=4.0, baud=2400)))
    api = _api(server)
    api.ok("Tracking", Tracking=True)
    ra, dec = api.ra_at_ha(-1.0), 40.0
    api.ok("SlewToCoordinatesAsync", RightAscension=ra, Declination=dec)
    wait_until(lambda: api.value("Slewing") is False, 60, "the first slew")
    rng = random.Random(13)
    for i in range(25):
        target = ((ra + (63.0 / 3600.0 / 15.0 if i % 2 else 0.0)) % 24.0, dec)
        api.ok("SyncToCoordinates", RightAscension=target[0], Declination=target[1])
        # Read for a varying while, so the next sync lands at every phase of the poll the last
        # one triggered (a sync asks for a poll at once; the next follows about a second later).
        deadline = time.monotonic() + rng.uniform(0.9, 1.4)
        while time.monotonic() < deadline:
            served = (api.value("RightAscension"), api.value("Declination"))
            error = _sky_error_arcsec(served, target)
            assert error < 2.0, f"sync {i}: read {error:.1f}″ from the synced position"


# -- braking-aware limits -------------------------------------------------------------------------


@pytest.mark.parametrize("site", SITES, ids=SITE_IDS)
def test_moveaxis_at_full_rate_stops_before_the_altitude_limit(server_factory: ServerFactory, site: Site) -> None:
    floor = 25.0
    server = _server(server_factory, site=site, limits=LimitSettings(min_altitude_deg=floor))
    api, model = _api(server), _model(server)
    api.ok("Tracking", Tracking=True)
    api.ok("SlewToCoordinatesAsync", RightAscension=api.ra_at_ha(-3.0), Declination=site.dec(20.0))
    wait_until(lambda: api.value("Slewing") is False, 60, "the set-up slew")
    assert model.horizontal()[0] > floor + 10.0
    api.ok("MoveAxis", Axis=1, Rate=-site.pole * MAX_RATE)  # away from the pole: down toward the horizon
    lowest = 90.0
    deadline = time.monotonic() + 60
    while api.value("Slewing") and time.monotonic() < deadline:
        lowest = min(lowest, model.horizontal()[0])
    lowest = min(lowest, model.horizontal()[0])
    assert _at_rest(model)
    assert lowest >= floor, f"MoveAxis went to {lowest:.3f}°, below the {floor}° limit"
    assert api.value("Slewing") is False


# -- rate offsets (issue 15.4): guide pulses on a schedule ----------------------------------------


def _offset_run(server: AlpacaZwoServer, api: Api, model: MountModel, seconds: float,
                ra_rate: float, dec_rate: float) -> tuple[float, float]:
    """Track with offsets for ``seconds`` of mount time; return the (RA, Dec) moved in arcsec."""
    api.ok("RightAscensionRate", RightAscensionRate=ra_rate)
    api.ok("DeclinationRate", DeclinationRate=dec_rate)
    ra0, dec0 = model.position()
    t0 = _mount_seconds(server)
    wait_until(lambda: _mount_seconds(server) - t0 >= seconds, 120, f"{seconds} s of offset tracking")
    ra1, dec1 = model.position()
    return wrap12(ra1 - ra0) * 15 * 3600, (dec1 - dec0) * 3600


@pytest.mark.parametrize(("ra_arcsec", "dec_arcsec"), [(3.0, -3.0), (40.0, -40.0)])
def test_rate_offsets_move_the_mount_at_the_requested_rates(server_factory: ServerFactory, ra_arcsec: float,
                                                            dec_arcsec: float) -> None:
    """Small offsets are paid in guide pulses, large ones (ConformU writes ±40″/s) by a slow move."""
    server = _server(server_factory)
    api, model = _api(server), _model(server)
    api.ok("Tracking", Tracking=True)
    api.ok("SlewToCoordinatesAsync", RightAscension=api.ra_at_ha(-1.0), Declination=20.0)
    wait_until(lambda: api.value("Slewing") is False, 60, "the slew")
    assert api.value("CanSetRightAscensionRate") is True and api.value("CanSetDeclinationRate") is True
    ra_rate, dec_rate = ra_arcsec / 15.0 / 1.00273790935, dec_arcsec  # RA seconds per sidereal second
    moved_ra, moved_dec = _offset_run(server, api, model, 20.0, ra_rate, dec_rate)
    assert api.value("RightAscensionRate") == ra_rate and api.value("DeclinationRate") == dec_rate
    expected_ra = ra_rate * 15 * 1.00273790935 * 20.0
    assert moved_ra == pytest.approx(expected_ra, abs=max(1.0, 0.05 * abs(expected_ra)))
    assert moved_dec == pytest.approx(dec_rate * 20.0, abs=max(1.0, 0.02 * abs(dec_rate * 20.0)))
    assert api.value("IsPulseGuiding") is False and api.value("Slewing") is False
    served = api.value("Declination")
    assert abs(served - model.position()[1]) * 3600 < 3.0, "the served Dec does not follow the offset"


def test_rate_offsets_and_client_pulses_share_the_axes(server_factory: ServerFactory) -> None:
    """A client's guide pulses during an offset: both displacements arrive, neither is lost."""
    server = _server(server_factory)
    api, model = _api(server), _model(server)
    api.ok("Tracking", Tracking=True)
    api.ok("SlewToCoordinatesAsync", RightAscension=api.ra_at_ha(-1.0), Declination=20.0)
    wait_until(lambda: api.value("Slewing") is False, 60, "the slew")
    guide = api.value("GuideRateDeclination") * 3600.0  # arcsec/s
    dec_rate = 2.0
    api.ok("DeclinationRate", DeclinationRate=dec_rate)
    _, dec0 = model.position()
    t0 = _mount_seconds(server)
    for _ in range(4):  # 4 x 1 s north pulses, PHD2-style, while the offset runs
        api.ok("PulseGuide", Direction=0, Duration=1000)
        wait_until(lambda: api.value("IsPulseGuiding") is False, 30, "the pulse to end")
    wait_until(lambda: _mount_seconds(server) - t0 >= 20.0, 120, "20 s")
    api.ok("DeclinationRate", DeclinationRate=0.0)
    elapsed = _mount_seconds(server) - t0
    moved = (model.position()[1] - dec0) * 3600
    expected = dec_rate * elapsed + 4 * guide * 1.0
    assert moved == pytest.approx(expected, abs=2.0), f"moved {moved:.1f}″, expected {expected:.1f}″"


def test_rate_offsets_are_refused_beyond_the_largest_and_off_sidereal(server_factory: ServerFactory) -> None:
    server = _server(server_factory)
    api = _api(server)
    api.ok("Tracking", Tracking=True)
    assert api.error("DeclinationRate", DeclinationRate=601.0) == 0x401
    assert api.error("RightAscensionRate", RightAscensionRate=100.0) == 0x401
    api.ok("TrackingRate", TrackingRate=1)
    assert api.error("DeclinationRate", DeclinationRate=1.0) == 0x40B
    assert api.value("DeclinationRate") == 0.0
