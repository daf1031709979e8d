"""The page's satellites (issue 41): keep TLE sets, list their passes, follow one.

``GET /setup/api/telescope/{number}/satellites?hours=`` lists the kept sets with their age (and a warning
when a set is older than a few days) and their passes over the next ``hours`` (default 24) that clear the
limits, each instant in UTC and in the site's zone (``objects.site_zone``, as the object card's rise and
set); and the follow running or last run. ``POST …/satellites`` keeps the sets of ``tle`` (pasted, or an
uploaded file's text) or forgets ``remove`` (a catalogue number); ``POST …/satellites/follow`` follows
``number``'s next pass, or with ``stop: true`` ends the follow. The follow is the Telescope's own
(``DeviceFacade.follow_satellite``), run as the page's own client, so its refusals are the Action's.
"""

from __future__ import annotations

import logging
from datetime import datetime
from typing import Any

import falcon

from ..facade import DeviceFacade, current_client
from .context import Resource
from .http import ApiError, api_errors, check_same_origin, flag, integer, iso, send

log = logging.getLogger(__name__)

#: A paste or a file of TLE sets: 50 sets of three lines fit.
MAX_TLE_TEXT = 12000
MAX_HOURS = 72


def _instants(value: Any, zone: Any) -> Any:
    """Every datetime in ``value`` as {"utc": ..., "site": ...} (the site's zone, with its offset)."""
    if isinstance(value, datetime):
        return {"utc": iso(value), "site": value.astimezone(zone).isoformat(timespec="seconds")}
    if isinstance(value, dict):
        return {key: _instants(item, zone) for key, item in value.items()}
    if isinstance(value, list):
        return [_instants(item, zone) for item in value]
    return value


def overview(device: DeviceFacade, hours: float) -> dict[str, Any]:
    """The kept sets and their passes, and the follow, with instants in UTC and the site's zone."""
    from ..catalogue import objects  # the zone rule the object card uses; imported on first use

    now = device.utc_now()
    zone = objects.site_zone(device.site()[1], now)
    progress = device.satellite_progress()
    return {"site_zone": zone.label(now), "hours": hours,
            "satellites": _instants(device.satellites(hours), zone.zone),
            "following": progress is not None and progress["phase"] != "ended",
            "progress": _instants(progress, zone.zone)}


def _hours(req: falcon.Request) -> float:
    raw = req.get_param("hours")
    if raw is None:
        return 24.0
    try:
        hours = float(raw) if len(raw) <= 10 else -1.0
    except ValueError:
        hours = -1.0
    if not 0.0 < hours <= MAX_HOURS:
        raise ApiError(400, f"hours must be a number from 0 to {MAX_HOURS}")
    return hours


class SatellitesResource(Resource):
    """``GET``/``POST /setup/api/telescope/{number}/satellites`` (module docstring)."""

    def on_get(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        with api_errors(resp):
            device = self.web.device(number)
            send(resp, overview(device, _hours(req)))

    def on_post(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        check_same_origin(req)
        with api_errors(resp):
            body = self.body(req)
            device = self.web.device(number)
            if "tle" in body:
                text = body["tle"]
                if not isinstance(text, str) or not text.strip() or len(text) > MAX_TLE_TEXT:
                    raise ApiError(400, f"tle must be the text of TLE sets (at most {MAX_TLE_TEXT} characters)")
                names = device.add_satellites(text)
                log.info("setup page (%s): kept %s", req.remote_addr, ", ".join(names))
            elif "remove" in body:
                device.remove_satellite(integer(body, "remove", 1, 999999999))
            else:
                raise ApiError(400, "give tle (the sets to keep) or remove (a catalogue number)")
            send(resp, overview(device, 24.0))


class FollowResource(Resource):
    """``POST /setup/api/telescope/{number}/satellites/follow``: ``number`` follows that satellite's next
    pass; ``stop: true`` ends the follow."""

    def on_post(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        check_same_origin(req)
        with api_errors(resp):
            body = self.body(req)
            device = self.web.device(number)
            token = current_client.set(self.web.touch(req))
            try:
                if "stop" in body and flag(body, "stop"):
                    device.stop_following()
                elif "number" in body:
                    device.follow_satellite(integer(body, "number", 1, 999999999))
                else:
                    raise ApiError(400, "give number (a kept satellite) or stop: true")
            finally:
                current_client.reset(token)
            send(resp, overview(device, 24.0))
