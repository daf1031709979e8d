"""The observatory interlock on the page: ``GET /setup/api/safety``, ``POST /setup/api/safety/discover`` and
``POST /setup/api/safety/test``.

The state (the verdict, the SafetyMonitor's and roof's last answers with their age, recent events)
is also in the status feed; this route gives it without a device number. ``discover`` is the only
place the server sends Alpaca discovery: when the user presses *Find devices* (a broadcast on this
machine's IPv4 networks, or one query to the host they typed), never by itself.
"""

from __future__ import annotations

import logging
import re

import falcon

from ..facade import settings_from_dict, settings_to_dict
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


class SafetyTestResource(Resource):
    """``POST /setup/api/safety/test`` ``{"role": "monitor"|"roof", "url": ...}``: ask that device once, as the
    interlock would, before saving it; the URL is read by the settings' own check (a missing scheme is
    http), and the answer or the failure comes back in words. Nothing is saved or changed."""

    def on_post(self, req: falcon.Request, resp: falcon.Response) -> None:
        check_same_origin(req)
        with api_errors(resp):
            body = self.body(req)
            only_keys(body, {"role", "url"}, "key(s)")
            role, url = body.get("role"), body.get("url")
            if role not in ("monitor", "roof"):
                raise ApiError(400, "role must be monitor or roof")
            if not isinstance(url, str) or not url.strip():
                raise ApiError(400, "type the device's URL first, e.g. 192.168.1.30:11111/api/v1/safetymonitor/0")
            facade = self.web.facade
            data = settings_to_dict(facade.settings)
            data["safety"] = {**data["safety"], role: url}
            url = getattr(settings_from_dict(data, "setup page").safety, role)  # ConfigError: 400 in its words
            log.info("setup page (%s): testing the %s %s", req.remote_addr, role, url)
            send(resp, {"url": url, **facade.test_safety_device(role, url)})
