"""The emulated mount as imperfect as a real one (issue 40 item 1): TPOINT's terms and a repeatable scatter
between the axes and the sky (alpaca_zwo/emulator/imperfection.py, docs/pointing-errors.md).

The expectations are written here from TPOINT's table (telescope = sky + Δ, applied raw-to-true at the
axes' mechanical position: sky = axes - Δ(axes)), in TPOINT's own mechanical coordinates read off the
axis angles, so they check the emulator's conventions (pier sides, hemispheres, the mount's frame)
rather than repeat its code. Emulated time moves only through a ManualClock.
"""

from __future__ import annotations

import math
import random
from datetime import datetime, timezone
from pathlib import Path

import pytest

from alpaca_zwo import sky
from alpaca_zwo._exceptions import ConfigError
from alpaca_zwo.config.file import load_settings
from alpaca_zwo.config.settings import EmulatorSettings
from alpaca_zwo.emulator import EmulatorServer, ManualClock, MountModel
from alpaca_zwo.emulator.cli import build_parser
from alpaca_zwo.emulator.control import execute
from alpaca_zwo.emulator.imperfection import Imperfection, NoiseField, equatorial_offset, parse_terms
from alpaca_zwo.zwo.wire_values import MountMode
from tests.conftest import ServerFactory, make_settings

START = datetime(2025, 3, 20, 22, 0, tzinfo=timezone.utc)
REALISTIC = "IH=20,ID=-8,MA=12,ME=-9,CH=5,NP=2,TF=1.5"
ALTAZ = "IA=14,IE=-6,CA=4,NPAE=3,AN=9,AW=-7,TF=2"
SITES = {"north": (52.5, 13.4), "sydney": (-33.8688, 151.2093), "equator": (0.0, 36.8)}
MILLIARCSEC_DEG = 0.001 / 3600.0


def tpoint_equatorial(terms: dict[str, float], h: float, d: float, lat: float) -> tuple[float, float]:
    """TPOINT's (Δh, Δδ) in degrees at the mechanical (h, δ) in degrees: the table in the module docstring."""
    t = {name: terms.get(name, 0.0) / 60.0 for name in ("IH", "ID", "CH", "NP", "MA", "ME", "TF")}
    hr, dr, fr = math.radians(h), math.radians(d), math.radians(lat)
    dh = (-t["IH"] - t["CH"] / math.cos(dr) - t["NP"] * math.tan(dr) - t["MA"] * math.cos(hr) * math.tan(dr)
          + t["ME"] * math.sin(hr) * math.tan(dr) + t["TF"] * math.cos(fr) * math.sin(hr) / math.cos(dr))
    dd = (-t["ID"] + t["MA"] * math.sin(hr) + t["ME"] * math.cos(hr)
          + t["TF"] * (math.cos(fr) * math.cos(hr) * math.sin(dr) - math.sin(fr) * math.cos(dr)))
    return dh, dd


def tpoint_altaz(terms: dict[str, float], az_north: float, e: float) -> tuple[float, float]:
    """TPOINT's (ΔA, ΔE) in degrees, A = 180° - azimuth (zero south, 90° east)."""
    t = {name: terms.get(name, 0.0) / 60.0 for name in ("IA", "IE", "CA", "NPAE", "AN", "AW", "TF")}
    a, er = math.radians(180.0 - az_north), math.radians(e)
    da = (-t["IA"] - t["CA"] / math.cos(er) - t["NPAE"] * math.tan(er) - t["AN"] * math.sin(a) * math.tan(er)
          - t["AW"] * math.cos(a) * math.tan(er))
    de = t["IE"] - t["AN"] * math.cos(a) + t["AW"] * math.sin(a) - t["TF"] * math.cos(er)
    return da, de


def fold(h_deg: float, d_deg: float) -> tuple[float, float]:
    """A mechanical (h, δ) with δ possibly past ±90° brought to (HA hours, Dec)."""
    if d_deg > 90.0 or d_deg < -90.0:
        return sky.wrap_hours_12(h_deg / 15.0 + 12.0), math.copysign(180.0, d_deg) - d_deg
    return sky.wrap_hours_12(h_deg / 15.0), d_deg


def make_model(site: str, errors: str = "", noise: float = 0.0, seed: int = 0,
               mode: MountMode = MountMode.EQUATORIAL) -> tuple[ManualClock, MountModel]:
    clock = ManualClock(START)
    model = MountModel(clock, site=SITES[site], initialized=True, mode=mode,
                       imperfection=Imperfection.of(errors, noise, seed))
    return clock, model


def goto(clock: ManualClock, model: MountModel, ha_h: float, dec: float) -> dict[str, object]:
    """GOTO (HA, Dec) the way a client does (target, :MS#) and let it arrive; the snapshot at rest."""
    lst = model.snapshot()["lst_h"]
    assert model.set_target_ra(sky.ra_from_hour_angle(lst, ha_h)) and model.set_target_dec(dec)
    assert model.goto() == 0
    for _ in range(600):
        clock.advance(1.0)
        if not model.slewing():
            return model.snapshot()
    raise AssertionError("the GOTO did not arrive")


def expected_sky(state: dict[str, object], terms: dict[str, float]) -> tuple[float, float]:
    """(HA hours, Dec) the tube points at, from the axis angles alone and TPOINT's formulas."""
    sign = 1.0 if float(state["latitude"]) >= 0.0 else -1.0  # type: ignore[arg-type]
    h_m, d_m = sign * float(state["primary_deg"]), sign * float(state["secondary_deg"])  # type: ignore[arg-type]
    dh, dd = tpoint_equatorial(terms, h_m, d_m, float(state["latitude"]))  # type: ignore[arg-type]
    return fold(h_m - dh, d_m - dd)


def sky_ha(state: dict[str, object]) -> float:
    return sky.hour_angle(float(state["lst_h"]), float(state["sky_ra_h"]))  # type: ignore[arg-type]


# Pointings (HA hours, Dec toward the site's elevated pole): both sides of the meridian, so both pier sides.
POINTINGS = [(-4.0, 10.0), (-1.5, 60.0), (-0.5, -20.0), (0.7, 35.0), (2.5, 0.0), (5.0, 70.0)]


@pytest.mark.parametrize("site", list(SITES))
def test_sky_is_tpoint_of_the_axes_at_every_site_and_on_both_pier_sides(site: str) -> None:
    clock, model = make_model(site, REALISTIC)
    terms = parse_terms(REALISTIC)
    pole = 1.0 if SITES[site][0] >= 0.0 else -1.0
    sides = set()
    for ha, toward_pole in POINTINGS:
        state = goto(clock, model, ha, pole * toward_pole)
        sides.add(state["side"])
        want_ha, want_dec = expected_sky(state, terms)
        assert abs(sky.wrap_hours_12(sky_ha(state) - want_ha)) * 15.0 < MILLIARCSEC_DEG * 10
        assert abs(float(state["sky_dec_deg"]) - want_dec) < MILLIARCSEC_DEG * 10  # type: ignore[arg-type]
        # The mount's own reading stays what its axes believe (no sync: the raw position itself).
        assert abs(sky.hour_angle(float(state["lst_h"]), float(state["ra_h"])) - float(state["raw_ha_h"])) < 1e-9  # type: ignore[arg-type]
        miss = sky.angular_separation(float(state["ra_h"]), float(state["dec_deg"]),  # type: ignore[arg-type]
                                      float(state["sky_ra_h"]), float(state["sky_dec_deg"]))  # type: ignore[arg-type]
        assert 5.0 / 60.0 < miss < 2.0  # arcminutes of error, really there
    assert sides == {"EAST", "WEST"}


def test_machine_terms_change_sign_across_a_flip_and_the_polar_axis_terms_do_not() -> None:
    """The same sky position pointed at from both sides: ID, CH and NP are properties of the axes and swap
    sign on the sky (TPOINT's mechanical Dec past 90°); MA, ME and TF keep their sky meaning."""
    ha, dec, lat = 0.3, 40.0, 52.5
    for name in ("ID", "CH", "NP"):
        inner = equatorial_offset({name: 10.0}, ha, dec, lat, outer=False)
        outer = equatorial_offset({name: 10.0}, ha, dec, lat, outer=True)
        assert outer == pytest.approx((-inner[0], -inner[1]), abs=1e-12) and max(map(abs, inner)) > 0.0
    for name in ("MA", "ME", "TF"):
        inner = equatorial_offset({name: 10.0}, ha, dec, lat, outer=False)
        assert equatorial_offset({name: 10.0}, ha, dec, lat, outer=True) == pytest.approx(inner, abs=1e-12)
    # IH is an index error of the hour axis: the same on the sky from both sides.
    assert equatorial_offset({"IH": 10.0}, ha, dec, lat, True) == pytest.approx((10.0 / 60.0 / 15.0, 0.0))


def test_signs_are_tpoints_one_term_at_a_time() -> None:
    """sky = axes - Δ(axes): a positive IH puts the tube west of where the axes say (larger HA), a positive
    ID north (TPOINT: Δδ = -ID), a positive ME (polar axis too high) lowers the sky Dec on the meridian, a
    positive MA (polar axis west of the pole) lowers it at HA +6 h (TPOINT: Δδ = +MA sin h, +ME cos h)."""
    lat = 40.0
    assert equatorial_offset({"IH": 6.0}, 1.0, 20.0, lat, False) == pytest.approx((0.1 / 15.0, 0.0))
    assert equatorial_offset({"ID": 6.0}, 1.0, 20.0, lat, False) == pytest.approx((0.0, 0.1))
    assert equatorial_offset({"ME": 6.0}, 0.0, 20.0, lat, False)[1] == pytest.approx(-0.1)
    assert equatorial_offset({"MA": 6.0}, 6.0, 20.0, lat, False)[1] == pytest.approx(-0.1)
    assert equatorial_offset({"CH": 6.0}, 1.0, 60.0, lat, False)[0] == pytest.approx(0.2 / 15.0)  # sec 60° = 2


def test_a_perfect_emulator_reports_the_sky_where_its_axes_point() -> None:
    clock, model = make_model("north")
    for ha, dec in POINTINGS:
        state = goto(clock, model, ha, dec)
        assert state["sky_dec_deg"] == state["raw_dec_deg"]
        assert sky_ha(state) == pytest.approx(float(state["raw_ha_h"]), abs=1e-12)  # type: ignore[arg-type]
        assert float(state["sky_ra_h"]) == pytest.approx(float(state["ra_h"]), abs=1e-12)  # type: ignore[arg-type]
        assert state["pointing_errors"] == {"terms_arcmin": {}, "noise_arcsec": 0.0, "seed": 0}


def test_readings_stay_what_the_axes_believe() -> None:
    """The same commands on a perfect and an imperfect mount: identical readings, different sky."""
    (clock_a, perfect), (clock_b, imperfect) = make_model("sydney"), make_model("sydney", REALISTIC, 5.0)
    for ha, dec in POINTINGS[:3]:
        a, b = goto(clock_a, perfect, ha, -dec), goto(clock_b, imperfect, ha, -dec)
        assert (a["ra_h"], a["dec_deg"], a["primary_deg"], a["secondary_deg"]) == (
            b["ra_h"], b["dec_deg"], b["primary_deg"], b["secondary_deg"])
        assert perfect.position() == imperfect.position()
        assert (a["sky_ra_h"], a["sky_dec_deg"]) != (b["sky_ra_h"], b["sky_dec_deg"])


def test_noise_is_repeatable_smooth_and_of_the_stated_rms() -> None:
    field = NoiseField(5.0, seed=7)
    rng = random.Random(1)
    samples = [(rng.uniform(-270.0, 90.0), rng.uniform(-90.0, 270.0)) for _ in range(4000)]
    values = [field.at(p, s) for p, s in samples]
    rms = math.sqrt(sum(x * x + y * y for x, y in values) / len(values))
    assert rms == pytest.approx(5.0, rel=0.08)
    assert values[0] == NoiseField(5.0, seed=7).at(*samples[0])  # same seed, same pointing: same scatter
    assert values[0] != NoiseField(5.0, seed=8).at(*samples[0])
    # A minute of tracking (15″ of the hour axis) moves the scatter by a small fraction of it.
    x0, y0 = field.at(-30.0, 40.0)
    x1, y1 = field.at(-30.0 + 15.0 / 3600.0 * 60.0, 40.0)
    assert math.hypot(x1 - x0, y1 - y0) < 0.5


def test_noise_alone_moves_the_sky_by_the_stated_rms() -> None:
    """On the sky (arcseconds of great circle, whatever the Dec), over pointings all over the sky."""
    noisy = Imperfection.of("", 5.0, 11)
    rng = random.Random(2)
    squares = []
    for _ in range(3000):
        p, s = rng.uniform(-270.0, 90.0), rng.uniform(-90.0, 270.0)
        outer = abs(s) > 90.0
        ha, dec = fold(p, s)
        sky_ha, sky_dec = noisy.equatorial_sky(p, s, ha, dec, 52.5, outer)
        squares.append((sky.angular_separation(-ha, dec, -sky_ha, sky_dec) * 3600.0) ** 2)
    assert math.sqrt(sum(squares) / len(squares)) == pytest.approx(5.0, rel=0.1)


def test_noise_on_the_sky_is_the_same_for_the_same_pointing() -> None:
    (clock_a, a), (clock_b, b) = make_model("north", "", 20.0, 3), make_model("north", "", 20.0, 3)
    misses = []
    for ha, dec in POINTINGS:
        sa, sb = goto(clock_a, a, ha, dec), goto(clock_b, b, ha, dec)
        assert (sa["sky_ra_h"], sa["sky_dec_deg"]) == (sb["sky_ra_h"], sb["sky_dec_deg"])
        misses.append(sky.angular_separation(float(sa["ra_h"]), float(sa["dec_deg"]),  # type: ignore[arg-type]
                                             float(sa["sky_ra_h"]), float(sa["sky_dec_deg"])) * 3600.0)  # type: ignore[arg-type]
    assert 0.0 < max(misses) < 5 * 20.0 and len(set(misses)) == len(misses)


@pytest.mark.parametrize("site", ["north", "sydney"])
def test_altaz_mode_takes_its_own_terms(site: str) -> None:
    clock, model = make_model(site, ALTAZ + ",IH=30", mode=MountMode.ALTAZ)  # IH is an equatorial term: unused here
    terms = parse_terms(ALTAZ)
    pole = 1.0 if SITES[site][0] >= 0.0 else -1.0
    for ha, toward_pole in POINTINGS[:5]:
        state = goto(clock, model, ha, pole * toward_pole)
        p, s = float(state["primary_deg"]), float(state["secondary_deg"])  # type: ignore[arg-type]
        da, de = tpoint_altaz(terms, p, s)
        want_az, want_alt = (p + da) % 360.0, s - de  # A_sky = A - ΔA, A = 180° - azimuth
        assert float(state["sky_alt_deg"]) == pytest.approx(want_alt, abs=1e-6)  # type: ignore[arg-type]
        assert abs((float(state["sky_az_deg"]) - want_az + 180.0) % 360.0 - 180.0) < 1e-6  # type: ignore[arg-type]
        assert abs(float(state["alt_deg"]) - s) < 1e-6  # the reading: the axes' own altitude


def test_control_port_sets_and_reports_the_errors() -> None:
    _clock, model = make_model("north")
    server = EmulatorServer(model, host="127.0.0.1", port=0, baud=0)
    assert execute(server, "pointing-errors IH=20.123456789,MA=-3") == {"ok": True, "command": "pointing-errors"}
    assert execute(server, "pointing-noise 4 9") == {"ok": True, "command": "pointing-noise"}
    assert execute(server, "pointing") == {
        "ok": True, "pointing": {"terms_arcmin": {"IH": 20.123456789, "MA": -3.0}, "noise_arcsec": 4.0, "seed": 9}}
    assert execute(server, "state")["state"]["pointing_errors"]["noise_arcsec"] == 4.0
    assert execute(server, "pointing-errors XX=1")["ok"] is False
    assert execute(server, "pointing-noise -1")["ok"] is False
    assert execute(server, "pointing-noise")["ok"] is False
    assert execute(server, "pointing-errors none")["ok"] is True
    assert model.imperfection.terms == {} and model.imperfection.noise.rms_arcsec == 4.0
    # A power cycle is no repair: the errors are the machine's.
    model.power_cycle()
    assert model.imperfection.noise.rms_arcsec == 4.0


@pytest.mark.parametrize("bad", ["IH=20,IH=3", "XY=1", "IH=", "IH=700", "IH=nan", "IH=20;ID=3"])
def test_bad_terms_are_refused_not_ignored(bad: str) -> None:
    with pytest.raises(ValueError):
        parse_terms(bad)
    with pytest.raises(SystemExit):
        build_parser().parse_args(["--pointing-errors", bad])


def test_command_line_and_settings_carry_the_errors() -> None:
    args = build_parser().parse_args(["--pointing-errors", REALISTIC, "--pointing-noise", "5", "--pointing-seed", "2"])
    assert (parse_terms(args.pointing_errors), args.pointing_noise, args.pointing_seed) == (
        parse_terms(REALISTIC), 5.0, 2)
    with pytest.raises(SystemExit):
        build_parser().parse_args(["--pointing-noise", "-1"])
    settings = EmulatorSettings()
    assert (settings.pointing_errors, settings.pointing_noise, settings.pointing_seed) == ("", 0.0, 0)


@pytest.mark.parametrize(("text", "reason"), [
    ('pointing_errors = "XX=1"', "TPOINT terms"), ('pointing_errors = "IH=1,IH=2"', "each term once"),
    ('pointing_errors = "IH=700"', "beyond"), ("pointing_noise = -1", "between 0 and 3600"),
    ("pointing_seed = -1", "between 0 and")])
def test_bad_pointing_settings_name_the_key(tmp_path: Path, text: str, reason: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(f"[emulator]\n{text}\n", encoding="utf-8")
    with pytest.raises(ConfigError) as excinfo:
        load_settings(path)
    assert f"emulator.{text.split()[0]}: " in str(excinfo.value) and reason in str(excinfo.value)


def test_the_built_in_emulator_takes_the_settings(server_factory: ServerFactory) -> None:
    settings = make_settings(emulator=EmulatorSettings(speed=1.0, baud=0, pointing_errors="MA=12,ME=-9",
                                                        pointing_noise=5.0, pointing_seed=3))
    server = server_factory(settings, setup=False)
    emulator = server.emulators[0]
    assert emulator is not None
    assert emulator.model.imperfection.describe() == {
        "terms_arcmin": {"MA": 12.0, "ME": -9.0}, "noise_arcsec": 5.0, "seed": 3}
