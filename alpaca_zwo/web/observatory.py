"""The observatory interlock on the page: ``GET /setup/api/safety`` and ``POST /setup/api/safety/discover``.

The state (the verdict, the SafetyMonitor's and roof's last answers with their age, recent events)
is also in the status feed; this route gives it without a device number. ``discover`` is the only
place the server sends Alpaca discovery: when the user presses *Find devices* (a broadcast on this
machine's IPv4 networks, or one query to the host they typed), never by itself.
"""

from __future__ import annotations

import logging
import re

import falcon

from .context import Resource
from .http import ApiError, api_errors, check_same_origin, only_keys, send

log = logging.getLogger(__name__)

#: A host name or an IPv4/IPv6 address the user may direct the discovery query to.
_HOST = re.compile(r"[A-Za-z0-9.:\-]{1,253}")


class SafetyResource(Resource):
    """``GET /setup/api/safety``: the interlock's verdict and the devices' last answers."""

    def on_get(self, req: falcon.Request, resp: falcon.Response) -> None:
        send(resp, self.web.facade.safety())


class SafetyDiscoverResource(Resource):
    """``POST /setup/api/safety/discover`` ``{"host": ""}``: SafetyMonitors and Domes found by Alpaca discovery."""

    def on_post(self, req: falcon.Request, resp: falcon.Response) -> None:
        check_same_origin(req)
        with api_errors(resp):
            body = self.body(req)
            only_keys(body, {"host"}, "key(s)")
            host = body.get("host", "")
            if not isinstance(host, str) or (host.strip() and not _HOST.fullmatch(host.strip())):
                raise ApiError(400, "host must be empty (broadcast on this machine's networks) or a host name or "
                                    "address, e.g. 192.168.1.30")
            host = host.strip()
            log.info("setup page (%s): Alpaca discovery %s", req.remote_addr, f"of {host}" if host else "(broadcast)")
            try:
                servers = self.web.facade.find_safety_devices(host)
            except OSError as exc:  # e.g. a host name that does not resolve
                raise ApiError(400, f"discovery failed: {exc}") from None
            send(resp, {"servers": servers})
