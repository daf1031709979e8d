"""The pointing model end to end (issue 40 item 2): an imperfect emulated mount (TPOINT terms and
scatter, emulator/imperfection.py), syncs on where the tube truly points (as a plate solve reports it),
then blind GoTos judged by the emulator's truth (its ``sky()``), north, at Sydney, on the equator and
in alt-az mode; the sync's read-back, the Action, a gross sync refused, and the model surviving a
server restart with a mount power cycle.
"""

from __future__ import annotations

import json
import math
from typing import Any

import pytest

from alpaca_zwo import sky
from alpaca_zwo.config.settings import EmulatorSettings
from alpaca_zwo.emulator import MountModel
from alpaca_zwo.server import AlpacaZwoServer
from tests.conftest import ServerFactory, make_settings
from tests.mount.test_sync_remainder import Api, error_arcsec, slew
from tests.support.sites import NORTH, SITE_IDS, SITES, Site

SPEED = 8.0
REALISTIC = "IH=20,ID=-8,MA=12,ME=-9,CH=5,NP=2,TF=1.5"
REALISTIC_ALTAZ = "IA=20,IE=-8,AN=12,AW=-9,CA=5,NPAE=2,TF=1.5"
NOISE = 5.0
#: Sync stars and blind targets as (hour angle h, declination toward the elevated pole °): both sides
#: of the meridian, kept 1 h from it (the mount refuses a sync across it) and 30° above every horizon.
SYNCS = ((-3.5, 10.0), (-2.2, 40.0), (-1.2, 20.0), (1.2, 45.0), (2.3, 5.0), (3.5, 30.0))
TARGETS = ((-2.8, 25.0), (-1.6, 5.0), (1.8, 20.0), (3.0, 40.0))


def _start(server_factory: ServerFactory, site: Site, altaz: bool = False, config: str = "config.toml"
           ) -> tuple[AlpacaZwoServer, Api, MountModel]:
    emulator = EmulatorSettings(speed=SPEED, baud=0, mode="altaz" if altaz else "eq",
                                pointing_errors=REALISTIC_ALTAZ if altaz else REALISTIC, pointing_noise=NOISE)
    server = server_factory(make_settings(emulator=emulator, site=site.settings()), config_name=config)
    assert server.emulators[0] is not None
    api = Api(server.port)
    api.ok("Connected", Connected=True)
    api.ok("Tracking", Tracking=True)
    return server, api, server.emulators[0].model


def _radec(api: Api, site: Site, ha: float, toward_pole: float) -> tuple[float, float]:
    return (api.value("SiderealTime") - ha) % 24.0, site.dec(toward_pole)


def _true_sky(model: MountModel) -> tuple[float, float]:
    ra, dec, _, _ = model.sky()
    return ra, dec


def _miss_arcsec(model: MountModel, target: tuple[float, float]) -> float:
    return sky.angular_separation(*_true_sky(model), *target) * 3600.0


def action(api: Api, parameters: dict[str, Any] | None = None) -> dict[str, Any]:
    call = api.put("action", Action="zwo:PointingModel", Parameters=json.dumps(parameters or {}))
    assert call.ok, call.describe()
    reply = json.loads(call.value)
    assert isinstance(reply, dict)
    return reply


def sync_on_truth(api: Api, model: MountModel, site: Site, ha: float, toward_pole: float) -> None:
    """GoTo near a star, then sync on where the tube truly is, as a plate solve would say; the sync
    reads back exactly what was synced."""
    slew(api, *_radec(api, site, ha, toward_pole))
    solved = _true_sky(model)
    api.ok("SyncToCoordinates", RightAscension=solved[0], Declination=solved[1])
    d_ra, d_dec = error_arcsec((api.value("RightAscension"), api.value("Declination")), solved)
    assert math.hypot(d_ra, d_dec) < 0.5, f"a sync read back {d_ra:+.2f}″ RA {d_dec:+.2f}″ Dec off"


def blind_misses(api: Api, model: MountModel, site: Site) -> list[float]:
    misses = []
    for ha, toward_pole in TARGETS:
        target = _radec(api, site, ha, toward_pole)
        slew(api, *target)
        misses.append(_miss_arcsec(model, target))
    return misses


@pytest.mark.parametrize("site", SITES, ids=SITE_IDS)
def test_after_six_syncs_a_blind_goto_lands_within_an_arcminute(server_factory: ServerFactory, site: Site) -> None:
    _server, api, model = _start(server_factory, site)
    sync_on_truth(api, model, site, *SYNCS[0])
    single = blind_misses(api, model, site)
    assert max(single) > 5 * 60.0, f"one sync should leave arcminutes of error: {single}"
    for star in SYNCS[1:]:
        sync_on_truth(api, model, site, *star)
    report = action(api)
    assert len(report["points"]) == 6 and report["rms_arcsec"] < 30.0, report
    assert {t["name"] for t in report["terms"]} >= {"IH", "ID", "MA", "ME"}, report
    misses = blind_misses(api, model, site)
    assert max(misses) < 60.0, f"blind GoTos after 6 syncs missed by {[round(m) for m in misses]}″"


def test_alt_az_mode_after_six_syncs_lands_within_an_arcminute(server_factory: ServerFactory) -> None:
    _server, api, model = _start(server_factory, NORTH, altaz=True)
    for star in SYNCS:
        sync_on_truth(api, model, NORTH, *star)
    report = action(api)
    assert report["mode"] == "altaz" and {t["name"] for t in report["terms"]} >= {"IA", "IE", "AN", "AW"}, report
    misses = blind_misses(api, model, NORTH)
    assert max(misses) < 60.0, f"blind GoTos after 6 syncs missed by {[round(m) for m in misses]}″"


def test_the_fit_recovers_the_emulators_terms_within_their_uncertainty(server_factory: ServerFactory) -> None:
    _server, api, model = _start(server_factory, NORTH)
    for star in (*SYNCS, *TARGETS, (-0.9, 60.0), (0.9, 0.0)):
        sync_on_truth(api, model, NORTH, *star)
    injected = {name: float(v) * 60.0 for name, v in (item.split("=") for item in REALISTIC.split(","))}
    terms = {t["name"]: t for t in action(api)["terms"]}
    assert set(terms) == set(injected)
    for name, term in terms.items():
        # 4σ plus the rounding of the report (0.1″) and the emulator's smooth scatter (5″ RMS)
        assert abs(term["arcsec"] - injected[name]) < 4.0 * term["sigma_arcsec"] + 0.2, (name, term, injected[name])


def test_a_gross_sync_holds_but_teaches_the_model_nothing(server_factory: ServerFactory) -> None:
    _server, api, model = _start(server_factory, NORTH)
    for star in SYNCS:
        sync_on_truth(api, model, NORTH, *star)
    before = action(api)
    slew(api, *_radec(api, NORTH, -2.0, 30.0))
    wrong = ((_true_sky(model)[0] + 0.1) % 24.0, _true_sky(model)[1] + 1.0)  # a wrong plate solve: 1.5° off
    api.ok("SyncToCoordinates", RightAscension=wrong[0], Declination=wrong[1])
    d_ra, d_dec = error_arcsec((api.value("RightAscension"), api.value("Declination")), wrong)
    assert math.hypot(d_ra, d_dec) < 0.5  # ASCOM: a sync reads back what was synced, whatever the model
    after = action(api)
    assert after["points"] == before["points"] and after["terms"] == before["terms"]
    assert "refused" in after["last_refusal"] and "from where the pointing model" in after["last_refusal"]


def test_the_action_switches_clears_and_refuses_bad_parameters(server_factory: ServerFactory) -> None:
    _server, api, model = _start(server_factory, NORTH)
    assert action(api) == {"enabled": True, "mode": "equatorial", "latitude": pytest.approx(NORTH.latitude),
                           "points": [], "terms": [], "rms_arcsec": 0.0, "last_refusal": ""}
    for star in SYNCS[:4]:
        sync_on_truth(api, model, NORTH, *star)
    here = (api.value("RightAscension"), api.value("Declination"))
    assert action(api, {"enabled": False})["enabled"] is False
    assert len(action(api)["points"]) == 4  # off keeps the points
    assert action(api, {"enabled": True, "clear": True}) == {
        "enabled": True, "mode": "equatorial", "latitude": pytest.approx(NORTH.latitude), "points": [],
        "terms": [], "rms_arcsec": 0.0, "last_refusal": ""}
    d_ra, d_dec = error_arcsec((api.value("RightAscension"), api.value("Declination")), here)
    assert math.hypot(d_ra, d_dec) < 120.0  # the last sync still holds as a single-point sync
    for bad in ({"clear": False}, {"enabled": "yes"}, {"terms": []}):
        call = api.put("action", Action="zwo:PointingModel", Parameters=json.dumps(bad))
        assert call.error_number == 0x401, call.describe()


def test_the_model_survives_a_server_restart_and_a_mount_power_cycle(server_factory: ServerFactory) -> None:
    server, api, model = _start(server_factory, NORTH)
    for star in SYNCS:
        sync_on_truth(api, model, NORTH, *star)
    points = action(api)["points"]
    server.stop()
    # A new server and a new emulated mount (its clock lost: a power cycle), the same settings folder.
    _server, api, model = _start(server_factory, NORTH)
    assert action(api)["points"] == points
    misses = blind_misses(api, model, NORTH)
    assert max(misses) < 60.0, f"blind GoTos after the restart missed by {[round(m) for m in misses]}″"


def test_a_sync_on_the_shared_zwo_port_is_a_point(server_factory: ServerFactory) -> None:
    """INDI and other programs on the shared ZWO port sync with ``:Sr :Sd :CM#``: a point like any other."""
    from alpaca_zwo.config.settings import ZwoPortSettings
    from alpaca_zwo.zwo import wire_values
    from tests.support.zwo_client import ZwoClient

    emulator = EmulatorSettings(speed=SPEED, baud=0, pointing_errors=REALISTIC)
    server = server_factory(make_settings(emulator=emulator, site=NORTH.settings(),
                                          zwo_port=ZwoPortSettings(enabled=True, host="127.0.0.1", port=0)))
    assert server.emulators[0] is not None and server.zwo_port is not None
    model = server.emulators[0].model
    api = Api(server.port)
    api.ok("Connected", Connected=True)
    api.ok("Tracking", Tracking=True)
    slew(api, *_radec(api, NORTH, -2.0, 30.0))
    ra, dec = _true_sky(model)
    zwo = ZwoClient(server.zwo_port.port)
    try:
        assert zwo.ask(f":Sr{wire_values.format_hms(ra)}#") == b"1"
        assert zwo.ask(f":Sd{wire_values.format_dms(dec)}#") == b"1"
        assert zwo.ask(":CM#").endswith(b"#")
    finally:
        zwo.close()
    points = action(api)["points"]
    assert len(points) == 1
    assert points[0]["ra_h"] == pytest.approx(ra, abs=1 / 3600)  # the wire's whole seconds
    assert points[0]["dec_deg"] == pytest.approx(dec, abs=1 / 3600)
