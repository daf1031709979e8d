"""sky.py against pyerfa (the IAU SOFA library) as the independent oracle, plus the pier-side rules.

pyerfa is given Julian dates built by its own calendar routine, never by ``sky.julian_date``, so a
shared mistake in date handling cannot hide.
"""

from __future__ import annotations

import math
from datetime import datetime, timedelta, timezone

import erfa
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from alpaca_zwo import sky
from alpaca_zwo.sky import PierSide

UTC = timezone.utc
ARCSEC = 1.0 / 3600.0
TT_MINUS_UTC_DAYS = 69.184 / 86400.0

finite = {"allow_nan": False, "allow_infinity": False}
utc_times = st.datetimes(min_value=datetime(1990, 1, 1), max_value=datetime(2060, 12, 31, 23, 59, 59)).map(
    lambda t: t.replace(tzinfo=UTC)
)
latitudes = st.floats(-89.0, 89.0, **finite)
longitudes = st.floats(-180.0, 180.0, **finite)
hour_angles = st.floats(-12.0, 12.0, exclude_max=True, **finite)
declinations = st.floats(-90.0, 90.0, **finite)
limits = st.floats(-15.0, 15.0, **finite)


def erfa_jd(t: datetime) -> tuple[float, float]:
    """Two-part UTC Julian date from erfa's own calendar conversion."""
    t = t.astimezone(UTC)
    jd0, mjd = erfa.cal2jd(t.year, t.month, t.day)
    seconds = t.hour * 3600 + t.minute * 60 + t.second + t.microsecond / 1e6
    return float(jd0), float(mjd) + seconds / 86400.0


def erfa_gmst_hours(t: datetime) -> float:
    ut1, ut2 = erfa_jd(t)
    return math.degrees(erfa.gmst06(ut1, ut2, ut1, ut2 + TT_MINUS_UTC_DAYS)) / 15.0


def time_diff_seconds(h1: float, h2: float) -> float:
    """Difference of two times of day in seconds, across the 0/24 h seam."""
    return abs(sky.wrap_hours_12(h1 - h2)) * 3600.0


def erfa_sep_deg(lon1: float, lat1: float, lon2: float, lat2: float) -> float:
    """Great-circle distance in degrees between two (longitude-like, latitude-like) points, by erfa."""
    return math.degrees(
        erfa.seps(math.radians(lon1), math.radians(lat1), math.radians(lon2), math.radians(lat2))
    )


def sky_distance_arcsec(alt1: float, az1: float, alt2: float, az2: float) -> float:
    """Distance between two Alt/Az positions, immune to the azimuth singularity at the zenith."""
    return erfa_sep_deg(az1, alt1, az2, alt2) * 3600


def sample_times(n: int) -> list[datetime]:
    """Deterministic spread of instants over 1990-2060 with irregular times of day."""
    start = datetime(1990, 1, 1, tzinfo=UTC)
    span = datetime(2060, 12, 31, tzinfo=UTC) - start
    rng = np.random.default_rng(20240601)
    return [start + span * float(f) for f in rng.random(n)]


# --- wrapping -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("value", "expected"),
    [(0.0, 0.0), (24.0, 0.0), (-24.0, 0.0), (25.5, 1.5), (-0.5, 23.5), (47.75, 23.75), (-1e-17, 0.0)],
)
def test_wrap_hours_24_examples(value: float, expected: float) -> None:
    assert sky.wrap_hours_24(value) == pytest.approx(expected, abs=1e-12)


@pytest.mark.parametrize(
    ("value", "expected"),
    [(0.0, 0.0), (12.0, -12.0), (-12.0, -12.0), (11.5, 11.5), (13.0, -11.0), (-13.0, 11.0), (36.0, -12.0)],
)
def test_wrap_hours_12_examples(value: float, expected: float) -> None:
    assert sky.wrap_hours_12(value) == expected


@pytest.mark.parametrize(
    ("value", "expected"), [(0.0, 0.0), (360.0, 0.0), (-90.0, 270.0), (725.0, 5.0), (-1e-15, 0.0)]
)
def test_wrap_degrees_360_examples(value: float, expected: float) -> None:
    assert sky.wrap_degrees_360(value) == pytest.approx(expected, abs=1e-12)


def test_wrap_keeps_tiny_negative_hour_angle_negative() -> None:
    # A rounding "+12 then -12" implementation would turn this into 0.0 and flip the pier side.
    assert sky.wrap_hours_12(-1e-15) == -1e-15


@given(st.floats(-1e6, 1e6, **finite))
def test_wraps_stay_in_range_and_preserve_the_angle(x: float) -> None:
    w24 = sky.wrap_hours_24(x)
    w12 = sky.wrap_hours_12(x)
    w360 = sky.wrap_degrees_360(x)
    assert 0.0 <= w24 < 24.0
    assert -12.0 <= w12 < 12.0
    assert 0.0 <= w360 < 360.0
    # Same angle: the difference is a whole number of turns (up to float noise at this magnitude).
    for wrapped, turn in ((w24, 24.0), (w12, 24.0), (w360, 360.0)):
        k = (x - wrapped) / turn
        assert abs(k - round(k)) < 1e-9


# --- Julian date --------------------------------------------------------------------------------


def test_julian_date_of_j2000_epoch() -> None:
    assert sky.julian_date(datetime(2000, 1, 1, 12, tzinfo=UTC)) == 2451545.0


def test_julian_date_naive_is_utc_and_offsets_are_converted() -> None:
    aware_utc = datetime(2023, 7, 14, 22, 30, tzinfo=UTC)
    naive = datetime(2023, 7, 14, 22, 30)
    beijing = datetime(2023, 7, 15, 6, 30, tzinfo=timezone(timedelta(hours=8)))
    jd = sky.julian_date(aware_utc)
    assert sky.julian_date(naive) == jd
    assert sky.julian_date(beijing) == jd
    assert sky.julian_date(datetime(2023, 7, 14, 22, 30, tzinfo=timezone(timedelta(hours=-5)))) != jd


@pytest.mark.parametrize("t", sample_times(200))
def test_julian_date_matches_erfa(t: datetime) -> None:
    assert sky.julian_date(t) == pytest.approx(sum(erfa_jd(t)), abs=1e-9)  # 1e-9 d = 86 us


# --- sidereal time ------------------------------------------------------------------------------


def test_gmst_matches_erfa_over_1990_2060() -> None:
    times = sample_times(5000) + [datetime(y, 1, 1, tzinfo=UTC) for y in range(1990, 2061)]
    worst = max(time_diff_seconds(sky.greenwich_mean_sidereal_time(t), erfa_gmst_hours(t)) for t in times)
    assert worst < 0.01


@given(utc_times)
def test_gmst_matches_erfa_property(t: datetime) -> None:
    gmst = sky.greenwich_mean_sidereal_time(t)
    assert 0.0 <= gmst < 24.0
    assert time_diff_seconds(gmst, erfa_gmst_hours(t)) < 0.01


def test_gmst_advances_one_sidereal_day_per_solar_day_less_3m56s() -> None:
    t = datetime(2031, 5, 17, 3, 0, tzinfo=UTC)
    gmst = sky.greenwich_mean_sidereal_time
    gain = sky.wrap_hours_24(gmst(t + timedelta(days=1)) - gmst(t))
    assert gain * 3600 == pytest.approx(236.555, abs=0.01)


@given(utc_times, longitudes)
def test_lst_is_gmst_plus_east_longitude(t: datetime, lon: float) -> None:
    expected = sky.wrap_hours_24(erfa_gmst_hours(t) + lon / 15.0)
    assert time_diff_seconds(sky.local_sidereal_time(t, lon), expected) < 0.01


@pytest.mark.parametrize("t", sample_times(40))
@pytest.mark.parametrize("lon", [-180.0, -120.7, -0.0005, 0.0, 13.4, 90.0, 179.999])
def test_lst_matches_erfa_at_sites(t: datetime, lon: float) -> None:
    expected = sky.wrap_hours_24(erfa_gmst_hours(t) + lon / 15.0)
    lst = sky.local_sidereal_time(t, lon)
    assert 0.0 <= lst < 24.0
    assert time_diff_seconds(lst, expected) < 0.01


def test_lst_longitude_is_east_positive() -> None:
    t = datetime(2025, 1, 1, tzinfo=UTC)
    gmst = sky.greenwich_mean_sidereal_time(t)
    assert time_diff_seconds(sky.local_sidereal_time(t, 90.0), gmst + 6.0) < 1e-6
    assert time_diff_seconds(sky.local_sidereal_time(t, -90.0), gmst - 6.0) < 1e-6


# --- hour angle / RA ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("lst", "ra", "ha"),
    [(10.0, 7.0, 3.0), (1.0, 23.0, 2.0), (23.0, 1.0, -2.0), (6.0, 18.0, -12.0), (0.0, 0.0, 0.0)],
)
def test_hour_angle_examples(lst: float, ra: float, ha: float) -> None:
    assert sky.hour_angle(lst, ra) == pytest.approx(ha, abs=1e-12)


@given(st.floats(0, 24, exclude_max=True, **finite), st.floats(0, 24, exclude_max=True, **finite))
def test_hour_angle_and_ra_round_trip(lst: float, ra: float) -> None:
    ha = sky.hour_angle(lst, ra)
    assert -12.0 <= ha < 12.0
    back = sky.ra_from_hour_angle(lst, ha)
    assert 0.0 <= back < 24.0
    assert time_diff_seconds(back, ra) < 1e-6


def test_home_position_ra_is_lst_plus_six_hours() -> None:
    # Field notes: at home (HA -6 h) :GS# 03:31:44 and :GR# 09:31:44.
    lst = 3 + 31 / 60 + 44 / 3600
    assert sky.ra_from_hour_angle(lst, -6.0) == pytest.approx(9 + 31 / 60 + 44 / 3600, abs=1e-12)


# --- equatorial <-> horizontal ------------------------------------------------------------------


def _grid() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    lat, ha, dec = np.meshgrid(
        np.array([-89.0, -75.0, -51.5, -31.95, -10.0, -0.5, 0.0, 0.5, 10.0, 31.26, 51.4769, 75.0, 89.0]),
        np.linspace(-12.0, 12.0, 49)[:-1],
        np.array([-90.0, -89.9, -60.0, -30.0, -1.0, 0.0, 1.0, 30.0, 45.0, 60.0, 89.9, 90.0]),
    )
    return lat.ravel(), ha.ravel(), dec.ravel()


def test_equatorial_to_horizontal_matches_erfa_on_grid() -> None:
    lats, has, decs = _grid()
    e_az, e_alt = erfa.hd2ae(np.radians(has * 15.0), np.radians(decs), np.radians(lats))
    for lat, ha, dec, az_r, alt_r in zip(lats, has, decs, e_az, e_alt, strict=True):
        alt, az = sky.equatorial_to_horizontal(float(ha), float(dec), float(lat))
        exp_alt, exp_az = math.degrees(alt_r), math.degrees(az_r)
        assert 0.0 <= az < 360.0
        assert abs(alt - exp_alt) < 0.1 * ARCSEC
        assert sky_distance_arcsec(alt, az, exp_alt, exp_az) < 0.1
        if abs(exp_alt) < 89.99:  # azimuth is only meaningful away from the zenith/nadir
            az_err = abs(((az - exp_az + 180.0) % 360.0) - 180.0)
            assert az_err * math.cos(math.radians(exp_alt)) < 0.1 * ARCSEC


@given(hour_angles, declinations, latitudes)
def test_equatorial_to_horizontal_matches_erfa_property(ha: float, dec: float, lat: float) -> None:
    alt, az = sky.equatorial_to_horizontal(ha, dec, lat)
    e_az, e_alt = erfa.hd2ae(math.radians(ha * 15.0), math.radians(dec), math.radians(lat))
    assert -90.0 <= alt <= 90.0
    assert 0.0 <= az < 360.0
    assert abs(alt - math.degrees(e_alt)) < 0.1 * ARCSEC
    assert sky_distance_arcsec(alt, az, math.degrees(e_alt), math.degrees(e_az)) < 0.1


@given(st.floats(-90.0, 90.0, **finite), st.floats(0.0, 360.0, exclude_max=True, **finite), latitudes)
def test_horizontal_to_equatorial_matches_erfa_property(alt: float, az: float, lat: float) -> None:
    ha, dec = sky.horizontal_to_equatorial(alt, az, lat)
    e_ha, e_dec = erfa.ae2hd(math.radians(az), math.radians(alt), math.radians(lat))
    assert -12.0 <= ha < 12.0
    assert abs(dec - math.degrees(e_dec)) < 0.1 * ARCSEC
    sep = math.degrees(erfa.seps(math.radians(ha * 15.0), math.radians(dec), e_ha, e_dec)) * 3600
    assert sep < 0.1


def test_horizontal_to_equatorial_matches_erfa_on_grid() -> None:
    lats, _, _ = _grid()
    rng = np.random.default_rng(7)
    alts = rng.uniform(-90.0, 90.0, lats.size)
    azs = rng.uniform(0.0, 360.0, lats.size)
    e_ha, e_dec = erfa.ae2hd(np.radians(azs), np.radians(alts), np.radians(lats))
    for lat, alt, az, ha_r, dec_r in zip(lats, alts, azs, e_ha, e_dec, strict=True):
        ha, dec = sky.horizontal_to_equatorial(float(alt), float(az), float(lat))
        assert abs(dec - math.degrees(dec_r)) < 0.1 * ARCSEC
        if abs(math.degrees(dec_r)) < 89.99:
            assert time_diff_seconds(ha, math.degrees(ha_r) / 15.0) * 15.0 * math.cos(dec_r) < 0.1


@given(hour_angles, declinations, latitudes)
def test_equatorial_horizontal_round_trip(ha: float, dec: float, lat: float) -> None:
    alt, az = sky.equatorial_to_horizontal(ha, dec, lat)
    ha2, dec2 = sky.horizontal_to_equatorial(alt, az, lat)
    assert abs(dec2 - dec) < 0.01 * ARCSEC
    # The hour angle degenerates at the poles; compare positions on the sphere instead.
    assert erfa_sep_deg(ha * 15, dec, ha2 * 15, dec2) * 3600 < 0.01


@pytest.mark.parametrize(
    ("ha", "dec", "lat", "alt", "az"),
    [
        (0.0, 52.0, 52.0, 90.0, None),  # object at the zenith on the meridian
        (0.0, 0.0, 52.0, 38.0, 180.0),  # celestial equator transits due south at 90 - lat
        (-6.0, 0.0, 52.0, 0.0, 90.0),  # equator rises due east
        (6.0, 0.0, 52.0, 0.0, 270.0),  # and sets due west
        (-6.0, 90.0, 31.26, 31.26, 0.0),  # the mount's home: pole at altitude = latitude, north
        (0.0, 0.0, -33.0, 57.0, 0.0),  # southern site: equator transits due north
        (12.0, 0.0, 52.0, -38.0, 0.0),  # lower culmination below the north point
    ],
)
def test_known_horizontal_positions(ha: float, dec: float, lat: float, alt: float, az: float | None) -> None:
    got_alt, got_az = sky.equatorial_to_horizontal(ha, dec, lat)
    assert got_alt == pytest.approx(alt, abs=1e-9)
    if az is not None:
        assert abs(((got_az - az + 180.0) % 360.0) - 180.0) < 1e-9


# --- angular separation -------------------------------------------------------------------------


@given(
    st.floats(0, 24, exclude_max=True, **finite),
    declinations,
    st.floats(0, 24, exclude_max=True, **finite),
    declinations,
)
def test_angular_separation_matches_erfa(ra1: float, dec1: float, ra2: float, dec2: float) -> None:
    expected = erfa_sep_deg(ra1 * 15, dec1, ra2 * 15, dec2)
    got = sky.angular_separation(ra1, dec1, ra2, dec2)
    assert 0.0 <= got <= 180.0
    assert got == pytest.approx(expected, abs=1e-9)


def test_angular_separation_resolves_one_arcsecond_and_antipodes() -> None:
    assert sky.angular_separation(5.0, 20.0, 5.0, 20.0 + ARCSEC) * 3600 == pytest.approx(1.0, rel=1e-6)
    assert sky.angular_separation(0.0, 0.0, 1.0 / 3600 / 15, 0.0) * 3600 == pytest.approx(1.0, rel=1e-6)
    assert sky.angular_separation(2.0, 10.0, 14.0, -10.0) == pytest.approx(180.0, abs=1e-9)
    assert sky.angular_separation(3.0, 90.0, 17.0, 90.0) == pytest.approx(0.0, abs=1e-9)


# --- pier side ----------------------------------------------------------------------------------


def test_pier_side_values_are_ascoms() -> None:
    assert (int(PierSide.EAST), int(PierSide.WEST), int(PierSide.UNKNOWN)) == (0, 1, -1)


@pytest.mark.parametrize(
    ("ha", "side"),
    [
        (0.0, PierSide.EAST),
        (-0.0, PierSide.EAST),
        (-1e-12, PierSide.WEST),
        (-3.0, PierSide.WEST),  # ConformU: pierWest at HA -3
        (-6.0, PierSide.WEST),
        (-9.0, PierSide.WEST),  # ConformU: pierWest at HA -9
        (-12.0, PierSide.WEST),
        (12.0, PierSide.WEST),  # same place as -12
        (3.0, PierSide.EAST),  # ConformU: pierEast at HA +3
        (6.0, PierSide.EAST),
        (9.0, PierSide.EAST),  # ConformU: pierEast at HA +9
        (11.999, PierSide.EAST),
        (24.5, PierSide.EAST),  # wraps to +0.5
        (-23.5, PierSide.EAST),  # wraps to +0.5
        (23.5, PierSide.WEST),  # wraps to -0.5
        (math.nan, PierSide.UNKNOWN),
        (math.inf, PierSide.UNKNOWN),
    ],
)
def test_pointing_state(ha: float, side: PierSide) -> None:
    assert sky.pointing_state(ha) is side


@given(st.floats(-100.0, 100.0, **finite))
def test_pointing_state_follows_sign_of_wrapped_hour_angle(ha: float) -> None:
    expected = PierSide.WEST if sky.wrap_hours_12(ha) < 0 else PierSide.EAST
    assert sky.pointing_state(ha) is expected


@given(hour_angles, st.sampled_from(list(PierSide)))
def test_goto_with_zero_limit_is_the_pointing_state(ha: float, current: PierSide) -> None:
    assert sky.goto_pier_side(ha, current, 0.0) is sky.pointing_state(ha)


@pytest.mark.parametrize(
    ("ha", "limit", "side"),
    [
        # positive limit: the west side may reach up to `limit` past the meridian
        (0.0, 15.0, PierSide.WEST),
        (0.5, 15.0, PierSide.WEST),
        (0.999, 15.0, PierSide.WEST),
        (1.0, 15.0, PierSide.EAST),  # exactly at the limit the mount flips
        (1.001, 15.0, PierSide.EAST),
        (-0.5, 15.0, PierSide.WEST),
        (-6.0, 15.0, PierSide.WEST),
        (6.0, 15.0, PierSide.EAST),
        (-12.0, 15.0, PierSide.WEST),
        (0.25, 7.5, PierSide.WEST),
        (0.5, 7.5, PierSide.EAST),
        # negative limit: the west side must stop `|limit|` before the meridian
        (-1.001, -15.0, PierSide.WEST),
        (-1.0, -15.0, PierSide.EAST),  # exactly at the limit: already flipped
        (-0.5, -15.0, PierSide.EAST),
        (-1e-9, -15.0, PierSide.EAST),
        (0.0, -15.0, PierSide.EAST),
        (6.0, -15.0, PierSide.EAST),
        (-6.0, -15.0, PierSide.WEST),
        (-12.0, -15.0, PierSide.WEST),
        # zero limit: the meridian itself
        (0.0, 0.0, PierSide.EAST),
        (-1e-9, 0.0, PierSide.WEST),
        (-6.0, 0.0, PierSide.WEST),
        (6.0, 0.0, PierSide.EAST),
        (-12.0, 0.0, PierSide.WEST),
        (12.0, 0.0, PierSide.WEST),
        (24.5, 15.0, PierSide.WEST),  # wraps to +0.5, inside the positive-limit zone
    ],
)
@pytest.mark.parametrize("current", list(PierSide))
def test_goto_pier_side_boundaries(ha: float, limit: float, side: PierSide, current: PierSide) -> None:
    assert sky.goto_pier_side(ha, current, limit) is side


@given(hour_angles, limits, st.sampled_from(list(PierSide)))
def test_goto_differs_from_pointing_state_only_between_meridian_and_limit(
    ha: float, limit: float, current: PierSide
) -> None:
    lim_h = limit / 15.0
    side = sky.goto_pier_side(ha, current, limit)
    assert side in (PierSide.EAST, PierSide.WEST)
    if min(0.0, lim_h) <= ha < max(0.0, lim_h):
        assert side is (PierSide.WEST if lim_h > 0 else PierSide.EAST)
    else:
        assert side is sky.pointing_state(ha)


@given(hour_angles, limits)
def test_goto_pier_side_is_independent_of_current_side(ha: float, limit: float) -> None:
    results = {sky.goto_pier_side(ha, current, limit) for current in PierSide}
    assert len(results) == 1


@pytest.mark.parametrize("limit", [-15.0, -7.5, 0.0, 7.5, 15.0])
@pytest.mark.parametrize("current", list(PierSide))
def test_goto_pier_side_satisfies_conformu_destination_checks(limit: float, current: PierSide) -> None:
    # ConformU 7.13: HA +2 and HA -2 must give different, known sides.
    east_of_meridian = sky.goto_pier_side(-2.0, current, limit)
    west_of_meridian = sky.goto_pier_side(2.0, current, limit)
    assert {east_of_meridian, west_of_meridian} == {PierSide.EAST, PierSide.WEST}
    # ConformU 7.17 applies the pointing-state convention to DestinationSideOfPier too.
    assert sky.goto_pier_side(-3.0, current, limit) is PierSide.WEST
    assert sky.goto_pier_side(-9.0, current, limit) is PierSide.WEST
    assert sky.goto_pier_side(3.0, current, limit) is PierSide.EAST
    assert sky.goto_pier_side(9.0, current, limit) is PierSide.EAST


@pytest.mark.parametrize("limit", [15.0001, -15.0001, 90.0, math.nan, math.inf])
def test_goto_pier_side_rejects_limits_outside_the_mount_range(limit: float) -> None:
    with pytest.raises(ValueError, match="meridian limit"):
        sky.goto_pier_side(1.0, PierSide.EAST, limit)


def test_goto_pier_side_unknown_for_non_finite_target() -> None:
    assert sky.goto_pier_side(math.nan, PierSide.EAST, 0.0) is PierSide.UNKNOWN


# --- pier flips (docs/meridian.md) ----------------------------------------------------------------


def _line(limit: int, track_past: bool, at_meridian: bool) -> float:
    """The flip line a mount with this :STa setting uses: A1 (the limit) or A2 (the meridian)."""
    if at_meridian:
        return min(float(limit), 0.0)
    return float(limit) if limit < 0 or track_past else 0.0


@given(st.floats(-12.0, 12.0), st.sampled_from([PierSide.EAST, PierSide.WEST]), st.booleans())
def test_side_limit_lands_the_goto_on_the_side_asked_for(ha: float, side: PierSide, at_meridian: bool) -> None:
    """Under the temporary limit a GOTO lands on the side asked for, under both readings of the
    evidence, also after the target's HA has grown by the margin (slew and landing)."""
    limit = sky.side_limit_deg(ha, side)
    ha_deg = sky.wrap_hours_12(ha) * 15.0
    if limit is None:
        assert (ha_deg < -sky.FLIP_ZONE_DEG) if side is PierSide.EAST else (ha_deg > 13.0 - 1e-9)
        return
    assert -15 <= limit <= 15
    if side is PierSide.WEST and ha_deg >= 0.0 and at_meridian:
        return  # A2 cannot keep pierWest past the meridian: the one case no limit reaches
    line = _line(limit, limit > 0, at_meridian)
    for later in (0.0, sky.FLIP_MARGIN_DEG * 0.99 / 15.0):
        later_deg = sky.wrap_hours_12(ha + later) * 15.0
        if later_deg < ha_deg:
            continue  # the HA wrapped through 12 h (the lower meridian): another question
        if side is PierSide.WEST and (later_deg >= 15.0 or (at_meridian and later_deg >= 0.0)):
            continue  # past what pierWest can reach (15°; A2: the meridian)
        assert sky.goto_pier_side(ha + later, PierSide.UNKNOWN, line) is side, (ha, later, limit, line)


@pytest.mark.parametrize(("ha_deg", "current", "expected"), [
    (0.3, PierSide.EAST, PierSide.EAST),     # just flipped: the next GOTO keeps pierEast
    (0.3, PierSide.WEST, PierSide.WEST),     # the mount's own rule inside "track past 5°"
    (4.9, PierSide.EAST, PierSide.EAST),     # up to the limit
    (-0.3, PierSide.EAST, PierSide.WEST),    # before the meridian: the mount's own choice (a sync there is e9)
    (-10.0, PierSide.EAST, PierSide.WEST),
    (6.0, PierSide.WEST, PierSide.EAST),     # past the limit
    (-30.0, PierSide.EAST, PierSide.WEST),   # ConformU's DestinationSideOfPier at HA -2 h from HA +3 h
])
def test_kept_goto_side_keeps_east_past_the_meridian_up_to_the_limit(
        ha_deg: float, current: PierSide, expected: PierSide) -> None:
    assert sky.kept_goto_side(ha_deg / 15.0, current, 5.0) is expected


@pytest.mark.parametrize(("limit", "track_past", "line"), [
    (-10.0, False, -10.0),  # a negative limit stops tracking before the meridian: the flag does not matter
    (-10.0, True, -10.0),
    (5.0, True, 5.0),  # "track past" up to the limit
    (5.0, False, 0.0),  # no "track past": the mount stops (and flips) at the meridian
    (0.0, False, 0.0),
])
def test_flip_line_deg(limit: float, track_past: bool, line: float) -> None:
    """The one flip-line rule (the page, DestinationSideOfPier, the GOTO side and the emulator use it)."""
    assert sky.flip_line_deg(limit, track_past) == line
