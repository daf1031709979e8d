"""The page's HTTP plumbing: security headers, JSON replies and refusals, same-origin checks, input checks.

The API changes the state of a real telescope from a browser, which may have other tabs open on
hostile sites. State-changing requests are therefore POSTs with a JSON body that must carry a
custom header (a cross-site HTML form can neither send it nor a JSON content type without a CORS
preflight, which this server never grants) and are refused when the browser reports a foreign
``Origin`` or a cross-site ``Sec-Fetch-Site``.
"""

from __future__ import annotations

import contextlib
import json
import math
import re
from collections.abc import Iterator
from datetime import datetime, timezone
from typing import Any
from urllib.parse import urlsplit

import falcon

from .._exceptions import (
    AlpacaError,
    ConfigError,
    InvalidValue,
    LinkError,
    LinkTimeout,
    MountReplyError,
    ProtocolError,
    SettingsNotSaved,
    refusal_error,
)
from ..facade import ClientKey

#: Header every state-changing request must carry; a cross-site form or image cannot add it.
CSRF_HEADER = "X-Alpaca-Zwo"

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


class ApiError(Exception):
    """A refusal the page shows as it is: HTTP status plus a message for a person."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status
        self.message = message


def secure(resp: falcon.Response) -> None:
    resp.set_headers(_SECURITY_HEADERS)


def send(resp: falcon.Response, body: object, status: int = 200) -> None:
    resp.status = status
    resp.content_type = falcon.MEDIA_JSON
    resp.cache_control = ["no-store"]
    secure(resp)
    resp.data = json.dumps(body, allow_nan=False, separators=(",", ":")).encode()


def text_download(resp: falcon.Response, text: str, stem: str) -> None:
    stamp = datetime.now(timezone.utc).strftime("%Y%m%d-%H%M%S")
    resp.content_type = "text/plain; charset=utf-8"
    resp.cache_control = ["no-store"]
    secure(resp)
    resp.set_header("Content-Disposition", f'attachment; filename="{stem}-{stamp}.txt"')
    resp.text = text


def _http_status(exc: AlpacaError) -> int:
    """A bad value is the user's to fix (400); a failed save is the server's storage (507, "Insufficient
    Storage": the disk is full or read-only); anything else is the mount's state (409)."""
    if isinstance(exc, SettingsNotSaved):
        return 507
    return 400 if isinstance(exc, InvalidValue) else 409


@contextlib.contextmanager
def api_errors(resp: falcon.Response) -> Iterator[None]:
    """Turn the failures a control can meet into JSON replies the page can show."""
    try:
        yield
    except ApiError as exc:
        send(resp, {"error": exc.message}, exc.status)
    except AlpacaError as exc:
        send(resp, {"error": plain_words(exc.message), "number": exc.number}, _http_status(exc))
    except ConfigError as exc:
        send(resp, {"error": str(exc)}, 400)
    except MountReplyError as exc:
        refusal = refusal_error("the mount refused", exc)  # the one table's words (_exceptions.MOUNT_REFUSALS)
        send(resp, {"error": plain_words(refusal.message), "number": refusal.number}, 409)
    except (LinkError, ProtocolError) as exc:
        send(resp, {"error": link_trouble(exc)}, 409)
    except ModuleNotFoundError as exc:  # an optional package this install lacks (32-bit ARM: PyEphem)
        send(resp, {"error": missing_package((exc.name or "?").partition(".")[0])}, 503)


#: The Alpaca members the driver's refusals name, in the words of the page's buttons: a person at the
#: page never typed "SlewToCoordinatesAsync" (Alpaca clients still get the member's name).
_PLAIN_WORDS = {
    "SlewToCoordinatesAsync": "a GoTo", "SlewToTargetAsync": "a GoTo", "SlewToAltAzAsync": "a GoTo",
    "SyncToCoordinates": "a sync", "SyncToTarget": "a sync", "SyncToAltAz": "a sync",
    "Tracking=true": "turning tracking on", "SideOfPier": "a meridian flip", "AbortSlew": "stopping",
    "FindHome": "going home", "MoveAxis": "a manual move", "PulseGuide": "a guide pulse",
}
_MEMBER = re.compile("|".join(re.escape(name) for name in _PLAIN_WORDS))


def plain_words(message: str) -> str:
    """A driver message for the page: Alpaca member names put in plain words."""
    return _MEMBER.sub(lambda m: _PLAIN_WORDS[m.group(0)], message)


def link_trouble(exc: LinkError | ProtocolError) -> str:
    """The mount's link failing, in a person's words: the page shows this under a thumb in the dark,
    so no errno or device path (the log and the trace keep those)."""
    if isinstance(exc, LinkTimeout):
        return ("the mount did not answer in time, so this may not have reached it: check its power and "
                "its USB cable or WiFi; alpaca-zwo keeps trying")
    if isinstance(exc, ProtocolError):
        return "the mount's reply was garbled, so this may not have taken effect: try again"
    return ("the mount cannot be reached, so this did not reach it: check its power and its USB cable or "
            "WiFi; alpaca-zwo keeps reconnecting (the log has the details)")


def missing_package(name: str) -> str:
    """What to do when a package the page needs is not installed, in a person's words."""
    return (f"this needs the Python package {name!r}, which is not installed here (PyPI has no 32-bit ARM "
            f"build of it): install it into the server's venv, e.g. '.venv/bin/pip install {name}' "
            "(Raspberry Pi OS takes it from piwheels), then restart alpaca-zwo")


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


class _NumberTooLarge(ValueError):
    pass


#: Digits an integer in a body may have: every real value fits; a 400-digit one cannot become a float.
_MAX_INT_DIGITS = 20


def _bounded_int(text: str) -> int:
    if len(text.lstrip("-")) > _MAX_INT_DIGITS:
        raise _NumberTooLarge(text)
    return int(text)


def read_json(req: falcon.Request, limit: int) -> dict[str, Any]:
    """The request's JSON object body ({} when empty); 413/415/400 for anything else."""
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
        body = json.loads(raw, parse_int=_bounded_int)
        # A "\ud800" escape decodes to a lone surrogate, which no file, log or reply can encode.
        json.dumps(body, ensure_ascii=False).encode("utf-8")
    except _NumberTooLarge:
        raise ApiError(400, "a number in the request body is too large") from None
    except UnicodeEncodeError:
        raise ApiError(400, "the request body holds text that is not valid Unicode (a lone surrogate escape)") from None
    except (UnicodeDecodeError, ValueError) as exc:
        raise ApiError(400, f"the request body is not valid JSON: {exc}") from None
    except RecursionError:  # json's C decoder gives up on ~1000 levels: refuse, as nothing here nests deeply
        raise ApiError(400, "the request body is nested too deeply") from None
    if not isinstance(body, dict):
        raise ApiError(400, "the request body must be a JSON object")
    return body


def query_float(req: falcon.Request, name: str) -> float:
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


# --- checked values from a JSON object --------------------------------------------------------------


def number(body: dict[str, Any], key: str, lo: float | None = None, hi: float | None = None) -> float:
    value = body.get(key)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ApiError(400, f"{key} must be a number")
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise ApiError(400, f"{key} {value} is outside {lo}..{hi}")
    return float(value)


def integer(body: dict[str, Any], key: str, lo: int, hi: int) -> int:
    value = body.get(key)
    if isinstance(value, bool) or not isinstance(value, int):
        raise ApiError(400, f"{key} must be a whole number")
    if not lo <= value <= hi:
        raise ApiError(400, f"{key} {value} is outside {lo}..{hi}")
    return value


def flag(body: dict[str, Any], key: str) -> bool:
    value = body.get(key)
    if not isinstance(value, bool):
        raise ApiError(400, f"{key} must be true or false")
    return value


def obj(value: Any, name: str) -> dict[str, Any]:
    """A settings group, which must be a JSON object."""
    if not isinstance(value, dict):
        raise ApiError(400, f"{name} must be an object")
    return value


def only_keys(group: dict[str, Any], allowed: set[str] | frozenset[str], what: str) -> None:
    unknown = set(group) - set(allowed)
    if unknown:
        raise ApiError(400, f"unknown {what}: {', '.join(sorted(unknown))}")


def iso(t: datetime) -> str:
    return t.astimezone(timezone.utc).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def finite(value: float | None, digits: int = 6) -> float | None:
    return round(value, digits) if value is not None and math.isfinite(value) else None


def page_client(req: falcon.Request) -> ClientKey:
    """The page as a client: its own key, so its connection and MoveAxis are tracked like any client's.

    The address is tagged so the page can never share a key (and so a connection count) with an
    Alpaca client on the same machine.
    """
    return ClientKey(f"{PAGE_TAG}{req.remote_addr}", 0)


#: Prefix of the page's client addresses in the client registry.
PAGE_TAG = "setup page "
