"""The setup and status web page: ``/setup``, the per-device setup URL, its assets and a JSON API.

N.I.N.A. disables its own setup button while it is connected, and the mount's settings (meridian
flip, altitude limits, heavy-duty mode, buzzer) are otherwise reachable only through the ZWO app,
so this page has to work *alongside* imaging clients: every status read is built from the
snapshots the mount poller already keeps (a page open on a phone must never add serial traffic or
wait behind a GOTO), and every control goes through the same :class:`~alpaca_zwo.telescope.Telescope`
methods the Alpaca API uses, so the safety rules (limits, park state, MoveAxis watchdog) hold for
both.

The API changes the state of a real telescope from a browser, which may have other tabs open on
hostile sites. State-changing requests are therefore POSTs with a JSON body that must carry a
custom header (a cross-site HTML form can neither send it nor a JSON content type without a CORS
preflight, which this server never grants) and are refused when the browser reports a foreign
``Origin`` or a cross-site ``Sec-Fetch-Site``. Static files are served from a list of names that
exist in the package's ``static`` directory, never by joining a client-supplied path.
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import hashlib
import html
import importlib.resources
import itertools
import json
import logging
import math
import mimetypes
import re
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any
from urllib.parse import urlsplit

import falcon

from . import __version__, sky
from ._exceptions import AlpacaError, ConfigError, InvalidValue, LinkError, MountReplyError, ProtocolError
from .clients import ClientKey, current_client
from .config import Settings, horizon_altitude_at, settings_from_dict, settings_to_dict
from .mount import SIDEREAL_DEG_S, MountSettings
from .protocol import MeridianSettings

if TYPE_CHECKING:
    from .server import AlpacaZwoServer
    from .telescope import Telescope

log = logging.getLogger(__name__)

#: Header every state-changing request must carry; a cross-site form or image cannot add it.
CSRF_HEADER = "X-Alpaca-Zwo"
#: Seconds a client stays in the page's client list after its last request.
CLIENT_WINDOW_S = 300.0
#: How many log records the page can show and download.
LOG_LINES = 2000
TRACE_LIMIT = 500
TRACKING_RATE_NAMES = {0: "sidereal", 1: "lunar", 2: "solar"}
#: Manual-move speeds the page offers, as multiples of sidereal (the mount's :R0..:R9 set minus 0.25x).
JOG_MULTIPLES = (0.5, 1.0, 2.0, 4.0, 8.0, 20.0, 60.0, 720.0, 1440.0)
SIDEREAL_HOURS_TO_SOLAR = 86164.0905 / 86400.0

_CONTENT_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".svg": "image/svg+xml",
    ".ico": "image/x-icon",
    ".png": "image/png",
    ".json": "application/json",
}
# No leading dot (no ".." and no hidden files), no separators of any kind, a known extension.
_STATIC_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,99}")

# Inline script and style are not used, so the policy can forbid them: an injected string that
# reached the DOM still could not run. frame-ancestors stops another site framing the Stop button.
_SECURITY_HEADERS = {
    "Content-Security-Policy": (
        "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; connect-src 'self'; "
        "object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'"
    ),
    "X-Content-Type-Options": "nosniff",
    "X-Frame-Options": "DENY",
    "Referrer-Policy": "no-referrer",
}


# --- log buffer ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class LogEntry:
    seq: int
    time: float
    level: str
    logger: str
    message: str


class LogBuffer(logging.Handler):
    """The last records of the ``alpaca_zwo`` logger, for the page's log view and download.

    Users report problems from the field with no shell at hand; a bounded in-memory copy of the
    log (whatever level the server runs at) lets them download it from the page they already have
    open, without the server writing anything it was not configured to write.
    """

    def __init__(self, capacity: int = LOG_LINES) -> None:
        super().__init__(logging.NOTSET)
        self._entries: collections.deque[LogEntry] = collections.deque(maxlen=capacity)
        self._seq = itertools.count(1)
        self.setFormatter(logging.Formatter("%(message)s"))

    def emit(self, record: logging.LogRecord) -> None:
        try:
            message = self.format(record)
        except Exception:  # a bad format string in some log call must not break the caller
            message = str(record.msg)
        self._entries.append(LogEntry(next(self._seq), record.created, record.levelname, record.name, message))

    def entries(self, after: int = 0) -> list[LogEntry]:
        return [e for e in list(self._entries) if e.seq > after]

    def text(self) -> str:
        lines = []
        for e in list(self._entries):
            stamp = datetime.fromtimestamp(e.time, timezone.utc).strftime("%Y-%m-%d %H:%M:%S.%f")[:-3]
            lines.append(f"{stamp}Z {e.level:<7} {e.logger}: {e.message}")
        return "\n".join(lines) + ("\n" if lines else "")


_log_buffer: LogBuffer | None = None
_log_buffer_lock = threading.Lock()


def log_buffer() -> LogBuffer:
    """The process-wide buffer, attached once however many servers a process starts (tests start many)."""
    global _log_buffer
    with _log_buffer_lock:
        if _log_buffer is None:
            _log_buffer = LogBuffer()
            logging.getLogger("alpaca_zwo").addHandler(_log_buffer)
        return _log_buffer


# --- static files -------------------------------------------------------------------------------


def static_dir() -> Path:
    """The page's files: the installed ``alpaca_zwo.static`` package, else ``static/`` beside the source."""
    with contextlib.suppress(ModuleNotFoundError, TypeError, ValueError):
        index = importlib.resources.files("alpaca_zwo.static").joinpath("index.html")
        if isinstance(index, Path) and index.is_file():
            return index.parent.resolve()
    return (Path(__file__).resolve().parent.parent / "static").resolve()


class StaticFiles:
    """``GET /setup/static/{name}``: one file directly inside the static directory, or 404.

    The name is checked against a strict pattern and the resolved file must still sit directly in
    the resolved directory and not be a symlink, so neither ``..`` (plain or percent-encoded), an
    absolute path nor a link planted in the directory can reach anything else.
    """

    def __init__(self, root: Path) -> None:
        self.root = root.resolve()

    def find(self, name: str) -> Path | None:
        if not _STATIC_NAME.fullmatch(name) or Path(name).suffix.lower() not in _CONTENT_TYPES:
            return None
        candidate = self.root / name
        try:
            if candidate.is_symlink() or not candidate.is_file():
                return None
            resolved = candidate.resolve(strict=True)
        except OSError:
            return None
        return resolved if resolved.parent == self.root else None

    def serve(self, req: falcon.Request, resp: falcon.Response, name: str, cache: str) -> None:
        path = self.find(name)
        if path is None:
            raise falcon.HTTPNotFound(description=f"No such file {name!r}")
        data = path.read_bytes()
        etag = '"' + hashlib.sha256(data).hexdigest()[:32] + '"'
        _secure(resp)
        resp.content_type = _CONTENT_TYPES.get(path.suffix.lower()) or mimetypes.guess_type(name)[0] or "text/plain"
        resp.cache_control = [cache]
        resp.set_header("ETag", etag)
        if etag in (req.get_header("If-None-Match") or "").replace(" ", "").split(","):
            resp.status = falcon.HTTP_304
            return
        resp.data = data

    def on_get(self, req: falcon.Request, resp: falcon.Response, name: str) -> None:
        # Revalidate every time: cheap on a LAN, and a server upgrade never mixes old and new files.
        self.serve(req, resp, name, "no-cache")


def _secure(resp: falcon.Response) -> None:
    resp.set_headers(_SECURITY_HEADERS)


# --- the pages ----------------------------------------------------------------------------------


class SetupPage:
    """``GET /setup``: the whole-server page (it shows device 0 and lets the user pick another)."""

    def __init__(self, files: StaticFiles) -> None:
        self._files = files

    def on_get(self, req: falcon.Request, resp: falcon.Response) -> None:
        self._files.serve(req, resp, "index.html", "no-cache")


class DeviceSetupPage:
    """``GET /setup/v1/{device_type}/{device_number}/{page}``: 403 for anything but our telescopes' ``setup``."""

    def __init__(self, server: AlpacaZwoServer, files: StaticFiles) -> None:
        self._server = server
        self._files = files

    def on_get(self, req: falcon.Request, resp: falcon.Response, device_type: str, device_number: str,
               page: str) -> None:
        numbers = [str(i) for i in range(len(self._server.telescopes))]
        if device_type != "telescope" or device_number not in numbers or page != "setup":
            # The Management API documents text/html for this 403, like the page itself.
            message = (f"No setup page for {device_type}/{device_number}/{page}: this server has telescope "
                       f"{', '.join(numbers) or 'none'} (/setup/v1/telescope/N/setup)")
            resp.status = falcon.HTTP_403
            resp.content_type = falcon.MEDIA_HTML
            resp.text = f"<!DOCTYPE html><title>No such device</title><p>{html.escape(message)}</p>"
            return
        self._files.serve(req, resp, "index.html", "no-cache")


# --- the JSON API: plumbing ---------------------------------------------------------------------


class ApiError(Exception):
    """A refusal the page shows as it is: HTTP status plus a message for a person."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status
        self.message = message


def _send(resp: falcon.Response, body: object, status: int = 200) -> None:
    resp.status = status
    resp.content_type = falcon.MEDIA_JSON
    resp.cache_control = ["no-store"]
    _secure(resp)
    resp.data = json.dumps(body, allow_nan=False, separators=(",", ":")).encode()


def _http_status(exc: AlpacaError) -> int:
    """A bad value is the user's to fix (400); anything else is the mount's state (409)."""
    return 400 if isinstance(exc, InvalidValue) else 409


@contextlib.contextmanager
def _api_errors(resp: falcon.Response) -> Iterator[None]:
    """Turn the failures a control can meet into JSON replies the page can show."""
    try:
        yield
    except ApiError as exc:
        _send(resp, {"error": exc.message}, exc.status)
    except AlpacaError as exc:
        _send(resp, {"error": exc.message, "number": exc.number}, _http_status(exc))
    except ConfigError as exc:
        _send(resp, {"error": str(exc)}, 400)
    except MountReplyError as exc:
        _send(resp, {"error": f"the mount refused: {exc.meaning or exc.reply}"}, 409)
    except (LinkError, ProtocolError) as exc:
        _send(resp, {"error": f"mount link problem: {exc}"}, 409)


def _host_of(value: str, scheme: str) -> str:
    """``host:port`` with the default port made explicit, lower case, for comparing origins."""
    parts = urlsplit(f"{scheme}://{value}")
    host = (parts.hostname or "").lower()
    try:
        port = parts.port
    except ValueError:
        return ""
    if port is None:
        port = 443 if scheme == "https" else 80
    if ":" in host:
        host = f"[{host}]"
    return f"{host}:{port}"


def check_same_origin(req: falcon.Request) -> None:
    """Refuse a state-changing request a page from another origin could have caused (403)."""
    if req.get_header(CSRF_HEADER) != "1":
        raise falcon.HTTPForbidden(description=f"Refused: state-changing requests need the {CSRF_HEADER}: 1 header")
    fetch_site = (req.get_header("Sec-Fetch-Site") or "").lower()
    if fetch_site in ("cross-site", "same-site"):
        raise falcon.HTTPForbidden(description=f"Refused: cross-origin request (Sec-Fetch-Site: {fetch_site})")
    origin = req.get_header("Origin")
    if origin is not None:
        parts = urlsplit(origin)
        host = req.get_header("Host") or ""
        if (origin == "null" or parts.scheme not in ("http", "https") or not host
                or _host_of(parts.netloc, parts.scheme) != _host_of(host, req.scheme)):
            raise falcon.HTTPForbidden(description=f"Refused: request from origin {origin!r}, not this server")


def _read_json(req: falcon.Request, limit: int) -> dict[str, Any]:
    length = req.content_length or 0
    if length > limit:
        raise ApiError(413, f"request body of {length} bytes exceeds the {limit} byte limit")
    raw = req.stream.read(length) if length else b""
    if not raw.strip():
        return {}
    media = (req.content_type or "").split(";")[0].strip().lower()
    if media != "application/json":
        raise ApiError(415, f"expected a JSON body (Content-Type: application/json), got {media or 'none'!r}")
    try:
        body = json.loads(raw)
    except (UnicodeDecodeError, ValueError) as exc:
        raise ApiError(400, f"the request body is not valid JSON: {exc}") from None
    if not isinstance(body, dict):
        raise ApiError(400, "the request body must be a JSON object")
    return body


def _number(body: dict[str, Any], key: str, lo: float | None = None, hi: float | None = None) -> float:
    value = body.get(key)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ApiError(400, f"{key} must be a number")
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise ApiError(400, f"{key} {value} is outside {lo}..{hi}")
    return float(value)


def _integer(body: dict[str, Any], key: str, lo: int, hi: int) -> int:
    value = body.get(key)
    if isinstance(value, bool) or not isinstance(value, int):
        raise ApiError(400, f"{key} must be a whole number")
    if not lo <= value <= hi:
        raise ApiError(400, f"{key} {value} is outside {lo}..{hi}")
    return value


def _flag(body: dict[str, Any], key: str) -> bool:
    value = body.get(key)
    if not isinstance(value, bool):
        raise ApiError(400, f"{key} must be true or false")
    return value


def _iso(t: datetime) -> str:
    return t.astimezone(timezone.utc).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def _finite(value: float | None, digits: int = 6) -> float | None:
    return round(value, digits) if value is not None and math.isfinite(value) else None


# --- the JSON API: the device view --------------------------------------------------------------


class Api:
    """Everything behind ``/setup/api``; one instance per server, shared by its route resources."""

    def __init__(self, server: AlpacaZwoServer, logs: LogBuffer) -> None:
        self.server = server
        self.logs = logs
        self._mount_settings: dict[int, MountSettings] = {}
        self._settings_lock = threading.Lock()

    # -- lookups -----------------------------------------------------------------------------

    def telescope(self, number: str) -> tuple[int, Telescope]:
        telescopes = self.server.telescopes
        if number not in [str(i) for i in range(len(telescopes))]:
            raise ApiError(404, f"no telescope {number!r} on this server (it has {len(telescopes)})")
        return int(number), telescopes[int(number)]

    @staticmethod
    def page_client(req: falcon.Request) -> ClientKey:
        """The page as a client: its own key, so its connection and MoveAxis are tracked like any client's.

        The address is tagged so the page can never share a key (and so a connection count)
        with an Alpaca client on the same machine.
        """
        return ClientKey(f"setup page {req.remote_addr}", 0)

    def touch(self, req: falcon.Request) -> ClientKey:
        """Record the page's activity: the MoveAxis watchdog stops a jog once the page goes quiet."""
        key = self.page_client(req)
        self.server.registry.touch(key, req.user_agent or "")
        return key

    # -- status --------------------------------------------------------------------------------

    def status(self, index: int, telescope: Telescope, page_key: ClientKey) -> dict[str, Any]:
        """One coherent picture for the page, from snapshots only: nothing here waits for the mount."""
        settings = self.server.settings
        mount = telescope.mount
        state = mount.state
        running = mount.running
        site = settings.site
        now = telescope.utc_now()
        lst = sky.local_sidereal_time(now, site.longitude)
        connected_keys = _connected_clients(telescope)
        # Snapshot times are on the mount's own clock (the emulator's, when it runs fast).
        mount_now = mount.monotonic()

        position: dict[str, Any] | None = None
        ha: float | None = None
        if state.ra is not None and state.dec is not None:
            ha = sky.hour_angle(lst, state.ra)
            alt, az = sky.equatorial_to_horizontal(ha, state.dec, site.latitude)
            floor = horizon_altitude_at(settings.limits, az)
            position = {"ra": _finite(state.ra, 7), "dec": _finite(state.dec), "ha": _finite(ha), "alt": _finite(alt),
                        "az": _finite(az), "floor": _finite(floor, 3), "below_limit": alt < floor,
                        "age_s": _finite(state.age(mount_now), 3)}

        pier = tracking_rate = target = None
        slewing = at_park = at_home = guiding = False
        if running:
            slewing = _quiet(telescope.slewing, False)
            at_park = _quiet(telescope.at_park, False)
            at_home = _quiet(telescope.at_home, False)
            guiding = _quiet(telescope.is_pulse_guiding, False) or state.is_guiding(mount_now)
            tracking_rate = _quiet(telescope.tracking_rate, None)
            pier_code = _quiet(telescope.side_of_pier, None)
            pier = {0: "east", 1: "west"}.get(pier_code, "unknown") if pier_code is not None else None
            if slewing:
                target = self._target(telescope, lst, site.latitude)
        tracking = bool(state.tracking and state.tracking.on)
        guide_rate = _finite(state.guide_rate, 3)

        link = state.link or mount.link.status
        counters = mount.link.counters
        info = state.info
        flags = state.status
        meridian = self._meridian_view(index, ha, tracking and pier == "west")
        return {
            "device": index,
            "name": telescope.device_name,
            "time": {"utc": _iso(now), "lst": _finite(lst, 7),
                     "offset_s": _finite((now - datetime.now(timezone.utc)).total_seconds(), 3)},
            "connected": running,
            "page_connected": page_key in connected_keys,
            "mount": {"model": info.model, "firmware": info.firmware} if info else None,
            "initialised": state.initialised,
            "link": {
                "state": link.state.value, "url": link.url, "since": link.since, "last_error": link.last_error,
                "reconnects": link.reconnects, "generation": link.generation, "poll_error": state.poll_error,
                "exchanges": counters.exchanges, "timeouts": counters.timeouts, "resyncs": counters.resyncs,
                "bytes_in": counters.bytes_in, "bytes_out": counters.bytes_out,
            },
            "position": position,
            "target": target,
            "pier_side": pier,
            "pier_letter": state.pier,
            "tracking": tracking,
            "tracking_rate": tracking_rate,
            "tracking_rate_name": TRACKING_RATE_NAMES.get(tracking_rate) if tracking_rate is not None else None,
            "tracking_stopped": state.tracking.reason if state.tracking and state.tracking.error else "",
            "slewing": slewing,
            "moving_axes": sorted(state.moving_axes),
            "guiding": guiding,
            "guide_rate": guide_rate,
            "at_park": at_park,
            "at_home": at_home,
            "flags": {
                "low_voltage": bool(flags and flags.low_voltage),
                "ra_stall": bool(flags and flags.ra_stall),
                "dec_stall": bool(flags and flags.dec_stall),
                "mode": flags.mode.name.lower() if flags else None,
            },
            "meridian": meridian,
            "clients": self._clients(connected_keys),
            "sky": self._sky(index, settings, meridian["limit_deg"]),
        }

    @staticmethod
    def _target(telescope: Telescope, lst: float, latitude: float) -> dict[str, Any] | None:
        try:
            ra, dec = telescope.target_right_ascension(), telescope.target_declination()
        except AlpacaError:
            return None
        alt, az = sky.equatorial_to_horizontal(sky.hour_angle(lst, ra), dec, latitude)
        return {"ra": _finite(ra, 7), "dec": _finite(dec), "alt": _finite(alt), "az": _finite(az)}

    def _meridian_view(self, index: int, ha: float | None, counting_down: bool) -> dict[str, Any]:
        """The flip limit in force (the mount's own setting when known) and the time left to reach it."""
        cached = self._mount_settings.get(index)
        if cached is not None and cached.meridian is not None:
            track_after, limit = cached.meridian.track_after, float(cached.meridian.limit_degrees)
        else:
            limits = self.server.settings.limits
            track_after, limit = limits.meridian_track_past, limits.meridian_limit_deg
        # The line the Telescope predicts flips with (DestinationSideOfPier): the meridian itself
        # unless the mount may track past it.
        effective = limit if track_after else 0.0
        minutes = None
        if counting_down and ha is not None:
            # HA grows one sidereal hour per 0.99727 solar hours while tracking.
            minutes = (effective / 15.0 - ha) * 60.0 * SIDEREAL_HOURS_TO_SOLAR
        return {"track_after": track_after, "limit_deg": effective, "minutes_to_limit": _finite(minutes, 1)}

    def _clients(self, connected: frozenset[ClientKey]) -> list[dict[str, Any]]:
        now = time.monotonic()
        rows = []
        for activity in self.server.registry.snapshot(active_within=CLIENT_WINDOW_S, now=now):
            key = activity.key
            page = key.address.startswith("setup page ")
            rows.append({
                "address": key.address.removeprefix("setup page ") if page else key.address,
                "client_id": key.client_id,
                "setup_page": page,
                "connected": key in connected,
                "user_agent": activity.user_agent,
                "requests": activity.requests,
                "idle_s": round(max(0.0, now - activity.last_seen), 1),
            })
        return rows

    def _sky(self, index: int, settings: Settings, limit_deg: float) -> dict[str, Any]:
        """What the all-sky plot draws besides the telescope: the allowed horizon and the flip line."""
        latitude = settings.site.latitude
        floor = [[az, round(horizon_altitude_at(settings.limits, az), 3)] for az in range(0, 360, 3)]
        flip_line: list[list[float]] = []
        if limit_deg:
            for dec10 in range(-900, 901, 25):
                alt, az = sky.equatorial_to_horizontal(limit_deg / 15.0, dec10 / 10.0, latitude)
                if alt > -5.0:
                    flip_line.append([round(az, 3), round(alt, 3)])
        cached = self._mount_settings.get(index)
        mount_limits = None
        if cached is not None and cached.limits_enabled:
            mount_limits = {"lower": cached.lower_limit, "upper": cached.upper_limit}
        pole_alt = abs(latitude)
        return {"latitude": latitude, "floor": floor, "min_altitude": settings.limits.min_altitude_deg,
                "flip_line": flip_line, "pole": [0.0 if latitude >= 0 else 180.0, pole_alt],
                "mount_limits": mount_limits}

    # -- settings --------------------------------------------------------------------------------

    def read_mount_settings(self, index: int, telescope: Telescope) -> MountSettings | None:
        """The settings stored in the mount, read now (a few short queries).

        Without a link the last ones read are returned (None if never read), so the page can still
        show them; the status poll never calls this, only the settings view does.
        """
        if not telescope.mount.running or not telescope.mount.link.status.connected:
            return self._mount_settings.get(index)
        current = telescope.mount.read_settings()
        self._mount_settings[index] = current
        return current

    def settings_view(self, index: int, telescope: Telescope, mount: MountSettings | None) -> dict[str, Any]:
        settings = self.server.settings
        limits = settings.limits
        mount_view = None
        if mount is not None:
            meridian = mount.meridian
            mount_view = {
                "meridian": dataclasses.asdict(meridian) if meridian is not None else None,
                "limits_enabled": mount.limits_enabled, "upper_limit": mount.upper_limit,
                "lower_limit": mount.lower_limit, "heavy_duty": mount.heavy_duty, "buzzer": mount.buzzer,
                "guide_rate": mount.guide_rate,
            }
        return {
            "device": {"name": telescope.device_name, "unique_id": telescope.unique_id,
                       "url": settings.devices[index].url or "(built-in emulator)"},
            "connected": telescope.mount.running,
            "mount": mount_view,
            "site": dataclasses.asdict(settings.site),
            "park": dataclasses.asdict(settings.park),
            "limits": {"min_altitude_deg": limits.min_altitude_deg,
                       "horizon": [list(p) for p in limits.horizon],
                       "meridian_limit_deg": limits.meridian_limit_deg,
                       "meridian_track_past": limits.meridian_track_past},
            "safety": {"moveaxis_watchdog_s": settings.safety.moveaxis_watchdog_s,
                       "on_shutdown": settings.safety.on_shutdown},
        }

    def change_settings(self, index: int, telescope: Telescope, body: dict[str, Any]) -> MountSettings | None:
        """Apply the groups present in ``body``, all or nothing as far as validation can tell.

        Everything is checked before anything is applied, so a typo in one field never leaves the
        mount changed and the file not (or the reverse). The mount goes first because it is the
        one that can still refuse; the file is then written in one atomic update.
        """
        file_groups = {k: body[k] for k in ("site", "park", "limits", "safety", "device") if k in body}
        mount_groups = {k: body[k] for k in ("meridian", "mount_limits", "heavy_duty", "buzzer") if k in body}
        unknown = set(body) - set(file_groups) - set(mount_groups)
        if unknown:
            raise ApiError(400, f"unknown settings group(s): {', '.join(sorted(unknown))}")
        for name, group in file_groups.items():
            if not isinstance(group, dict):
                raise ApiError(400, f"{name} must be an object")
        if mount_groups and not telescope.mount.running:
            raise ApiError(409, "these settings are stored in the mount: connect the mount first")
        commands = self._mount_commands(index, telescope, mount_groups)
        meridian = next((value for name, value in commands if name == "meridian"), None)
        if isinstance(meridian, MeridianSettings):
            # Mirrored in the file, so the setting is known (and shown) while the mount is away.
            file_groups["limits"] = {**file_groups.get("limits", {}), "meridian_limit_deg": meridian.limit_degrees,
                                     "meridian_track_past": meridian.track_after}
        site = _site_values(file_groups.pop("site", {}))
        device = file_groups.pop("device", None)
        if device is not None and set(device) - {"name"}:
            raise ApiError(400, "only the device name can be changed here")

        def change(current: Settings) -> Settings:
            data = settings_to_dict(current)
            for name, group in file_groups.items():
                data[name] = {**data[name], **group}
            if device is not None:
                data["devices"][index] = {**data["devices"][index], **device}
            return settings_from_dict(data, "setup page")

        with self._settings_lock:
            if file_groups or device is not None:
                try:
                    change(self.server.settings)  # dry run: refuse bad values before the mount is touched
                except (TypeError, ValueError) as exc:
                    raise ApiError(400, f"invalid setting: {exc}") from None
            for name, value in commands:
                self._apply_mount(telescope, name, value)
            if file_groups or device is not None:
                self.server.store.update(change)
            if site:
                # Through the Telescope, so the mount gets the new site at once and clients read the same values.
                setters: dict[str, Callable[[float], None]] = {
                    "latitude": telescope.set_site_latitude, "longitude": telescope.set_site_longitude,
                    "elevation": telescope.set_site_elevation}
                for key, value in site.items():
                    setters[key](value)
            return self.read_mount_settings(index, telescope) if mount_groups else self._mount_settings.get(index)

    def _mount_commands(self, index: int, telescope: Telescope, groups: dict[str, Any]) -> list[tuple[str, Any]]:
        """The mount-held settings as checked (name, value) pairs, in the order they are sent."""
        commands: list[tuple[str, Any]] = []
        if "meridian" in groups:
            raw = groups["meridian"]
            if not isinstance(raw, dict):
                raise ApiError(400, "meridian must be an object")
            cached = self._mount_settings.get(index)
            flip = cached.meridian.flip if cached is not None and cached.meridian is not None else False
            commands.append(("meridian", MeridianSettings(flip=flip, track_after=_flag(raw, "track_after"),
                                                          limit_degrees=_integer(raw, "limit_degrees", -15, 15))))
        if "mount_limits" in groups:
            raw = groups["mount_limits"]
            if not isinstance(raw, dict):
                raise ApiError(400, "mount_limits must be an object")
            unknown = set(raw) - {"enabled", "upper", "lower"}
            if unknown:
                raise ApiError(400, f"unknown mount_limits key(s): {', '.join(sorted(unknown))}")
            if "upper" in raw:
                commands.append(("upper_limit", _integer(raw, "upper", 60, 90)))
            if "lower" in raw:
                commands.append(("lower_limit", _integer(raw, "lower", 0, 30)))
            if "enabled" in raw:
                commands.append(("limits_enabled", _flag(raw, "enabled")))
        if "heavy_duty" in groups:
            commands.append(("heavy_duty", _flag(groups, "heavy_duty")))
        if "buzzer" in groups:
            commands.append(("buzzer", _integer(groups, "buzzer", 0, 2)))
        return commands

    @staticmethod
    def _apply_mount(telescope: Telescope, name: str, value: Any) -> None:
        mount = telescope.mount
        setters: dict[str, Callable[[Any], None]] = {
            "meridian": telescope.set_meridian_settings, "upper_limit": mount.set_upper_limit,
            "lower_limit": mount.set_lower_limit, "limits_enabled": mount.set_limits_enabled,
            "heavy_duty": mount.set_heavy_duty, "buzzer": mount.set_buzzer}
        setters[name](value)
        log.info("setup page: mount %s set to %s", name.replace("_", " "), value)

    def server_view(self) -> dict[str, Any]:
        server = self.server
        net = server.settings.server
        return {
            "name": "alpaca-zwo",
            "manufacturer": "alpaca-zwo project",
            "version": __version__,
            "location": net.location,
            "port": server.port,
            "discovery_port": server.discovery.port if server.discovery is not None else None,
            "configured": {"host": net.host, "port": net.port, "discovery_port": net.discovery_port,
                           "mdns": net.mdns},
            "config_file": str(server.store.path) if server.store.path else None,
            "basic_auth": bool(net.basic_auth_user),
            "devices": [{"number": i, "name": t.device_name, "unique_id": t.unique_id}
                        for i, t in enumerate(server.telescopes)],
            "jog_multiples": list(JOG_MULTIPLES),
            "sidereal_deg_s": SIDEREAL_DEG_S,
        }

    def change_server(self, body: dict[str, Any]) -> None:
        allowed = {"host", "port", "discovery_port", "mdns", "location"}
        unknown = set(body) - allowed
        if unknown:
            raise ApiError(400, f"unknown server setting(s): {', '.join(sorted(unknown))}")

        def change(current: Settings) -> Settings:
            data = settings_to_dict(current)
            data["server"] = {**data["server"], **body}
            return settings_from_dict(data, "setup page")

        self.server.store.update(change)
        log.info("setup page: server settings changed (%s); they apply after a restart", ", ".join(sorted(body)))


def _site_values(site: dict[str, Any]) -> dict[str, float]:
    """Checked before anything is saved, so a bad longitude cannot leave a new latitude half-applied."""
    ranges = {"latitude": (-90.0, 90.0), "longitude": (-180.0, 180.0), "elevation": (-300.0, 10000.0)}
    unknown = set(site) - set(ranges)
    if unknown:
        raise ApiError(400, f"unknown site key(s): {', '.join(sorted(unknown))}")
    return {key: _number(site, key, *ranges[key]) for key in ranges if key in site}


def _quiet(getter: Callable[[], Any], default: Any) -> Any:
    """A Telescope property for display: its ASCOM refusal (not connected, no position yet) shows as blank."""
    try:
        return getter()
    except AlpacaError:
        return default


def _connected_clients(telescope: Telescope) -> frozenset[ClientKey]:
    """Who holds the device connected. Read-only view of the Telescope's reference count."""
    return telescope.connected_clients()


# --- the JSON API: routes -----------------------------------------------------------------------


class _Resource:
    def __init__(self, api: Api) -> None:
        self.api = api

    def body(self, req: falcon.Request) -> dict[str, Any]:
        return _read_json(req, self.api.server.settings.server.max_body_bytes)


class ServerResource(_Resource):
    """``/setup/api/server``: who this server is; POST changes the network settings (applied on restart)."""

    def on_get(self, req: falcon.Request, resp: falcon.Response) -> None:
        _send(resp, self.api.server_view())

    def on_post(self, req: falcon.Request, resp: falcon.Response) -> None:
        check_same_origin(req)
        with _api_errors(resp):
            self.api.change_server(self.body(req))
            _send(resp, {**self.api.server_view(), "restart_required": True})


class StatusResource(_Resource):
    """``GET /setup/api/telescope/{number}/status``: polled about once a second by the page."""

    def on_get(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        with _api_errors(resp):
            index, telescope = self.api.telescope(number)
            key = self.api.touch(req)
            _send(resp, self.api.status(index, telescope, key))


class SettingsResource(_Resource):
    """``/setup/api/telescope/{number}/settings``: GET reads (the mount's own settings too), POST changes."""

    def on_get(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        with _api_errors(resp):
            index, telescope = self.api.telescope(number)
            mount = self.api.read_mount_settings(index, telescope)
            _send(resp, self.api.settings_view(index, telescope, mount))

    def on_post(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        check_same_origin(req)
        with _api_errors(resp):
            body = self.body(req)
            index, telescope = self.api.telescope(number)
            self.api.touch(req)
            mount = self.api.change_settings(index, telescope, body)
            log.info("setup page (%s): settings changed: %s", req.remote_addr, ", ".join(sorted(body)) or "nothing")
            _send(resp, self.api.settings_view(index, telescope, mount))


class ActionResource(_Resource):
    """``POST /setup/api/telescope/{number}/action/{name}``: the page's controls, run as the page's client."""

    def on_post(self, req: falcon.Request, resp: falcon.Response, number: str, name: str) -> None:
        check_same_origin(req)
        with _api_errors(resp):
            body = self.body(req)
            _, telescope = self.api.telescope(number)
            handler = ACTIONS.get(name)
            if handler is None:
                raise ApiError(404, f"unknown action {name!r}; actions: {', '.join(sorted(ACTIONS))}")
            key = self.api.touch(req)
            token = current_client.set(key)
            try:
                result = handler(telescope, body)
            finally:
                current_client.reset(token)
            if name != "move" or body.get("rate"):
                log.info("setup page (%s): %s %s", req.remote_addr, name, json.dumps(body) if body else "")
            _send(resp, {"ok": True, **(result or {})})


class TraceResource(_Resource):
    """``GET /setup/api/telescope/{number}/trace[?after=T]``: the recent serial exchanges, oldest first."""

    def on_get(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        with _api_errors(resp):
            _, telescope = self.api.telescope(number)
            after = _query_float(req, "after")
            entries = [e for e in telescope.mount.link.trace() if e.time > after][-TRACE_LIMIT:]
            _send(resp, {"entries": [{"time": e.time, "request": e.request, "reply": e.reply,
                                      "duration_ms": round(e.duration_ms, 2), "note": e.note} for e in entries]})


class TraceText(_Resource):
    """``GET /setup/api/telescope/{number}/trace.txt``: the whole trace buffer as a download."""

    def on_get(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        with _api_errors(resp):
            index, telescope = self.api.telescope(number)
            lines = []
            for e in telescope.mount.link.trace():
                stamp = datetime.fromtimestamp(e.time, timezone.utc).strftime("%H:%M:%S.%f")[:-3]
                reply = "(no reply)" if e.reply is None else e.reply
                lines.append(f"{stamp}Z {e.duration_ms:8.1f} ms  {e.request!s:<16} -> {reply}  {e.note}".rstrip())
            _text_download(resp, "\n".join(lines) + "\n", f"alpaca-zwo-trace-{index}")


class LogResource(_Resource):
    """``GET /setup/api/log[?after=SEQ]``: new log lines since the last call, for the live log view."""

    def on_get(self, req: falcon.Request, resp: falcon.Response) -> None:
        with _api_errors(resp):
            after = int(_query_float(req, "after"))
            entries = self.api.logs.entries(after)[-TRACE_LIMIT:]
            _send(resp, {"entries": [dataclasses.asdict(e) for e in entries]})


class LogText(_Resource):
    """``GET /setup/api/log.txt``: the buffered log as a file, to attach to a bug report."""

    def on_get(self, req: falcon.Request, resp: falcon.Response) -> None:
        _text_download(resp, self.api.logs.text(), "alpaca-zwo-log")


def _query_float(req: falcon.Request, name: str) -> float:
    raw = req.get_param(name)
    if raw is None:
        return 0.0
    try:
        value = float(raw)
    except ValueError:
        raise ApiError(400, f"{name} must be a number") from None
    if not math.isfinite(value):
        raise ApiError(400, f"{name} must be a finite number")
    return value


def _text_download(resp: falcon.Response, text: str, stem: str) -> None:
    stamp = datetime.now(timezone.utc).strftime("%Y%m%d-%H%M%S")
    resp.content_type = "text/plain; charset=utf-8"
    resp.cache_control = ["no-store"]
    _secure(resp)
    resp.set_header("Content-Disposition", f'attachment; filename="{stem}-{stamp}.txt"')
    resp.text = text


# --- the controls -------------------------------------------------------------------------------

Action = Callable[["Telescope", dict[str, Any]], "dict[str, Any] | None"]


def _connect(t: Telescope, body: dict[str, Any]) -> None:
    t.set_connected(True)


def _disconnect(t: Telescope, body: dict[str, Any]) -> None:
    t.set_connected(False)


def _abort(t: Telescope, body: dict[str, Any]) -> None:
    """Stop means stop: also when parked (AbortSlew refuses then), send the mount's stop-all."""
    try:
        t.abort_slew()
    except AlpacaError:
        if not t.mount.running:
            raise
        t.mount.stop()


def _move(t: Telescope, body: dict[str, Any]) -> None:
    axis = _integer(body, "axis", 0, 1)
    t.move_axis(axis, _number(body, "rate", -10.0, 10.0))


def _tracking(t: Telescope, body: dict[str, Any]) -> None:
    t.set_tracking(_flag(body, "on"))


def _tracking_rate(t: Telescope, body: dict[str, Any]) -> None:
    t.set_tracking_rate(_integer(body, "rate", 0, 2))


def _guide_rate(t: Telescope, body: dict[str, Any]) -> None:
    fraction = _number(body, "rate", 0.1, 0.9)
    t.set_guide_rate_right_ascension(fraction * SIDEREAL_DEG_S)


def _set_time(t: Telescope, body: dict[str, Any]) -> dict[str, Any]:
    raw = body.get("utc")
    if not isinstance(raw, str):
        raise ApiError(400, "utc must be an ISO 8601 date and time, e.g. 2025-01-31T21:05:00.000Z")
    try:
        value = datetime.fromisoformat(raw.strip().replace("z", "Z").replace("Z", "+00:00"))
    except ValueError:
        raise ApiError(400, f"utc {raw!r} is not an ISO 8601 date and time") from None
    if value.tzinfo is None:
        raise ApiError(400, "utc must say its zone (end it with Z)")
    t.set_utc_date(value)
    return {"utc": _iso(t.utc_now())}


def _set_park(t: Telescope, body: dict[str, Any]) -> dict[str, Any]:
    t.set_park()
    return {"park": dataclasses.asdict(t.settings.park)}


ACTIONS: dict[str, Action] = {
    "connect": _connect,
    "disconnect": _disconnect,
    "abort": _abort,
    "move": _move,
    "park": lambda t, body: t.park(),
    "unpark": lambda t, body: t.unpark(),
    "find_home": lambda t, body: t.find_home(),
    "set_park": _set_park,
    "tracking": _tracking,
    "tracking_rate": _tracking_rate,
    "guide_rate": _guide_rate,
    "time": _set_time,
}


# --- wiring -------------------------------------------------------------------------------------


def setup_routes(server: AlpacaZwoServer, static_root: Path | None = None) -> list[tuple[str, object]]:
    """The ``(uri_template, resource)`` pairs of the setup page, mounted by the server on its app."""
    files = StaticFiles(static_root or static_dir())
    if files.find("index.html") is None:
        log.error("setup page files not found in %s: /setup will answer 404", files.root)
    api = Api(server, log_buffer())
    return [
        ("/setup", SetupPage(files)),
        ("/setup/v1/{device_type}/{device_number}/{page}", DeviceSetupPage(server, files)),
        ("/setup/static/{name}", files),
        ("/setup/api/server", ServerResource(api)),
        ("/setup/api/log", LogResource(api)),
        ("/setup/api/log.txt", LogText(api)),
        ("/setup/api/telescope/{number}/status", StatusResource(api)),
        ("/setup/api/telescope/{number}/settings", SettingsResource(api)),
        ("/setup/api/telescope/{number}/action/{name}", ActionResource(api)),
        ("/setup/api/telescope/{number}/trace", TraceResource(api)),
        ("/setup/api/telescope/{number}/trace.txt", TraceText(api)),
    ]


__all__ = ["CSRF_HEADER", "LogBuffer", "StaticFiles", "check_same_origin", "log_buffer", "setup_routes", "static_dir"]
