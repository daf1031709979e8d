"""config/settings.py: defaults, TOML round trips, UniqueID persistence, validation messages, horizon profile."""

from __future__ import annotations

import dataclasses
import os
import stat
import sys
import uuid
from pathlib import Path
from typing import Any

import pytest
import tomli_w
import tomllib
from hypothesis import given
from hypothesis import strategies as st

from alpaca_zwo._exceptions import ConfigError
from alpaca_zwo.config import file as config_file
from alpaca_zwo.config import settings as config
from alpaca_zwo.config.file import load_settings, save_settings
from alpaca_zwo.config.settings import (
    DeviceSettings,
    LimitSettings,
    ParkSettings,
    ServerSettings,
    Settings,
    SiteSettings,
    horizon_altitude_at,
    settings_from_dict,
    settings_to_dict,
)


def write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


# --- defaults -----------------------------------------------------------------------------------


def test_defaults_match_the_documented_values() -> None:
    s = Settings()
    assert s.server == ServerSettings(
        host="0.0.0.0",
        port=11111,
        discovery_port=32227,
        mdns=False,
        threads=16,
        max_body_bytes=65536,
        basic_auth_user="",
        basic_auth_password="",
        allow_raw_commands=False,
        location="",
    )
    assert s.devices == (DeviceSettings(name="ZWO AM5", url="", unique_id="", baud=9600, timeout=2.5),)
    assert (s.site.latitude, s.site.longitude, s.site.elevation) == (51.4769, -0.0005, 46.0)
    assert (s.park.mode, s.park.ha_hours, s.park.dec_deg) == ("home", -6.0, 90.0)
    assert s.limits == LimitSettings(
        min_altitude_deg=0.0, horizon=(), meridian_limit_deg=0.0, meridian_track_past=False
    )
    assert (s.safety.moveaxis_watchdog_s, s.safety.on_shutdown, s.safety.guide_max_ms) == (15.0, "stop", 60000)
    assert (s.logging.level, s.logging.file, s.logging.trace_size) == ("INFO", "", 2000)
    # Model and firmware version come from the preset unless set: one default, in alpaca_zwo.zwo.firmware.
    assert (s.emulator.speed, s.emulator.baud, s.emulator.preset, s.emulator.firmware, s.emulator.model) == (
        1.0,
        0,
        "am5-1.9.2",
        "",
        "",
    )


def test_settings_are_frozen_and_changed_with_replace() -> None:
    s = Settings()
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.server.port = 1234  # type: ignore[misc]
    changed = dataclasses.replace(s, server=dataclasses.replace(s.server, port=1234))
    assert changed.server.port == 1234
    assert s.server.port == 11111


def test_sequences_are_stored_as_tuples() -> None:
    s = Settings(devices=[DeviceSettings(name="a"), DeviceSettings(name="b")])
    assert isinstance(s.devices, tuple)
    limits = LimitSettings(horizon=[[270, 5], (90, 10)])
    assert limits.horizon == ((90.0, 10.0), (270.0, 5.0))  # sorted by azimuth
    hash(s)  # immutable all the way down, so usable as a dict key / in sets


def test_default_config_path_is_in_the_user_config_dir() -> None:
    path = config_file.default_config_path()
    assert path.name == "config.toml"
    assert path.parent.name == "alpaca-zwo"
    assert path.parent.parent.name != "alpaca-zwo"  # no vendor/app doubling on Windows


def test_empty_dict_gives_defaults() -> None:
    assert settings_from_dict({}) == Settings()


# --- load / save --------------------------------------------------------------------------------


def test_missing_file_yields_defaults_and_is_created_with_unique_id(tmp_path: Path) -> None:
    path = tmp_path / "sub" / "dir" / "config.toml"
    s = load_settings(path)
    assert path.is_file()
    assert dataclasses.replace(s, devices=(DeviceSettings(),)) == Settings()
    uid = s.devices[0].unique_id
    assert uuid.UUID(uid).version == 4
    on_disk = tomllib.loads(path.read_text(encoding="utf-8"))
    assert on_disk["devices"][0]["unique_id"] == uid


def test_unique_id_is_generated_once_and_stable(tmp_path: Path) -> None:
    path = tmp_path / "config.toml"
    first = load_settings(path).devices[0].unique_id
    mtime = path.stat().st_mtime_ns
    for _ in range(3):
        assert load_settings(path).devices[0].unique_id == first
    assert path.stat().st_mtime_ns == mtime  # nothing to add, so the file is not rewritten


def test_unique_ids_added_to_devices_lacking_them_and_existing_ids_kept(tmp_path: Path) -> None:
    path = write(
        tmp_path / "config.toml",
        '[[devices]]\nname = "Mine"\nunique_id = "keep-me"\n\n[[devices]]\nname = "Second"\n'
        "[server]\nport = 12000\n",
    )
    s = load_settings(path)
    assert s.devices[0].unique_id == "keep-me"
    new_id = s.devices[1].unique_id
    assert new_id and new_id != "keep-me"
    again = load_settings(path)
    assert [d.unique_id for d in again.devices] == ["keep-me", new_id]
    assert again.server.port == 12000  # the rewrite kept the user's values
    assert again.devices[1].name == "Second"


def test_round_trip_of_non_default_settings(tmp_path: Path) -> None:
    path = tmp_path / "config.toml"
    original = Settings(
        server=ServerSettings(
            host="127.0.0.1",
            port=0,
            discovery_port=0,
            mdns=True,
            threads=4,
            max_body_bytes=4096,
            basic_auth_user="obs",
            basic_auth_password="pa:ss wörd",
            allow_raw_commands=True,
            location='Roof "Dome" #2',
        ),
        devices=[
            DeviceSettings(name="AM5 USB", url="/dev/ttyACM0", unique_id="id-1", baud=115200, timeout=0.5),
            DeviceSettings(name="AM3 WiFi", url="socket://10.0.0.1:4030", unique_id="id-2"),
        ],
        site=SiteSettings(latitude=-33.8568, longitude=151.2153, elevation=-12.5),
        park=ParkSettings(mode="custom", ha_hours=3.25, dec_deg=-45.0),
        limits=LimitSettings(
            min_altitude_deg=-5.0,
            horizon=[(350.0, 20.0), (10.0, 12.5)],
            meridian_limit_deg=-7.5,
            meridian_track_past=True,
        ),
        safety=config.SafetySettings(moveaxis_watchdog_s=30.0, on_shutdown="park", guide_max_ms=10000),
        logging=config.LoggingSettings(level="DEBUG", file="/var/log/az.log", trace_size=0),
        emulator=config.EmulatorSettings(speed=50.0, baud=9600, preset="am5n-1.6.3", firmware="1.6.3", model="AM5N"),
    )
    save_settings(original, path)
    assert load_settings(path) == original
    assert settings_from_dict(settings_to_dict(original)) == original


def test_saved_file_is_valid_toml_with_header_and_owner_only_permissions(tmp_path: Path) -> None:
    path = tmp_path / "config.toml"
    save_settings(Settings(devices=[DeviceSettings(unique_id="x")]), path)
    text = path.read_text(encoding="utf-8")
    assert text.startswith("# alpaca-zwo settings.")
    assert tomllib.loads(text)["server"]["port"] == 11111
    if sys.platform != "win32":
        assert stat.S_IMODE(path.stat().st_mode) == 0o600  # may hold the basic-auth password
    assert [p.name for p in tmp_path.iterdir()] == ["config.toml"]  # no temp file left behind


def test_save_replaces_atomically_and_leaves_old_file_on_failure(tmp_path: Path) -> None:
    path = tmp_path / "config.toml"
    save_settings(Settings(devices=[DeviceSettings(unique_id="old")]), path)
    before = path.read_text(encoding="utf-8")
    bad = Settings(server=ServerSettings(port=70000), devices=[DeviceSettings(unique_id="new")])
    with pytest.raises(ConfigError, match=r"server\.port"):
        save_settings(bad, path)
    assert path.read_text(encoding="utf-8") == before


def test_save_into_unwritable_place_is_a_config_error(tmp_path: Path) -> None:
    blocker = write(tmp_path / "not-a-dir", "")
    with pytest.raises(ConfigError) as excinfo:
        save_settings(Settings(), blocker / "config.toml")
    assert str(blocker / "config.toml") in str(excinfo.value)
    assert "cannot write" in str(excinfo.value)


def test_directory_instead_of_file_is_a_config_error(tmp_path: Path) -> None:
    path = tmp_path / "config.toml"
    path.mkdir()
    with pytest.raises(ConfigError, match="cannot read"):
        load_settings(path)


def test_partial_file_keeps_defaults_for_missing_keys(tmp_path: Path) -> None:
    path = write(tmp_path / "c.toml", "[site]\nlatitude = 31\n[limits]\nhorizon = [[90, 10]]\n")
    s = load_settings(path)
    assert s.site.latitude == 31.0 and isinstance(s.site.latitude, float)
    assert s.site.longitude == -0.0005
    assert s.limits.horizon == ((90.0, 10.0),)
    assert s.server == ServerSettings()


def test_case_insensitive_choices_are_stored_canonically(tmp_path: Path) -> None:
    path = write(
        tmp_path / "c.toml",
        '[logging]\nlevel = "debug"\n[emulator]\nmodel = "am7"\n[park]\nmode = "Custom"\n'
        '[safety]\non_shutdown = "PARK"\n',
    )
    s = load_settings(path)
    assert (s.logging.level, s.emulator.model, s.park.mode, s.safety.on_shutdown) == (
        "DEBUG",
        "AM7",
        "custom",
        "park",
    )


def test_utf8_bom_is_accepted(tmp_path: Path) -> None:
    path = tmp_path / "c.toml"
    path.write_bytes(b"\xef\xbb\xbf[server]\nport = 8080\n")
    assert load_settings(path).server.port == 8080


# --- invalid values -----------------------------------------------------------------------------

INVALID: list[tuple[str, str, str]] = [
    # (TOML text, key path expected in the message, fragment of the reason)
    ("[server]\nport = 70000", "server.port", "between 0 and 65535"),
    ("[server]\nport = -1", "server.port", "between 0 and 65535"),
    ('[server]\nport = "11111"', "server.port", "must be an integer"),
    ("[server]\nport = 11111.0", "server.port", "must be an integer"),
    ("[server]\nport = true", "server.port", "must be an integer"),
    ("[server]\ndiscovery_port = 65536", "server.discovery_port", "between 0 and 65535"),
    ('[server]\nmdns = "yes"', "server.mdns", "true or false"),
    ("[server]\nmdns = 1", "server.mdns", "true or false"),
    ("[server]\nthreads = 0", "server.threads", "between 1 and 256"),
    ("[server]\nmax_body_bytes = 10", "server.max_body_bytes", "between"),
    ('[server]\nhost = ""', "server.host", "must not be empty"),
    ('[server]\nhost = "my host"', "server.host", "host name"),
    ("[server]\nlocation = 5", "server.location", "must be a string"),
    ('[server]\nbasic_auth_user = "bob"', "server.basic_auth_password", "set together"),
    ('[server]\nbasic_auth_password = "pw"', "server.basic_auth_password", "set together"),
    (
        '[server]\nbasic_auth_user = "a:b"\nbasic_auth_password = "pw"',
        "server.basic_auth_user",
        "without ':'",
    ),
    ("[site]\nlatitude = 90.5", "site.latitude", "between -90 and 90"),
    ("[site]\nlatitude = -91", "site.latitude", "between -90 and 90"),
    ("[site]\nlatitude = nan", "site.latitude", "finite"),
    ("[site]\nlongitude = 180.01", "site.longitude", "between -180 and 180"),
    ("[site]\nlongitude = -inf", "site.longitude", "finite"),
    ('[site]\nlongitude = "0"', "site.longitude", "must be a number"),
    ("[site]\nelevation = -301", "site.elevation", "between -300 and 10000"),
    ("[site]\nelevation = 10001", "site.elevation", "between -300 and 10000"),
    ('[park]\nmode = "away"', "park.mode", "'home', 'custom'"),
    ("[park]\nmode = 1", "park.mode", "must be one of"),
    ("[park]\nha_hours = 13", "park.ha_hours", "between -12 and 12"),
    ("[park]\ndec_deg = 90.1", "park.dec_deg", "between -90 and 90"),
    ("[limits]\nmin_altitude_deg = -10.5", "limits.min_altitude_deg", "between -10 and 60"),
    ("[limits]\nmin_altitude_deg = 61", "limits.min_altitude_deg", "between -10 and 60"),
    ("[limits]\nmeridian_limit_deg = 16", "limits.meridian_limit_deg", "between -15 and 15"),
    ("[limits]\nmeridian_limit_deg = -15.5", "limits.meridian_limit_deg", "between -15 and 15"),
    ('[limits]\nmeridian_track_past = "no"', "limits.meridian_track_past", "true or false"),
    ("[limits]\nhorizon = 5", "limits.horizon", "array of [azimuth, altitude]"),
    ("[limits]\nhorizon = [[1, 2, 3]]", "limits.horizon", "point 0 must be an [azimuth, altitude] pair"),
    ("[limits]\nhorizon = [[0, 5], [361, 5]]", "limits.horizon", "point 1 azimuth must be between 0 and 360"),
    ("[limits]\nhorizon = [[10, 91]]", "limits.horizon", "point 0 altitude must be between -10 and 90"),
    ('[limits]\nhorizon = [[10, "x"]]', "limits.horizon", "point 0 altitude must be a number"),
    ("[limits]\nhorizon = [[10, 5], [10.0, 6]]", "limits.horizon", "azimuth 10 appears more than once"),
    ('[safety]\non_shutdown = "explode"', "safety.on_shutdown", "'stop', 'park'"),
    ("[safety]\nmoveaxis_watchdog_s = 0", "safety.moveaxis_watchdog_s", "between 1 and 600"),
    ("[safety]\nguide_max_ms = 0", "safety.guide_max_ms", "between 1 and 60000"),
    ('[logging]\nlevel = "LOUD"', "logging.level", "must be one of"),
    ("[logging]\ntrace_size = -1", "logging.trace_size", "between 0 and 1000000"),
    ("[emulator]\nspeed = 0", "emulator.speed", "between 0.01 and 10000"),
    ("[emulator]\nbaud = 300", "emulator.baud", "or 0"),
    ('[emulator]\nfirmware = "v2"', "emulator.firmware", "like '1.9.0'"),
    ('[emulator]\nmodel = "EQ6"', "emulator.model", "'AM3', 'AM5', 'AM5N', 'AM7'"),
    ("[[devices]]\nbaud = 100", "devices[0].baud", "between 1200 and 921600"),
    ("[[devices]]\ntimeout = 0", "devices[0].timeout", "between 0.1 and 60"),
    ('[[devices]]\nname = "  "', "devices[0].name", "must not be empty"),
    ("[[devices]]\nurl = 3", "devices[0].url", "must be a string"),
    ("[[devices]]\n[[devices]]\nname = 7", "devices[1].name", "must be a string"),
    (
        '[[devices]]\nunique_id = "same"\n[[devices]]\nunique_id = "same"',
        "devices[1].unique_id",
        "same as devices[0].unique_id",
    ),
    ("devices = []", "devices", "at least one device"),
    ('devices = "AM5"', "devices", "array of tables"),
    ('server = "fast"', "server", "must be a table"),
    ("devices = [1]", "devices[0]", "must be a table"),
]


@pytest.mark.parametrize(
    ("text", "key", "reason"), INVALID, ids=[case[1] + ":" + case[2] for case in INVALID]
)
def test_invalid_value_names_file_key_and_reason(tmp_path: Path, text: str, key: str, reason: str) -> None:
    path = write(tmp_path / "bad.toml", text + "\n")
    before = path.read_text(encoding="utf-8")
    with pytest.raises(ConfigError) as excinfo:
        load_settings(path)
    message = str(excinfo.value)
    assert message.startswith(f"{path}: {key}: "), message
    assert reason in message
    assert path.read_text(encoding="utf-8") == before  # an invalid file is never "repaired"


@pytest.mark.parametrize(
    ("text", "key", "hint"),
    [
        ("[server]\nprot = 1", "server.prot", "did you mean 'port'?"),
        ("[site]\naltitude = 5", "site.altitude", "did you mean 'latitude'?"),
        ("[site]\nfoo = 5", "site.foo", "allowed: latitude, longitude, elevation"),
        ("[[devices]]\nbaudrate = 9600", "devices[0].baudrate", "did you mean 'baud'?"),
        ("[sever]\nport = 1", "sever", "unknown section (did you mean 'server'?)"),
        ("port = 1", "port", "unknown section"),
    ],
)
def test_unknown_keys_are_rejected_by_name(tmp_path: Path, text: str, key: str, hint: str) -> None:
    path = write(tmp_path / "c.toml", text + "\n")
    with pytest.raises(ConfigError) as excinfo:
        load_settings(path)
    message = str(excinfo.value)
    assert message.startswith(f"{path}: {key}: unknown "), message
    assert hint in message


def test_all_problems_are_reported_together(tmp_path: Path) -> None:
    path = write(
        tmp_path / "c.toml",
        "[server]\nport = 99999\nprot = 1\n[site]\nlatitude = 100\n[[devices]]\nbaud = 1\n",
    )
    with pytest.raises(ConfigError) as excinfo:
        load_settings(path)
    message = str(excinfo.value)
    assert message.startswith(f"{path}: 4 invalid settings:")
    for key in ("server.port", "server.prot", "site.latitude", "devices[0].baud"):
        assert f"\n  {key}: " in message


def test_error_is_not_chained_to_an_internal_exception(tmp_path: Path) -> None:
    path = write(tmp_path / "c.toml", "[server]\nport = 99999\n")
    with pytest.raises(ConfigError) as excinfo:
        load_settings(path)
    assert excinfo.value.__cause__ is None
    assert "Traceback" not in str(excinfo.value)


@pytest.mark.parametrize(
    ("text", "line", "column"),
    [
        ("[server]\nport = \n", 2, 8),
        ("[server]\nport = 1\n[server]\nhost = 'x'\n", 3, 8),
        ('[site]\nlatitude = 51.0\nname = "unterminated\n', 3, 21),
        ("[limits]\nhorizon = [[0, 1],\n", 3, 1),
    ],
)
def test_malformed_toml_reports_file_line_and_column(
    tmp_path: Path, text: str, line: int, column: int
) -> None:
    path = write(tmp_path / "broken.toml", text)
    with pytest.raises(ConfigError) as excinfo:
        load_settings(path)
    message = str(excinfo.value)
    assert message.startswith(f"{path}: line {line}, column {column}: invalid TOML: "), message
    assert excinfo.value.__cause__ is None
    assert path.read_text(encoding="utf-8") == text  # never overwritten


def test_non_utf8_file_is_a_config_error(tmp_path: Path) -> None:
    path = tmp_path / "c.toml"
    path.write_bytes(b'[server]\nlocation = "\xff"\n')
    with pytest.raises(ConfigError, match="not UTF-8"):
        load_settings(path)


def test_validate_settings_catches_values_set_in_code() -> None:
    s = Settings(site=SiteSettings(latitude=123.0))
    with pytest.raises(ConfigError, match=r"^<settings>: site\.latitude: "):
        config.validate_settings(s)
    config.validate_settings(Settings())


@given(
    st.integers(0, 65535),
    st.floats(-90, 90, allow_nan=False),
    st.floats(-180, 180, allow_nan=False),
    st.floats(-15, 15, allow_nan=False),
    st.lists(
        st.tuples(st.floats(0, 360, allow_nan=False), st.floats(-10, 90, allow_nan=False)),
        max_size=6,
        unique_by=lambda p: p[0],
    ),
)
def test_any_valid_settings_survive_a_toml_round_trip(
    port: int, lat: float, lon: float, meridian: float, horizon: list[tuple[float, float]]
) -> None:
    s = Settings(
        server=ServerSettings(port=port),
        site=SiteSettings(latitude=lat, longitude=lon),
        limits=LimitSettings(horizon=horizon, meridian_limit_deg=meridian),
    )
    text = tomli_w.dumps(settings_to_dict(s))
    assert settings_from_dict(tomllib.loads(text)) == s


# --- horizon ------------------------------------------------------------------------------------


def limits(min_alt: float = 0.0, horizon: Any = ()) -> LimitSettings:
    return LimitSettings(min_altitude_deg=min_alt, horizon=horizon)


def test_no_horizon_means_min_altitude_everywhere() -> None:
    for az in (0.0, 90.0, 359.9):
        assert horizon_altitude_at(limits(7.5), az) == 7.5


def test_single_point_horizon_is_constant() -> None:
    lim = limits(0.0, [(123.0, 15.0)])
    for az in (0.0, 123.0, 200.0, 359.0):
        assert horizon_altitude_at(lim, az) == 15.0


def test_horizon_interpolates_linearly_between_points() -> None:
    lim = limits(0.0, [(90.0, 10.0), (180.0, 30.0), (270.0, 20.0)])
    assert horizon_altitude_at(lim, 90.0) == 10.0
    assert horizon_altitude_at(lim, 135.0) == pytest.approx(20.0)
    assert horizon_altitude_at(lim, 180.0) == 30.0
    assert horizon_altitude_at(lim, 247.5) == pytest.approx(22.5)
    assert horizon_altitude_at(lim, 270.0) == 20.0


def test_horizon_wraps_through_north() -> None:
    # 350 -> 10 is a 20-degree segment across north, from 20 to 10 degrees of altitude.
    lim = limits(0.0, [(10.0, 10.0), (180.0, 40.0), (350.0, 20.0)])
    assert horizon_altitude_at(lim, 350.0) == 20.0
    assert horizon_altitude_at(lim, 355.0) == pytest.approx(17.5)
    assert horizon_altitude_at(lim, 0.0) == pytest.approx(15.0)
    assert horizon_altitude_at(lim, 360.0) == pytest.approx(15.0)
    assert horizon_altitude_at(lim, 5.0) == pytest.approx(12.5)
    assert horizon_altitude_at(lim, -5.0) == pytest.approx(17.5)
    assert horizon_altitude_at(lim, 725.0) == pytest.approx(12.5)
    assert horizon_altitude_at(lim, 10.0) == 10.0


def test_horizon_with_points_at_0_and_360() -> None:
    lim = limits(0.0, [(0.0, 10.0), (180.0, 30.0), (360.0, 50.0)])
    assert horizon_altitude_at(lim, 0.0) == 10.0
    assert horizon_altitude_at(lim, 90.0) == pytest.approx(20.0)
    assert horizon_altitude_at(lim, 270.0) == pytest.approx(40.0)
    assert horizon_altitude_at(lim, 359.999) == pytest.approx(50.0, abs=1e-3)


def test_min_altitude_floors_the_horizon() -> None:
    lim = limits(15.0, [(0.0, 10.0), (180.0, 30.0)])
    assert horizon_altitude_at(lim, 0.0) == 15.0  # horizon below the floor
    assert horizon_altitude_at(lim, 90.0) == 20.0  # horizon above it
    assert horizon_altitude_at(limits(5.0, [(0.0, -10.0)]), 42.0) == 5.0


def test_horizon_from_file_is_sorted_before_use(tmp_path: Path) -> None:
    path = write(tmp_path / "c.toml", "[limits]\nhorizon = [[270, 20], [90, 10], [180, 30]]\n")
    lim = load_settings(path).limits
    assert lim.horizon == ((90.0, 10.0), (180.0, 30.0), (270.0, 20.0))
    assert horizon_altitude_at(lim, 135.0) == pytest.approx(20.0)


@given(
    st.lists(
        st.tuples(st.floats(0, 360, allow_nan=False), st.floats(-10, 90, allow_nan=False)),
        min_size=1,
        max_size=8,
        unique_by=lambda p: p[0],
    ),
    st.floats(-10, 60, allow_nan=False),
    st.floats(-720, 720, allow_nan=False),
)
def test_horizon_stays_within_its_points_and_the_floor(
    points: list[tuple[float, float]], floor: float, az: float
) -> None:
    lim = limits(floor, points)
    value = horizon_altitude_at(lim, az)
    lowest = min(alt for _, alt in points)
    highest = max(alt for _, alt in points)
    assert value >= floor
    assert max(floor, lowest) - 1e-9 <= value <= max(floor, highest) + 1e-9
    # periodic in azimuth: one turn later (computed so the float subtraction is exact) is the same
    later = az % 360.0 + 360.0
    assert horizon_altitude_at(lim, later) == horizon_altitude_at(lim, later - 360.0)


def test_environment_is_not_consulted_for_explicit_paths(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # An explicit --config path must be used as given, whatever the platform config dir is.
    monkeypatch.setenv("XDG_CONFIG_HOME", os.fspath(tmp_path / "xdg"))
    path = tmp_path / "explicit.toml"
    load_settings(path)
    assert path.is_file()
    assert not (tmp_path / "xdg").exists()
