"""Non-200 replies: every one is plain text, as the Alpaca spec requires for 4xx and 5xx.

Falcon would otherwise answer errors in JSON (or XML, by Accept header); an Alpaca client would
then mistake a rejected request for a device reply. ASCOM-level failures are *not* handled here:
they are HTTP 200 with ErrorNumber, rendered by the device API itself.
"""

from __future__ import annotations

import logging
from typing import Any

import falcon

from alpaca_zwo.alpaca.params import BadRequest

log = logging.getLogger("alpaca_zwo.alpaca")
access_log = logging.getLogger("alpaca_zwo.alpaca.access")

TEXT = "text/plain; charset=utf-8"


def _reply(req: falcon.Request, resp: falcon.Response, status: int, text: str) -> None:
    resp.status = status
    resp.content_type = TEXT
    resp.text = text + "\n"
    if access_log.isEnabledFor(logging.DEBUG):
        access_log.debug("%s %s client=%s -> %d %s", req.method, req.path, req.remote_addr, status, text)


def handle_bad_request(req: falcon.Request, resp: falcon.Response, ex: BadRequest, params: Any) -> None:
    """A malformed Alpaca request: 400 with a message naming the offending parameter or path."""
    _reply(req, resp, 400, ex.message)


def handle_http_error(req: falcon.Request, resp: falcon.Response, ex: falcon.HTTPError, params: Any) -> None:
    """Falcon's own rejections (405, 413, 401, bad headers) keep their headers but lose the JSON."""
    if ex.headers:
        resp.set_headers(ex.headers)
    _reply(req, resp, ex.status_code, ex.description or ex.title)


def handle_unexpected(req: falcon.Request, resp: falcon.Response, ex: Exception, params: Any) -> None:
    """A bug: log the traceback, answer 500, and keep serving (waitress threads survive).

    The reply names only the exception's type: its text may hold a file path or other internals,
    which belong in the log, not in a reply any host on the network can read.
    """
    log.error("Unhandled error in %s %s", req.method, req.path, exc_info=ex)
    _reply(req, resp, 500, f"Internal server error ({type(ex).__name__}); the server log has the details")


def unmatched(req: falcon.Request, resp: falcon.Response, **_: Any) -> None:
    """Sink for every path no route claimed.

    Malformed device API paths are 400 (Alpaca reference §2.5.2: wrong case, version, type, ...);
    unknown management paths are 403 as the management spec lists; anything else is a plain 404.
    """
    lowered = req.path.lower()
    if lowered.startswith("/api"):
        raise BadRequest(f"Invalid Alpaca device API path {req.path!r}: expected "
                         "/api/v1/{device_type}/{device_number}/{member}, all lower case")
    if lowered.startswith("/management/v1/"):
        raise falcon.HTTPForbidden(description=f"Unsupported management method {req.path!r}")
    if lowered.startswith("/management"):
        raise BadRequest(f"Invalid Alpaca management path {req.path!r}: expected /management/apiversions "
                         "or /management/v1/{description,configureddevices}")
    raise falcon.HTTPNotFound(description=f"No such page {req.path!r}")
