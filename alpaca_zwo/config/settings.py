"""Server settings: immutable dataclasses, validated key by key (``config_file`` reads and writes them).

Settings are frozen so that the threads serving HTTP, the poller and the setup page can share one
object without locks; a change is a new object made with :func:`dataclasses.replace` and published
by whoever owns it. Every key of a file is checked for type and range and unknown keys are refused,
because a typo in a hand-edited file (``prot = 8080``) that silently falls back to a default is
much harder to diagnose than a refusal to start. Problems are reported as one :class:`ConfigError`
naming the file, the key path and the reason, so the CLI can print it without a traceback.
"""

from __future__ import annotations

import bisect
import dataclasses
import difflib
import ipaddress
import itertools
import math
import os
import re
import urllib.parse
import uuid
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

from alpaca_zwo._exceptions import ConfigError
from alpaca_zwo.zwo.firmware import DEFAULT_PRESET, MODELS, PRESETS
from alpaca_zwo.zwo.protocol import Effect, codes_with

__all__ = [
    "LOCAL_NETWORKS",
    "ZWO_PORT_DANGEROUS",
    "DeviceSettings",
    "EmulatorSettings",
    "LimitSettings",
    "LoggingSettings",
    "ParkSettings",
    "SafetySettings",
    "ServerSettings",
    "Settings",
    "SiteSettings",
    "StellariumSettings",
    "TimeSettings",
    "ZwoPortSettings",
    "assign_unique_ids",
    "horizon_altitude_at",
    "settings_from_dict",
    "settings_to_dict",
    "validate_settings",
]

# --- value checks -----------------------------------------------------------------------------------
# Each field carries its check in its metadata, so the dataclass is the single table of keys,
# defaults and allowed values; the parser, the unknown-key check and the docs read it from there.


class _Invalid(Exception):
    """A value failed its check; the message is the reason, the caller adds file and key."""


Check = Callable[[Any], Any]


def _kind(value: Any) -> str:
    """TOML-flavoured name of a value's type, for messages aimed at people editing the file."""
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, int):
        return "an integer"
    if isinstance(value, float):
        return "a float"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, Mapping):
        return "a table"
    if isinstance(value, (list, tuple)):
        return "an array"
    return f"a {type(value).__name__}"


def _int(lo: int, hi: int, *, also: tuple[int, ...] = ()) -> Check:
    def check(value: Any) -> int:
        # bool is an int subclass in Python but a different type in TOML
        if isinstance(value, bool) or not isinstance(value, int):
            raise _Invalid(f"must be an integer, not {_kind(value)}")
        if not (lo <= value <= hi or value in also):
            extra = "".join(f" or {a}" for a in also)
            raise _Invalid(f"must be between {lo} and {hi}{extra}, got {value}")
        return value

    return check


def _float(lo: float, hi: float) -> Check:
    def check(value: Any) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise _Invalid(f"must be a number, not {_kind(value)}")
        number = float(value)
        if not math.isfinite(number):  # TOML allows inf and nan
            raise _Invalid(f"must be a finite number, got {value}")
        if not lo <= number <= hi:
            raise _Invalid(f"must be between {lo:g} and {hi:g}, got {value}")
        return number

    return check


def _bool(value: Any) -> bool:
    if not isinstance(value, bool):
        raise _Invalid(f"must be true or false, not {_kind(value)}")
    return value


def _str(*, nonempty: bool = False, pattern: str | None = None, hint: str = "") -> Check:
    compiled = re.compile(pattern) if pattern else None

    def check(value: Any) -> str:
        if not isinstance(value, str):
            raise _Invalid(f"must be a string, not {_kind(value)}")
        if nonempty and not value.strip():
            raise _Invalid("must not be empty")
        if compiled and value and not compiled.fullmatch(value):
            raise _Invalid(f"must be {hint}, got {value!r}")
        return value

    return check


def _choice(*choices: str) -> Check:
    def check(value: Any) -> str:
        if isinstance(value, str):
            for choice in choices:  # case-insensitive, stored in the canonical spelling
                if value.lower() == choice.lower():
                    return choice
        shown = value if isinstance(value, str) else _kind(value)
        raise _Invalid(f"must be one of {', '.join(repr(c) for c in choices)}, got {shown!r}")

    return check


def _horizon(value: Any) -> tuple[tuple[float, float], ...]:
    """An array of [azimuth, altitude] pairs; sorted by azimuth, duplicates refused."""
    if not isinstance(value, (list, tuple)):
        raise _Invalid(f"must be an array of [azimuth, altitude] pairs, not {_kind(value)}")
    azimuth = _float(0.0, 360.0)
    altitude = _float(-10.0, 90.0)
    points: list[tuple[float, float]] = []
    for i, point in enumerate(value):
        if not isinstance(point, (list, tuple)) or len(point) != 2:
            raise _Invalid(f"point {i} must be an [azimuth, altitude] pair, got {point!r}")
        try:
            az = azimuth(point[0])
        except _Invalid as exc:
            raise _Invalid(f"point {i} azimuth {exc}") from None
        try:
            alt = altitude(point[1])
        except _Invalid as exc:
            raise _Invalid(f"point {i} altitude {exc}") from None
        points.append((az, alt))
    points.sort()
    for (a1, _), (a2, _) in itertools.pairwise(points):
        if a1 == a2:
            raise _Invalid(f"azimuth {a1:g} appears more than once")
    return tuple(points)


def _host_names(value: Any) -> tuple[str, ...]:
    """``server.allowed_hosts``: host names (no scheme, port or spaces), or "*" to allow any."""
    if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
        raise _Invalid(f"must be an array of host names, not {_kind(value)}")
    for name in value:
        if not name or len(name) > 253 or any(c.isspace() or not c.isprintable() for c in name):
            raise _Invalid(f"{name!r} is not a host name (no spaces or control characters, 1 to 253 characters)")
        if "/" in name or "@" in name:
            raise _Invalid(f"{name!r} is not a host name: give the name alone, like 'astropi.example.org'")
        if ":" in name and not _is_ipv6(name):
            raise _Invalid(f"{name!r}: give the name without a port (the port is never checked)")
    return tuple(value)


#: The ``allowed_networks`` entry meaning loopback plus the networks of this machine's own interfaces.
LOCAL_NETWORKS = "local"


def _networks(value: Any) -> tuple[str, ...]:
    """A bridge's ``allowed_networks``: CIDRs or single addresses, and "local"; never empty."""
    if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
        raise _Invalid(f"must be an array of networks such as \"local\" or \"10.8.0.0/24\", not {_kind(value)}")
    if not value:
        raise _Invalid("must list at least one network (\"local\" is the default); to refuse everyone, "
                       "turn the bridge off")
    for entry in value:
        if entry == LOCAL_NETWORKS:
            continue
        try:
            ipaddress.ip_network(entry, strict=False)
        except ValueError:
            raise _Invalid(f"{entry!r} is not a network: give \"local\", an address (192.168.1.7) or "
                           f"a network (192.168.1.0/24, fd00::/64)") from None
    return tuple(value)


def _is_ipv6(name: str) -> bool:
    try:
        ipaddress.IPv6Address(name.removeprefix("[").removesuffix("]").split("%", 1)[0])
    except ValueError:
        return False
    return True


def _host_port(value: Any) -> str:
    """``host:port`` (``[v6]:port`` for an IPv6 address), or empty."""
    text = str(_str()(value)).strip()
    if not text:
        return ""
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or not 1 <= int(port) <= 65535 or any(c.isspace() for c in host):
        raise _Invalid(f"must be host:port, like \"localhost:2947\", got {text!r}")
    return text


def _device_url(device_type: str) -> Check:
    """An Alpaca device's URL, ``http(s)://host[:port]/api/v1/<device_type>/<number>``, or "" (none).

    Stored in the canonical spelling (lower-case scheme and device type, no trailing slash), so the
    page shows what the server will poll. A user name or password in the URL is refused: it would be
    shown on the page and in the log."""
    path = re.compile(rf"/api/v1/{device_type}/(\d{{1,4}})/?", re.IGNORECASE)

    def check(value: Any) -> str:
        if not isinstance(value, str):
            raise _Invalid(f"must be a string, not {_kind(value)}")
        text = value.strip()
        if not text:
            return ""
        example = f"http://192.168.1.30:11111/api/v1/{device_type}/0"
        parts = urllib.parse.urlsplit(text)
        if parts.scheme.lower() not in ("http", "https") or not parts.netloc:
            raise _Invalid(f"must be an http:// or https:// URL of an Alpaca {device_type} such as {example}")
        if parts.username is not None or parts.password is not None:
            raise _Invalid("must not carry a user name or password")
        try:
            host, port = parts.hostname, parts.port
        except ValueError as exc:  # a port that is not a number, or out of range
            raise _Invalid(f"has a bad port: {exc}") from None
        if port == 0:
            raise _Invalid("has port 0; give the device's port, e.g. 11111")
        match = path.fullmatch(parts.path)
        if not host or match is None or parts.query or parts.fragment:
            raise _Invalid(f"must be the URL of an Alpaca {device_type} device, e.g. {example}, got {text!r}")
        shown = f"[{host}]" if ":" in host else host
        authority = shown if port is None else f"{shown}:{port}"
        return f"{parts.scheme.lower()}://{authority}/api/v1/{device_type}/{int(match.group(1))}"

    return check


def _setting(default: Any, check: Check) -> Any:
    """A dataclass field whose metadata carries the check used when loading."""
    return field(default=default, metadata={"check": check})


# --- settings -----------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class ServerSettings:
    """How the HTTP server, discovery and advertisement are exposed on the network."""

    #: The address to listen on: "0.0.0.0" all IPv4 interfaces, "::" all IPv6, or one of this machine's addresses.
    host: str = _setting("0.0.0.0", _str(nonempty=True, pattern=r"\S+", hint="a host name or address"))
    #: The HTTP port of the Alpaca API and the setup page (0 picks a free one).
    port: int = _setting(11111, _int(0, 65535))
    discovery_port: int = _setting(32227, _int(0, 65535))  # 0 = no UDP discovery responder
    #: Advertise the setup page with mDNS (off by default because it multicasts on the network).
    mdns: bool = _setting(False, _bool)
    #: Worker threads answering HTTP requests.
    threads: int = _setting(16, _int(1, 256))
    #: Larger request bodies are refused (413) before they are read.
    max_body_bytes: int = _setting(65536, _int(1024, 16 * 1024 * 1024))
    # Open HTTP connections one remote address may hold; at most half of waitress's 1000 in all, so
    # one address can never fill the server. 0 = no limit.
    max_connections_per_address: int = _setting(64, _int(0, 500))
    #: Set this and basic_auth_password to require HTTP basic auth on the API and the setup page.
    basic_auth_user: str = _setting("", _str(pattern=r"[^:]+", hint="a name without ':'"))
    basic_auth_password: str = _setting("", _str())  # both empty = no authentication
    #: Pass CommandBlind/Bool/String through to the mount; bypasses every safety check.
    allow_raw_commands: bool = _setting(False, _bool)
    #: A free text shown to clients as the device's location (e.g. "back garden").
    location: str = _setting("", _str())
    #: Host names the server answers to besides its own (hosts.py: IP addresses, localhost, the
    #: hostname, <hostname>.local, <hostname>.<domain>); ["*"] answers to any (no DNS-rebinding guard).
    allowed_hosts: tuple[str, ...] = _setting((), _host_names)


@dataclass(frozen=True, kw_only=True)
class DeviceSettings:
    """One mount served as one Alpaca Telescope device; its index is the Alpaca device number."""

    #: The name clients show for this mount.
    name: str = _setting("ZWO AM5", _str(nonempty=True))
    url: str = _setting("", _str())  # pyserial URL or port; empty = the built-in emulator
    unique_id: str = _setting("", _str())  # generated once, then never changes (ASCOM UniqueID)
    #: The serial line rate (the mount's USB port ignores it; 9600 is the mount's own).
    baud: int = _setting(9600, _int(1200, 921600))
    #: Seconds to wait for the mount's reply before the exchange counts as lost.
    timeout: float = _setting(2.5, _float(0.1, 60.0))


@dataclass(frozen=True, kw_only=True)
class SiteSettings:
    """Observing site pushed to the mount; degrees with EAST-positive longitude, metres.

    Defaults to Greenwich rather than 0/0 so that a fresh install has a real mid-latitude sky
    (ConformU skips its pier-side tests within 10 degrees of the equator).
    """

    #: Degrees, north positive; clients (N.I.N.A., KStars) and the setup page write it.
    latitude: float = _setting(51.4769, _float(-90.0, 90.0))
    #: Degrees, EAST positive.
    longitude: float = _setting(-0.0005, _float(-180.0, 180.0))
    #: Metres above sea level.
    elevation: float = _setting(46.0, _float(-300.0, 10000.0))
    #: gpsd's address ("localhost:2947") to take the site from a GPS receiver; empty = off (bridges/gpsd.py).
    gpsd: str = _setting("", _host_port)

    @property
    def is_default(self) -> bool:
        """Still the factory site (Greenwich): nobody has told the server where it is."""
        default = SiteSettings()
        return (self.latitude, self.longitude, self.elevation) == (default.latitude, default.longitude,
                                                                   default.elevation)


@dataclass(frozen=True, kw_only=True)
class ParkSettings:
    """Where Park goes: the mount's home (Dec +90, HA -6 h) or a custom HA/Dec.

    Stored as HA/Dec rather than Alt/Az because that is what stays fixed relative to the mount's
    axes when the site is edited.
    """

    #: "home" parks at the mount's home position; "custom" at ha_hours/dec_deg.
    mode: Literal["home", "custom"] = _setting("home", _choice("home", "custom"))
    #: The custom park position's hour angle (set with SetPark or the setup page).
    ha_hours: float = _setting(-6.0, _float(-12.0, 12.0))
    #: The custom park position's declination.
    dec_deg: float = _setting(90.0, _float(-90.0, 90.0))


@dataclass(frozen=True, kw_only=True)
class LimitSettings:
    """Pointing limits enforced by the server before commands reach the mount.

    ``horizon`` is a list of (azimuth, altitude) points in degrees, interpolated linearly with
    wrap-around at north; it is kept sorted by azimuth whatever order it is given in.
    """

    #: GOTOs below this altitude are refused, and a manual move that reaches it is stopped.
    min_altitude_deg: float = _setting(0.0, _float(-10.0, 60.0))
    #: The local horizon profile: [[azimuth, altitude], ...], linear between the points.
    horizon: tuple[tuple[float, float], ...] = _setting((), _horizon)
    #: How far past the meridian the mount tracks (negative: stops before it); pushed to the mount.
    meridian_limit_deg: float = _setting(0.0, _float(-15.0, 15.0))
    #: Track past the meridian up to meridian_limit_deg instead of stopping at it.
    meridian_track_past: bool = _setting(False, _bool)

    def __post_init__(self) -> None:
        points = tuple(sorted((float(az), float(alt)) for az, alt in self.horizon))
        object.__setattr__(self, "horizon", points)


@dataclass(frozen=True, kw_only=True)
class SafetySettings:
    """Guards against a client that vanishes mid-motion, what to do when the server stops, and the
    observatory interlock: the Alpaca SafetyMonitor (and roof) the mount obeys (docs/guide/observatory.md)."""

    #: Stop a MoveAxis whose client stopped talking for this long.
    moveaxis_watchdog_s: float = _setting(15.0, _float(1.0, 600.0))
    #: What the server does to the mount when it stops: "stop" every motion, or "park" it.
    on_shutdown: Literal["stop", "park"] = _setting("stop", _choice("stop", "park"))
    guide_max_ms: int = _setting(60000, _int(1, 60000))  # the longest PulseGuide accepted (ms)
    #: An Alpaca SafetyMonitor's URL; while it is not safe no motion starts. Empty: no monitor.
    monitor: str = _setting("", _device_url("safetymonitor"))
    #: An Alpaca Dome's URL (a roll-off roof or a dome): its ShutterStatus must read open (0). Empty: none.
    roof: str = _setting("", _device_url("dome"))
    poll_s: float = _setting(5.0, _float(0.1, 600.0))  # how often both are read
    #: No answer (or an error) for this long counts as unsafe; at least poll_s.
    unreachable_s: float = _setting(30.0, _float(0.5, 3600.0))
    #: What the server does when it turns unsafe: park (tracking off), stop (tracking off) or nothing.
    on_unsafe: Literal["park", "stop", "nothing"] = _setting("park", _choice("park", "stop", "nothing"))


@dataclass(frozen=True, kw_only=True)
class LoggingSettings:
    """Log verbosity and destination, and how many mount exchanges the traffic trace keeps."""

    #: The log's verbosity; DEBUG logs every request and every serial exchange.
    level: str = _setting("INFO", _choice("DEBUG", "INFO", "WARNING", "ERROR", "CRITICAL"))
    file: str = _setting("", _str())  # empty = standard error
    #: Serial exchanges kept for the setup page's trace view.
    trace_size: int = _setting(2000, _int(0, 1_000_000))


#: ``[emulator] pointing_errors``: NAME=ARCMINUTES pairs of TPOINT's terms (the emulator checks the values).
_POINTING_TERM = r"(?:NPAE|IH|ID|CH|NP|MA|ME|TF|IA|IE|CA|AN|AW)=[-+]?(?:\d+\.?\d*|\.\d+)"
_POINTING_TERMS = rf"{_POINTING_TERM}(?:,{_POINTING_TERM})*"
_POINTING_MAX_ARCMIN = 600.0  # emulator/imperfection.py's MAX_TERM_ARCMIN (config may not import the emulator)


def _pointing_terms(value: Any) -> str:
    """``[emulator] pointing_errors``: the pattern, each term once, none beyond ±600′ (the emulator's own limits)."""
    text: str = _str(pattern=_POINTING_TERMS, hint="TPOINT terms like 'IH=20,MA=-3.5'")(value)
    pairs = [item.split("=") for item in text.split(",")] if text else []
    names = [name for name, _ in pairs]
    if len(set(names)) != len(names):
        raise _Invalid(f"must name each term once, got {text!r}")
    for name, number in pairs:
        if abs(float(number)) > _POINTING_MAX_ARCMIN:
            raise _Invalid(f"{name}={number} is beyond ±{_POINTING_MAX_ARCMIN:g} arcminutes")
    return text


@dataclass(frozen=True, kw_only=True)
class EmulatorSettings:
    """The built-in mount emulator used by devices whose url is empty."""

    speed: float = _setting(1.0, _float(0.01, 10000.0))  # clock rate relative to real time
    baud: int = _setting(0, _int(1200, 921600, also=(0,)))  # 0 = unpaced, in-process
    #: The firmware build to behave as, by name (``alpaca_zwo.zwo.firmware.PRESETS``: version, model and quirks).
    preset: str = _setting(DEFAULT_PRESET, _choice(*PRESETS))
    #: The version ``:GV#`` reports and the model; empty: the preset's own.
    firmware: str = _setting("", _str(pattern=r"\d+\.\d+\.\d+", hint="like '1.9.0'"))
    #: The model :GVP# reports (AM3, AM5, AM5N, AM7); empty: the preset's.
    model: str = _setting("", _choice("", *MODELS))
    #: The mount mode stored in the emulated mount's flash at start: "eq" (German equatorial) or
    #: "altaz" (as if :AA# had been sent and the mount restarted), to run the whole server in alt-az.
    mode: str = _setting("eq", _choice("eq", "altaz"))
    #: Mechanical errors of the emulated mount (emulator/imperfection.py): TPOINT terms in arcminutes, like
    #: "IH=20,ID=-8,MA=12,ME=-9,CH=5,NP=2,TF=1.5" (alt-az: IA, IE, CA, NPAE, AN, AW, TF); "" = a perfect mount.
    pointing_errors: str = _setting("", _pointing_terms)
    #: Unmodelled scatter of every pointing, RMS arcseconds on the sky (repeatable: seeded by pointing_seed).
    pointing_noise: float = _setting(0.0, _float(0.0, 3600.0))
    #: The seed of pointing_noise's scatter: the same seed gives the same scatter, run after run.
    pointing_seed: int = _setting(0, _int(0, 2**31 - 1))


@dataclass(frozen=True, kw_only=True)
class StellariumSettings:
    """Stellarium's telescope server (its "External software or a remote computer" connection).

    Off by default because it opens a second listening port. ``equinox`` must match the equinox
    chosen for the telescope in Stellarium: J2000 (Stellarium's default) or JNow (the mount's own
    apparent coordinates, sent unconverted). Stellarium connects over IPv4 only.
    """

    #: Serve Stellarium's telescope protocol (also for one run: --stellarium-port).
    enabled: bool = _setting(False, _bool)
    #: The address to listen on (Stellarium connects over IPv4).
    host: str = _setting("0.0.0.0", _str(nonempty=True, pattern=r"\S+", hint="a host name or IPv4 address"))
    port: int = _setting(10001, _int(0, 65535))  # 0 = any free port
    #: Must match the telescope's coordinate system in Stellarium: "J2000" or "JNow".
    equinox: Literal["J2000", "JNow"] = _setting("J2000", _choice("J2000", "JNow"))
    #: Who may connect: "local" (loopback and this machine's own networks) and CIDRs (a VPN, a routed LAN).
    allowed_networks: tuple[str, ...] = _setting((LOCAL_NETWORKS,), _networks)


#: Commands of the shared ZWO port that change the mount for every program (mode, alignment,
#: firmware-stored settings, BLE pairing, clock): refused unless listed in ``zwo_port.allow_dangerous``.
#: Read off the command table (``Effect.GUARDED``).
ZWO_PORT_DANGEROUS = codes_with(Effect.GUARDED)


def _dangerous_codes(value: Any) -> tuple[str, ...]:
    """An array of command codes from ZWO_PORT_DANGEROUS, or ["all"]."""
    if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
        raise _Invalid(f"must be an array of command codes, not {_kind(value)}")
    for code in value:
        if code != "all" and code not in ZWO_PORT_DANGEROUS:
            raise _Invalid(f"{code!r} is not one of the guarded commands ({', '.join(ZWO_PORT_DANGEROUS)}) or 'all'")
    return tuple(value)


@dataclass(frozen=True, kw_only=True)
class ZwoPortSettings:
    """The shared ZWO-protocol TCP port (like the mount's WiFi port 4030) for INDI and other ZWO/LX200 drivers."""

    #: Serve the mount's own ZWO protocol on TCP for INDI (also for one run: --zwo-port).
    enabled: bool = _setting(False, _bool)
    #: The address to listen on.
    host: str = _setting("0.0.0.0", _str(nonempty=True, pattern=r"\S+", hint="a host name or address"))
    #: The TCP port; 4030 is the mount's own WiFi port number.
    port: int = _setting(4030, _int(0, 65535))
    #: Programs connected at once.
    max_clients: int = _setting(16, _int(1, 256))
    #: Guarded command codes allowed anyway (e.g. ["SRl", "STa"]), or ["all"].
    allow_dangerous: tuple[str, ...] = _setting((), _dangerous_codes)
    #: Who may connect: "local" (loopback and this machine's own networks) and CIDRs (a VPN, a routed LAN).
    allowed_networks: tuple[str, ...] = _setting((LOCAL_NETWORKS,), _networks)


@dataclass(frozen=True, kw_only=True)
class TimeSettings:
    """Whose clock is right when the computer's and the mount's disagree (mount/timekeeping.py).

    ``auto``: the computer's when its operating system says it is synchronised (or cannot say), or when
    the mount has no time; otherwise the mount's. ``host``: always the computer's (set into the mount at
    connect). ``mount``: the mount's whenever it has one. A client's UTCDate always wins.
    """

    #: Whose clock is right: "auto", "host" (always set the mount's clock) or "mount" (keep the mount's).
    source: Literal["auto", "host", "mount"] = _setting("auto", _choice("auto", "host", "mount"))


def _default_devices() -> tuple[DeviceSettings, ...]:
    return (DeviceSettings(),)


@dataclass(frozen=True, kw_only=True)
class Settings:
    """Everything the server reads at start-up; ``devices`` is stored as a tuple, any sequence is accepted."""

    server: ServerSettings = field(default_factory=ServerSettings)
    devices: tuple[DeviceSettings, ...] = field(default_factory=_default_devices)
    site: SiteSettings = field(default_factory=SiteSettings)
    park: ParkSettings = field(default_factory=ParkSettings)
    limits: LimitSettings = field(default_factory=LimitSettings)
    safety: SafetySettings = field(default_factory=SafetySettings)
    logging: LoggingSettings = field(default_factory=LoggingSettings)
    emulator: EmulatorSettings = field(default_factory=EmulatorSettings)
    stellarium: StellariumSettings = field(default_factory=StellariumSettings)
    zwo_port: ZwoPortSettings = field(default_factory=ZwoPortSettings)
    time: TimeSettings = field(default_factory=TimeSettings)

    def __post_init__(self) -> None:
        object.__setattr__(self, "devices", tuple(self.devices))


# Table sections in file order; "devices" is an array of tables and handled on its own.
_SECTIONS: dict[str, type] = {
    "server": ServerSettings,
    "site": SiteSettings,
    "park": ParkSettings,
    "limits": LimitSettings,
    "safety": SafetySettings,
    "logging": LoggingSettings,
    "emulator": EmulatorSettings,
    "stellarium": StellariumSettings,
    "zwo_port": ZwoPortSettings,
    "time": TimeSettings,
}
_TOP_LEVEL = ("server", "devices", "site", "park", "limits", "safety", "logging", "emulator", "stellarium",
              "zwo_port", "time")


# --- dict <-> settings --------------------------------------------------------------------------


class _Problems:
    """Collects every problem in a file so the user can fix them all in one edit."""

    def __init__(self) -> None:
        self.items: list[tuple[str, str]] = []

    def add(self, key: str, reason: str) -> None:
        self.items.append((key, reason))

    def raise_if_any(self, source: str) -> None:
        if len(self.items) == 1:
            key, reason = self.items[0]
            raise ConfigError(f"{source}: {key}: {reason}")
        if self.items:
            lines = "".join(f"\n  {key}: {reason}" for key, reason in self.items)
            raise ConfigError(f"{source}: {len(self.items)} invalid settings:{lines}")


def _unknown_key_reason(key: str, allowed: Sequence[str], what: str) -> str:
    close = difflib.get_close_matches(key, allowed, n=1)
    if close:
        return f"unknown {what} (did you mean {close[0]!r}?)"
    return f"unknown {what} (allowed: {', '.join(allowed)})"


def _parse_table(cls: type, raw: Any, path: str, problems: _Problems) -> Any | None:
    """Build one section from its table, or record its problems and return None."""
    if not isinstance(raw, Mapping):
        problems.add(path, f"must be a table, not {_kind(raw)}")
        return None
    checks: dict[str, Check] = {f.name: f.metadata["check"] for f in dataclasses.fields(cls)}
    before = len(problems.items)
    values: dict[str, Any] = {}
    for key, value in raw.items():
        if key not in checks:
            problems.add(f"{path}.{key}", _unknown_key_reason(str(key), list(checks), "key"))
            continue
        try:
            values[key] = checks[key](value)
        except _Invalid as exc:
            problems.add(f"{path}.{key}", str(exc))
    if len(problems.items) > before:
        return None
    section = cls(**values)
    if isinstance(section, SafetySettings) and section.unreachable_s < section.poll_s:
        problems.add(f"{path}.unreachable_s", f"must be at least poll_s ({section.poll_s:g} s): a device counts "
                                              "as unreachable only after it missed a poll")
        return None
    if isinstance(section, ServerSettings) and bool(section.basic_auth_user) != bool(
        section.basic_auth_password
    ):
        problems.add(
            f"{path}.basic_auth_password", "basic_auth_user and basic_auth_password must be set together"
        )
        return None
    return section


def _parse_devices(raw: Any, problems: _Problems) -> tuple[DeviceSettings, ...] | None:
    if not isinstance(raw, (list, tuple)):
        problems.add("devices", f"must be an array of tables ([[devices]]), not {_kind(raw)}")
        return None
    if not raw:
        problems.add("devices", "at least one device is needed")
        return None
    parsed = [_parse_table(DeviceSettings, item, f"devices[{i}]", problems) for i, item in enumerate(raw)]
    devices = [d for d in parsed if d is not None]
    if len(devices) != len(parsed):
        return None
    seen: dict[str, int] = {}
    for i, device in enumerate(devices):
        if device.unique_id and device.unique_id in seen:
            problems.add(f"devices[{i}].unique_id", f"same as devices[{seen[device.unique_id]}].unique_id")
        seen.setdefault(device.unique_id, i)
    return tuple(devices)


def settings_from_dict(data: Mapping[str, Any], source: str | os.PathLike[str] = "<settings>") -> Settings:
    """Validate a TOML-shaped dict into Settings; missing keys take their defaults.

    ``source`` names where the dict came from in error messages (normally the file path).
    Raises ConfigError listing every problem found.
    """
    where = os.fspath(source)
    problems = _Problems()
    if not isinstance(data, Mapping):
        raise ConfigError(f"{where}: the top level must be a table, not {_kind(data)}")
    for key in data:
        if key not in _TOP_LEVEL:
            problems.add(str(key), _unknown_key_reason(str(key), _TOP_LEVEL, "section"))
    kwargs: dict[str, Any] = {}
    for name, cls in _SECTIONS.items():
        if name in data:
            kwargs[name] = _parse_table(cls, data[name], name, problems)
    if "devices" in data:
        kwargs["devices"] = _parse_devices(data["devices"], problems)
    problems.raise_if_any(where)
    return Settings(**kwargs)


def _plain(value: Any) -> Any:
    """Turn tuples into lists and dataclasses into dicts, the shapes tomli_w writes."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def settings_to_dict(settings: Settings) -> dict[str, Any]:
    """The TOML-shaped dict of ``settings``, every key present, in file order."""
    return {name: _plain(getattr(settings, name)) for name in _TOP_LEVEL}


def validate_settings(settings: Settings, source: str | os.PathLike[str] = "<settings>") -> None:
    """Apply the file rules to settings built in code (e.g. with dataclasses.replace); raise ConfigError."""
    settings_from_dict(settings_to_dict(settings), source)


def assign_unique_ids(settings: Settings) -> Settings:
    """Give every device without a UniqueID a fresh uuid4; returns ``settings`` itself if none lacked one."""
    if all(d.unique_id for d in settings.devices):
        return settings
    devices = tuple(
        d if d.unique_id else dataclasses.replace(d, unique_id=str(uuid.uuid4())) for d in settings.devices
    )
    return dataclasses.replace(settings, devices=devices)


# --- horizon ------------------------------------------------------------------------------------


def horizon_altitude_at(limits: LimitSettings, azimuth_deg: float) -> float:
    """Lowest altitude allowed at ``azimuth_deg``: the higher of min_altitude and the horizon profile.

    The profile is linear between points and wraps from the last point round through north to the
    first, so a few points describe a whole horizon; with one point it is a constant.
    """
    floor = limits.min_altitude_deg
    points = limits.horizon
    if not points:
        return floor
    az = math.fmod(azimuth_deg, 360.0)
    if az < 0.0:
        az += 360.0
    azimuths = [p[0] for p in points]
    i = bisect.bisect_right(azimuths, az)
    if i == 0 or i == len(points):
        # Between the last point and the first one, across north.
        (a0, h0), (a1, h1) = points[-1], points[0]
        a1 += 360.0
        if az < a0:
            az += 360.0
    else:
        (a0, h0), (a1, h1) = points[i - 1], points[i]
    span = a1 - a0
    profile = h0 if span <= 0.0 else h0 + (h1 - h0) * (az - a0) / span
    return max(floor, profile)
